"""The lane's two friction levels for the reference ball: the paper's, and the bowlers' layer's
calibrated ones.

The reference ball is a reactive solid cover at 1000 grit (:mod:`bowlrec.bowling.surface`);
other covers and surfaces scale these levels by their factors. Two sets:

* :data:`PAPER`: Frohlich (2004), 0.04 on oil and 0.20 on the dry lane, the levels of the
  paper's scenes and of ``oil_friction: "paper"`` in a bowler scene.
* :func:`calibrated`: the levels fitted to published observables of ball motion (breakpoints,
  entry angles, where the ball rolls, a measured line) by ``python -m benchmarks.calibration
  --fit``, which writes ``data/calibration/friction_fit.json``, with the film from which a
  board counts as fully oiled; the default of every bowler scene and session.
  The fit, its objective, its uncertainty and the held-out comparison are in
  ``docs/calibration.md``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from importlib.resources import files
from typing import Any

__all__ = ["FIT_FILE", "PAPER", "FrictionLevels", "calibrated"]

#: the fitted levels (written by benchmarks/calibration.py --fit), inside the package
FIT_FILE = "calibration/friction_fit.json"


@dataclass(frozen=True)
class FrictionLevels:
    """Friction coefficients of the reference ball on full oil and on the dry lane, with the
    interval each is known to (dimensionless; the interval equals the value when exact by
    definition), the film from which a board counts as fully oiled, and where the numbers
    come from."""

    mu_oil: float
    mu_dry: float
    mu_oil_interval: tuple[float, float]
    mu_dry_interval: tuple[float, float]
    source: str
    #: film (um) from which a board is fully oiled; thinner films rise toward mu_dry along the
    #: power ramp (exponent 0.4, OilFrictionMapping); 0: any film is fully oiled
    oiled_at_or_above_um: float = 0.0


#: Frohlich's levels (Am. J. Phys. 72, 1170, 2004: 0.04 oiled, 0.20 dry)
PAPER = FrictionLevels(
    mu_oil=0.04,
    mu_dry=0.20,
    mu_oil_interval=(0.04, 0.04),
    mu_dry_interval=(0.20, 0.20),
    source="Frohlich, Am. J. Phys. 72, 1170 (2004): 0.04 oiled, 0.20 dry",
)


def _levels(data: dict[str, Any]) -> FrictionLevels:
    return FrictionLevels(
        mu_oil=float(data["mu_oil"]),
        mu_dry=float(data["mu_dry"]),
        mu_oil_interval=(float(data["mu_oil_interval"][0]), float(data["mu_oil_interval"][1])),
        mu_dry_interval=(float(data["mu_dry_interval"][0]), float(data["mu_dry_interval"][1])),
        source=str(data["source"]),
        oiled_at_or_above_um=float(data.get("oiled_at_or_above_um", 0.0)),
    )


@lru_cache(maxsize=1)
def calibrated() -> FrictionLevels:
    """The calibrated levels of the bowlers' layer (read once from :data:`FIT_FILE`)."""
    text = files("bowlrec.bowling").joinpath("data", FIT_FILE).read_text(encoding="utf-8")
    return _levels(json.loads(text))

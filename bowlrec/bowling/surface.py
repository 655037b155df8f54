"""A ball's coverstock and surface finish as factors on the lane's friction coefficient.

Published sources rank coverstocks and surface finishes by traction; none gives a friction
coefficient per cover (the sources, the ranking and the reasoning behind every number are in
``docs/coverstock.md``). This module holds that ranking as numbers. Every number here is an
**assumption** chosen to respect the sourced ranking, with a plausible range around it; only
the ranking is sourced. The factors are dimensionless multipliers of the friction coefficient
(:class:`~bowlrec.bowling.oil_friction.OilFrictionMapping` applies them):

    mu_oil(ball) = cover_oil[coverstock] * surface_oil(surface) * mu_oil
    mu_dry(ball) = cover_dry[coverstock] * surface_dry(surface) * mu_dry

**Reference.** ``reactive_solid`` at :data:`REFERENCE_GRIT` (1000) has factor 1 on oil and on
dry, exactly, so that ball sees Frohlich's two levels (0.04 oiled, 0.20 dry). Frohlich's Table I
names the reactive ball as the one whose friction is "very low on oil, very high when there is
no oil", the contrast his 0.04 / 0.20 describe; solid is the base reactive resin (a pearl is
that resin with a mica filler, a particle cover with added particles: USBC, "Unlocking the
Mysteries of Particle-Ball Performance"); and 600-800 grit was the usual out-of-box finish
around 2000 (Orlando Sentinel, 2 June 2000), rounded here to the Abralon step 1000.

**Coverstocks** (:data:`COVER_FACTORS`): on oil, particle > solid > hybrid > urethane > pearl >
polyester; on the dry lane, particle > solid > hybrid > pearl > urethane > polyester. Reactive
covers have the largest dry / oil contrast, urethane less (it "reads the lane earlier" and
hooks less on the backend), polyester is low on both (Frohlich's spare ball).

**Surface** (:func:`grit_factor`): a grit number g (the sanding pad's grit, e.g. Abralon
180-4000; larger is finer) gives ``(g / REFERENCE_GRIT) ** -a``, with exponent a = 0.10 on oil
and 0.02 on the dry lane (sanding changes the traction in oil most: a sanded ball reads the
lane earlier, a polished one skids farther; Bowling This Month). The power law assumes the
roughness scales with the abrasive's particle size, about 1 / grit. A polished surface has
its own factors, 0.75 on oil and 0.95 dry, below every grit of the model's range
(:data:`GRIT_MIN`-:data:`GRIT_MAX`) for the assumed exponents.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Literal, get_args

__all__ = [
    "COVERSTOCKS",
    "COVER_FACTORS",
    "DRY_RANKING",
    "GRIT_EXPONENT_DRY",
    "GRIT_EXPONENT_OIL",
    "GRIT_MAX",
    "GRIT_MIN",
    "OIL_RANKING",
    "POLISHED_DRY",
    "POLISHED_OIL",
    "REFERENCE_COVERSTOCK",
    "REFERENCE_GRIT",
    "CoverFactors",
    "Coverstock",
    "FactorRange",
    "Surface",
    "check_surface",
    "grit_factor",
    "surface_text",
]

#: coverstock classes
Coverstock = Literal[
    "polyester", "urethane", "reactive_solid", "reactive_pearl", "reactive_hybrid", "particle"
]
COVERSTOCKS: tuple[str, ...] = get_args(Coverstock)
#: a ball's surface: a grit number (e.g. 2000 for 2000 Abralon) or "polished"
Surface = int | Literal["polished"]

#: the coverstock whose factors are 1 (it sees the mapping's mu_oil / mu_dry unchanged)
REFERENCE_COVERSTOCK: Coverstock = "reactive_solid"
#: the grit whose surface factors are 1
REFERENCE_GRIT = 1000
#: the grits the surface model covers (inclusive): coarser than any ball pad to finer than any
GRIT_MIN = 100
GRIT_MAX = 10000


@dataclass(frozen=True)
class FactorRange:
    """An assumed value and the plausible range around it (low <= assumed <= high)."""

    low: float
    assumed: float
    high: float

    def __post_init__(self) -> None:
        if not 0.0 <= self.low <= self.assumed <= self.high:
            raise ValueError(f"need 0 <= low <= assumed <= high, got {self}")


@dataclass(frozen=True)
class CoverFactors:
    """A coverstock's factors on the oiled friction and on the dry friction (dimensionless)."""

    oil: FactorRange
    dry: FactorRange


_ONE = FactorRange(1.0, 1.0, 1.0)

#: per coverstock: factor on mu_oil and on mu_dry, assumed value and plausible range
#: (assumptions respecting the sourced ranking; docs/coverstock.md)
COVER_FACTORS: MappingProxyType[str, CoverFactors] = MappingProxyType(
    {
        "particle": CoverFactors(
            oil=FactorRange(1.05, 1.20, 1.40), dry=FactorRange(1.0, 1.05, 1.15)
        ),
        "reactive_solid": CoverFactors(oil=_ONE, dry=_ONE),
        "reactive_hybrid": CoverFactors(
            oil=FactorRange(0.82, 0.90, 0.97), dry=FactorRange(0.93, 0.98, 1.0)
        ),
        "urethane": CoverFactors(
            oil=FactorRange(0.70, 0.85, 0.95), dry=FactorRange(0.55, 0.70, 0.85)
        ),
        "reactive_pearl": CoverFactors(
            oil=FactorRange(0.65, 0.80, 0.92), dry=FactorRange(0.88, 0.95, 1.0)
        ),
        "polyester": CoverFactors(
            oil=FactorRange(0.35, 0.50, 0.70), dry=FactorRange(0.30, 0.45, 0.60)
        ),
    }
)

#: the sourced ranking on oil, most traction first (urethane vs hybrid / pearl: see the doc)
OIL_RANKING: tuple[Coverstock, ...] = (
    "particle",
    "reactive_solid",
    "reactive_hybrid",
    "urethane",
    "reactive_pearl",
    "polyester",
)
#: the sourced ranking on the dry lane, most traction first
DRY_RANKING: tuple[Coverstock, ...] = (
    "particle",
    "reactive_solid",
    "reactive_hybrid",
    "reactive_pearl",
    "urethane",
    "polyester",
)

#: exponent a of (grit / REFERENCE_GRIT) ** -a on the oiled friction
GRIT_EXPONENT_OIL = FactorRange(0.05, 0.10, 0.15)
#: exponent a of (grit / REFERENCE_GRIT) ** -a on the dry friction
GRIT_EXPONENT_DRY = FactorRange(0.0, 0.02, 0.04)
#: factor of a polished surface on the oiled friction
POLISHED_OIL = FactorRange(0.60, 0.75, 0.85)
#: factor of a polished surface on the dry friction
POLISHED_DRY = FactorRange(0.90, 0.95, 1.0)


def grit_factor(grit: float, exponent: float, reference: float = REFERENCE_GRIT) -> float:
    """(grit / reference) ** -exponent: 1 exactly at the reference grit, > 1 for a coarser
    (lower) grit when exponent > 0; grits are pad grit numbers (dimensionless)."""
    return float((grit / reference) ** -exponent)


def check_surface(surface: object, field: str = "surface") -> None:
    """ValueError (one line naming ``field``, the value and the allowed range) unless
    ``surface`` is a grit number in [GRIT_MIN, GRIT_MAX] or 'polished'."""
    if surface == "polished":
        return
    if isinstance(surface, bool) or not isinstance(surface, int):
        raise ValueError(
            f"{field} = {surface!r} must be a grit number ({GRIT_MIN}-{GRIT_MAX}) or 'polished'"
        )
    if not GRIT_MIN <= surface <= GRIT_MAX:
        raise ValueError(
            f"{field} = {surface} is outside the grits the friction model covers: "
            f"{GRIT_MIN}-{GRIT_MAX} (or 'polished')"
        )


def surface_text(surface: Surface | None) -> str:
    """Short text of a surface, e.g. '1500 grit', 'polished'; '' for None."""
    if surface is None:
        return ""
    return "polished" if surface == "polished" else f"{surface} grit"

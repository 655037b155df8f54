"""The strike percentage of a whole shot: release scatter down the lane, then the pins.

A bowler repeats a shot with the release-variance model (:mod:`.variance`: speed, rev rate,
axis, launch angle and laydown drawn around the shot); each repeat runs down the lane in the
kernel and through the pins in the pin engine (:mod:`bowlrec.pins`), its pins' tolerances drawn
from the repeat's own seed (``seed * 1_000_003 + i``). Reported: the strike share with its
binomial standard error, the share of repeats that entered the pocket window and the strikes
among those (carry), and how often each leave was left. Repeats run in a process pool.

The pins' parameters are the scene's ``options.pins`` when it has them, else the pin model's
defaults; needs the ``bowlrec[pins]`` extra.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .pocket import POCKET, Pocket
from .scene import BowlerScene, Shot
from .variance import ReleaseScatter, draw_releases

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan

__all__ = ["ShotCarry", "shot_carry"]


@dataclass(frozen=True)
class ShotCarry:
    """Repeats of a shot through the pins: per repeat its entry (board, angle; NaN when it
    missed the pins), whether it entered the pocket window, its pinfall and leave."""

    n: int
    seed: int
    pocket: Pocket
    entry_board: np.ndarray
    entry_angle_deg: np.ndarray
    in_pocket: np.ndarray
    pinfall: np.ndarray
    leaves: tuple[str, ...]
    seconds: float

    @property
    def strikes(self) -> np.ndarray:
        return self.pinfall == 10

    @property
    def strike_share(self) -> float:
        return float(np.mean(self.strikes))

    @property
    def strike_share_se(self) -> float:
        q = self.strike_share
        return math.sqrt(q * (1.0 - q) / self.n)

    @property
    def pocket_share(self) -> float:
        return float(np.mean(self.in_pocket))

    @property
    def carry(self) -> float | None:
        """Strikes among the repeats that entered the pocket window (None: none did)."""
        hits = int(self.in_pocket.sum())
        return None if hits == 0 else float(np.sum(self.strikes & self.in_pocket)) / hits

    def leave_counts(self) -> list[tuple[str, int]]:
        """Each leave and how many repeats left it, most frequent first."""
        return Counter(self.leaves).most_common()

    def to_dict(self) -> dict[str, Any]:
        return {
            "n": self.n,
            "seed": self.seed,
            "strike_share": self.strike_share,
            "strike_share_se": self.strike_share_se,
            "pocket_share": self.pocket_share,
            "carry": self.carry,
            "mean_pinfall": float(np.mean(self.pinfall)),
            "leaves": dict(self.leave_counts()),
            "seconds": self.seconds,
        }


def _through_the_pins(plan: Plan) -> tuple[int, str]:
    from bowlrec.core.solver import run_plan
    from bowlrec.pins.outcome import pin_outcome

    pins = pin_outcome(plan, run_plan(plan))
    return pins.pinfall, pins.leave


def shot_carry(
    scene: BowlerScene,
    scatter: ReleaseScatter,
    n: int = 200,
    seed: int = 0,
    pocket: Pocket = POCKET,
    workers: int | None = None,
) -> ShotCarry:
    """``n`` repeats of ``scene``'s shot with ``scatter`` through the pins (module docstring),
    reproducible by ``seed`` whatever ``workers`` (None: every core; 0: this process)."""
    from bowlrec.spec.resolve import pin_plan

    from .variance import _entries

    if n < 1:
        raise ValueError(f"n = {n} must be >= 1")
    t0 = time.perf_counter()
    shot = Shot(scene)
    d = scene.delivery
    repeats = draw_releases(d, shot.launch_angle(d), scatter, np.random.default_rng(seed), n)
    plans = [shot.plan(r.to_physical(scene.lane)) for r in repeats]
    _outcomes, board, angle = _entries(plans, scene, parallel=False)
    options = scene.options.pin_options or scene.options.model_validate({"pins": True}).pin_options
    assert options is not None
    if options.hand == "auto":
        options = options.model_copy(update={"hand": d.handedness})
    pinned = []
    for i, plan in enumerate(plans):
        pins = pin_plan(options.model_copy(update={"seed": seed * 1_000_003 + i}))
        pinned.append(dataclasses.replace(plan, pins=pins))
    count = (os.cpu_count() or 1) if workers is None else workers
    if count == 0 or n == 1:
        results = [_through_the_pins(p) for p in pinned]
    else:
        with ProcessPoolExecutor(max_workers=count) as pool:
            results = list(pool.map(_through_the_pins, pinned, chunksize=max(1, n // (4 * count))))
    return ShotCarry(
        n=n,
        seed=seed,
        pocket=pocket,
        entry_board=board,
        entry_angle_deg=angle,
        in_pocket=pocket.contains_all(board, angle),
        pinfall=np.array([r[0] for r in results], dtype=np.int64),
        leaves=tuple(r[1] for r in results),
        seconds=time.perf_counter() - t0,
    )

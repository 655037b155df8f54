"""Release variance: a bowler repeats a shot with scatter; how often does it enter the pocket?

Each repeat draws the speed, rev rate, axis rotation, axis tilt, launch angle and laydown board
from independent normal distributions around the scene's shot (the launch angle around the one
that crosses the scene's target at the arrows: :class:`~bowlrec.bowling.scene.Shot`), and all
repeats run at once in the many-delivery kernel (:func:`bowlrec.core.batch.run_batch`, summary
only). Reported: the distribution of entry board and entry angle at the head pin line, the share
of repeats that reach the pins and the share inside the pocket window
(:data:`~bowlrec.bowling.pocket.POCKET` unless another is given), with a binomial standard error.

Presets (standard deviations, one sigma). No published measurement of a bowler's release
repeatability per parameter is known to bowlrec, so every number below is an assumption,
chosen from what tracking systems show as typical spreads and labelled as such:

=============  =====  =====  ========  ====  ======  =======
preset         mph    rpm    rotation  tilt  launch  laydown
=============  =====  =====  ========  ====  ======  =======
robot          0.05   2      0.25      0.25  0.02    0.05
pro            0.3    15     3         2     0.17    0.5
league         0.8    30     8         5     0.5     1.5
=============  =====  =====  ========  ====  ======  =======

(rotation, tilt and launch in degrees, laydown in boards). 0.17 deg of launch angle is about
half a board at the arrows and two boards at the pins; the "robot" preset stands for a
throwing machine such as USBC's EARL, whose repeatability is far better than a person's.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from bowlrec.spec._base import NonNegativeFloat, SpecModel

from .delivery import BowlerDelivery
from .pocket import POCKET, Pocket
from .scene import BowlerScene, Shot

__all__ = [
    "draw_releases",
    "PRESETS",
    "ReleaseScatter",
    "ScatterResult",
    "ToleranceMap",
    "release_scatter",
    "tolerance_map",
]


class ReleaseScatter(SpecModel):
    """Standard deviations of a bowler's release, one sigma (bowlers' units)."""

    speed_mph: NonNegativeFloat = Field(default=0.3, description="Speed (mph).")
    rev_rate_rpm: NonNegativeFloat = Field(default=15.0, description="Rev rate (rpm).")
    axis_rotation_deg: NonNegativeFloat = Field(default=3.0, description="Axis rotation (deg).")
    axis_tilt_deg: NonNegativeFloat = Field(default=2.0, description="Axis tilt (deg).")
    launch_angle_deg: NonNegativeFloat = Field(default=0.17, description="Launch angle (deg).")
    laydown_board: NonNegativeFloat = Field(default=0.5, description="Laydown (boards).")


#: labelled presets (module docstring: every number is an assumption)
PRESETS: dict[str, ReleaseScatter] = {
    "robot": ReleaseScatter(
        speed_mph=0.05, rev_rate_rpm=2.0, axis_rotation_deg=0.25, axis_tilt_deg=0.25,
        launch_angle_deg=0.02, laydown_board=0.05,
    ),
    "pro": ReleaseScatter(),
    "league": ReleaseScatter(
        speed_mph=0.8, rev_rate_rpm=30.0, axis_rotation_deg=8.0, axis_tilt_deg=5.0,
        launch_angle_deg=0.5, laydown_board=1.5,
    ),
}  # fmt: skip


@dataclass(frozen=True)
class ScatterResult:
    """Entry board and angle of every repeat (NaN where it did not reach the pins) and the
    shares; ``pocket_share`` is of all repeats, ``pocket_share_se`` its binomial standard
    error."""

    n: int
    seed: int
    scatter: ReleaseScatter
    pocket: Pocket
    entry_board: NDArray[np.float64]
    entry_angle_deg: NDArray[np.float64]
    outcomes: NDArray[np.str_]
    seconds: float
    #: whose count the entry boards are in (from that hand's gutter)
    handedness: str = "right"

    @property
    def pins_share(self) -> float:
        return float(np.mean(self.outcomes == "pins"))

    @property
    def in_pocket(self) -> NDArray[np.bool_]:
        return self.pocket.contains_all(self.entry_board, self.entry_angle_deg)

    @property
    def pocket_share(self) -> float:
        return float(np.mean(self.in_pocket))

    @property
    def pocket_share_se(self) -> float:
        q = self.pocket_share
        return math.sqrt(q * (1.0 - q) / self.n)

    def to_dict(self) -> dict[str, Any]:
        """The shares and the entry distributions' mean, standard deviation and 5/95 %
        quantiles (over the repeats that reached the pins)."""

        def stats(x: NDArray[np.float64]) -> dict[str, float | None]:
            x = x[np.isfinite(x)]
            if x.size == 0:
                return {"mean": None, "std": None, "p05": None, "p95": None}
            return {
                "mean": float(x.mean()),
                "std": float(x.std(ddof=1)) if x.size > 1 else 0.0,
                "p05": float(np.quantile(x, 0.05)),
                "p95": float(np.quantile(x, 0.95)),
            }

        return {
            "n": self.n,
            "seed": self.seed,
            "scatter": self.scatter.model_dump(),
            "pocket": self.pocket.model_dump(),
            "pins_share": self.pins_share,
            "pocket_share": self.pocket_share,
            "pocket_share_se": self.pocket_share_se,
            "entry_board": stats(self.entry_board),
            "entry_angle_deg": stats(self.entry_angle_deg),
            "seconds": self.seconds,
        }


def release_scatter(
    scene: BowlerScene,
    scatter: ReleaseScatter,
    n: int = 2000,
    seed: int = 0,
    pocket: Pocket = POCKET,
    parallel: bool = True,
) -> ScatterResult:
    """``n`` repeats of ``scene``'s shot with ``scatter`` (module docstring), reproducible by
    ``seed``."""

    if n < 1:
        raise ValueError(f"n = {n} must be >= 1")
    t0 = time.perf_counter()
    shot = Shot(scene)
    d = scene.delivery
    launch = shot.launch_angle(d)
    repeats = draw_releases(d, launch, scatter, np.random.default_rng(seed), n)
    plans = [shot.plan(repeat.to_physical(scene.lane)) for repeat in repeats]
    outcomes, entry_board, entry_angle = _entries(plans, scene, parallel)
    return ScatterResult(
        n=n,
        seed=seed,
        scatter=scatter,
        pocket=pocket,
        entry_board=entry_board,
        entry_angle_deg=entry_angle,
        outcomes=outcomes,
        seconds=time.perf_counter() - t0,
        handedness=d.handedness,
    )


def draw_releases(
    d: BowlerDelivery,
    launch_angle_deg: float,
    scatter: ReleaseScatter,
    rng: np.random.Generator,
    n: int,
) -> list[BowlerDelivery]:
    """``n`` releases of ``d`` launched at ``launch_angle_deg`` (deg) with ``scatter``'s normal
    spread drawn from ``rng`` (speed and rev rate kept positive, the laydown on the lane, the
    axis angles in range; the target at the arrows dropped: the launch angle is given)."""
    launch = launch_angle_deg
    draws = {
        name: getattr(d, name) + getattr(scatter, name) * rng.standard_normal(n)
        for name in ("speed_mph", "rev_rate_rpm", "axis_rotation_deg", "axis_tilt_deg")
    }
    draws["launch_angle_deg"] = launch + scatter.launch_angle_deg * rng.standard_normal(n)
    draws["laydown_board"] = np.clip(
        d.laydown_board + scatter.laydown_board * rng.standard_normal(n), 0.5, 39.5
    )
    draws["speed_mph"] = np.maximum(draws["speed_mph"], 0.1)
    draws["rev_rate_rpm"] = np.maximum(draws["rev_rate_rpm"], 1e-3)
    base = d.model_dump()
    base["target_board_at_arrows"] = None
    repeats = []
    for i in range(n):
        fields = {**base, **{k: float(v[i]) for k, v in draws.items()}}
        fields["axis_rotation_deg"] = max(-180.0, min(180.0, fields["axis_rotation_deg"]))
        fields["axis_tilt_deg"] = max(-90.0, min(90.0, fields["axis_tilt_deg"]))
        repeats.append(type(d).model_validate(fields))
    return repeats


def _entries(
    plans: list[Any], scene: BowlerScene, parallel: bool = True
) -> tuple[NDArray[np.str_], NDArray[np.float64], NDArray[np.float64]]:
    """Run ``plans`` in the many-delivery kernel: (outcomes, entry board, entry angle in deg
    toward the bowler's higher boards; NaN where the ball does not reach the pins)."""
    from bowlrec.core.batch import B_STATE, batch_metrics, pack_plans, run_batch
    from bowlrec.core.codes import S_Y

    packed = pack_plans(plans)
    result = run_batch(packed, parallel=parallel)
    metrics = batch_metrics(packed, result)
    outcomes = np.asarray(metrics["outcome"]).astype(str)
    pins = outcomes == "pins"
    hand = scene.delivery.handedness
    sign = 1.0 if hand == "right" else -1.0
    boards = np.array([scene.lane.y_to_board(float(y), hand) for y in result.out[:, B_STATE + S_Y]])
    entry_board = np.where(pins, boards, np.nan)
    entry_angle = np.where(pins, sign * np.asarray(metrics["pocket_deg"], dtype=float), np.nan)
    return outcomes, entry_board, entry_angle


@dataclass(frozen=True)
class ToleranceMap:
    """Entry board and angle over a grid of target board at the arrows (columns) x release
    speed (rows), every other release parameter as in the scene; NaN where the ball does not
    reach the pins or cannot cross the target."""

    targets: NDArray[np.float64]
    speeds_mph: NDArray[np.float64]
    entry_board: NDArray[np.float64]
    entry_angle_deg: NDArray[np.float64]
    pocket: Pocket
    scene_target: float
    scene_speed_mph: float
    seconds: float
    #: whose count the boards are in (from that hand's gutter)
    handedness: str = "right"

    @property
    def in_pocket(self) -> NDArray[np.bool_]:
        return self.pocket.contains_all(self.entry_board, self.entry_angle_deg)

    def to_dict(self) -> dict[str, Any]:
        """The grid and the mistake area: the target range (boards) at the scene's speed and
        the speed range (mph) at its target over which the entry board stays in the pocket
        window (linear interpolation between grid points), with the entry angles at its ends."""
        i = int(np.argmin(np.abs(self.speeds_mph - self.scene_speed_mph)))
        j = int(np.argmin(np.abs(self.targets - self.scene_target)))
        p = self.pocket
        return {
            "targets": self.targets.tolist(),
            "speeds_mph": self.speeds_mph.tolist(),
            "entry_board": _nan_to_none(self.entry_board),
            "entry_angle_deg": _nan_to_none(self.entry_angle_deg),
            "pocket": p.model_dump(),
            "scene_target": self.scene_target,
            "scene_speed_mph": self.scene_speed_mph,
            "target_range_at_scene_speed": _band(
                self.targets, self.entry_board[i], j, p.board_min, p.board_max
            ),
            "speed_range_at_scene_target": _band(
                self.speeds_mph, self.entry_board[:, j], i, p.board_min, p.board_max
            ),
            "seconds": self.seconds,
        }


def _nan_to_none(a: NDArray[np.float64]) -> list[list[float | None]]:
    return [[None if math.isnan(v) else float(v) for v in row] for row in a]


def _band(
    x: NDArray[np.float64], f: NDArray[np.float64], at: int, lo: float, hi: float
) -> list[float] | None:
    """[x_a, x_b]: the interval around x[at] where the piecewise-linear f stays in [lo, hi]
    (None when f[at] is outside or NaN); an end at the grid's edge is the edge."""
    if not lo <= f[at] <= hi:
        return None

    def edge(step: int) -> float:
        k = at
        while 0 <= k + step < len(x):
            a, b = f[k], f[k + step]
            if not np.isfinite(b):
                return float(x[k])
            if not lo <= b <= hi:
                bound = lo if b < lo else hi
                return float(x[k] + (bound - a) / (b - a) * (x[k + step] - x[k]))
            k += step
        return float(x[k])

    ends = sorted((edge(-1), edge(1)))
    return [ends[0], ends[1]]


def tolerance_map(
    scene: BowlerScene,
    targets: NDArray[np.float64] | None = None,
    speeds_mph: NDArray[np.float64] | None = None,
    pocket: Pocket = POCKET,
) -> ToleranceMap:
    """Where the shot still enters the pocket when the bowler misses the target at the arrows
    or the speed (the "mistake area"): by default +-1.5 boards around the scene's target in
    0.125-board steps and +-2 mph around its speed in 0.25 mph steps. Each cell's launch angle
    crosses its target (:meth:`Shot.launch_angle`); the cells run in the many-delivery kernel."""
    from bowlrec.errors import AimError

    t0 = time.perf_counter()
    shot = Shot(scene)
    d = scene.delivery
    if d.target_board_at_arrows is None:
        board = shot.arrows_board(d, shot.launch_angle(d))
        if board is None:
            raise AimError("the ball does not reach the arrows: no target to map around")
        base_target = board
    else:
        base_target = d.target_board_at_arrows
    grid_t = base_target + np.arange(-12, 13) * 0.125 if targets is None else targets
    grid_v = d.speed_mph + np.arange(-8, 9) * 0.25 if speeds_mph is None else speeds_mph
    targets = np.asarray(grid_t, dtype=np.float64)
    speeds_mph = np.asarray(grid_v, dtype=np.float64)
    base = {**d.model_dump(), "launch_angle_deg": None}
    plans, cells = [], []
    for i, v in enumerate(speeds_mph):
        for j, target in enumerate(targets):
            try:
                cell = type(d).model_validate(
                    {**base, "speed_mph": float(v), "target_board_at_arrows": float(target)}
                )
                launch = shot.launch_angle(cell)
            except (AimError, ValueError):
                continue
            plans.append(shot.plan(cell.to_physical(scene.lane, launch)))
            cells.append((i, j))
    entry_board = np.full((len(speeds_mph), len(targets)), np.nan)
    entry_angle = np.full_like(entry_board, np.nan)
    if plans:
        _, boards, angles = _entries(plans, scene)
        rows, cols = np.array(cells).T
        entry_board[rows, cols] = boards
        entry_angle[rows, cols] = angles
    return ToleranceMap(
        targets=targets,
        speeds_mph=speeds_mph,
        entry_board=entry_board,
        entry_angle_deg=entry_angle,
        pocket=pocket,
        scene_target=float(base_target),
        scene_speed_mph=float(d.speed_mph),
        seconds=time.perf_counter() - t0,
        handedness=d.handedness,
    )

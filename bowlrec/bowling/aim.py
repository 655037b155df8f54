"""Aiming: the shot that enters the pocket.

Free variables, the user's choice, each between bounds:

=========  ==========================================  ===============
name       what changes                                bounds
=========  ==========================================  ===============
target     the board crossed at the arrows (15 ft)     1 - 39 boards
launch     the launch angle                            -10 - 10 deg
laydown    the laydown board                           1 - 39 boards
speed      the release speed                           8 - 30 mph
=========  ==========================================  ===============

One free variable is solved for the entry board (``Pocket.board`` at the head pin line), two for
the entry board and the entry angle (``Pocket.angle_deg``), or, given ``breakpoint_board``, for
the entry board and the board of the breakpoint (the line a bowler picks on a pattern: the
breakpoint where the pattern puts it, e.g. Kegel's rule of 31; the entry angle is then what
the ball gives). With ``target`` free the launch angle follows from it
(:class:`~bowlrec.bowling.scene.Shot`); with ``launch`` free the scene aims by its launch
angle. Every evaluation is one summary-only kernel run (a few with a target at the arrows), the
arrows and the turning point observed on the way.

Method: one variable, the secant method from the scene's own value; if that does not converge,
a scan of 13 values across the bounds and the Illinois variant of regula falsi on the sign
change nearest the start. Two variables: the first is searched by the secant method for the
entry angle while, for each of its values, the second is solved for the entry board (warm
started from the last solution); for a breakpoint board the first is found by the same scan
and Illinois (the breakpoint can jump where a line crosses an oil step, which a secant does
not survive). At most 60 shots are tried (400 for a breakpoint). Converged when the entry board
is within ``BOARD_TOL`` and (two variables) the entry angle within ``ANGLE_TOL_DEG`` or the
breakpoint within ``BREAKPOINT_TOL``, or when the closest shot tried lies inside the pocket's
window (board, and angle or breakpoint with two variables); otherwise the result says the
pocket was not reached and keeps the closest shot tried (distance: boards, plus degrees or
breakpoint boards with two variables).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

import numpy as np

from bowlrec.errors import AimError, SpecError
from bowlrec.spec import Lane

from .delivery import BowlerDelivery
from .pocket import POCKET, Pocket
from .report import BowlerReport, bowler_report, report_stations
from .scene import BowlerScene, Shot

__all__ = ["VARIABLES", "AimResult", "ShotResult", "Variable", "aim", "evaluate"]

Variable = Literal["target", "launch", "laydown", "speed"]
VARIABLES: tuple[str, ...] = get_args(Variable)
_BOUNDS: dict[str, tuple[float, float]] = {
    "target": (1.0, 39.0),
    "launch": (-10.0, 10.0),
    "laydown": (1.0, 39.0),
    "speed": (8.0, 30.0),
}
#: first step of each variable (its units)
_STEP = {"target": 1.0, "launch": 0.3, "laydown": 1.0, "speed": 0.5}
#: entry board within this of the pocket board (boards)
BOARD_TOL = 1e-3
#: entry angle within this of the pocket angle (deg)
ANGLE_TOL_DEG = 1e-3
#: breakpoint board within this of the one asked for (boards)
BREAKPOINT_TOL = 0.1
#: shots tried before the search gives up and reports the closest
_MAX_EVALUATIONS = 60
#: the same for a search that places the breakpoint (its outer variable has no secant-friendly
#: start: it scans the bounds more often)
_MAX_EVALUATIONS_BREAKPOINT = 400


@dataclass(frozen=True)
class ShotResult:
    """One shot: its launch angle (deg, toward higher boards) and its report in bowlers' terms
    (:class:`~bowlrec.bowling.report.BowlerReport`; entry values None unless it reached the
    pins)."""

    launch_angle_deg: float
    report: BowlerReport

    @property
    def outcome(self) -> str:
        return self.report.outcome

    @property
    def arrows_board(self) -> float | None:
        return self.report.arrows_board

    @property
    def breakpoint_board(self) -> float:
        return self.report.breakpoint_board

    @property
    def breakpoint_ft(self) -> float:
        return self.report.breakpoint_ft

    @property
    def entry_board(self) -> float | None:
        return self.report.entry_board

    @property
    def entry_angle_deg(self) -> float | None:
        return self.report.entry_angle_deg

    def miss(
        self, pocket: Pocket, with_angle: bool, breakpoint_board: float | None = None
    ) -> float:
        """Distance from the pocket (boards, plus degrees when the angle counts, plus boards
        from ``breakpoint_board`` when given); inf when the ball does not reach the pins."""
        if self.entry_board is None or self.entry_angle_deg is None:
            return math.inf
        d = abs(self.entry_board - pocket.board)
        if breakpoint_board is not None:
            return d + abs(self.breakpoint_board - breakpoint_board)
        return d + abs(self.entry_angle_deg - pocket.angle_deg) if with_angle else d


@dataclass(frozen=True)
class AimResult:
    """What :func:`aim` found: ``found`` says whether the pocket was reached; ``values`` the
    free variables' values of the returned shot (the solution, or the closest tried)."""

    found: bool
    vary: tuple[str, ...]
    values: dict[str, float]
    shot: ShotResult
    scene: BowlerScene
    pocket: Pocket
    evaluations: int
    seconds: float
    message: str
    tried: list[tuple[dict[str, float], ShotResult]] = field(default_factory=list, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready values (the solved scene as its bowler-scene JSON)."""
        return {
            "found": self.found,
            "message": self.message,
            "vary": list(self.vary),
            "values": self.values,
            "launch_angle_deg": self.shot.launch_angle_deg,
            "report": self.shot.report.to_dict(),
            "in_window": self.pocket.contains(self.shot.entry_board, self.shot.entry_angle_deg),
            "pocket": self.pocket.model_dump(),
            "evaluations": self.evaluations,
            "seconds": self.seconds,
            "scene": self.scene.model_dump(mode="json"),
        }


def _value(shot: Shot, scene: BowlerScene, name: str) -> float:
    """The current value of free variable ``name`` in ``scene``."""
    d = scene.delivery
    if name == "target":
        if d.target_board_at_arrows is not None:
            return d.target_board_at_arrows
        board = shot.arrows_board(d, shot.launch_angle(d))
        if board is None:
            raise AimError("the ball does not reach the arrows: no target board to start from")
        return board
    if name == "launch":
        return shot.launch_angle(d)
    if name == "laydown":
        return d.laydown_board
    return d.speed_mph


def _with(delivery: BowlerDelivery, values: dict[str, float]) -> BowlerDelivery:
    """``delivery`` with the free variables set (validated: a bad value is one clear line)."""
    data = delivery.model_dump()
    for name, v in values.items():
        if name == "target":
            data.update(target_board_at_arrows=v, launch_angle_deg=None)
        elif name == "launch":
            data.update(launch_angle_deg=v, target_board_at_arrows=None)
        elif name == "laydown":
            data["laydown_board"] = v
        else:
            data["speed_mph"] = v
    return BowlerDelivery.model_validate(data)


def evaluate(shot: Shot, delivery: BowlerDelivery) -> ShotResult:
    """Run ``delivery`` (summary only, observed as a report reads it) and report it."""
    lane = shot.scene.lane
    launch = shot.launch_angle(delivery)
    physical = delivery.to_physical(lane, launch)
    x0 = lane.ft_to_x_m(delivery.laydown_ft)
    traj = shot.run(physical, report_stations(lane, x0), turns=True)
    return ShotResult(
        launch_angle_deg=launch, report=bowler_report(traj, lane, delivery.handedness)
    )


class _Spent(AimError):
    """The evaluation budget is used up (caught by :func:`aim`, which reports the closest)."""


class _Search:
    """Evaluations with their bookkeeping: the shot, every shot tried, the closest."""

    def __init__(
        self,
        scene: BowlerScene,
        vary: tuple[str, ...],
        pocket: Pocket,
        lane: Lane | None = None,
        breakpoint_board: float | None = None,
    ) -> None:
        self.scene, self.vary, self.pocket = scene, vary, pocket
        self.breakpoint_board = breakpoint_board
        self.shot = Shot(scene, lane=lane)
        self.with_angle = len(vary) == 2 and breakpoint_board is None
        self.tried: list[tuple[dict[str, float], ShotResult]] = []
        self.attempts = 0
        self.budget = _MAX_EVALUATIONS if breakpoint_board is None else _MAX_EVALUATIONS_BREAKPOINT

    def run(self, values: dict[str, float]) -> ShotResult | None:
        """The shot with the free variables at ``values``; None if it cannot be thrown.
        Raises _Spent once the evaluation budget is used up."""
        if self.attempts >= self.budget:
            raise _Spent
        self.attempts += 1
        try:
            result = evaluate(self.shot, _with(self.scene.delivery, values))
        except (AimError, SpecError, ValueError):
            return None
        self.tried.append((values, result))
        return result

    def spent(self) -> bool:
        return self.attempts >= self.budget

    def best(self) -> tuple[dict[str, float], ShotResult] | None:
        if not self.tried:
            return None
        return min(
            self.tried,
            key=lambda t: t[1].miss(self.pocket, self.with_angle, self.breakpoint_board),
        )


_Residual = Callable[[float], float | None]


def _secant(
    f: _Residual, x0: float, step: float, lo: float, hi: float, tol: float, search: _Search
) -> float | None:
    """A root of f near x0 by the secant method (steps at most 8 ``step``), None if it does
    not converge within a few evaluations."""
    xa, fa = x0, f(x0)
    if fa is None:
        return None
    if abs(fa) <= tol:
        return xa
    xb = min(hi, max(lo, x0 + step))
    for _ in range(8):
        if search.spent():
            return None
        fb = f(xb)
        if fb is None:
            return None
        if abs(fb) <= tol:
            return xb
        if fb == fa:
            return None
        x = xb - fb * (xb - xa) / (fb - fa)
        x = min(hi, max(lo, max(xb - 8 * abs(step), min(xb + 8 * abs(step), x))))
        if x == xb:
            return None
        xa, fa, xb = xb, fb, x
    return None


def _bracketed(
    f: _Residual, a: float, fa: float, b: float, fb: float, tol: float, search: _Search
) -> float | None:
    """The root of f between a and b (fa, fb of opposite signs) by Illinois."""
    side = 0
    while not search.spent():
        x = (a * fb - b * fa) / (fb - fa)
        fx = f(x)
        if fx is None:
            return None
        if abs(fx) <= tol:
            return x
        if (fx < 0) == (fa < 0):
            a, fa = x, fx
            if side == -1:
                fb *= 0.5
            side = -1
        else:
            b, fb = x, fx
            if side == 1:
                fa *= 0.5
            side = 1
    return None


def _root(
    f: _Residual, x0: float, step: float, lo: float, hi: float, tol: float, search: _Search
) -> float | None:
    """A root of f in [lo, hi]: the secant method from x0, else a scan of 13 points across
    the bounds and Illinois on the sign change nearest x0; None if there is none."""
    x = _secant(f, x0, step, lo, hi, tol, search)
    if x is not None:
        return x
    grid = np.linspace(lo, hi, 13)
    values = [(float(g), f(float(g))) for g in grid]
    pairs = [
        (a, fa, b, fb)
        for (a, fa), (b, fb) in zip(values, values[1:], strict=False)
        if fa is not None and fb is not None and (fa < 0) != (fb < 0)
    ]
    for a, fa, b, fb in sorted(pairs, key=lambda p: abs(0.5 * (p[0] + p[2]) - x0)):
        x = _bracketed(f, a, fa, b, fb, tol, search)
        if x is not None:
            return x
    return None


def _board_residual(search: _Search, fixed: dict[str, float], name: str) -> _Residual:
    def f(v: float) -> float | None:
        r = search.run({**fixed, name: v})
        if r is None or r.entry_board is None:
            return None
        return r.entry_board - search.pocket.board

    return f


def _solve(search: _Search) -> bool:
    """One variable: the entry board. Two: the first variable for the entry angle (or the
    breakpoint board, when one is asked for), with the second solved for the entry board at
    every step."""
    starts = {n: _value(search.shot, search.scene, n) for n in search.vary}
    if len(search.vary) == 1:
        (name,) = search.vary
        lo, hi = _BOUNDS[name]
        f = _board_residual(search, {}, name)
        return _root(f, starts[name], _STEP[name], lo, hi, BOARD_TOL, search) is not None
    outer, inner = search.vary
    inner_start = [starts[inner]]

    def angle_residual(v: float) -> float | None:
        lo, hi = _BOUNDS[inner]
        f = _board_residual(search, {outer: v}, inner)
        w = _root(f, inner_start[0], _STEP[inner], lo, hi, BOARD_TOL, search)
        if w is None:
            return None
        inner_start[0] = w
        r = search.run({outer: v, inner: w})
        if r is None or r.entry_angle_deg is None:
            return None
        if search.breakpoint_board is not None:
            return r.breakpoint_board - search.breakpoint_board
        return r.entry_angle_deg - search.pocket.angle_deg

    lo, hi = _BOUNDS[outer]
    step = _STEP[outer]
    if search.breakpoint_board is not None:  # no start to go on: scanned and bracketed
        found = _root(angle_residual, starts[outer], step, lo, hi, BREAKPOINT_TOL, search)
    else:
        found = _secant(angle_residual, starts[outer], step, lo, hi, ANGLE_TOL_DEG, search)
    return found is not None


def aim(
    scene: BowlerScene,
    vary: Sequence[str] = ("target",),
    pocket: Pocket = POCKET,
    lane: Lane | None = None,
    breakpoint_board: float | None = None,
) -> AimResult:
    """The shot of ``scene`` that enters ``pocket``, varying ``vary`` (one or two names of
    :data:`VARIABLES`; module docstring), on ``lane`` (a physical lane; default the scene's
    own, its pattern's friction for its ball). With two variables and ``breakpoint_board``
    (boards), the shot enters the pocket's board with its breakpoint on that board instead of
    at the pocket's angle. Raises AimError for a bad request; an unreachable pocket is a
    result with ``found`` False and the closest shot tried."""
    names = tuple(vary)
    unknown = [n for n in names if n not in VARIABLES]
    if unknown or not 1 <= len(names) <= 2 or len(set(names)) != len(names):
        raise AimError(
            f"vary = {list(names)}: give one or two different names of {', '.join(VARIABLES)}"
        )
    if set(names) == {"target", "launch"}:
        raise AimError("vary = ['target', 'launch']: the target decides the launch angle")
    if breakpoint_board is not None and len(names) != 2:
        raise AimError(
            f"breakpoint_board = {breakpoint_board:g}: free two variables (e.g. laydown and "
            "target) to place both the entry board and the breakpoint"
        )
    if breakpoint_board is not None and not 0.0 < breakpoint_board < 39.0:
        raise AimError(f"breakpoint_board = {breakpoint_board:g} must be between 0 and 39")
    t0 = time.perf_counter()
    search = _Search(scene, names, pocket, lane, breakpoint_board)
    try:
        found = _solve(search)
    except _Spent:
        found = False
    best = search.best()
    seconds = time.perf_counter() - t0
    if best is None:
        raise AimError(
            f"no shot varying {' and '.join(names)} from this scene reaches the pins: "
            "change the delivery"
        )
    values, shot = best
    # a shot inside the window is an answer even where the aim point itself was not hit
    if len(names) == 1:
        found = found or pocket.board_ok(shot.entry_board)
    elif breakpoint_board is not None:
        found = found or (
            pocket.board_ok(shot.entry_board)
            and abs(shot.breakpoint_board - breakpoint_board) <= BREAKPOINT_TOL
        )
    else:
        found = found or pocket.contains(shot.entry_board, shot.entry_angle_deg)
    solved = scene.model_copy(update={"delivery": _with(scene.delivery, values)})
    if found and breakpoint_board is not None:
        window = "inside" if pocket.angle_ok(shot.entry_angle_deg) else "outside"
        message = (
            f"enters at board {shot.entry_board:.2f} with the breakpoint on board "
            f"{shot.breakpoint_board:.2f} at {shot.breakpoint_ft:.1f} ft; its entry angle "
            f"{shot.entry_angle_deg:.2f} deg is {window} the angle window ({pocket.describe()})"
        )
    elif found and not pocket.angle_ok(shot.entry_angle_deg):
        message = (
            f"enters at board {shot.entry_board:.2f}, but at {shot.entry_angle_deg:.2f} deg, "
            f"outside the angle window ({pocket.describe()}): free a second variable to solve "
            "the angle too"
        )
    elif found:
        message = f"enters the pocket ({pocket.describe()})"
    elif shot.entry_board is None:
        message = f"no shot reaches the pins (closest: {shot.outcome})"
    else:
        message = (
            f"no {' and '.join(names)} within the bounds enters the pocket "
            f"({pocket.describe()}); the closest enters at board {shot.entry_board:.2f}, "
            f"{shot.entry_angle_deg:.2f} deg"
        )
    return AimResult(
        found=found,
        vary=names,
        values=values,
        shot=shot,
        scene=solved,
        pocket=pocket,
        evaluations=search.attempts,
        seconds=seconds,
        message=message,
        tried=search.tried,
    )

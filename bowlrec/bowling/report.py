"""A delivery's result in bowlers' terms (mph, rpm, boards, ft, degrees), from a Trajectory.

Names follow what tracking systems (Kegel Specto and the like) report. Definitions, all for the
ball's geometric center and with boards counted from the bowling hand's gutter
(:mod:`bowlrec.bowling.lane`); angles to the boards are positive toward higher boards (see
:mod:`bowlrec.bowling.delivery`):

* launch speed / launch angle / rev rate at release / laydown: the first sample (release).
* arrows board: the board crossed at 15 ft past the foul line.
* breakpoint: the point of the path farthest toward the bowling hand's gutter (the lowest board
  number; Specto's "outermost position"), located between samples as the turning point of the
  cubic Hermite interpolant of the path. If the path has no interior turning point it is the
  release point (a ball moving inward from the start) or the last point (one that never comes
  back); ties go to the earliest point.
* entry board / entry angle / entry speed / rev rate at the pins / axis at the pins: where the
  center crosses the head-pin line (x = lane length, 60 ft). Specto reads the entry board at
  59.5 ft and the entry angle over 51-55 ft; here both are at 60 ft, so the entry angle equals
  the physics summary's pocket angle (sign flipped for a left-hander).
* hook boards: entry board - breakpoint board (boards the ball comes back from the breakpoint
  to the pins; > 0 for a hooking ball).
* slide length: distance from the foul line where the ball first rolls without slipping (the
  physics summary's slide_m), in ft; the laydown distance for a ball rolling from the release;
  None if it never rolls.
* axis rotation / tilt (axis migration): of omega relative to the current direction of travel,
  with the same zero and signs as the delivery's
  (:func:`~bowlrec.bowling.delivery.axis_angles_deg`).

* Specto's windows, as Kegel's Specto defines its terms (Specto Bowling, "Specto terms",
  https://www.spectobowling.com/specto-terms), beside the exact values at 60 ft: launch speed,
  "the average speed of the ball in the first 3 feet of readings" (from the release point);
  launch angle, "the angle the ball traveled the first 10 feet"; entry angle, "the angle of
  the ball between 51 and 55 feet"; entry board, "ball position at 59.5 feet"; entry speed,
  "the average speed of the ball between 57 and 59.5 feet"; impact angle, "the angle of the
  ball between 57 and 59.5 feet". An angle over a window is that of the chord between its ends
  (the mean of dy/dx over it), a speed over a window the chord length over the time between
  its ends.

The path comes from either of two sources, with the same definitions:

* the kernel's observation events (:mod:`bowlrec.core.observe`), for any run, summary-only
  included, simulated with :func:`report_stations` and turning points observed
  (:func:`observed_run`): exact states on the dense output at those x;
* the recorded samples: between samples, positions and velocities from the cubic Hermite
  interpolant of (position, velocity) on each step, omega from linear interpolation.

Quantities at the pins are None unless the ball reaches the head-pin line; the arrows board and
the windows are None unless the ball reaches them.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bowlrec.core.codes import OBS_END, OBS_RELEASE, OBS_TURN
from bowlrec.core.trajectory import Trajectory
from bowlrec.errors import SamplesRequiredError
from bowlrec.units import ARROWS_FT, FT_M, MPH_MPS, RPM_RADPS

from .delivery import axis_angles_deg
from .lane import BowlerLane, Handedness
from .sides import sideways, summary_rows

__all__ = [
    "ENTRY_FT",
    "LAUNCH_ANGLE_FT",
    "LAUNCH_SPEED_FT",
    "BowlerReport",
    "board_count",
    "bowler_report",
    "inferred_handedness",
    "observed_run",
    "report_stations",
    "sideways",
    "summary_rows",
]

#: bisection steps when solving x(s) = X on one step (2**-60 of the step: below rounding)
_BISECTIONS = 60
#: Specto's launch windows from the release point (ft): speed over 3, angle over 10
LAUNCH_SPEED_FT = 3.0
LAUNCH_ANGLE_FT = 10.0
#: the stations (ft from the foul line) of Specto's entry windows
ENTRY_FT = (51.0, 55.0, 57.0, 59.5)
#: how close to the last state a station counts as the pins (m)
_AT_END_M = 1e-9


def board_count(handedness: str) -> str:
    """How a view counts boards, said on it: the bowler's count, from the bowling hand's
    gutter ("bowler's count, from the left gutter" for a left-hander)."""
    side = "left" if handedness == "left" else "right"
    return f"bowler's count, from the {side} gutter"


def inferred_handedness(y_m: ArrayLike) -> Handedness:
    """The bowling hand of a path from its lane-frame y samples (m): a right-hander's ball
    hooks left, so a path that ends to the left (+y) of its outermost point toward the right
    gutter, by more than it ends right of its outermost point toward the left gutter, is a
    right-hander's; otherwise a left-hander's (a straight path counts as a right-hander's)."""
    y = np.asarray(y_m, dtype=np.float64).ravel()
    if y.size == 0:
        return "right"
    y_end = float(y[-1])
    return "right" if y_end - float(y.min()) >= float(y.max()) - y_end else "left"


@dataclass(frozen=True)
class BowlerReport:
    """A delivery's result in bowlers' terms; units in the field names (module doc)."""

    handedness: str
    outcome: str
    laydown_board: float
    laydown_ft: float
    launch_speed_mph: float
    launch_angle_deg: float
    rev_rate_release_rpm: float
    axis_rotation_release_deg: float
    axis_tilt_release_deg: float
    arrows_board: float | None
    breakpoint_board: float
    breakpoint_ft: float
    axis_rotation_breakpoint_deg: float
    axis_tilt_breakpoint_deg: float
    entry_board: float | None
    entry_angle_deg: float | None
    entry_speed_mph: float | None
    rev_rate_pins_rpm: float | None
    axis_rotation_pins_deg: float | None
    axis_tilt_pins_deg: float | None
    hook_boards: float | None
    slide_ft: float | None
    specto_launch_speed_mph: float | None
    specto_launch_angle_deg: float | None
    specto_entry_angle_deg: float | None
    specto_entry_board: float | None
    specto_entry_speed_mph: float | None
    specto_impact_angle_deg: float | None

    def to_dict(self) -> dict[str, Any]:
        """All fields by name (plain floats, None and strings)."""
        return asdict(self)


@dataclass(frozen=True)
class _State:
    """The time (s), the center's position (m), velocity (m/s) and omega (rad/s)."""

    t: float
    x: float
    y: float
    vx: float
    vy: float
    omega: tuple[float, float, float]


def report_stations(lane: BowlerLane, release_x_m: float) -> list[float]:
    """The x stations (m, ascending) a report reads: the ends of Specto's windows and the
    arrows (the release point itself and the pins come with every observed run)."""
    rel = [release_x_m + LAUNCH_SPEED_FT * FT_M, release_x_m + LAUNCH_ANGLE_FT * FT_M]
    fixed = [ARROWS_FT, *ENTRY_FT]
    xs = {x for x in rel if x < lane.length_m} | {lane.ft_to_x_m(ft) for ft in fixed}
    return sorted(x for x in xs if x > release_x_m)


def observed_run(plan: Any, lane: BowlerLane) -> Trajectory:
    """Simulate ``plan`` (any recording) observing what :func:`bowler_report` reads."""
    from bowlrec.core.solver import run_plan

    x0 = float(plan.position0_m[0])
    return run_plan(plan, "auto", report_stations(lane, x0), turns=True)


def bowler_report(
    trajectory: Trajectory, lane: BowlerLane, handedness: Handedness = "right"
) -> BowlerReport:
    """The bowler's report of ``trajectory`` on ``lane`` by ``handedness`` (module doc), from
    its observations when it has them (:func:`observed_run`), else from its samples.

    Raises :class:`~bowlrec.errors.SamplesRequiredError` for a run with neither (a
    summary-only run simulated without observations)."""
    track: _Track = (
        _Observed.of(trajectory) if _Observed.usable(trajectory) else _Path.of(trajectory)
    )
    release = track.release()
    x0 = release.x
    arrows = track.at_x(lane.ft_to_x_m(ARROWS_FT))
    breakpoint_ = track.outermost(handedness)
    pins = track.at_x(lane.length_m)
    slide = trajectory.summary.slide_m

    def board(s: _State) -> float:
        return lane.y_to_board(s.y, handedness)

    def chord_angle(a: _State | None, b: _State | None) -> float | None:
        if a is None or b is None or not b.x > a.x:
            return None
        heading = math.degrees(math.atan2(b.y - a.y, b.x - a.x))
        return heading if handedness == "right" else -heading

    def chord_speed(a: _State | None, b: _State | None) -> float | None:
        if a is None or b is None or not b.t > a.t:
            return None
        return math.hypot(b.x - a.x, b.y - a.y) / (b.t - a.t) / MPH_MPS

    def at_ft(ft: float) -> _State | None:
        return track.at_x(lane.ft_to_x_m(ft))

    e59 = at_ft(59.5)
    rot0, tilt0 = _axis(release, handedness)
    rot_b, tilt_b = _axis(breakpoint_, handedness)
    rot_p, tilt_p = (None, None) if pins is None else _axis(pins, handedness)
    return BowlerReport(
        handedness=handedness,
        outcome=trajectory.summary.outcome,
        laydown_board=board(release),
        laydown_ft=release.x / FT_M,
        launch_speed_mph=_speed_mph(release),
        launch_angle_deg=_angle_to_boards_deg(release, handedness),
        rev_rate_release_rpm=_rev_rate_rpm(release),
        axis_rotation_release_deg=rot0,
        axis_tilt_release_deg=tilt0,
        arrows_board=None if arrows is None else board(arrows),
        breakpoint_board=board(breakpoint_),
        breakpoint_ft=breakpoint_.x / FT_M,
        axis_rotation_breakpoint_deg=rot_b,
        axis_tilt_breakpoint_deg=tilt_b,
        entry_board=None if pins is None else board(pins),
        entry_angle_deg=None if pins is None else _angle_to_boards_deg(pins, handedness),
        entry_speed_mph=None if pins is None else _speed_mph(pins),
        rev_rate_pins_rpm=None if pins is None else _rev_rate_rpm(pins),
        axis_rotation_pins_deg=rot_p,
        axis_tilt_pins_deg=tilt_p,
        hook_boards=None if pins is None else board(pins) - board(breakpoint_),
        slide_ft=None if slide is None else slide / FT_M,
        specto_launch_speed_mph=chord_speed(release, track.at_x(x0 + LAUNCH_SPEED_FT * FT_M)),
        specto_launch_angle_deg=chord_angle(release, track.at_x(x0 + LAUNCH_ANGLE_FT * FT_M)),
        specto_entry_angle_deg=chord_angle(at_ft(51.0), at_ft(55.0)),
        specto_entry_board=None if e59 is None else board(e59),
        specto_entry_speed_mph=chord_speed(at_ft(57.0), e59),
        specto_impact_angle_deg=chord_angle(at_ft(57.0), e59),
    )


class _Track(Protocol):
    """Where the center was: at release, where it reached an x, where it was outermost."""

    def release(self) -> _State: ...

    def at_x(self, x: float) -> _State | None: ...

    def outermost(self, handedness: Handedness) -> _State: ...


def _speed_mph(s: _State) -> float:
    """Speed of the center (mph)."""
    return math.hypot(s.vx, s.vy) / MPH_MPS


def _rev_rate_rpm(s: _State) -> float:
    """|omega| (rpm)."""
    return math.sqrt(sum(w * w for w in s.omega)) / RPM_RADPS


def _heading_deg(s: _State) -> float:
    """Angle of the velocity to +x (deg), positive toward +y (the left)."""
    return math.degrees(math.atan2(s.vy, s.vx))


def _angle_to_boards_deg(s: _State, handedness: Handedness) -> float:
    """Angle of the velocity to the boards (deg), positive toward higher boards."""
    heading = _heading_deg(s)
    return heading if handedness == "right" else -heading


def _axis(s: _State, handedness: Handedness) -> tuple[float, float]:
    """(axis rotation, axis tilt) in degrees relative to the current direction of travel."""
    return axis_angles_deg(s.omega, _heading_deg(s), handedness)


def _hermite(p0: float, p1: float, m0: float, m1: float) -> tuple[float, float, float, float]:
    """Coefficients (a0, a1, a2, a3) of p(s) = a0 + a1 s + a2 s^2 + a3 s^3 on s in [0, 1] with
    p(0) = p0, p(1) = p1, p'(0) = m0, p'(1) = m1 (m = velocity times the step length)."""
    d = p1 - p0
    return p0, m0, 3.0 * d - 2.0 * m0 - m1, -2.0 * d + m0 + m1


def _poly(a: tuple[float, float, float, float], s: float) -> float:
    """a0 + a1 s + a2 s^2 + a3 s^3."""
    return a[0] + s * (a[1] + s * (a[2] + s * a[3]))


def _dpoly(a: tuple[float, float, float, float], s: float) -> float:
    """d/ds of :func:`_poly`."""
    return a[1] + s * (2.0 * a[2] + s * 3.0 * a[3])


def _critical_points(a: tuple[float, float, float, float]) -> list[float]:
    """Roots in (0, 1) of the derivative of the cubic ``a`` (a quadratic)."""
    qa, qb, qc = 3.0 * a[3], 2.0 * a[2], a[1]
    if qa == 0.0:
        roots = [] if qb == 0.0 else [-qc / qb]
    else:
        disc = qb * qb - 4.0 * qa * qc
        if disc < 0.0:
            return []
        r = math.sqrt(disc)
        # numerically stable pair of roots
        q = -0.5 * (qb + math.copysign(r, qb))
        roots = [q / qa] + ([qc / q] if q != 0.0 else [])
    return [s for s in roots if 0.0 < s < 1.0]


class _Path:
    """Samples of the center's path with Hermite interpolation on each step."""

    def __init__(
        self,
        t: NDArray[np.float64],
        pos: NDArray[np.float64],
        vel: NDArray[np.float64],
        omega: NDArray[np.float64],
    ) -> None:
        self.t, self.pos, self.vel, self.omega = t, pos, vel, omega

    @classmethod
    def of(cls, trajectory: Trajectory) -> _Path:
        """The path of a recorded trajectory; :class:`~bowlrec.errors.SamplesRequiredError`
        if it has no samples."""
        if trajectory.n_samples == 0:
            raise SamplesRequiredError(
                "the trajectory has no samples (it was recorded with options.record = "
                "'summary'); a bowler's report interpolates the path: record 'steps' or 'rate'"
            )
        return cls(
            np.asarray(trajectory.t_s, dtype=np.float64),
            np.asarray(trajectory.position_m, dtype=np.float64),
            np.asarray(trajectory.velocity_mps, dtype=np.float64),
            np.asarray(trajectory.omega_radps, dtype=np.float64),
        )

    def _coeffs(self, i: int, k: int) -> tuple[float, float, float, float]:
        """Hermite coefficients of coordinate k (0: x, 1: y) on step [i, i + 1]."""
        h = float(self.t[i + 1] - self.t[i])
        return _hermite(
            float(self.pos[i, k]),
            float(self.pos[i + 1, k]),
            h * float(self.vel[i, k]),
            h * float(self.vel[i + 1, k]),
        )

    def state(self, i: int, s: float) -> _State:
        """The state at fraction ``s`` in [0, 1] of step [i, i + 1] (s = 0: sample i)."""
        if s == 0.0:
            return _State(
                float(self.t[i]),
                float(self.pos[i, 0]),
                float(self.pos[i, 1]),
                float(self.vel[i, 0]),
                float(self.vel[i, 1]),
                (float(self.omega[i, 0]), float(self.omega[i, 1]), float(self.omega[i, 2])),
            )
        h = float(self.t[i + 1] - self.t[i])
        ax, ay = self._coeffs(i, 0), self._coeffs(i, 1)
        w = (1.0 - s) * self.omega[i] + s * self.omega[i + 1]
        return _State(
            float(self.t[i]) + s * h,
            _poly(ax, s),
            _poly(ay, s),
            _dpoly(ax, s) / h,
            _dpoly(ay, s) / h,
            (float(w[0]), float(w[1]), float(w[2])),
        )

    def release(self) -> _State:
        return self.state(0, 0.0)

    def at_x(self, x: float) -> _State | None:
        """The state where the center first reaches ``x`` (m), or None if it never does or
        starts beyond it."""
        xs = self.pos[:, 0]
        reached = np.flatnonzero(xs >= x)
        if reached.size == 0:
            return None
        j = int(reached[0])
        if xs[j] == x:
            return self.state(j, 0.0)
        if j == 0:
            return None
        return self.state(j - 1, self._solve_x(j - 1, x))

    def _solve_x(self, i: int, x: float) -> float:
        """Fraction s of step [i, i + 1] where the interpolated x equals ``x`` (bisection;
        x(0) < x < x(1))."""
        a = self._coeffs(i, 0)
        lo, hi = 0.0, 1.0
        for _ in range(_BISECTIONS):
            mid = 0.5 * (lo + hi)
            if _poly(a, mid) < x:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    def outermost(self, handedness: Handedness) -> _State:
        """The point farthest toward the bowling hand's gutter: minimum y for a right-hander,
        maximum y for a left-hander."""
        return self.state(*self._outermost(handedness))

    def _outermost(self, handedness: Handedness) -> tuple[int, float]:
        sign = 1.0 if handedness == "right" else -1.0
        u = sign * self.pos[:, 1]
        k = int(np.argmin(u))
        best = (k, 0.0)
        best_u = float(u[k])
        for i in (k - 1, k):
            if not 0 <= i < len(self.t) - 1 or self.t[i + 1] == self.t[i]:
                continue
            a = self._coeffs(i, 1)
            for s in _critical_points(a):
                us = sign * _poly(a, s)
                if us < best_u:
                    best, best_u = (i, s), us
        return best


class _Observed:
    """The kernel's observations of a run: release, stations, turning points, last state."""

    def __init__(self, trajectory: Trajectory) -> None:
        obs = trajectory.observations
        self._release = next(_observed_state(o) for o in obs if o.station == OBS_RELEASE)
        self._end = next(_observed_state(o) for o in obs if o.station == OBS_END)
        self._pins = trajectory.summary.outcome == "pins"
        self._stations = sorted(
            (_observed_state(o) for o in obs if o.station >= 0), key=lambda s: s.x
        )
        self._turns = [_observed_state(o) for o in obs if o.station == OBS_TURN]

    @staticmethod
    def usable(trajectory: Trajectory) -> bool:
        """The run was simulated observing (it has its release and last state)."""
        kinds = {o.station for o in trajectory.observations}
        return OBS_RELEASE in kinds and OBS_END in kinds

    @classmethod
    def of(cls, trajectory: Trajectory) -> _Observed:
        return cls(trajectory)

    def release(self) -> _State:
        return self._release

    def at_x(self, x: float) -> _State | None:
        """The observed state at station ``x`` (the pins: the run's last state when it ended
        there); None where the path did not reach it or it was not observed."""
        if self._pins and abs(x - self._end.x) <= _AT_END_M:
            return self._end
        if x == self._release.x:
            return self._release
        for s in self._stations:
            if s.x == x:
                return s
        return None

    def outermost(self, handedness: Handedness) -> _State:
        """The release, a turning point or the last state, whichever is farthest toward the
        bowling hand's gutter (ties: the earliest)."""
        sign = 1.0 if handedness == "right" else -1.0
        candidates = [self._release, *sorted(self._turns, key=lambda s: s.t), self._end]
        return min(candidates, key=lambda s: sign * s.y)


def _observed_state(o: Any) -> _State:
    return _State(
        o.t_s, o.position_m[0], o.position_m[1], o.velocity_mps[0], o.velocity_mps[1],
        o.omega_radps,
    )  # fmt: skip

"""Comparison methods for the work-precision benchmark: the same equations, other integrators.

Every method takes a :class:`~bowlrec.core.plan.Plan` and returns a dict with the keys

    outcome ("pins", "gutter", "stopped", "airborne", "max_time", "stalled", ...),
    slide_m (x where rolling first starts, None if never), hook_m, pocket_deg (None unless the
    ball reaches the pins), time_s, x_end_m, y_end_m, n_rhs (right-hand-side evaluations),

plus method-specific bookkeeping (``n_segments``/``n_steps``/``n_events``).

* :func:`bowlrec_solve`: bowlrec itself (``bowlrec.core.solver.solve``).
* :func:`scipy_solve`: ``scipy.integrate.solve_ivp`` (RK45, DOP853, LSODA) on bowlrec's compiled
  right-hand side ``rhs``, segment by segment with terminal events (slip zero, friction-cell
  boundaries, pins, gutters, vx = 0, normal force 0, friction reserve of the rolling ball).
* :func:`dop853_compiled`: the same DOP853 run as ``scipy_solve(plan, "DOP853")`` compiled into
  one numba kernel (:mod:`benchmarks.dop853_kernel`: scipy's tableau, error norm, step control,
  dense output and ``solve_ivp``'s event location, with the same right-hand side, segments and
  events; no Python per right-hand side). ``run_method("DOP853-compiled", plan, rtol)`` times it
  as the median of ``REPEATS`` kernel calls after a warm-up call (compile / cache load excluded).
* :func:`paper_scheme`: the paper's scheme, fixed-step classical RK4 with the 1 cm/s
  slide -> roll rule, as a numba kernel on the same ``rhs`` (:mod:`bowlrec.testing.rk4`, with
  the common result dict and the slip-zeroing impulse that ``scipy_solve`` shares).

The right-hand side is bowlrec's ``rhs(y, par, phase, mu, ux_ref, uy_ref, orient, dy)`` with
``par = kernel_params(plan)``; only PHASE_SLIDE and PHASE_ROLL are used. Note that ``rhs`` in
PHASE_SLIDE lets friction act along the *slaved* direction whenever |s| < s_layer / 2
(``par``'s slip-layer speed, tied to the tolerance by
``bowlrec.core.arguments.slip_layer``): that is part of the right-hand side, and the only way
it is defined at s = 0.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
import time
from typing import Any

import numpy as np

from bowlrec.core.arguments import (
    initial_state,
    kernel_params,
    needs_orientation,
    restart_layer,
    slip_layer,
)
from bowlrec.core.codes import PHASE_ROLL, PHASE_SLIDE, RECORD_SUMMARY
from bowlrec.core.dynamics import rhs, roll_accel, slaved_direction, slip
from bowlrec.core.plan import Plan
from bowlrec.core.solver import solve
from bowlrec.testing.rk4 import paper_scheme
from bowlrec.testing.rk4 import remove_slip_impulse as _remove_slip_impulse
from bowlrec.testing.rk4 import result_dict as _result
from bowlrec.testing.rk4 import summary_plan as _summary_plan

__all__ = [
    "METHODS",
    "REPEATS",
    "bowlrec_solve",
    "dop853_compiled",
    "paper_scheme",
    "run_method",
    "scipy_solve",
]


# --------------------------------------------------------------------------------------------
# bowlrec
# --------------------------------------------------------------------------------------------


def bowlrec_solve(plan: Plan, rtol: float = 1e-9) -> dict[str, Any]:
    """bowlrec's own solver at tolerance ``rtol`` (summary only)."""
    s = solve(dataclasses.replace(plan, rtol=float(rtol), record_mode=RECORD_SUMMARY)).summary
    return {
        "outcome": s.outcome,
        "slide_m": s.slide_m,
        "hook_m": s.hook_m,
        "pocket_deg": s.pocket_deg,
        "time_s": s.time_s,
        "x_end_m": s.x_end_m,
        "y_end_m": s.y_end_m,
        "n_rhs": s.n_rhs,
        "n_steps": s.n_steps,
        "n_events": s.n_events,
    }


# --------------------------------------------------------------------------------------------
# scipy.integrate.solve_ivp, segment by segment
# --------------------------------------------------------------------------------------------


class _Rhs:
    """Thin Python wrapper of the compiled ``rhs`` for one segment (fixed phase, mu, u_ref).

    Remembers (n, margin, ux, uy) at the last state it was called with, so the event functions
    that need the dynamics (normal force, friction reserve, friction direction) reuse the
    evaluation at a step end (RK45 and DOP853 evaluate f there: first same as last)."""

    def __init__(self, par: np.ndarray, orient: bool) -> None:
        self.par = par
        self.orient = bool(orient)
        self.phase = PHASE_SLIDE
        self.mu = 0.0
        self.uxr = 1.0
        self.uyr = 0.0
        self.n_rhs = 0
        self._t = math.nan
        self._y = np.full(11, np.nan)
        self._r: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    def set(self, phase: int, mu: float, uxr: float, uyr: float) -> None:
        self.phase = int(phase)
        self.mu = float(mu)
        self.uxr = float(uxr)
        self.uyr = float(uyr)
        self._t = math.nan

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        y = np.ascontiguousarray(y, dtype=np.float64)
        dy = np.empty(11)
        r = rhs(y, self.par, self.phase, self.mu, self.uxr, self.uyr, self.orient, dy)
        self.n_rhs += 1
        self._t = t
        self._y = y.copy()
        self._r = (r[0], r[1], r[2], r[3])
        return dy

    def dyn(self, t: float, y: np.ndarray) -> tuple[float, float, float, float]:
        """rhs's (n, margin, ux, uy) at (t, y), from the cache when possible."""
        if not (t == self._t and np.array_equal(y, self._y)):
            self(t, y)
        return self._r


def _event(fun: Any, direction: float) -> Any:
    fun.terminal = True
    fun.direction = direction
    return fun


def _rolling_reserve(y: np.ndarray, par: np.ndarray, mu: float) -> tuple[float, float, float]:
    """(mu n - |f|, fx / |f|, fy / |f|) of the ball if it rolled at state y."""
    r = roll_accel(y, par)
    fx, fy, n = r[5], r[6], r[7]
    fn = math.hypot(fx, fy)
    if fn > 0.0:
        return mu * n - fn, fx / fn, fy / fn
    return mu * n, 1.0, 0.0


#: dense samples per step on which a rolling segment's reserve and normal force are scanned
N_SCAN = 4


def _scan_rolling(sol: Any, f: _Rhs, margin_tol: float) -> tuple[float, np.ndarray, str] | None:
    """First dip of the friction reserve below -margin_tol (or of n below 0) strictly inside a
    step of a rolling segment, located by Brent's method on the dense output; None if none."""
    from scipy.optimize import brentq

    def g(tt: float) -> tuple[float, float]:
        yy = np.ascontiguousarray(sol.sol(tt))
        r = f.dyn(tt, yy)
        return r[1] + margin_tol, r[0]

    ts = sol.t
    for i in range(len(ts) - 1):
        ta = float(ts[i])
        h = float(ts[i + 1]) - ta
        for j in range(1, N_SCAN):
            tb = ta + h * j / N_SCAN
            m, n = g(tb)
            if m < 0.0 or n <= 0.0:
                idx = 0 if m < 0.0 else 1
                kind = "reserve" if idx == 0 else "airborne"
                lo = ta + h * (j - 1) / N_SCAN
                if g(lo)[idx] < 0.0:  # pragma: no cover - the step start is checked by scipy
                    lo = ta
                root = brentq(lambda tt, k=idx: g(tt)[k], lo, tb, xtol=1e-15)
                tr = float(root)
                return tr, np.array(sol.sol(tr), dtype=np.float64), kind
    return None


#: a sliding segment restarts when the friction direction has turned by this angle from u_ref
TURN_DEG = 30.0


def scipy_solve(
    plan: Plan,
    method: str = "DOP853",
    rtol: float = 1e-9,
    atol: float = 1e-12,
    *,
    s_layer: float | None = None,
    snap: str = "impulse",
    max_segments: int = 10_000,
    log: list | None = None,  # type: ignore[type-arg]
) -> dict[str, Any]:
    """Integrate the plan with ``scipy.integrate.solve_ivp`` (``method`` RK45, DOP853, LSODA...).

    The trajectory is split into segments of fixed phase, friction coefficient and reference
    direction u_ref; each ends at the first terminal event:

    * sliding with |s| > s_layer / 2 (Coulomb friction along s; u_ref = slip direction at the
      segment start): s . u_ref = cos(30 deg) |s| -> restart with the new slip direction (so
      u_ref is never stale: the slip direction can turn by > 100 deg within microseconds as
      |s| -> 0, e.g. in the stick-slip of case 18); |s| = s_layer / 2 -> the slip enters the
      layer; s . u_ref = 0 -> slip zero (only reachable through the layer).
    * sliding in the layer, entered at |s| = s_layer / 2 and left at |s| = s_restart (bowlrec's
      hysteresis; ``rhs`` gets twice the exit speed in these segments, so it lets friction
      act along the slaved direction for |s| < s_restart; without the hysteresis a slip whose
      direction is still turning at the layer edge chatters across it with zero-length
      segments), found by Newton's method from u_ref; u_ref = the slaved direction found from
      the slip direction at the layer entry, as bowlrec does: s . u_ref = 0 -> slip zero;
      u . u_ref = cos(30 deg) (u: the friction direction ``rhs`` uses) -> restart with
      u_ref = u, so the Newton start tracks the root (from a stale u_ref Newton can converge
      to the other root and the slip then chatters at |s| = s_layer / 2 for millions of
      right-hand sides); |s| = s_restart (growing; ``arguments.restart_layer``) -> back to
      Coulomb.
    * slip zero: the residual slip (< s_layer) is set to exactly 0 (``snap="impulse"``:
      by a contact impulse, as bowlrec does; ``"velocity"``: v = R_con x w, omega unchanged,
      which moves v by up to s_layer / 2 and the hook by ~ that times the remaining time,
      e.g. 1e-8 m at rtol 1e-11 but 1e-4 m at rtol 1e-8) and the ball rolls if the friction
      reserve of the rolling ball is >= -rtol g; else it keeps sliding from zero slip (slip
      reversal) in the layer, along the slaved direction found from the direction of the
      friction the rolling ball needed.
    * rolling: friction reserve mu n - |f| < -rtol g -> sliding (slip reversal as above).
    * both: x or y crossing an edge of the current friction cell (new mu; a rolling ball
      re-checks its friction reserve), pins x = L, gutters y = 0 / y = W, vx = 0, n = 0.

    The state at an event is solve_ivp's dense output at the located root; the quaternion is
    renormalized at every segment end. ``s_layer`` (m/s): slip speed of ``rhs``'s slaved
    layer; None ties it to ``rtol`` as bowlrec does (``bowlrec.core.arguments.slip_layer``).
    ``n_rhs`` counts every call of the compiled ``rhs`` (by the solver and by the event
    functions). More than ``max_segments`` segments -> outcome "stalled". ``log``: if a list,
    one dict per segment end (event, time, slip, solver evaluations, state) is appended.
    """
    from scipy.integrate import solve_ivp

    if snap not in ("velocity", "impulse"):
        raise ValueError(f"snap = {snap!r} must be 'velocity' or 'impulse'")
    p = _summary_plan(plan, rtol, s_layer)
    par = kernel_params(p)
    s_lay = slip_layer(p)
    s_rst = restart_layer(p)
    # inside the layer rhs gets twice the exit speed: slaved friction up to |s| = s_restart
    # (bowlrec's hysteresis: enter at s_layer / 2, leave at s_restart)
    par_layer = kernel_params(dataclasses.replace(p, slip_layer_mps=2.0 * s_rst))
    orient = needs_orientation(p)
    R = float(p.radius_m)
    L = float(p.lane_length_m)
    W = float(p.lane_width_m)
    xe = np.asarray(p.friction_x_edges_m, dtype=np.float64)
    ye = np.asarray(p.friction_y_edges_m, dtype=np.float64)
    mug = np.asarray(p.friction_mu, dtype=np.float64)
    margin_tol = float(rtol) * float(p.g_mps2)
    s_zero = 0.6 * s_lay  # a slip event in a Coulomb segment below this is a slip zero
    cos_turn = math.cos(math.radians(TURN_DEG))
    t_max = float(p.max_time_s)

    y = initial_state(p)
    t = 0.0
    ix = int(np.searchsorted(xe, y[0], side="right"))
    iy = int(np.searchsorted(ye, y[1], side="right"))
    mu = float(mug[ix, iy])
    phase = PHASE_SLIDE
    layer = False  # sliding inside the slaved-direction layer (entered at s_layer / 2)
    uxr, uyr = 1.0, 0.0
    slide_x: float | None = None
    sx, sy = slip(y, par)
    if sx == 0.0 and sy == 0.0:
        reserve, fx, fy = _rolling_reserve(y, par, mu)
        if reserve >= -margin_tol:
            phase = PHASE_ROLL
            slide_x = float(y[0])
        else:
            layer = True
            uxr, uyr = slaved_direction(y, par, mu, fx, fy)
    f = _Rhs(par, orient)
    n_seg = 0
    n_ev = 0
    outcome = None
    while outcome is None:
        if n_seg >= max_segments:
            outcome = "stalled"
            break
        if t >= t_max:
            outcome = "max_time"
            break
        if phase == PHASE_SLIDE and not layer:
            sx, sy = slip(y, par)
            s = math.hypot(sx, sy)
            uxr, uyr = sx / s, sy / s
        f.par = par_layer if (phase == PHASE_SLIDE and layer) else par
        f.set(phase, mu, uxr, uyr)
        if f.dyn(t, y)[0] <= 0.0:
            outcome = "airborne"
            break
        n_seg += 1
        evs: list[tuple[str, Any]] = [
            ("pins", _event(lambda t, y: y[0] - L, 1.0)),
            ("gutter", _event(lambda t, y: y[1], -1.0)),
            ("gutter", _event(lambda t, y: y[1] - W, 1.0)),
            ("stopped", _event(lambda t, y: y[2], -1.0)),
            ("airborne", _event(lambda t, y: f.dyn(t, y)[0], -1.0)),
        ]
        if ix < xe.size:
            xh = float(xe[ix])
            evs.append(("x+", _event(lambda t, y, e=xh: y[0] - e, 1.0)))
        if ix > 0:
            xl = float(xe[ix - 1])
            evs.append(("x-", _event(lambda t, y, e=xl: y[0] - e, -1.0)))
        if iy < ye.size:
            yh = float(ye[iy])
            evs.append(("y+", _event(lambda t, y, e=yh: y[1] - e, 1.0)))
        if iy > 0:
            yl = float(ye[iy - 1])
            evs.append(("y-", _event(lambda t, y, e=yl: y[1] - e, -1.0)))
        if phase == PHASE_SLIDE:
            a, b = uxr, uyr
            evs.append(
                (
                    "slip",
                    _event(
                        lambda t, y, a=a, b=b: (R * y[9] - y[2]) * a + (-R * y[8] - y[3]) * b, -1.0
                    ),
                )
            )

            def smag(
                t: float, y: np.ndarray, level: float = s_rst if layer else 0.5 * s_lay
            ) -> float:
                return math.hypot(R * y[9] - y[2], -R * y[8] - y[3]) - level

            if layer:
                evs.append(("exit", _event(smag, 1.0)))
                evs.append(
                    (
                        "turn",
                        _event(
                            lambda t, y, a=a, b=b: (lambda r: r[2] * a + r[3] * b - cos_turn)(
                                f.dyn(t, y)
                            ),
                            -1.0,
                        ),
                    )
                )
            else:
                evs.append(("enter", _event(smag, -1.0)))
                evs.append(
                    (
                        "cturn",
                        _event(
                            lambda t, y, a=a, b=b: (
                                (R * y[9] - y[2]) * a
                                + (-R * y[8] - y[3]) * b
                                - cos_turn * math.hypot(R * y[9] - y[2], -R * y[8] - y[3])
                            ),
                            -1.0,
                        ),
                    )
                )
        else:
            evs.append(("reserve", _event(lambda t, y: f.dyn(t, y)[1] + margin_tol, -1.0)))
        rolling = phase == PHASE_ROLL
        sol = solve_ivp(
            f,
            (t, t_max),
            y,
            method=method,
            rtol=rtol,
            atol=atol,
            events=[e for _, e in evs],
            dense_output=rolling,
        )
        if sol.status == -1:
            outcome = "stalled"
            break
        t = float(sol.t[-1])
        y = np.array(sol.y[:, -1], dtype=np.float64)
        # the terminal event: the earliest root (solve_ivp keeps events up to the first terminal)
        kind = None
        t_best = math.inf
        for (k, _), te in zip(evs, sol.t_events, strict=True):
            if te.size and te[0] < t_best:
                t_best = float(te[0])
                kind = k
        if rolling:
            # solve_ivp sees an event only as a sign change between step ends; the friction
            # reserve can dip below zero for less than a step (a short slip episode of a few
            # cm, missed by DOP853's long steps): scan the dense output inside every step
            hit = _scan_rolling(sol, f, margin_tol)
            if hit is not None:
                t, y, kind = hit[0], hit[1], hit[2]
        if orient:
            y[4:8] /= np.linalg.norm(y[4:8])
        if kind is None:
            outcome = "max_time"
            break
        n_ev += 1
        if log is not None:
            sx, sy = slip(y, par)
            log.append(
                {
                    "segment": n_seg,
                    "phase": phase,
                    "layer": layer,
                    "mu": mu,
                    "t": t,
                    "event": kind,
                    "slip": math.hypot(sx, sy),
                    "nfev": sol.nfev,
                    "y": y.copy(),
                }
            )
        if kind in ("pins", "gutter", "stopped", "airborne"):
            outcome = kind
            break
        if kind in ("x+", "x-", "y+", "y-"):
            ix += 1 if kind == "x+" else -1 if kind == "x-" else 0
            iy += 1 if kind == "y+" else -1 if kind == "y-" else 0
            mu = float(mug[ix, iy])
            if phase == PHASE_ROLL:
                reserve, fx, fy = _rolling_reserve(y, par, mu)
                if reserve < -margin_tol:
                    phase, layer = PHASE_SLIDE, True
                    uxr, uyr = slaved_direction(y, par, mu, fx, fy)
            elif layer:
                uxr, uyr = slaved_direction(y, par, mu, uxr, uyr)
        elif kind in ("slip", "cturn"):
            sx, sy = slip(y, par)
            if layer or math.hypot(sx, sy) <= s_zero:
                if snap == "impulse":
                    _remove_slip_impulse(y, par)
                else:
                    y[2] = R * y[9]
                    y[3] = -R * y[8]
                reserve, fx, fy = _rolling_reserve(y, par, mu)
                if reserve >= -margin_tol:
                    phase = PHASE_ROLL
                    layer = False
                    if slide_x is None:
                        slide_x = float(y[0])
                else:  # slip reversal: the ball cannot stick
                    layer = True
                    uxr, uyr = slaved_direction(y, par, mu, fx, fy)
            # else: the slip turned by 30 deg; the next segment restarts with its direction
        elif kind == "enter":
            sx, sy = slip(y, par)
            s = math.hypot(sx, sy)
            layer = True
            uxr, uyr = slaved_direction(y, par, mu, sx / s, sy / s)
        elif kind == "exit":
            layer = False
        elif kind == "turn":
            uxr, uyr = f.dyn(t, y)[2:4]
        elif kind == "reserve":
            _, fx, fy = _rolling_reserve(y, par, mu)
            phase, layer = PHASE_SLIDE, True
            uxr, uyr = slaved_direction(y, par, mu, fx, fy)
        else:  # pragma: no cover
            raise RuntimeError(f"unexpected event {kind!r}")
    return _result(p, outcome, slide_x, t, y, f.n_rhs, n_segments=n_seg, n_events=n_ev)


# --------------------------------------------------------------------------------------------
# scipy's DOP853 compiled
# --------------------------------------------------------------------------------------------


def dop853_compiled(
    plan: Plan,
    rtol: float = 1e-9,
    atol: float | None = None,
    *,
    s_layer: float | None = None,
    snap: str = "impulse",
    max_segments: int = 10_000,
) -> dict[str, Any]:
    """``scipy_solve(plan, "DOP853", rtol, atol)`` compiled (:mod:`benchmarks.dop853_kernel`):
    the same method, right-hand side, segments and events; atol None -> 0.1 rtol. The result
    dict adds n_steps (accepted), n_rejected, n_segments, n_events and ``events`` (event name ->
    how many segments it ended)."""
    from .dop853_kernel import solve_dop853

    return solve_dop853(plan, rtol, atol, s_layer=s_layer, snap=snap, max_segments=max_segments)


def _time_dop853_compiled(plan: Plan, tol: float, repeats: int) -> dict[str, Any]:
    """Run the compiled DOP853 once (this call compiles or loads the kernel) and time
    ``repeats`` further kernel calls on arguments prepared beforehand: ``wall_s`` is their
    median, ``wall_repeats_s`` all of them."""
    from .dop853_kernel import _kernel, kernel_args, result

    p, args = kernel_args(plan, tol, 0.1 * tol)
    out = result(p, _kernel(*args))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        _kernel(*args)
        times.append(time.perf_counter() - t0)
    out["wall_s"] = statistics.median(times)
    out["wall_repeats_s"] = times
    return out


# --------------------------------------------------------------------------------------------
# uniform entry point
# --------------------------------------------------------------------------------------------

#: name -> callable(plan, tol) used by the benchmark drivers; tol is rtol for bowlrec and the
#: scipy methods (atol = 0.1 rtol: the state is O(1-10) in SI, bowlrec scales its error by
#: rtol (1 + |y|)) and the step dt (s) for the paper's scheme
METHODS = {
    "bowlrec": lambda plan, tol: bowlrec_solve(plan, tol),
    "RK45": lambda plan, tol: scipy_solve(plan, "RK45", tol, 0.1 * tol),
    "DOP853": lambda plan, tol: scipy_solve(plan, "DOP853", tol, 0.1 * tol),
    "LSODA": lambda plan, tol: scipy_solve(plan, "LSODA", tol, 0.1 * tol),
    "DOP853-compiled": lambda plan, tol: dop853_compiled(plan, tol, 0.1 * tol),
    "paper": lambda plan, tol: paper_scheme(plan, tol),
}


#: default number of timed runs per delivery in :func:`run_method` (the median is reported)
REPEATS = {"DOP853-compiled": 5}


def run_method(name: str, plan: Plan, tol: float, repeats: int | None = None) -> dict[str, Any]:
    """Run one method and add its wall-clock time ``wall_s`` (s per delivery).

    ``repeats`` (default ``REPEATS.get(name, 1)``) > 1: ``wall_s`` is the median of that many
    runs, all of them in ``wall_repeats_s``. "DOP853-compiled" is run once untimed first (numba
    compiles or loads its kernel then) and its repeats time the kernel call alone, on arguments
    prepared beforehand (as the work-precision benchmark times bowlrec's kernel); the other
    methods time the whole call, Python included.
    """
    n = REPEATS.get(name, 1) if repeats is None else int(repeats)
    if n < 1:
        raise ValueError(f"repeats = {n} must be >= 1")
    if name == "DOP853-compiled":
        return _time_dop853_compiled(plan, tol, n)
    times = []
    out: dict[str, Any] = {}
    for _ in range(n):
        t0 = time.perf_counter()
        out = METHODS[name](plan, tol)
        times.append(time.perf_counter() - t0)
    out["wall_s"] = statistics.median(times)
    if n > 1:
        out["wall_repeats_s"] = times
    return out

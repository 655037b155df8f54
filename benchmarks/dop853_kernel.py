"""scipy's DOP853 compiled with numba: ``benchmarks.methods.scipy_solve(plan, "DOP853")`` as one
numba kernel, for a fair comparison of bowlrec's compiled kernel with DOP853 (issue 32, item 6).

What it is: a line-by-line port of what ``scipy_solve(plan, "DOP853", rtol, atol)`` runs, with
the same right-hand side (bowlrec's compiled ``rhs``, called directly instead of through a Python
wrapper and ``solve_ivp``), the same segments and the same events:

* the integrator is scipy's DOP853 (``scipy.integrate._ivp.rk.DOP853``, Hairer's DOP853 as
  scipy implements it): the tableau is imported from ``scipy.integrate._ivp.dop853_coefficients``
  (A, B, C, E3, E5, D); scipy's initial step (``select_initial_step``, error-estimator order 7),
  scipy's error norm (the 5th/3rd-order blend of ``DOP853._estimate_error_norm``), scipy's step
  control (safety 0.9, factors 0.2 .. 10, exponent -1/8, no increase right after a rejection,
  the minimum step ``10 ulp(t)``) and scipy's 7th-order dense output (3 extra stages, the
  ``Dop853DenseOutput`` polynomial);
* events as ``solve_ivp`` handles them: every event function is evaluated at every step end; a
  sign change in the event's direction (``find_active_events``) is located by Brent's method
  (a port of scipy's ``brentq``, xtol = rtol = 4 eps) on the dense output; the earliest root of
  the step ends the segment (all events are terminal);
* the segments and events of ``scipy_solve`` (read its docstring): pins x = L, gutters y = 0 /
  y = W, vx = 0, n = 0, friction-cell edges in x and y, and while sliding the slip zero
  (s . u_ref = 0), the 30 degree turn of the slip (Coulomb) or of the friction direction (in
  the slip layer), the layer's entry at |s| = s_layer / 2 and exit at |s| = s_restart
  (``arguments.slip_layer`` and ``restart_layer``, as bowlrec's; ``lay`` holds both); slip
  zero -> the contact impulse that zeroes the slip, then rolling if the rolling ball's friction
  reserve is >= -rtol g, else sliding again along the slaved direction; while rolling the friction
  reserve mu n - |f| < -rtol g -> sliding, found at step ends and, as ``scipy_solve`` does, by
  scanning the dense output at 3 interior points of every step (``N_SCAN``) with Brent's method on
  the bracket. The state at an event is the dense output at the root; the quaternion is
  renormalized at every segment end.

Differences from the interpreted run, none of which changes the method: ``rhs`` is evaluated
once where the Python run evaluates it twice at the same point (its segment start check and
``solve_ivp``'s first evaluation; an event function after a dense output); the rolling scan runs
after every step instead of once after the segment, so a dip found in a step ends the segment
there instead of after integrating on to the segment's terminal event (the Python run discards
those steps); sums of the tableau are plain loops instead of BLAS dot products (last-bit
differences, which can flip a step decision now and then). ``n_rhs`` counts every evaluation of
``rhs`` (stages, dense output, event functions that need the dynamics, the scan).

The kernel is cached on disk by numba (``benchmarks/__pycache__``); :func:`drop_stale_cache`
drops its entries when this file, ``bowlrec/core`` or ``bowlrec/testing/rk4.py`` (whose code it
compiles in) changed since they were written.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from scipy.integrate._ivp import dop853_coefficients as _dc

from bowlrec.core.arguments import (
    initial_state,
    kernel_params,
    needs_orientation,
    restart_layer,
    slip_layer,
)
from bowlrec.core.codes import (
    OUTCOMES,
    PHASE_ROLL,
    PHASE_SLIDE,
    STATUS_AIRBORNE,
    STATUS_GUTTER,
    STATUS_MAX_TIME,
    STATUS_PINS,
    STATUS_STALLED,
    STATUS_STOPPED,
)
from bowlrec.core.dynamics import P_R, rhs, roll_accel, slaved_direction, slip
from bowlrec.core.plan import Plan
from bowlrec.testing.rk4 import remove_slip_impulse, result_dict, summary_plan

__all__ = ["N_SCAN", "TURN_DEG", "drop_stale_cache", "kernel_args", "result", "solve_dop853"]

ROOT = Path(__file__).resolve().parents[1]
#: the stamp beside numba's cache entries: the hash of the sources the kernel was built from
STAMP = "dop853-kernel-deps.sha256"


def _dependencies() -> list[Path]:
    core = sorted((ROOT / "bowlrec" / "core").glob("*.py"))
    return [Path(__file__).resolve(), ROOT / "bowlrec" / "testing" / "rk4.py", *core]


def drop_stale_cache() -> bool:
    """Drop this module's numba cache entries if the sources they were compiled from changed
    (numba keys them on this file only); True if entries were dropped."""
    cache = Path(__file__).resolve().parent / "__pycache__"
    h = hashlib.sha256()
    for p in _dependencies():
        h.update(str(p.relative_to(ROOT)).encode())
        h.update(p.read_bytes())
    digest = h.hexdigest()
    stamp = cache / STAMP
    if stamp.is_file() and stamp.read_text().strip() == digest:
        return False
    dropped = False
    if cache.is_dir():
        for f in list(cache.glob(f"{Path(__file__).stem}.*.nbi")) + list(
            cache.glob(f"{Path(__file__).stem}.*.nbc")
        ):
            f.unlink(missing_ok=True)
            dropped = True
    try:
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest + "\n")
    except OSError:  # pragma: no cover - a read-only checkout: numba copes alone
        pass
    return dropped


#: what the check of the cache did at import (before the kernel loads)
CACHE_DROPPED = drop_stale_cache()

# ---------------------------------------------------------------------------------------------
# scipy's DOP853: tableau and step-control constants (scipy.integrate._ivp.rk)
# ---------------------------------------------------------------------------------------------

N_STAGES = _dc.N_STAGES  # 12
N_EXT = _dc.N_STAGES_EXTENDED  # 16
A = np.ascontiguousarray(_dc.A, dtype=np.float64)  # (16, 16): the stages and the 3 extra ones
B = np.ascontiguousarray(_dc.B, dtype=np.float64)  # (12,)
C = np.ascontiguousarray(_dc.C, dtype=np.float64)  # (16,)
E3 = np.ascontiguousarray(_dc.E3, dtype=np.float64)  # (13,)
E5 = np.ascontiguousarray(_dc.E5, dtype=np.float64)  # (13,)
D = np.ascontiguousarray(_dc.D, dtype=np.float64)  # (4, 16)
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
ERROR_EXPONENT = -1.0 / (7 + 1)  # DOP853.error_estimator_order = 7
EPS = float(np.finfo(float).eps)

#: dense samples per step on which a rolling segment's reserve and normal force are scanned
N_SCAN = 4
#: a sliding segment restarts when the friction direction has turned by this angle from u_ref
TURN_DEG = 30.0

# event codes, in scipy_solve's order of its event list (ties go to the first)
EV_PINS = 0
EV_GUTTER_LO = 1
EV_GUTTER_HI = 2
EV_STOPPED = 3
EV_AIRBORNE = 4
EV_X_UP = 5
EV_X_DOWN = 6
EV_Y_UP = 7
EV_Y_DOWN = 8
EV_SLIP = 9
EV_EXIT = 10
EV_TURN = 11
EV_ENTER = 12
EV_CTURN = 13
EV_RESERVE = 14
#: the event names of scipy_solve
EVENT_NAMES = (
    "pins",
    "gutter",
    "gutter",
    "stopped",
    "airborne",
    "x+",
    "x-",
    "y+",
    "y-",
    "slip",
    "exit",
    "turn",
    "enter",
    "cturn",
    "reserve",
)
N_STATE = 11
# counters
C_RHS = 0
C_STEPS = 1
C_REJECTED = 2
C_SEGMENTS = 3
C_EVENTS = 4
#: counters[C_KINDS + code]: how often event ``code`` ended a segment
C_KINDS = 5


# ---------------------------------------------------------------------------------------------
# kernel pieces
# ---------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def _f(t, y, par, phase, mu, uxr, uyr, orient, dy, cnt):  # type: ignore[no-untyped-def]
    """One counted evaluation of bowlrec's ``rhs``; returns (n, margin, ux, uy)."""
    cnt[C_RHS] += 1
    return rhs(y, par, phase, mu, uxr, uyr, orient, dy)


@njit(cache=True, error_model="numpy")
def _reserve(y, par, mu):  # type: ignore[no-untyped-def]
    """(mu n - |f|, fx / |f|, fy / |f|) of the ball if it rolled at state y."""
    r = roll_accel(y, par)
    fx = r[5]
    fy = r[6]
    fn = math.hypot(fx, fy)
    if fn > 0.0:
        return mu * r[7] - fn, fx / fn, fy / fn
    return mu * r[7], 1.0, 0.0


@njit(cache=True, error_model="numpy")
def _needs_dyn(code):  # type: ignore[no-untyped-def]
    return code in (EV_AIRBORNE, EV_TURN, EV_RESERVE)


@njit(cache=True, error_model="numpy")
def _event_value(code, edge, y, n, margin, ux, uy, a, b, R, L, W, lay, cos_turn, margin_tol):  # type: ignore[no-untyped-def]  # fmt: skip
    """The event function ``code`` of scipy_solve at state y ((n, margin, ux, uy): ``rhs``'s
    dynamics there, used by the airborne, turn and reserve events; (a, b) = u_ref)."""
    if code == EV_PINS:
        return y[0] - L
    if code == EV_GUTTER_LO:
        return y[1]
    if code == EV_GUTTER_HI:
        return y[1] - W
    if code == EV_STOPPED:
        return y[2]
    if code == EV_AIRBORNE:
        return n
    if code in (EV_X_UP, EV_X_DOWN):
        return y[0] - edge
    if code in (EV_Y_UP, EV_Y_DOWN):
        return y[1] - edge
    sx = R * y[9] - y[2]
    sy = -R * y[8] - y[3]
    if code == EV_SLIP:
        return sx * a + sy * b
    if code == EV_EXIT:
        return math.hypot(sx, sy) - lay[1]
    if code == EV_TURN:
        return ux * a + uy * b - cos_turn
    if code == EV_ENTER:
        return math.hypot(sx, sy) - 0.5 * lay[0]
    if code == EV_CTURN:
        return sx * a + sy * b - cos_turn * math.hypot(sx, sy)
    return margin + margin_tol  # EV_RESERVE


@njit(cache=True, error_model="numpy")
def _dense_prepare(t_old, h, y_old, y_new, f_new, K, F, acc, ytmp, par, phase, mu, uxr, uyr,
                   orient, cnt):  # type: ignore[no-untyped-def]  # fmt: skip
    """scipy's ``DOP853._dense_output_impl``: the 3 extra stages into K[13:16] and the
    interpolant's coefficients F (7, n); acc, ytmp: work arrays (n,)."""
    n = y_old.shape[0]
    for s in range(N_STAGES + 1, N_EXT):
        _combine(K, A[s], s, acc)
        for i in range(n):
            ytmp[i] = y_old[i] + acc[i] * h
        _f(t_old + C[s] * h, ytmp, par, phase, mu, uxr, uyr, orient, K[s], cnt)
    for i in range(n):
        delta = y_new[i] - y_old[i]
        F[0, i] = delta
        F[1, i] = h * K[0, i] - delta
        F[2, i] = 2.0 * delta - h * (f_new[i] + K[0, i])
    for r in range(4):
        _combine(K, D[r], N_EXT, acc)
        for i in range(n):
            F[3 + r, i] = h * acc[i]


@njit(cache=True, error_model="numpy")
def _combine(K, w, m, out):  # type: ignore[no-untyped-def]
    """out = sum_{j < m} w[j] K[j] (j ascending, as a dot product adds; zero weights skipped:
    they add exact zeros)."""
    n = out.shape[0]
    for i in range(n):
        out[i] = 0.0
    for j in range(m):
        c = w[j]
        if c != 0.0:
            for i in range(n):
                out[i] += K[j, i] * c


@njit(cache=True, error_model="numpy")
def _dense_eval(t, t_old, h, y_old, F, out):  # type: ignore[no-untyped-def]
    """scipy's ``Dop853DenseOutput._call_impl`` at t into ``out``."""
    x = (t - t_old) / h
    n = y_old.shape[0]
    for i in range(n):
        v = 0.0
        for k in range(7):
            v += F[6 - k, i]
            if k % 2 == 0:
                v *= x
            else:
                v *= 1.0 - x
        out[i] = v + y_old[i]


@njit(cache=True, error_model="numpy")
def _ev_at(code, edge, t, t_old, h, y_old, F, ytmp, dy, par, phase, mu, uxr, uyr, orient, cnt,
           R, L, W, lay, cos_turn, margin_tol):  # type: ignore[no-untyped-def]  # fmt: skip
    """Event function ``code`` on the dense output at t (``rhs`` evaluated if it needs it)."""
    _dense_eval(t, t_old, h, y_old, F, ytmp)
    n = 0.0
    margin = 0.0
    ux = 0.0
    uy = 0.0
    if _needs_dyn(code):
        n, margin, ux, uy = _f(t, ytmp, par, phase, mu, uxr, uyr, orient, dy, cnt)
    return _event_value(code, edge, ytmp, n, margin, ux, uy, uxr, uyr, R, L, W, lay,
                        cos_turn, margin_tol)  # fmt: skip


@njit(cache=True, error_model="numpy")
def _scan_value(which, t, t_old, h, y_old, F, ytmp, dy, par, phase, mu, uxr, uyr, orient, cnt,
                margin_tol):  # type: ignore[no-untyped-def]  # fmt: skip
    """The rolling scan's g: which 0 -> reserve + rtol g, 1 -> n."""
    _dense_eval(t, t_old, h, y_old, F, ytmp)
    n, margin, _, _ = _f(t, ytmp, par, phase, mu, uxr, uyr, orient, dy, cnt)
    if which == 0:
        return margin + margin_tol
    return n


@njit(cache=True, error_model="numpy")
def _brent(kind, code, edge, xa, xb, xtol, rtol_b, t_old, h, y_old, F, ytmp, dy, par, phase, mu,
           uxr, uyr, orient, cnt, R, L, W, lay, cos_turn, margin_tol):  # type: ignore[no-untyped-def]  # fmt: skip
    """scipy's ``brentq`` (scipy/optimize/Zeros/brentq.c, 100 iterations) on an event function
    of the dense output: kind 0 -> event ``code``, kind 1 -> the scan's g number ``code``."""
    xpre = xa
    xcur = xb
    if kind == 0:
        fpre = _ev_at(code, edge, xpre, t_old, h, y_old, F, ytmp, dy, par, phase, mu, uxr, uyr,
                      orient, cnt, R, L, W, lay, cos_turn, margin_tol)  # fmt: skip
        fcur = _ev_at(code, edge, xcur, t_old, h, y_old, F, ytmp, dy, par, phase, mu, uxr, uyr,
                      orient, cnt, R, L, W, lay, cos_turn, margin_tol)  # fmt: skip
    else:
        fpre = _scan_value(code, xpre, t_old, h, y_old, F, ytmp, dy, par, phase, mu, uxr, uyr,
                           orient, cnt, margin_tol)  # fmt: skip
        fcur = _scan_value(code, xcur, t_old, h, y_old, F, ytmp, dy, par, phase, mu, uxr, uyr,
                           orient, cnt, margin_tol)  # fmt: skip
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if (fpre < 0.0) == (fcur < 0.0):
        # scipy raises here (the interpolant's end value disagrees in sign with the step end's):
        # take the end nearer the root
        return xa if abs(fpre) < abs(fcur) else xb
    xblk = 0.0
    fblk = 0.0
    spre = 0.0
    scur = 0.0
    for _ in range(100):
        if fpre != 0.0 and fcur != 0.0 and ((fpre < 0.0) != (fcur < 0.0)):
            xblk = xpre
            fblk = fpre
            spre = xcur - xpre
            scur = spre
        if abs(fblk) < abs(fcur):
            xpre = xcur
            xcur = xblk
            xblk = xpre
            fpre = fcur
            fcur = fblk
            fblk = fpre
        delta = (xtol + rtol_b * abs(xcur)) / 2.0
        sbis = (xblk - xcur) / 2.0
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                spre = scur
                scur = stry
            else:
                spre = sbis
                scur = sbis
        else:
            spre = sbis
            scur = sbis
        xpre = xcur
        fpre = fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0.0 else -delta
        if kind == 0:
            fcur = _ev_at(code, edge, xcur, t_old, h, y_old, F, ytmp, dy, par, phase, mu, uxr,
                          uyr, orient, cnt, R, L, W, lay, cos_turn, margin_tol)  # fmt: skip
        else:
            fcur = _scan_value(code, xcur, t_old, h, y_old, F, ytmp, dy, par, phase, mu, uxr,
                               uyr, orient, cnt, margin_tol)  # fmt: skip
    return xcur


@njit(cache=True, error_model="numpy")
def _segment(t0, y, f0, dyn0, t_bound, par, phase, mu, uxr, uyr, orient, rtol, atol, codes,
             edges, dirs, n_events, rolling, R, L, W, lay, cos_turn, margin_tol, cnt, K, F,
             work):  # type: ignore[no-untyped-def]  # fmt: skip
    """``solve_ivp(fun, (t0, t_bound), y, method="DOP853", rtol, atol, events)`` with terminal
    events (and, while rolling, scipy_solve's scan of the dense output); f0 = fun(t0, y) and
    dyn0 its (n, margin, ux, uy). y is overwritten with the end state. K (16, n), F (7, n),
    work (10, n): work arrays.

    Returns (status, t_end, event): status 0 t_bound reached, 1 an event (its code, or
    EV_RESERVE / EV_AIRBORNE for a dip found by the scan), -1 the step fell below 10 ulp(t)."""
    n = y.shape[0]
    y_old = work[0]
    y_new = work[1]
    f = work[2]
    f_new = work[3]
    ytmp = work[4]
    dy = work[5]
    scale = work[6]
    acc = work[7]
    a5 = work[8]
    a3 = work[9]
    for i in range(n):
        f[i] = f0[i]
    g = np.empty(n_events)
    g_new = np.empty(n_events)
    for k in range(n_events):
        g[k] = _event_value(codes[k], edges[k], y, dyn0[0], dyn0[1], dyn0[2], dyn0[3], uxr, uyr,
                            R, L, W, lay, cos_turn, margin_tol)  # fmt: skip

    # select_initial_step (error-estimator order 7)
    interval = abs(t_bound - t0)
    if interval == 0.0:
        return 0, t0, -1
    d0 = 0.0
    d1 = 0.0
    for i in range(n):
        scale[i] = atol + abs(y[i]) * rtol
        d0 += (y[i] / scale[i]) ** 2
        d1 += (f[i] / scale[i]) ** 2
    d0 = math.sqrt(d0) / math.sqrt(n)
    d1 = math.sqrt(d1) / math.sqrt(n)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, interval)
    for i in range(n):
        ytmp[i] = y[i] + h0 * f[i]
    _f(t0 + h0, ytmp, par, phase, mu, uxr, uyr, orient, dy, cnt)
    d2 = 0.0
    for i in range(n):
        d2 += ((dy[i] - f[i]) / scale[i]) ** 2
    d2 = math.sqrt(d2) / math.sqrt(n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    h_abs = min(100.0 * h0, h1, interval)

    t = t0
    while True:
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        accepted = False
        rejected = False
        h = 0.0
        t_new = t
        dyn_new = dyn0
        while not accepted:
            if h_abs < min_step:
                return -1, t, -1
            h = h_abs
            t_new = t + h
            if t_new - t_bound > 0.0:
                t_new = t_bound
            h = t_new - t
            h_abs = abs(h)
            # rk_step
            for i in range(n):
                K[0, i] = f[i]
            for s in range(1, N_STAGES):
                _combine(K, A[s], s, acc)
                for i in range(n):
                    ytmp[i] = y[i] + acc[i] * h
                _f(t + C[s] * h, ytmp, par, phase, mu, uxr, uyr, orient, K[s], cnt)
            _combine(K, B, N_STAGES, acc)
            for i in range(n):
                y_new[i] = y[i] + h * acc[i]
            dyn_new = _f(t + h, y_new, par, phase, mu, uxr, uyr, orient, f_new, cnt)
            for i in range(n):
                K[N_STAGES, i] = f_new[i]
            # DOP853._estimate_error_norm
            _combine(K, E5, N_STAGES + 1, a5)
            _combine(K, E3, N_STAGES + 1, a3)
            e5 = 0.0
            e3 = 0.0
            for i in range(n):
                sc = atol + max(abs(y[i]), abs(y_new[i])) * rtol
                e5 += (a5[i] / sc) ** 2
                e3 += (a3[i] / sc) ** 2
            if e5 == 0.0 and e3 == 0.0:
                err = 0.0
            else:
                err = abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * n)
            if err < 1.0:
                if err == 0.0:
                    factor = MAX_FACTOR
                else:
                    factor = min(MAX_FACTOR, SAFETY * err**ERROR_EXPONENT)
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                accepted = True
            else:
                h_abs *= max(MIN_FACTOR, SAFETY * err**ERROR_EXPONENT)
                rejected = True
                cnt[C_REJECTED] += 1
        cnt[C_STEPS] += 1
        t_old = t
        for i in range(n):
            y_old[i] = y[i]
            y[i] = y_new[i]
            f[i] = f_new[i]
        t = t_new
        finished = t - t_bound >= 0.0
        have_dense = False
        if rolling:
            _dense_prepare(t_old, h, y_old, y, f, K, F, acc, ytmp, par, phase, mu, uxr, uyr,
                           orient, cnt)  # fmt: skip
            have_dense = True
        # events at the step end (find_active_events), roots by brentq on the dense output
        h_dense = t - t_old  # Dop853DenseOutput.h
        t_root = math.inf
        ev = -1
        for k in range(n_events):
            n_, m_, ux_, uy_ = dyn_new
            g_new[k] = _event_value(codes[k], edges[k], y, n_, m_, ux_, uy_, uxr, uyr, R, L, W,
                                    lay, cos_turn, margin_tol)  # fmt: skip
        for k in range(n_events):
            up = g[k] <= 0.0 and g_new[k] >= 0.0
            down = g[k] >= 0.0 and g_new[k] <= 0.0
            if (up and dirs[k] > 0.0) or (down and dirs[k] < 0.0):
                if not have_dense:
                    _dense_prepare(t_old, h, y_old, y, f, K, F, acc, ytmp, par, phase, mu, uxr,
                                   uyr, orient, cnt)  # fmt: skip
                    have_dense = True
                r = _brent(0, codes[k], edges[k], t_old, t, 4.0 * EPS, 4.0 * EPS, t_old,
                           h_dense, y_old, F, ytmp, dy, par, phase, mu, uxr, uyr, orient, cnt,
                           R, L, W, lay, cos_turn, margin_tol)  # fmt: skip
                if r < t_root:
                    t_root = r
                    ev = codes[k]
        if rolling:
            # scipy_solve's scan: the first dip of the reserve (or of n) strictly inside the step
            t_end = t_root if ev >= 0 else t
            hh = t_end - t_old
            for j in range(1, N_SCAN):
                tb = t_old + hh * j / N_SCAN
                _dense_eval(tb, t_old, h_dense, y_old, F, ytmp)
                nn, m, _, _ = _f(tb, ytmp, par, phase, mu, uxr, uyr, orient, dy, cnt)
                m += margin_tol
                if m < 0.0 or nn <= 0.0:
                    which = 0 if m < 0.0 else 1
                    lo = t_old + hh * (j - 1) / N_SCAN
                    glo = _scan_value(which, lo, t_old, h_dense, y_old, F, ytmp, dy, par, phase,
                                      mu, uxr, uyr, orient, cnt, margin_tol)  # fmt: skip
                    if glo < 0.0:
                        lo = t_old
                    r = _brent(1, which, 0.0, lo, tb, 1e-15, 4.0 * EPS, t_old, h_dense, y_old,
                               F, ytmp, dy, par, phase, mu, uxr, uyr, orient, cnt, R, L, W,
                               lay, cos_turn, margin_tol)  # fmt: skip
                    _dense_eval(r, t_old, h_dense, y_old, F, y)
                    return 1, r, EV_RESERVE if which == 0 else EV_AIRBORNE
        if ev >= 0:
            _dense_eval(t_root, t_old, h_dense, y_old, F, y)
            return 1, t_root, ev
        for k in range(n_events):
            g[k] = g_new[k]
        if finished:
            return 0, t, -1


@njit(cache=True, error_model="numpy")
def _kernel(par, par_layer, y0, xe, ye, mug, L, W, lay, margin_tol, cos_turn, rtol, atol,
            t_max, orient, snap_impulse, max_segments):  # type: ignore[no-untyped-def]  # fmt: skip
    """One delivery, scipy_solve's segment loop; returns (status, t, y, slide_x, counters)
    (slide_x NaN if the ball never rolls; counters: n_rhs, n_steps, n_rejected, n_segments,
    n_events, then per event code how often it ended a segment)."""
    n = y0.shape[0]
    R = par[P_R]
    s_zero = 0.6 * lay[0]
    cnt = np.zeros(C_KINDS + len(EVENT_NAMES), dtype=np.int64)
    y = y0.copy()
    f0 = np.empty(n)
    K = np.empty((N_EXT, n))
    F = np.empty((7, n))
    work = np.empty((10, n))
    codes = np.empty(16, dtype=np.int64)
    edges = np.zeros(16)
    dirs = np.empty(16)
    t = 0.0
    ix = np.searchsorted(xe, y[0], side="right")
    iy = np.searchsorted(ye, y[1], side="right")
    mu = mug[ix, iy]
    phase = PHASE_SLIDE
    layer = False
    uxr = 1.0
    uyr = 0.0
    slide_x = math.nan
    sx, sy = slip(y, par)
    if sx == 0.0 and sy == 0.0:
        reserve, fx, fy = _reserve(y, par, mu)
        if reserve >= -margin_tol:
            phase = PHASE_ROLL
            slide_x = y[0]
        else:
            layer = True
            uxr, uyr = slaved_direction(y, par, mu, fx, fy)
    status = STATUS_STALLED
    while True:
        if cnt[C_SEGMENTS] >= max_segments:
            status = STATUS_STALLED
            break
        if t >= t_max:
            status = STATUS_MAX_TIME
            break
        if phase == PHASE_SLIDE and not layer:
            sx, sy = slip(y, par)
            s = math.hypot(sx, sy)
            uxr = sx / s
            uyr = sy / s
        p = par_layer if (phase == PHASE_SLIDE and layer) else par
        dyn0 = _f(t, y, p, phase, mu, uxr, uyr, orient, f0, cnt)
        if dyn0[0] <= 0.0:
            status = STATUS_AIRBORNE
            break
        cnt[C_SEGMENTS] += 1
        codes[0] = EV_PINS
        dirs[0] = 1.0
        codes[1] = EV_GUTTER_LO
        dirs[1] = -1.0
        codes[2] = EV_GUTTER_HI
        dirs[2] = 1.0
        codes[3] = EV_STOPPED
        dirs[3] = -1.0
        codes[4] = EV_AIRBORNE
        dirs[4] = -1.0
        ne = 5
        if ix < xe.size:
            codes[ne] = EV_X_UP
            edges[ne] = xe[ix]
            dirs[ne] = 1.0
            ne += 1
        if ix > 0:
            codes[ne] = EV_X_DOWN
            edges[ne] = xe[ix - 1]
            dirs[ne] = -1.0
            ne += 1
        if iy < ye.size:
            codes[ne] = EV_Y_UP
            edges[ne] = ye[iy]
            dirs[ne] = 1.0
            ne += 1
        if iy > 0:
            codes[ne] = EV_Y_DOWN
            edges[ne] = ye[iy - 1]
            dirs[ne] = -1.0
            ne += 1
        if phase == PHASE_SLIDE:
            codes[ne] = EV_SLIP
            dirs[ne] = -1.0
            ne += 1
            if layer:
                codes[ne] = EV_EXIT
                dirs[ne] = 1.0
                codes[ne + 1] = EV_TURN
                dirs[ne + 1] = -1.0
            else:
                codes[ne] = EV_ENTER
                dirs[ne] = -1.0
                codes[ne + 1] = EV_CTURN
                dirs[ne + 1] = -1.0
            ne += 2
        else:
            codes[ne] = EV_RESERVE
            dirs[ne] = -1.0
            ne += 1
        rolling = phase == PHASE_ROLL
        # the layer's events compare |s| with s_layer / 2 (entry) and s_restart (exit); rhs gets
        # twice s_restart inside the layer
        st, t, kind = _segment(t, y, f0, dyn0, t_max, p, phase, mu, uxr, uyr, orient, rtol,
                               atol, codes, edges, dirs, ne, rolling, R, L, W, lay, cos_turn,
                               margin_tol, cnt, K, F, work)  # fmt: skip
        if st < 0:
            status = STATUS_STALLED
            break
        if orient:
            qn = math.sqrt(y[4] ** 2 + y[5] ** 2 + y[6] ** 2 + y[7] ** 2)
            for i in range(4, 8):
                y[i] /= qn
        if kind < 0:
            status = STATUS_MAX_TIME
            break
        cnt[C_EVENTS] += 1
        cnt[C_KINDS + kind] += 1
        if kind == EV_PINS:
            status = STATUS_PINS
            break
        if kind in (EV_GUTTER_LO, EV_GUTTER_HI):
            status = STATUS_GUTTER
            break
        if kind == EV_STOPPED:
            status = STATUS_STOPPED
            break
        if kind == EV_AIRBORNE:
            status = STATUS_AIRBORNE
            break
        if kind in (EV_X_UP, EV_X_DOWN, EV_Y_UP, EV_Y_DOWN):
            if kind == EV_X_UP:
                ix += 1
            elif kind == EV_X_DOWN:
                ix -= 1
            elif kind == EV_Y_UP:
                iy += 1
            else:
                iy -= 1
            mu = mug[ix, iy]
            if phase == PHASE_ROLL:
                reserve, fx, fy = _reserve(y, par, mu)
                if reserve < -margin_tol:
                    phase = PHASE_SLIDE
                    layer = True
                    uxr, uyr = slaved_direction(y, par, mu, fx, fy)
            elif layer:
                uxr, uyr = slaved_direction(y, par, mu, uxr, uyr)
        elif kind in (EV_SLIP, EV_CTURN):
            sx, sy = slip(y, par)
            if layer or math.hypot(sx, sy) <= s_zero:
                if snap_impulse:
                    remove_slip_impulse(y, par)
                else:
                    y[2] = R * y[9]
                    y[3] = -R * y[8]
                reserve, fx, fy = _reserve(y, par, mu)
                if reserve >= -margin_tol:
                    phase = PHASE_ROLL
                    layer = False
                    if slide_x != slide_x:
                        slide_x = y[0]
                else:
                    layer = True
                    uxr, uyr = slaved_direction(y, par, mu, fx, fy)
        elif kind == EV_ENTER:
            sx, sy = slip(y, par)
            s = math.hypot(sx, sy)
            layer = True
            uxr, uyr = slaved_direction(y, par, mu, sx / s, sy / s)
        elif kind == EV_EXIT:
            layer = False
        elif kind == EV_TURN:
            dyn = _f(t, y, p, phase, mu, uxr, uyr, orient, f0, cnt)
            uxr = dyn[2]
            uyr = dyn[3]
        else:  # EV_RESERVE
            _, fx, fy = _reserve(y, par, mu)
            phase = PHASE_SLIDE
            layer = True
            uxr, uyr = slaved_direction(y, par, mu, fx, fy)
    return status, t, y, slide_x, cnt


# ---------------------------------------------------------------------------------------------
# Python side
# ---------------------------------------------------------------------------------------------


def kernel_args(
    plan: Plan,
    rtol: float = 1e-9,
    atol: float | None = None,
    *,
    s_layer: float | None = None,
    snap: str = "impulse",
    max_segments: int = 10_000,
) -> tuple[Plan, tuple[Any, ...]]:
    """The summary plan and the kernel's arguments for ``plan`` at (rtol, atol) (atol None ->
    0.1 rtol, as the benchmark runs scipy) with scipy_solve's settings (``s_layer`` None ties
    the slip layer to rtol as bowlrec does; ``snap`` "impulse" or "velocity")."""
    if snap not in ("velocity", "impulse"):
        raise ValueError(f"snap = {snap!r} must be 'velocity' or 'impulse'")
    atol = 0.1 * rtol if atol is None else atol
    p = summary_plan(plan, rtol, s_layer)
    par = kernel_params(p)
    # the layer is entered at s_layer / 2 and left at s_restart (bowlrec's hysteresis); inside
    # it rhs gets twice the exit speed: slaved (or radial) friction up to |s| = s_restart
    lay = np.array([slip_layer(p), restart_layer(p)])
    par_layer = kernel_params(dataclasses.replace(p, slip_layer_mps=2.0 * lay[1]))
    args = (
        par,
        par_layer,
        np.ascontiguousarray(initial_state(p), dtype=np.float64),
        np.ascontiguousarray(p.friction_x_edges_m, dtype=np.float64),
        np.ascontiguousarray(p.friction_y_edges_m, dtype=np.float64),
        np.ascontiguousarray(p.friction_mu, dtype=np.float64),
        float(p.lane_length_m),
        float(p.lane_width_m),
        lay,
        float(rtol) * float(p.g_mps2),
        math.cos(math.radians(TURN_DEG)),
        float(rtol),
        float(atol),
        float(p.max_time_s),
        bool(needs_orientation(p)),
        snap == "impulse",
        int(max_segments),
    )
    return p, args


def result(p: Plan, out: tuple[Any, ...]) -> dict[str, Any]:
    """The common result dict of ``benchmarks.methods`` from the kernel's return value, with
    n_steps (accepted), n_rejected, n_segments, n_events and ``events`` (event name ->
    how many segments it ended, scipy_solve's names)."""
    status, t, y, slide_x, cnt = out
    slide = None if math.isnan(slide_x) else float(slide_x)
    kinds: dict[str, int] = {}
    for code, name in enumerate(EVENT_NAMES):
        if cnt[C_KINDS + code]:
            kinds[name] = kinds.get(name, 0) + int(cnt[C_KINDS + code])
    return result_dict(
        p,
        OUTCOMES.get(int(status), "error"),
        slide,
        t,
        y,
        int(cnt[C_RHS]),
        n_steps=int(cnt[C_STEPS]),
        n_rejected=int(cnt[C_REJECTED]),
        n_segments=int(cnt[C_SEGMENTS]),
        n_events=int(cnt[C_EVENTS]),
        events=kinds,
    )


def solve_dop853(
    plan: Plan,
    rtol: float = 1e-9,
    atol: float | None = None,
    *,
    s_layer: float | None = None,
    snap: str = "impulse",
    max_segments: int = 10_000,
) -> dict[str, Any]:
    """The compiled ``scipy_solve(plan, "DOP853", rtol, atol)``: the common result dict plus
    n_steps (accepted), n_rejected, n_segments, n_events."""
    p, args = kernel_args(plan, rtol, atol, s_layer=s_layer, snap=snap, max_segments=max_segments)
    return result(p, _kernel(*args))

"""Compiled adaptive integrator with event location: one delivery from release to an outcome.

Method: Dormand-Prince 5(4) (FSAL, Hairer's step-size control with a PI factor; no growth right
after a rejected step, and a steeper cut when consecutive rejections show the error falling
slower than h^5) and its 4th-order continuous extension for dense output. Events are located on
the dense output by safeguarded regula falsi (Illinois) to ~1e-15 relative in time; the state at
the event is the dense output there (its error is of the order of the step's own, as in the
root finding of SUNDIALS or DifferentialEquations.jl), and the integration restarts at every
event (the right-hand side is discontinuous there). The event functions are scanned at
4 points of the dense output only when one of them could change sign inside the step
(``_may_cross``: bounds from the stage derivatives); most steps need just the two end values.

Events (a function g fires where it goes from >= 0 to < 0 between two dense samples):

* zone boundaries of the friction grid (restart with the new mu),
* the pins x = L (the summary is taken exactly there), the gutters y = 0 and y = W,
* vx = 0 (the ball stops or comes back: it cannot reach the pins),
* slide -> roll: g = s . u_ref with u_ref the slip direction at the start of the step. The friction
  direction is continued smoothly through s = 0 (see ``friction_direction``), so a step cannot
  jump over the kink of |s| and the root is an ordinary sign change. A root where |s| is not
  small (the slip turned by 90 degrees within a step) just refreshes u_ref. At a real root the
  residual slip (~ the tolerance) is removed by a tiny impulse at the contact point (physically
  consistent: it changes v and w as a friction impulse does);
* with the paper's rule (``slide_mode`` 1) slide -> roll fires where s . u_ref falls through the
  threshold; a slip that restarted from zero and never exceeded it rolls again at zero;
* roll -> slide: the friction reserve mu n - |f| of the rolling ball turns negative (checked at
  every stage and step end, then located on the dense output);
* loss of contact: the normal force turns negative (outcome "airborne").

Stiff restart of sliding. When a rolling ball starts to slip again, |s| grows from zero and the
slip direction relaxes at a rate ~ mu g (1 + R^2/k^2) / |s|; an explicit method would crawl with
~1e-9 s steps. The same stiffness appears whenever the slip lingers near zero (a ball at the edge
of the friction cone, the stick-slip of Table III cases 5 and 18). Below a slip speed ``s_layer``
(entered at s_layer / 2, left at s_layer: hysteresis) bowlrec does not integrate the stiff
relaxation of the slip direction. Where rolling is possible (the rolling ball needs at most mu n)
every small slip reaches zero in finite time, and friction acts along the direction that makes
it shrink straight to zero (``dynamics.radial_direction``); otherwise (the slip restarts from
rolling) along the slaved direction (the unit u with ds/dt(u) parallel to +u, the |s| -> 0 limit
of the exact dynamics). While sliding, a step is cut to end about where the linearly
extrapolated slip reaches s_layer / 4, so steps do not jump across |s| = 0, where the Coulomb
direction is singular (a curved approach could pass beside the root unseen). The error this
introduces vanishes with s_layer; ``solver.slip_layer`` ties it to the tolerance (1e-5 m/s at
rtol 1e-9, where against s_layer = 1e-8 m/s it moves hook, pocket and slide of cases 5 and 18 by
<= 4.6e-7 m, 3.2e-5 deg and 3.2e-8 m while taking 11-37x fewer right-hand sides).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .dynamics import (
    N_STATE,
    P_G,
    P_QWEIGHT,
    P_R,
    P_SLAYER,
    PHASE_LAYER,
    PHASE_ROLL,
    PHASE_SLIDE,
    ball_frame,
    rhs,
    roll_accel,
    slaved_direction,
    slip,
)
from .vec import NO_NRT, cross, solve3

# Outcome / status codes.
STATUS_RUNNING = 0
STATUS_PINS = 1
STATUS_GUTTER = 2
STATUS_STOPPED = 3
STATUS_AIRBORNE = 4
STATUS_MAX_TIME = 5
STATUS_MAX_STEPS = 6
STATUS_STALLED = 7

# Event kinds stored in the event table.
EVENT_SLIDE_TO_ROLL = 1
EVENT_ROLL_TO_SLIDE = 2
EVENT_ZONE = 3
EVENT_PINS = 4
EVENT_GUTTER = 5
EVENT_STOPPED = 6
EVENT_AIRBORNE = 7
EVENT_MAX_TIME = 8
EVENT_SLIP_REVERSAL = 9

# Columns of the sample table.
COL_T = 0
COL_STATE = 1  # 11 state columns follow
COL_PHASE = 12
COL_MU = 13
COL_UX = 14
COL_UY = 15
N_COL = 16

# Columns of the event table: t, kind, x, y, mu after the event, phase after the event.
N_EVCOL = 6

# Dormand-Prince 5(4) tableau.
C2, C3, C4, C5 = 0.2, 0.3, 0.8, 8.0 / 9.0
A21 = 0.2
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (
    9017.0 / 3168.0,
    -355.0 / 33.0,
    46732.0 / 5247.0,
    49.0 / 176.0,
    -5103.0 / 18656.0,
)
A71, A73, A74, A75, A76 = (
    35.0 / 384.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
)
E1, E3, E4, E5, E6, E7 = (
    71.0 / 57600.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
)
D1, D3, D4, D5, D6, D7 = (
    -12715105075.0 / 11282082432.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
)

N_SUB = 4  # dense samples per step on which event functions are scanned
MAX_EVENTS = 100_000
H_MAX = 0.1  # largest step (s)
LOG_1E_4 = math.log(1e-4)  # the PI controller's floor of the previous error (log)


@njit(cache=True, error_model="numpy", **NO_NRT)
def _stages(t, y, h, K, ytmp, ynew, par, phase, mu, uxr, uyr, orient):  # type: ignore[no-untyped-def]
    """Stages 2..7 of one DP5 step from (t, y) with K[0] = f(y). Returns the minimum normal force
    and friction margin over stages 2..7 and the normal force / margin / direction at the end."""
    n = N_STATE
    nmin = 1e300
    mmin = 1e300
    for i in range(n):
        ytmp[i] = y[i] + h * A21 * K[0, i]
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[1])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ytmp[i] = y[i] + h * (A31 * K[0, i] + A32 * K[1, i])
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[2])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ytmp[i] = y[i] + h * (A41 * K[0, i] + A42 * K[1, i] + A43 * K[2, i])
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[3])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ytmp[i] = y[i] + h * (A51 * K[0, i] + A52 * K[1, i] + A53 * K[2, i] + A54 * K[3, i])
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[4])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ytmp[i] = y[i] + h * (
            A61 * K[0, i] + A62 * K[1, i] + A63 * K[2, i] + A64 * K[3, i] + A65 * K[4, i]
        )
    r = rhs(ytmp, par, phase, mu, uxr, uyr, orient, K[5])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    for i in range(n):
        ynew[i] = y[i] + h * (
            A71 * K[0, i] + A73 * K[2, i] + A74 * K[3, i] + A75 * K[4, i] + A76 * K[5, i]
        )
    r = rhs(ynew, par, phase, mu, uxr, uyr, orient, K[6])
    nmin = min(nmin, r[0])
    mmin = min(mmin, r[1])
    return nmin, mmin, r[0], r[1], r[2], r[3]


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _embedded_error(K, h, i):  # type: ignore[no-untyped-def]
    """Component i of the embedded (5th - 4th order) error estimate of a step of size h."""
    return h * (
        E1 * K[0, i] + E3 * K[2, i] + E4 * K[3, i] + E5 * K[4, i] + E6 * K[5, i] + E7 * K[6, i]
    )


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _error_norm(y, ynew, K, h, rtol, q_weight):  # type: ignore[no-untyped-def]
    """RMS of the embedded error estimate scaled by rtol * (1 + |y|) per component.

    The quaternion's error counts with the weight ``q_weight`` (0 drops it): see
    ``solver.orientation_weight``. (Three loops in component order, so the sum is the same.)"""
    acc = 0.0
    for i in range(4):
        sc = rtol * (1.0 + max(abs(y[i]), abs(ynew[i])))
        acc += (_embedded_error(K, h, i) / sc) ** 2
    cnt = 7
    if q_weight != 0.0:
        cnt = 11
        for i in range(4, 8):
            sc = rtol * (1.0 + max(abs(y[i]), abs(ynew[i])))
            acc += (q_weight * _embedded_error(K, h, i) / sc) ** 2
    for i in range(8, N_STATE):
        sc = rtol * (1.0 + max(abs(y[i]), abs(ynew[i])))
        acc += (_embedded_error(K, h, i) / sc) ** 2
    return math.sqrt(acc / cnt)


@njit(cache=True, error_model="numpy", **NO_NRT)
def _dense_coeffs(y, ynew, K, h, rc):  # type: ignore[no-untyped-def]
    for i in range(N_STATE):
        ydiff = ynew[i] - y[i]
        bspl = h * K[0, i] - ydiff
        rc[0, i] = y[i]
        rc[1, i] = ydiff
        rc[2, i] = bspl
        rc[3, i] = ydiff - h * K[6, i] - bspl
        rc[4, i] = h * (
            D1 * K[0, i] + D3 * K[2, i] + D4 * K[3, i] + D5 * K[4, i] + D6 * K[5, i] + D7 * K[6, i]
        )


@njit(cache=True, error_model="numpy", **NO_NRT)
def _dense(rc, theta, out):  # type: ignore[no-untyped-def]
    th1 = 1.0 - theta
    for i in range(N_STATE):
        out[i] = rc[0, i] + theta * (
            rc[1, i] + th1 * (rc[2, i] + theta * (rc[3, i] + th1 * rc[4, i]))
        )


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _dense_scan(rc, theta, out):  # type: ignore[no-untyped-def]
    """Like ``_dense`` for the components the event functions 0..9 read (x, y, v, w_x, w_y)."""
    th1 = 1.0 - theta
    for i in (0, 1, 2, 3, 8, 9):
        out[i] = rc[0, i] + theta * (
            rc[1, i] + th1 * (rc[2, i] + theta * (rc[3, i] + th1 * rc[4, i]))
        )


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _event_values(yy, par, phase, mu, uxr, uyr, bounds, slide_mode, thr, s_layer, gv):  # type: ignore[no-untyped-def]
    """Values of the event functions at state yy (each fires on a >= 0 -> < 0 change).

    0: x_hi - x   1: x - x_lo   2: y_hi - y   3: y - y_lo   (friction cell)
    4: L - x (pins)   5: y (right gutter)   6: W - y (left gutter)   7: vx (stop)
    8: slide->roll    9: s_layer - |s| (end of the slip boundary layer)
    10: friction reserve while rolling   11: normal force (contact)
    """
    x = yy[0]
    yv = yy[1]
    gv[0] = bounds[1] - x
    gv[1] = x - bounds[0]
    gv[2] = bounds[3] - yv
    gv[3] = yv - bounds[2]
    gv[4] = bounds[4] - x
    gv[5] = yv
    gv[6] = bounds[5] - yv
    gv[7] = yy[2]
    gv[8] = 1.0
    gv[9] = 1.0
    gv[10] = 1.0
    gv[11] = 1.0
    if phase != PHASE_ROLL:
        sx, sy = slip(yy, par)
        if slide_mode == 1 and phase == PHASE_SLIDE:
            # the slip along the reference direction falls through the threshold (monotonic
            # across the root, unlike |s| - thr, which a large step could dip through unseen)
            gv[8] = sx * uxr + sy * uyr - thr
        else:
            gv[8] = sx * uxr + sy * uyr
        if phase == PHASE_LAYER:
            gv[9] = s_layer - math.sqrt(sx * sx + sy * sy)
        else:
            gv[9] = math.sqrt(sx * sx + sy * sy) - 0.5 * s_layer


@njit(cache=True, error_model="numpy", **NO_NRT)
def _dynamic_values(yy, par, phase, mu, uxr, uyr, orient, dtmp):  # type: ignore[no-untyped-def]
    """Friction reserve (rolling only) and normal force at yy (these need the equations)."""
    r = rhs(yy, par, phase, mu, uxr, uyr, orient, dtmp)
    if phase == PHASE_ROLL:
        return r[1], r[0]
    return 1.0, r[0]


@njit(cache=True, error_model="numpy", **NO_NRT)
def _locate(idx, ta, tb, rc, t0, h, par, phase, mu, uxr, uyr, bounds, slide_mode, thr, s_layer,
            orient, ybuf, gv, dtmp):  # type: ignore[no-untyped-def]  # fmt: skip
    """Illinois root of event function idx on the dense output between ta (g >= 0) and tb (< 0)."""
    ga = _eval_one(idx, ta, rc, t0, h, par, phase, mu, uxr, uyr, bounds, slide_mode, thr,
                   s_layer, orient, ybuf, gv, dtmp)  # fmt: skip
    gb = _eval_one(idx, tb, rc, t0, h, par, phase, mu, uxr, uyr, bounds, slide_mode, thr,
                   s_layer, orient, ybuf, gv, dtmp)  # fmt: skip
    side = 0
    for _ in range(200):
        if tb - ta <= 4e-16 * max(1.0, abs(tb)):
            break
        if ga == gb:
            tm = 0.5 * (ta + tb)
        else:
            tm = (ta * gb - tb * ga) / (gb - ga)
        if not (ta < tm < tb):
            tm = 0.5 * (ta + tb)
        gm = _eval_one(idx, tm, rc, t0, h, par, phase, mu, uxr, uyr, bounds, slide_mode, thr,
                       s_layer, orient, ybuf, gv, dtmp)  # fmt: skip
        if gm >= 0.0:
            ta = tm
            ga = gm
            if side == -1:
                gb *= 0.5
            side = -1
        else:
            tb = tm
            gb = gm
            if side == 1:
                ga *= 0.5
            side = 1
    return tb


@njit(cache=True, error_model="numpy", **NO_NRT)
def _eval_one(idx, t, rc, t0, h, par, phase, mu, uxr, uyr, bounds, slide_mode, thr, s_layer,
              orient, ybuf, gv, dtmp):  # type: ignore[no-untyped-def]  # fmt: skip
    _dense(rc, (t - t0) / h, ybuf)
    if idx >= 10:
        m, nn = _dynamic_values(ybuf, par, phase, mu, uxr, uyr, orient, dtmp)
        return m if idx == 10 else nn
    _event_values(ybuf, par, phase, mu, uxr, uyr, bounds, slide_mode, thr, s_layer, gv)
    return gv[idx]


@njit(cache=True, error_model="numpy", **NO_NRT)
def _cell_bounds(ix, iy, x_edges, y_edges, lane_length, lane_width, bounds):  # type: ignore[no-untyped-def]
    nx = x_edges.shape[0]
    ny = y_edges.shape[0]
    bounds[0] = x_edges[ix - 1] if ix > 0 else -1e300
    bounds[1] = x_edges[ix] if ix < nx else 1e300
    bounds[2] = y_edges[iy - 1] if iy > 0 else -1e300
    bounds[3] = y_edges[iy] if iy < ny else 1e300
    bounds[4] = lane_length
    bounds[5] = lane_width


@njit(cache=True, error_model="numpy")
def _push(rec, nrec, t, y, phase, mu, ux, uy):  # type: ignore[no-untyped-def]
    if nrec >= rec.shape[0]:
        bigger = np.empty((2 * rec.shape[0], rec.shape[1]))
        bigger[: rec.shape[0]] = rec
        rec = bigger
    rec[nrec, COL_T] = t
    for i in range(N_STATE):
        rec[nrec, COL_STATE + i] = y[i]
    # report a unit quaternion even between renormalizations
    qn = math.sqrt(y[4] ** 2 + y[5] ** 2 + y[6] ** 2 + y[7] ** 2)
    for i in range(4):
        rec[nrec, COL_STATE + 4 + i] = y[4 + i] / qn
    rec[nrec, COL_PHASE] = float(phase)  # 0 slide, 1 roll, 2 slide in the slip layer
    rec[nrec, COL_MU] = mu
    rec[nrec, COL_UX] = ux
    rec[nrec, COL_UY] = uy
    return rec, nrec + 1


@njit(cache=True, error_model="numpy")
def _push_event(ev, nev, t, kind, y, mu, phase):  # type: ignore[no-untyped-def]
    if nev >= ev.shape[0]:
        bigger = np.empty((2 * ev.shape[0], ev.shape[1]))
        bigger[: ev.shape[0]] = ev
        ev = bigger
    ev[nev, 0] = t
    ev[nev, 1] = kind
    ev[nev, 2] = y[0]
    ev[nev, 3] = y[1]
    ev[nev, 4] = mu
    ev[nev, 5] = 1.0 if phase == PHASE_ROLL else 0.0
    return ev, nev + 1


@njit(cache=True, error_model="numpy")
def _remove_slip(y, par):  # type: ignore[no-untyped-def]
    """Apply the horizontal contact impulse that makes the slip exactly zero (in place)."""
    sx, sy = slip(y, par)
    if sx == 0.0 and sy == 0.0:
        return
    # The slip responds linearly to an impulse J (per unit mass) at the contact point; build the
    # 2x2 response matrix by applying unit impulses to a copy of the state.
    base = y.copy()
    cols = np.empty((2, 2))
    for j in range(2):
        yy = base.copy()
        _apply_impulse(yy, par, 1.0 if j == 0 else 0.0, 1.0 if j == 1 else 0.0)
        tx, ty = slip(yy, par)
        cols[0, j] = tx - sx
        cols[1, j] = ty - sy
    det = cols[0, 0] * cols[1, 1] - cols[0, 1] * cols[1, 0]
    jx = (-sx * cols[1, 1] + sy * cols[0, 1]) / det
    jy = (-sy * cols[0, 0] + sx * cols[1, 0]) / det
    _apply_impulse(y, par, jx, jy)


@njit(cache=True, error_model="numpy", **NO_NRT)
def _apply_impulse(y, par, jx, jy):  # type: ignore[no-untyped-def]
    """Horizontal impulse (jx, jy, 0) per unit mass at the contact point (in place)."""
    iw, rd = ball_frame(y, par)
    ixx, iyy, izz, ixy, ixz, iyz = iw
    rdx, rdy, rdz = rd
    R = par[P_R]
    # angular impulse about the center of mass: rho x J, rho = r_Delta + R_con
    lx, ly, lz = cross(rdx, rdy, rdz - R, jx, jy, 0.0)
    dwx, dwy, dwz = solve3(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz, lx, ly, lz)
    # v_cb = v_com + w x r_Delta
    cx, cy, _ = cross(dwx, dwy, dwz, rdx, rdy, rdz)
    y[2] += jx + cx
    y[3] += jy + cy
    y[8] += dwx
    y[9] += dwy
    y[10] += dwz


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _normalize_quaternion(y):  # type: ignore[no-untyped-def]
    """Scale the quaternion y[4:8] to unit length (in place)."""
    qn = math.sqrt(y[4] ** 2 + y[5] ** 2 + y[6] ** 2 + y[7] ** 2)
    for i in range(4, 8):
        y[i] /= qn


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _may_cross(g0, g1, K, h, par, phase):  # type: ignore[no-untyped-def]
    """False when no event function 0..9 can change sign inside the accepted step, so the
    4-point scan of the dense output is skipped (it is then bit-identical: it would find nothing).

    g0, g1: the event values at the ends of the step. Between them a function of x or y stays
    within max|a| h^2 / 8 of the chord (a bound on its curvature; 2x safety); vx and the slip
    functions move by at most h max|dg/dt| (1.5x safety), the maxima taken over the 7 stages."""
    ax = 0.0
    ay = 0.0
    sd = 0.0
    for i in range(7):
        ax = max(ax, abs(K[i, 2]))
        ay = max(ay, abs(K[i, 3]))
        if phase != PHASE_ROLL:
            dsx, dsy = slip(K[i], par)  # slip() is linear: applied to dy/dt it gives ds/dt
            sd = max(sd, abs(dsx) + abs(dsy))
    cx = 0.25 * h * h * ax
    cy = 0.25 * h * h * ay
    lv = 1.5 * h * ax
    ls = 1.5 * h * sd
    if min(g0[0], g1[0]) <= cx or min(g0[1], g1[1]) <= cx or min(g0[4], g1[4]) <= cx:
        return True
    if min(g0[2], g1[2]) <= cy or min(g0[3], g1[3]) <= cy:
        return True
    if min(g0[5], g1[5]) <= cy or min(g0[6], g1[6]) <= cy:
        return True
    if min(g0[7], g1[7]) <= lv:
        return True
    return min(g0[8], g1[8]) <= ls or min(g0[9], g1[9]) <= ls


@njit(cache=True, error_model="numpy", **NO_NRT)
def _initial_step(y, K, ytmp, dtmp, par, phase, mu, uxr, uyr, orient, rtol):  # type: ignore[no-untyped-def]
    """Starting step size (s) for y with K[0] = f(y): Hairer's estimate (DOPRI5's ``hinit``),
    from |f| and a finite-difference second derivative (one extra right-hand side), in the same
    weighted norm as the error control, so that the first step's error is ~ the tolerance."""
    qw = par[P_QWEIGHT]
    dny = 0.0
    dnf = 0.0
    for i in range(N_STATE):
        w = qw if 4 <= i < 8 else 1.0
        sc = rtol * (1.0 + abs(y[i]))
        dny += (w * y[i] / sc) ** 2
        dnf += (w * K[0, i] / sc) ** 2
    h = 0.01 * math.sqrt(dny / dnf) if dnf > 1e-10 and dny > 1e-10 else 1e-6
    h = min(h, H_MAX)
    for i in range(N_STATE):
        ytmp[i] = y[i] + h * K[0, i]
    rhs(ytmp, par, phase, mu, uxr, uyr, orient, dtmp)
    der2 = 0.0
    for i in range(N_STATE):
        w = qw if 4 <= i < 8 else 1.0
        sc = rtol * (1.0 + abs(y[i]))
        der2 += (w * (dtmp[i] - K[0, i]) / sc) ** 2
    der12 = max(math.sqrt(der2) / h, math.sqrt(dnf))
    h1 = (0.01 / der12) ** 0.2 if der12 > 1e-15 else max(1e-6, h * 1e-3)
    return max(1e-6, min(100.0 * h, h1, H_MAX))


ADV_EVENT = 0  # an accepted step with an event inside it (or, when recording, any accepted step)
ADV_MAX_STEPS = 1
ADV_MAX_TIME = 2
ADV_STALLED = 3


@njit(cache=True, error_model="numpy", **NO_NRT)
def _advance(y, K, ytmp, ynew, ybuf, dtmp, rc, gv, gprev, gcur, bounds, par, phase, mu, uxr, uyr,
             t, h, lfacold, nsteps, nfev, rtol, slide_mode, slip_threshold, s_layer, orient,
             margin_tol, max_time, max_steps, record_mode):  # type: ignore[no-untyped-def]  # fmt: skip
    """Take steps (same phase, zone and friction law) until one contains an event or a limit
    is hit; while recording, return after every accepted step.

    A step without an event is taken (y, K[0], t, h updated) before returning; a step with an
    event is not (t, h are its start and size, ``rc`` its dense output). Returns (code, t, h,
    lfacold, nsteps, nfev, uxr, uyr, best_t, best_idx, t0, h0, ux, uy): t0, h0 the start and size
    of the last accepted step, (ux, uy) the friction direction at its end. ``lfacold`` is the
    log of the last accepted error (at least 1e-4), for the PI controller."""
    nrej = 0  # consecutive rejections, the last one's error and step
    err_rej = 1.0
    h_rej = h
    while True:
        if nsteps >= max_steps:
            return (ADV_MAX_STEPS, t, h, lfacold, nsteps, nfev, uxr, uyr, 1e300, -1, t, h, uxr, uyr)
        if t >= max_time:
            return (ADV_MAX_TIME, t, h, lfacold, nsteps, nfev, uxr, uyr, 1e300, -1, t, h, uxr, uyr)
        if h < 1e-13 * max(1.0, t):
            return (ADV_STALLED, t, h, lfacold, nsteps, nfev, uxr, uyr, 1e300, -1, t, h, uxr, uyr)
        if t + h > max_time:
            h = max_time - t
        if phase == PHASE_SLIDE:
            sx, sy = slip(y, par)
            s0 = math.sqrt(sx * sx + sy * sy)
            if s0 > 0.0:
                uxr = sx / s0
                uyr = sy / s0
                # aim the step at the slip layer rather than across it: near |s| = 0 the Coulomb
                # direction is singular, and a step whose stages land there can miss the root
                # (a curved approach passes beside zero). Inside the layer the slip runs straight
                # to zero (``radial_direction``) and the root is an ordinary sign change.
                dsx, dsy = slip(K[0], par)  # ds/dt: slip() is linear in the state
                decay = -(uxr * dsx + uyr * dsy)
                if decay > 0.0 and s0 > 0.5 * s_layer:
                    h_layer = (s0 - 0.25 * s_layer) / decay
                    if h > h_layer:
                        h = h_layer
        elif phase == PHASE_LAYER:
            sx, sy = slip(y, par)
            s0 = math.sqrt(sx * sx + sy * sy)
            if s0 > 1e-2 * s_layer:
                uxr = sx / s0
                uyr = sy / s0
        st = _stages(t, y, h, K, ytmp, ynew, par, phase, mu, uxr, uyr, orient)
        nfev += 6
        err = _error_norm(y, ynew, K, h, rtol, par[P_QWEIGHT])
        if not (err <= 1.0):
            # reject: h * (0.9 / err)^(1/5), at most 10x smaller ...
            if err != err:
                hn = 0.1 * h
            else:
                hn = h / min(10.0, math.exp(0.2 * math.log(err)) / 0.9)
                if nrej > 0 and not (err < err_rej and h < h_rej):
                    hn = min(hn, 0.2 * h)  # ... 5x at least if the error did not fall ...
                elif nrej > 0:
                    # ... and if it fell slower than h^5 (near the kink of a restarting slip it
                    # falls ~ h^1), cut at the order the last two rejections showed
                    p_eff = math.log(err_rej / err) / math.log(h_rej / h)
                    if p_eff < 4.0:
                        p_eff = max(p_eff, 0.5)
                        hn = min(hn, max(h * (0.8 / err) ** (1.0 / p_eff), 0.1 * h))
            err_rej = err
            h_rej = h
            nrej += 1
            h = hn
            continue
        nsteps += 1
        # ---- event scan on the dense output ----
        best_t = 1e300
        best_idx = -1
        _event_values(y, par, phase, mu, uxr, uyr, bounds, slide_mode, slip_threshold, s_layer,
                      gprev)  # fmt: skip
        _event_values(ynew, par, phase, mu, uxr, uyr, bounds, slide_mode, slip_threshold,
                      s_layer, gcur)  # fmt: skip
        scan = phase == PHASE_LAYER or _may_cross(gprev, gcur, K, h, par, phase)
        # the normal force or (rolling) the friction reserve fell below zero at some stage
        dynamic = st[0] <= 0.0 or (phase == PHASE_ROLL and st[1] < -margin_tol)
        if scan or dynamic or record_mode == 2:
            _dense_coeffs(y, ynew, K, h, rc)
        ta = t
        for j in range(1, N_SUB + 1 if scan else 1):
            tj = t + h * j / N_SUB
            if j == N_SUB:
                for i in range(N_STATE):
                    ybuf[i] = ynew[i]
            else:
                _dense_scan(rc, j / N_SUB, ybuf)
            _event_values(ybuf, par, phase, mu, uxr, uyr, bounds, slide_mode, slip_threshold,
                          s_layer, gcur)  # fmt: skip
            for idx in range(10):
                if gprev[idx] >= 0.0 and gcur[idx] < 0.0:
                    te = _locate(idx, ta, tj, rc, t, h, par, phase, mu, uxr, uyr, bounds,
                                 slide_mode, slip_threshold, s_layer, orient, ybuf, gv,
                                 dtmp)  # fmt: skip
                    if te < best_t:
                        best_t = te
                        best_idx = idx
            if best_idx >= 0:
                break
            for idx in range(10):
                gprev[idx] = gcur[idx]
            ta = tj
        # dynamic events: friction reserve (rolling) and contact
        if dynamic:
            m_prev, n_prev = _dynamic_values(y, par, phase, mu, uxr, uyr, orient, dtmp)
            ta = t
            t_hi = best_t if best_idx >= 0 else t + h
            for j in range(1, N_SUB + 1):
                tj = t + h * j / N_SUB
                if tj > t_hi:
                    tj = t_hi
                _dense(rc, (tj - t) / h, ybuf)
                m_cur, n_cur = _dynamic_values(ybuf, par, phase, mu, uxr, uyr, orient, dtmp)
                nfev += 1
                found = -1
                if n_prev >= 0.0 and n_cur < 0.0:
                    found = 11
                elif phase == PHASE_ROLL and m_prev >= -margin_tol and m_cur < -margin_tol:
                    found = 10
                if found >= 0:
                    te = _locate(found, ta, tj, rc, t, h, par, phase, mu, uxr, uyr, bounds,
                                 slide_mode, slip_threshold, s_layer, orient, ybuf, gv,
                                 dtmp)  # fmt: skip
                    if te <= best_t:
                        best_t = te
                        best_idx = found
                    break
                m_prev = m_cur
                n_prev = n_cur
                ta = tj
                if tj >= t_hi:
                    break

        if best_idx >= 0:
            return (ADV_EVENT, t, h, lfacold, nsteps, nfev, uxr, uyr, best_t, best_idx, t, h,
                    st[4], st[5])  # fmt: skip
        # plain accepted step
        t_start = t
        h_acc = h
        for i in range(N_STATE):
            y[i] = ynew[i]
            K[0, i] = K[6, i]
        t = t + h
        if orient:
            _normalize_quaternion(y)
        # PI control: h * 0.9 err^-0.2 errold^0.08 within [h / 5, 10 h] (Hairer's DOPRI5; one
        # exp and one log instead of two powers), and no growth right after a rejection
        lerr = math.log(max(err, 1e-300))
        fac = max(0.1, min(5.0, math.exp(0.2 * lerr - 0.08 * lfacold) / 0.9))
        lfacold = max(lerr, LOG_1E_4)
        if nrej > 0:
            h = min(h, h / fac, H_MAX)
        else:
            h = min(h / fac, H_MAX)
        nrej = 0
        if record_mode != 0:
            return (ADV_EVENT, t, h, lfacold, nsteps, nfev, uxr, uyr, 1e300, -1, t_start, h_acc,
                    st[4], st[5])  # fmt: skip


@njit(cache=True, error_model="numpy")
def simulate_kernel(  # type: ignore[no-untyped-def]
    par,
    y_init,
    x_edges,
    y_edges,
    mu_grid,
    lane_length,
    lane_width,
    rtol,
    record_mode,
    record_dt,
    slide_mode,
    slip_threshold,
    max_time,
    max_steps,
    orient,
):
    """Integrate one delivery. See the module docstring.

    Returns (samples, n_samples, events, n_events, status, t_end, y_end, n_steps, n_rhs).
    ``record_mode``: 0 summary only, 1 every step, 2 fixed rate ``record_dt``.
    ``slide_mode``: 0 exact slide->roll, 1 the paper's |s| < slip_threshold rule.
    """
    g = par[P_G]
    s_layer = par[P_SLAYER]
    y = y_init.copy()
    t = 0.0
    K = np.empty((7, N_STATE))
    ytmp = np.empty(N_STATE)
    ynew = np.empty(N_STATE)
    ybuf = np.empty(N_STATE)
    dtmp = np.empty(N_STATE)
    rc = np.empty((5, N_STATE))
    gv = np.empty(12)
    gprev = np.empty(12)
    gcur = np.empty(12)
    bounds = np.empty(6)
    rec = np.empty((1024 if record_mode != 0 else 1, 16))
    nrec = 0
    ev = np.empty((16, N_EVCOL))
    nev = 0
    s_accept = s_layer  # a slip-direction root above the layer is a turn, not a zero
    margin_tol = rtol * g

    ix = np.searchsorted(x_edges, y[0], side="right")
    iy = np.searchsorted(y_edges, y[1], side="right")
    mu = mu_grid[ix, iy]
    _cell_bounds(ix, iy, x_edges, y_edges, lane_length, lane_width, bounds)

    # initial phase: rolling if released without slip and the friction suffices
    sx, sy = slip(y, par)
    s0 = math.sqrt(sx * sx + sy * sy)
    phase = PHASE_SLIDE
    uxr = 1.0
    uyr = 0.0
    if s0 > 0.0:
        uxr = sx / s0
        uyr = sy / s0
    else:
        r = roll_accel(y, par)
        fx = r[5]
        fy = r[6]
        fn = math.sqrt(fx * fx + fy * fy)
        if mu * r[7] - fn >= -margin_tol:
            phase = PHASE_ROLL
        else:
            phase = PHASE_LAYER
            uxr = fx / fn
            uyr = fy / fn

    r0 = rhs(y, par, phase, mu, uxr, uyr, orient, K[0])
    nfev = 1
    if record_mode != 0:
        rec, nrec = _push(rec, nrec, t, y, phase, mu, r0[2], r0[3])
    status = STATUS_RUNNING
    if r0[0] <= 0.0:
        status = STATUS_AIRBORNE
        ev, nev = _push_event(ev, nev, t, EVENT_AIRBORNE, y, mu, phase)

    h = _initial_step(y, K, ytmp, dtmp, par, phase, mu, uxr, uyr, orient, rtol)
    nfev += 1
    lfacold = LOG_1E_4
    t_next_sample = record_dt
    nsteps = 0
    n_transitions = 0

    while status == STATUS_RUNNING:
        adv = _advance(
            y, K, ytmp, ynew, ybuf, dtmp, rc, gv, gprev, gcur, bounds, par, phase, mu, uxr, uyr,
            t, h, lfacold, nsteps, nfev, rtol, slide_mode, slip_threshold, s_layer, orient,
            margin_tol, max_time, max_steps, record_mode,
        )  # fmt: skip
        (code, t, h, lfacold, nsteps, nfev, uxr, uyr, best_t, best_idx, t0, h0, ux1, uy1) = adv
        if code == ADV_MAX_STEPS:
            status = STATUS_MAX_STEPS
            break
        if code == ADV_MAX_TIME:
            status = STATUS_MAX_TIME
            ev, nev = _push_event(ev, nev, t, EVENT_MAX_TIME, y, mu, phase)
            break
        if code == ADV_STALLED:
            status = STATUS_STALLED
            break
        # an accepted step from t0 to t0 + h0 (already taken unless an event lies inside it)
        t_step_end = t0 + h0 if best_idx < 0 else best_t
        # ---- samples at a fixed rate from the dense output ----
        if record_mode == 2:
            while t_next_sample <= t_step_end:
                _dense(rc, (t_next_sample - t0) / h0, ybuf)
                rr = rhs(ybuf, par, phase, mu, uxr, uyr, orient, dtmp)
                rec, nrec = _push(rec, nrec, t_next_sample, ybuf, phase, mu, rr[2], rr[3])
                t_next_sample += record_dt

        if best_idx < 0:
            if record_mode == 1:
                rec, nrec = _push(rec, nrec, t, y, phase, mu, ux1, uy1)
            continue

        # ---- an event inside this step: the state there from the dense output ----
        if best_t > t:
            _dense(rc, (best_t - t) / h, y)
        t = best_t
        if orient:
            _normalize_quaternion(y)
        phase_before = phase
        lfacold = LOG_1E_4
        n_transitions += 1
        if n_transitions > MAX_EVENTS:
            status = STATUS_STALLED
            break
        if record_mode != 0:
            rr = rhs(y, par, phase, mu, uxr, uyr, orient, dtmp)
            rec, nrec = _push(rec, nrec, t, y, phase, mu, rr[2], rr[3])

        if best_idx == 4:
            status = STATUS_PINS
            ev, nev = _push_event(ev, nev, t, EVENT_PINS, y, mu, phase)
        elif best_idx == 5 or best_idx == 6:
            status = STATUS_GUTTER
            ev, nev = _push_event(ev, nev, t, EVENT_GUTTER, y, mu, phase)
        elif best_idx == 7:
            status = STATUS_STOPPED
            ev, nev = _push_event(ev, nev, t, EVENT_STOPPED, y, mu, phase)
        elif best_idx == 11:
            status = STATUS_AIRBORNE
            ev, nev = _push_event(ev, nev, t, EVENT_AIRBORNE, y, mu, phase)
        elif best_idx <= 3:
            # friction zone crossing: step into the neighbouring cell
            if best_idx == 0:
                ix += 1
            elif best_idx == 1:
                ix -= 1
            elif best_idx == 2:
                iy += 1
            else:
                iy -= 1
            mu = mu_grid[ix, iy]
            _cell_bounds(ix, iy, x_edges, y_edges, lane_length, lane_width, bounds)
            ev, nev = _push_event(ev, nev, t, EVENT_ZONE, y, mu, phase)
        elif best_idx == 8:
            sx, sy = slip(y, par)
            s_e = math.sqrt(sx * sx + sy * sy)
            turned = s_e > (1.5 * slip_threshold if slide_mode == 1 else s_accept)
            if phase == PHASE_SLIDE and turned:
                # not a zero of the slip: its direction turned within the step
                uxr = sx / s_e
                uyr = sy / s_e
            else:
                _remove_slip(y, par)
                phase = PHASE_ROLL
                ev, nev = _push_event(ev, nev, t, EVENT_SLIDE_TO_ROLL, y, mu, phase)
        elif best_idx == 9:
            sx, sy = slip(y, par)
            s_e = math.sqrt(sx * sx + sy * sy)
            if phase == PHASE_LAYER:
                # the slip is established: back to the plain Coulomb law along s
                uxr = sx / s_e
                uyr = sy / s_e
                phase = PHASE_SLIDE
            else:
                # the slip became tiny: friction along the slaved direction (not stiff)
                phase = PHASE_LAYER
                uxr, uyr = slaved_direction(y, par, mu, sx / s_e, sy / s_e)
        elif best_idx == 10:
            pass  # handled by the friction-reserve check below

        if status != STATUS_RUNNING:
            break
        # a rolling ball that needs more friction than mu n starts to slide
        if phase == PHASE_ROLL:
            r = roll_accel(y, par)
            fx = r[5]
            fy = r[6]
            fn = math.sqrt(fx * fx + fy * fy)
            if mu * r[7] - fn < -margin_tol or best_idx == 10:
                # the slip restarts from zero along the friction the rolling ball needed
                phase = PHASE_LAYER
                uxr = fx / fn
                uyr = fy / fn
                kind = EVENT_SLIP_REVERSAL if best_idx == 8 else EVENT_ROLL_TO_SLIDE
                if best_idx == 8:
                    # drop the slide->roll event we just recorded: the ball never rolled
                    nev -= 1
                ev, nev = _push_event(ev, nev, t, kind, y, mu, phase)
        r0 = rhs(y, par, phase, mu, uxr, uyr, orient, K[0])
        nfev += 1
        if phase != phase_before:
            # the step size of the old phase says nothing about the new one (after a roll ->
            # slide -> roll cycle it was the slip layer's ~1e-5 s): start afresh
            h = _initial_step(y, K, ytmp, dtmp, par, phase, mu, uxr, uyr, orient, rtol)
            nfev += 1
        else:
            h = max(h, 1e-6)
        if record_mode != 0:
            rec, nrec = _push(rec, nrec, t, y, phase, mu, r0[2], r0[3])

    if record_mode != 0 and (nrec == 0 or rec[nrec - 1, COL_T] != t):
        r0 = rhs(y, par, phase, mu, uxr, uyr, orient, dtmp)
        rec, nrec = _push(rec, nrec, t, y, phase, mu, r0[2], r0[3])
    return rec, nrec, ev, nev, status, t, y, nsteps, nfev

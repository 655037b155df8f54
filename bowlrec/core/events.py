"""Event functions and their location on the dense output.

An event function g fires where it goes from >= 0 to < 0. The functions, by index:

=====================  ======================================================================
G_X_HI, G_X_LO,        the ball's center leaves its friction cell (x_hi - x, x - x_lo,
G_Y_HI, G_Y_LO         y_hi - y, y - y_lo)
G_PINS                 L - x: the center reaches the pins
G_GUTTER_RIGHT         y: the center crosses the right edge (y = 0)
G_GUTTER_LEFT          W - y: the center crosses the left edge (y = W)
G_STOP                 vx: the ball stops or comes back
G_SLIP_ZERO            s . u_ref (minus the threshold with the paper's rule): slide -> roll
G_LAYER                s_restart - |s| in the slip layer, |s| - s_layer / 2 outside it
G_RESERVE              mu n - |f| of the rolling ball (needs the equations of motion)
G_CONTACT              the normal force (needs the equations of motion)
=====================  ======================================================================

The first ``N_KINEMATIC`` read only the state; the last two need the right-hand side and are
checked only when a stage showed them falling (see ``integrator.advance``). Roots are found by
safeguarded regula falsi (Illinois) on the step's dense output to ~1e-15 relative in time.
"""

from __future__ import annotations

import math

from numba import njit

from .codes import PHASE_LAYER, PHASE_ROLL, PHASE_SLIDE, SLIDE_TO_ROLL_THRESHOLD
from .dynamics import rhs, slip
from .tsit5 import N_STAGES, dense
from .vec import NO_NRT

G_X_HI, G_X_LO, G_Y_HI, G_Y_LO = 0, 1, 2, 3
G_PINS = 4
G_GUTTER_RIGHT = 5
G_GUTTER_LEFT = 6
G_STOP = 7
G_SLIP_ZERO = 8
G_LAYER = 9
G_RESERVE = 10
G_CONTACT = 11
#: functions of the state alone (G_X_HI .. G_LAYER)
N_KINEMATIC = 10
N_EVENT_FUNCTIONS = 12

# indices of Workspace.bounds
B_X_LO, B_X_HI, B_Y_LO, B_Y_HI, B_LENGTH, B_WIDTH = range(6)
N_BOUNDS = 6


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def kinematic_values(yy, law, run, bounds, gv):  # type: ignore[no-untyped-def]
    """The event functions G_X_HI .. G_LAYER at state yy into ``gv`` (the two dynamic ones are
    set to 1: they are evaluated apart, by :func:`dynamic_values`)."""
    x = yy[0]
    yv = yy[1]
    gv[G_X_HI] = bounds[B_X_HI] - x
    gv[G_X_LO] = x - bounds[B_X_LO]
    gv[G_Y_HI] = bounds[B_Y_HI] - yv
    gv[G_Y_LO] = yv - bounds[B_Y_LO]
    gv[G_PINS] = bounds[B_LENGTH] - x
    gv[G_GUTTER_RIGHT] = yv
    gv[G_GUTTER_LEFT] = bounds[B_WIDTH] - yv
    gv[G_STOP] = yy[2]
    gv[G_SLIP_ZERO] = 1.0
    gv[G_LAYER] = 1.0
    gv[G_RESERVE] = 1.0
    gv[G_CONTACT] = 1.0
    phase = law.phase
    if phase != PHASE_ROLL:
        sx, sy = slip(yy, run.par)
        if run.slide_mode == SLIDE_TO_ROLL_THRESHOLD and phase == PHASE_SLIDE:
            # the slip along the reference direction falls through the threshold (monotonic
            # across the root, unlike |s| - thr, which a large step could dip through unseen)
            gv[G_SLIP_ZERO] = sx * law.ux + sy * law.uy - run.slip_threshold
        else:
            gv[G_SLIP_ZERO] = sx * law.ux + sy * law.uy
        if phase == PHASE_LAYER:
            gv[G_LAYER] = run.s_restart - math.sqrt(sx * sx + sy * sy)
        else:
            gv[G_LAYER] = math.sqrt(sx * sx + sy * sy) - 0.5 * run.s_layer


@njit(cache=True, error_model="numpy", **NO_NRT)
def dynamic_values(yy, law, run, dtmp):  # type: ignore[no-untyped-def]
    """G_RESERVE (rolling only; 1 otherwise) and G_CONTACT at yy (per unit mass, m/s^2)."""
    r = rhs(yy, run.par, law.phase, law.mu, law.ux, law.uy, run.orient, dtmp)
    if law.phase == PHASE_ROLL:
        return r[1], r[0]
    return 1.0, r[0]


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def may_cross(g0, g1, K, h, par, phase):  # type: ignore[no-untyped-def]
    """False when no kinematic event function can change sign inside the accepted step, so the
    4-point scan of the dense output is skipped (it is then bit-identical: it would find nothing).

    g0, g1: the event values at the ends of the step. Between them a function of x or y stays
    within max|a| h^2 / 8 of the chord (a bound on its curvature; 2x safety); vx and the slip
    functions move by at most h max|dg/dt| (1.5x safety), the maxima taken over the 7 stages."""
    ax = 0.0
    ay = 0.0
    sd = 0.0
    for i in range(N_STAGES):
        ax = max(ax, abs(K[i, 2]))
        ay = max(ay, abs(K[i, 3]))
        if phase != PHASE_ROLL:
            dsx, dsy = slip(K[i], par)  # slip() is linear: applied to dy/dt it gives ds/dt
            sd = max(sd, abs(dsx) + abs(dsy))
    cx = 0.25 * h * h * ax
    cy = 0.25 * h * h * ay
    lv = 1.5 * h * ax
    ls = 1.5 * h * sd
    if min(g0[G_X_HI], g1[G_X_HI]) <= cx or min(g0[G_X_LO], g1[G_X_LO]) <= cx:
        return True
    if min(g0[G_PINS], g1[G_PINS]) <= cx:
        return True
    if min(g0[G_Y_HI], g1[G_Y_HI]) <= cy or min(g0[G_Y_LO], g1[G_Y_LO]) <= cy:
        return True
    if min(g0[G_GUTTER_RIGHT], g1[G_GUTTER_RIGHT]) <= cy:
        return True
    if min(g0[G_GUTTER_LEFT], g1[G_GUTTER_LEFT]) <= cy:
        return True
    if min(g0[G_STOP], g1[G_STOP]) <= lv:
        return True
    return min(g0[G_SLIP_ZERO], g1[G_SLIP_ZERO]) <= ls or min(g0[G_LAYER], g1[G_LAYER]) <= ls


@njit(cache=True, error_model="numpy", **NO_NRT)
def value_at(idx, t, t0, h, law, run, ws):  # type: ignore[no-untyped-def]
    """Event function ``idx`` at time t (s) on the dense output ``ws.rc`` of the step (t0, h)."""
    dense(ws.rc, (t - t0) / h, ws.ybuf)
    if idx >= N_KINEMATIC:
        m, nn = dynamic_values(ws.ybuf, law, run, ws.dtmp)
        return m if idx == G_RESERVE else nn
    kinematic_values(ws.ybuf, law, run, ws.bounds, ws.gv)
    return ws.gv[idx]


@njit(cache=True, error_model="numpy", **NO_NRT)
def locate(idx, ta, tb, t0, h, law, run, ws):  # type: ignore[no-untyped-def]
    """Illinois root (s) of event function ``idx`` on the dense output of the step (t0, h),
    between ta (g >= 0) and tb (g < 0)."""
    ga = value_at(idx, ta, t0, h, law, run, ws)
    gb = value_at(idx, tb, t0, h, law, run, ws)
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
        gm = value_at(idx, tm, t0, h, law, run, ws)
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
def cell_bounds(ix, iy, x_edges, y_edges, lane_length, lane_width, bounds):  # type: ignore[no-untyped-def]
    """Fill ``bounds`` with friction cell (ix, iy) of the grid and the lane's size (m)."""
    nx = x_edges.shape[0]
    ny = y_edges.shape[0]
    bounds[B_X_LO] = x_edges[ix - 1] if ix > 0 else -1e300
    bounds[B_X_HI] = x_edges[ix] if ix < nx else 1e300
    bounds[B_Y_LO] = y_edges[iy - 1] if iy > 0 else -1e300
    bounds[B_Y_HI] = y_edges[iy] if iy < ny else 1e300
    bounds[B_LENGTH] = lane_length
    bounds[B_WIDTH] = lane_width

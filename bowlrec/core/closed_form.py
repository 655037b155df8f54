"""Exact solution for a uniform ball (scalar inertia, no offset) on piecewise-constant friction.

While sliding on friction mu the contact force is mu M g along the slip direction u, which for a
uniform sphere never turns (ds/dt = -mu g (1 + R^2/k^2) u), so within a friction cell

    v(t) = v0 + mu g u t,   r(t) = r0 + v0 t + mu g u t^2 / 2,
    w(t) = w0 + mu g R (u_y, -u_x, 0) t / k^2,   |s|(t) = |s0| - mu g (1 + R^2/k^2) t,

and a rolling uniform ball needs no friction, so it rolls straight at constant speed. The events
(cell boundaries, slip zero, v_x = 0, pins, gutters) are roots of these polynomials, solved in
closed form; the solution is continued cell by cell. It returns the same tuple as
``integrator.simulate_kernel`` (summary only: no samples), so ``solver.solve`` can use either.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .codes import (
    EVENT_GUTTER,
    EVENT_PINS,
    EVENT_SLIDE_TO_ROLL,
    EVENT_STOPPED,
    EVENT_ZONE,
    N_COL,
    N_EVCOL,
    N_OBSCOL,
    PHASE_ROLL,
    PHASE_SLIDE,
    STATUS_GUTTER,
    STATUS_MAX_TIME,
    STATUS_PINS,
    STATUS_RUNNING,
    STATUS_STALLED,
    STATUS_STOPPED,
)
from .dynamics import P_G, P_K1, P_R
from .recording import push_event

_INF = 1e300


@njit(cache=True, error_model="numpy")
def _first_root(c0, c1, c2):  # type: ignore[no-untyped-def]
    """Smallest t > 0 with c0 + c1 t + c2 t^2 crossing zero from c0 (inf if none).

    c0 is the signed distance to the boundary at t = 0 (the boundary is ahead when the sign of
    the polynomial changes). Numerically stable quadratic formula."""
    if c2 == 0.0:
        if c1 == 0.0:
            return _INF
        t = -c0 / c1
        return t if t > 0.0 else _INF
    disc = c1 * c1 - 4.0 * c2 * c0
    if disc < 0.0:
        return _INF
    sq = math.sqrt(disc)
    q = -0.5 * (c1 + math.copysign(sq, c1))
    t1 = q / c2
    t2 = c0 / q if q != 0.0 else _INF
    lo = min(t1, t2)
    hi = max(t1, t2)
    if lo > 0.0:
        return lo
    if hi > 0.0:
        return hi
    return _INF


@njit(cache=True, error_model="numpy")
def closed_form_kernel(  # type: ignore[no-untyped-def]
    par, y_init, x_edges, y_edges, mu_grid, lane_length, lane_width, max_time
):
    """Uniform ball, piecewise-constant friction; same return tuple as ``simulate_kernel``."""
    R = par[P_R]
    g = par[P_G]
    k2 = par[P_K1]
    y = y_init.copy()
    t = 0.0
    ev = np.empty((16, N_EVCOL))
    nev = 0
    rec = np.empty((0, N_COL))
    nx = x_edges.shape[0]
    ny = y_edges.shape[0]
    ix = np.searchsorted(x_edges, y[0], side="right")
    iy = np.searchsorted(y_edges, y[1], side="right")
    # released exactly on a cell boundary: take the cell the ball moves into
    if ix > 0 and y[0] == x_edges[ix - 1] and y[2] < 0.0:
        ix -= 1
    if iy > 0 and y[1] == y_edges[iy - 1] and y[3] < 0.0:
        iy -= 1
    mu = mu_grid[ix, iy]
    sx = R * y[9] - y[2]
    sy = -R * y[8] - y[3]
    s = math.sqrt(sx * sx + sy * sy)
    phase = PHASE_ROLL if s == 0.0 else PHASE_SLIDE
    ux = sx / s if s > 0.0 else 0.0
    uy = sy / s if s > 0.0 else 0.0
    status = STATUS_RUNNING
    nseg = 0
    while status == STATUS_RUNNING:
        nseg += 1
        if nseg > 100_000:
            status = STATUS_STALLED
            break
        a = mu * g if phase == PHASE_SLIDE else 0.0
        ax = a * ux
        ay = a * uy
        x0 = y[0]
        y0 = y[1]
        vx = y[2]
        vy = y[3]
        # candidate event times (relative to t)
        best = max_time - t
        kind = 0
        # cell boundaries
        xlo = x_edges[ix - 1] if ix > 0 else -_INF
        xhi = x_edges[ix] if ix < nx else _INF
        ylo = y_edges[iy - 1] if iy > 0 else -_INF
        yhi = y_edges[iy] if iy < ny else _INF
        if xhi < _INF:
            tt = _first_root(xhi - x0, -vx, -0.5 * ax)
            if tt < best:
                best, kind = tt, 1
        if xlo > -_INF:
            tt = _first_root(x0 - xlo, vx, 0.5 * ax)
            if tt < best:
                best, kind = tt, 2
        if yhi < _INF:
            tt = _first_root(yhi - y0, -vy, -0.5 * ay)
            if tt < best:
                best, kind = tt, 3
        if ylo > -_INF:
            tt = _first_root(y0 - ylo, vy, 0.5 * ay)
            if tt < best:
                best, kind = tt, 4
        tt = _first_root(lane_length - x0, -vx, -0.5 * ax)
        if tt < best:
            best, kind = tt, 5
        tt = _first_root(y0, vy, 0.5 * ay)
        if tt < best:
            best, kind = tt, 6
        tt = _first_root(lane_width - y0, -vy, -0.5 * ay)
        if tt < best:
            best, kind = tt, 6
        tt = _first_root(vx, ax, 0.0)
        if tt < best:
            best, kind = tt, 7
        if phase == PHASE_SLIDE and a > 0.0:
            sx = R * y[9] - y[2]
            sy = -R * y[8] - y[3]
            tt = math.sqrt(sx * sx + sy * sy) / (a * (1.0 + R * R / k2))
            if tt <= best:
                best, kind = tt, 8
        # advance exactly by `best`
        dt = best
        y[0] = x0 + vx * dt + 0.5 * ax * dt * dt
        y[1] = y0 + vy * dt + 0.5 * ay * dt * dt
        y[2] = vx + ax * dt
        y[3] = vy + ay * dt
        y[8] += a * R * uy * dt / k2
        y[9] -= a * R * ux * dt / k2
        t += dt
        if kind == 0:
            status = STATUS_MAX_TIME
        elif kind <= 4:
            if kind == 1:
                ix += 1
                y[0] = xhi
            elif kind == 2:
                ix -= 1
                y[0] = xlo
            elif kind == 3:
                iy += 1
                y[1] = yhi
            else:
                iy -= 1
                y[1] = ylo
            mu = mu_grid[ix, iy]
            ev, nev = push_event(ev, nev, t, EVENT_ZONE, y, mu, phase)
        elif kind == 5:
            y[0] = lane_length
            status = STATUS_PINS
            ev, nev = push_event(ev, nev, t, EVENT_PINS, y, mu, phase)
        elif kind == 6:
            y[1] = 0.0 if y[1] < 0.5 * lane_width else lane_width
            status = STATUS_GUTTER
            ev, nev = push_event(ev, nev, t, EVENT_GUTTER, y, mu, phase)
        elif kind == 7:
            y[2] = 0.0
            status = STATUS_STOPPED
            ev, nev = push_event(ev, nev, t, EVENT_STOPPED, y, mu, phase)
        else:
            # slip exactly zero: rolling from here on
            y[2] = R * y[9]
            y[3] = -R * y[8]
            phase = PHASE_ROLL
            ev, nev = push_event(ev, nev, t, EVENT_SLIDE_TO_ROLL, y, mu, phase)
    return rec, 0, ev, nev, status, t, y, nseg, 0, np.empty((0, N_OBSCOL)), 0

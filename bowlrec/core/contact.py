"""The contact between ball and lane: whether friction holds a ball rolling, the friction law at
release, and the impulse that ends a slide exactly.

At a located slide -> roll root the slip is zero only to within the tolerance; the residual is
removed by an impulse at the contact point, which changes v and w as a friction impulse does.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .codes import PHASE_LAYER, PHASE_ROLL, PHASE_SLIDE, S_VX, S_VY, S_WX, S_WY, S_WZ
from .dynamics import P_R, ball_frame, roll_accel, slip
from .records import FrictionLaw
from .vec import NO_NRT, cross, solve3


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def rolling_grip(y, par, mu, margin_tol):  # type: ignore[no-untyped-def]
    """Whether friction mu holds the ball at state y rolling: the friction it needs (per unit
    mass) is at most mu n + ``margin_tol`` (m/s^2). Returns (holds, ux, uy), (ux, uy) the unit
    direction of the friction it needs."""
    r = roll_accel(y, par)
    fx = r[5]
    fy = r[6]
    fn = math.sqrt(fx * fx + fy * fy)
    return mu * r[7] - fn >= -margin_tol, fx / fn, fy / fn


@njit(cache=True, error_model="numpy", **NO_NRT)
def release_law(y, par, mu, margin_tol):  # type: ignore[no-untyped-def]
    """The friction law at release: sliding along the slip; rolling when there is no slip and
    friction mu holds the ball (:func:`rolling_grip`); else the slip layer, along the friction
    the rolling ball needs."""
    sx, sy = slip(y, par)
    s0 = math.sqrt(sx * sx + sy * sy)
    if s0 > 0.0:
        return FrictionLaw(PHASE_SLIDE, mu, sx / s0, sy / s0)
    holds, ux, uy = rolling_grip(y, par, mu, margin_tol)
    if holds:
        return FrictionLaw(PHASE_ROLL, mu, 1.0, 0.0)
    return FrictionLaw(PHASE_LAYER, mu, ux, uy)


@njit(cache=True, error_model="numpy")
def remove_slip(y, par):  # type: ignore[no-untyped-def]
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
        apply_impulse(yy, par, 1.0 if j == 0 else 0.0, 1.0 if j == 1 else 0.0)
        tx, ty = slip(yy, par)
        cols[0, j] = tx - sx
        cols[1, j] = ty - sy
    det = cols[0, 0] * cols[1, 1] - cols[0, 1] * cols[1, 0]
    jx = (-sx * cols[1, 1] + sy * cols[0, 1]) / det
    jy = (-sy * cols[0, 0] + sx * cols[1, 0]) / det
    apply_impulse(y, par, jx, jy)


@njit(cache=True, error_model="numpy", **NO_NRT)
def apply_impulse(y, par, jx, jy):  # type: ignore[no-untyped-def]
    """Horizontal impulse (jx, jy, 0) per unit mass (m/s) at the contact point (in place)."""
    iw, rd = ball_frame(y, par)
    ixx, iyy, izz, ixy, ixz, iyz = iw
    rdx, rdy, rdz = rd
    R = par[P_R]
    # angular impulse about the center of mass: rho x J, rho = r_Delta + R_con
    lx, ly, lz = cross(rdx, rdy, rdz - R, jx, jy, 0.0)
    dwx, dwy, dwz = solve3(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz, lx, ly, lz)
    # v_cb = v_com + w x r_Delta
    cx, cy, _ = cross(dwx, dwy, dwz, rdx, rdy, rdz)
    y[S_VX] += jx + cx
    y[S_VY] += jy + cy
    y[S_WX] += dwx
    y[S_WY] += dwy
    y[S_WZ] += dwz

"""Equations of motion of Frohlich (2004), fused for speed: the right-hand side of the ODE.

State vector ``y`` (SI):

====  ==========================================================
0, 1  x, y of the geometric center (m); the center stays at z = 0
2, 3  vx, vy of the geometric center (m/s)
4..7  unit quaternion (w, x, y, z), body -> lane frame
8..10 angular velocity omega in the lane frame (rad/s)
====  ==========================================================

Parameters ``par`` (see :func:`pack_params`): ball radius R, gravity g, the principal moments per
unit mass k_i^2 (m^2), r_Delta in the body frame (m), and two flags that switch off terms that are
exactly zero for the scene (scalar inertia: no I_dev / tau_dev; zero offset: no r_Delta terms);
then the optional external terms (none in the paper) and their flag P_EXT: air drag, rolling
resistance and Magnus lift, forces e at the geometric center, and the lane topography's lateral
gravity g_h at the center of mass (:func:`external_accel`). With P_EXT = 0 the right-hand side
computes none of them (``roll_accel`` and ``_slide_accel_frame`` branch to their external
versions only when it is set), so flat-lane scenes give the same bits with or without these
parameters.

Sliding (paper Eqs. (6), (A8)-(A12)): with rho = r_Delta + R_con and mu_vec = (mu u_x, mu u_y, 1)
(u the unit slip direction), the torque equation per unit mass is

    (I - (rho x mu_vec) e_a^T) alpha = (I_dev w) x w + (g + a_w) rho x mu_vec,

e_a = z x r_Delta so that a_alpha = e_a . alpha, a_w = [(w x r_Delta) x w]_z. This is the sum of the
paper's terms: I_Delta^s + I_DeltaDelta^s = -(rho x mu_vec) e_a^T and
tau_fric + tau_Delta^s + tau_DeltaDelta^s = (g + a_w) rho x mu_vec. The normal force per unit mass
is n = g + a_alpha + a_w and the center accelerates at
n mu u + [alpha x r_Delta + w x (w x r_Delta)]_h.

Rolling (Eqs. (7), (B1)-(B7)): (I + |rho|^2 1 - rho rho^T) alpha = (I_dev w) x w + tau_Delta^r
+ tau_DeltaDelta^r, the center accelerates at R_con x alpha and the contact force per unit mass is
F/M = g z + rho x alpha + (w x r_Delta) x w (the paper's Eq. (B3) prints -g n: a sign slip).

External terms (per unit mass; e at the geometric center, g_h = (0, -g dz/dy, 0) at the center
of mass): sliding, n = g - e_z + a_alpha + a_w and the torque gains r_Delta x e; rolling, the
torque gains -R_con x e - rho x g_h and F/M gains -e - g_h; in both the center accelerates by
e_h + g_h more (see ``_slide_accel_external`` and ``_roll_accel_external``).

``bowlrec.core.terms`` computes every term separately; tests check both against a direct
Newton-Euler solve (tests/test_physics_newton_euler.py, tests/test_external_terms.py).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .codes import LIFT_SAWICKI, PHASE_LAYER, PHASE_ROLL
from .vec import NO_NRT, cross, quat_matrix, rotate, solve3, world_inertia

(
    P_R,
    P_G,
    P_K1,
    P_K2,
    P_K3,
    P_RDX,
    P_RDY,
    P_RDZ,
    P_SCALAR,
    P_OFFSET,
    P_SLAYER,
    P_QWEIGHT,
    P_EXT,
    P_DRAG,
    P_RR,
    P_LIFT,
    P_LIFTMODEL,
    P_SLOPE,
    P_NPROF,
    P_SRESTART,
) = range(20)
N_PAR = 20
#: the height profile's spline follows the N_PAR entries: knots y_i (m), heights z_i (m) and the
#: spline's second derivatives z''_i (1/m), P_NPROF values each
P_PROFILE = N_PAR


def pack_params(
    radius_m: float,
    g_mps2: float,
    inertia_per_mass_m2: np.ndarray,
    r_delta_body_m: np.ndarray,
    slip_layer_mps: float = 1e-5,
    orientation_weight: float = 1.0,
    restart_layer_mps: float | None = None,
    drag_per_m: float = 0.0,
    rolling_resistance_mps2: float = 0.0,
    lift_per_m: float = 0.0,
    lift_model: int = 0,
    cross_slope: float = 0.0,
    profile: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Parameter vector for the kernels; sets the scalar-inertia, offset and external-terms
    flags exactly.

    ``slip_layer_mps``: slip speed (m/s) below which friction acts along the slaved direction
    (see :func:`friction_direction`). ``orientation_weight``: weight of the quaternion in the
    integrator's error norm (0 drops it). ``restart_layer_mps``: slip speed (m/s) at which a
    slip that restarted from rolling leaves the layer (None: ``slip_layer_mps``).

    External terms (see :func:`external_accel`; all zero: the flag P_EXT is 0 and the
    right-hand side computes nothing of them): ``drag_per_m`` = C_D rho_air A / (2 M) (1/m),
    ``rolling_resistance_mps2`` = C_rr g (m/s^2), ``lift_per_m`` = rho_air A / (2 M) (1/m) with
    ``lift_model`` a LIFT_* code, ``cross_slope`` dz/dy of the lane (dimensionless) and
    ``profile`` = (y_i, z_i, z''_i) of a natural cubic spline of the lane's height across it
    (m, m, 1/m; see :func:`bowlrec.core.topography.natural_spline`)."""
    k = np.asarray(inertia_per_mass_m2, dtype=np.float64)
    rd = np.asarray(r_delta_body_m, dtype=np.float64)
    scalar = 1.0 if (k[0] == k[1] == k[2]) else 0.0
    offset = 0.0 if not np.any(rd != 0.0) else 1.0
    n_prof = 0 if profile is None else int(np.asarray(profile[0]).size)
    lift = lift_per_m if lift_model != 0 else 0.0
    ext = (
        1.0
        if (drag_per_m != 0.0 or rolling_resistance_mps2 != 0.0 or lift != 0.0)
        or (cross_slope != 0.0 or n_prof > 0)
        else 0.0
    )
    head = [
        radius_m,
        g_mps2,
        k[0],
        k[1],
        k[2],
        rd[0],
        rd[1],
        rd[2],
        scalar,
        offset,
        slip_layer_mps,
        orientation_weight,
        ext,
        drag_per_m,
        rolling_resistance_mps2,
        lift,
        float(lift_model) if lift != 0.0 else 0.0,
        cross_slope,
        float(n_prof),
        slip_layer_mps if restart_layer_mps is None else restart_layer_mps,
    ]
    if profile is None:
        return np.array(head, dtype=np.float64)
    tail = np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in profile])
    return np.concatenate([np.array(head, dtype=np.float64), tail])


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def ball_frame(y, par):  # type: ignore[no-untyped-def]
    """World inertia per unit mass (6-tuple) and r_Delta in the lane frame at state y."""
    if par[P_SCALAR] != 0.0 and par[P_OFFSET] == 0.0:
        k = par[P_K1]
        return (k, k, k, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    m = quat_matrix(y[4], y[5], y[6], y[7])
    if par[P_SCALAR] != 0.0:
        k = par[P_K1]
        iw = (k, k, k, 0.0, 0.0, 0.0)
    else:
        iw = world_inertia(m, par[P_K1], par[P_K2], par[P_K3])
    if par[P_OFFSET] != 0.0:
        rd = rotate(m, par[P_RDX], par[P_RDY], par[P_RDZ])
    else:
        rd = (0.0, 0.0, 0.0)
    return iw, rd


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def profile_slope(par, yq):  # type: ignore[no-untyped-def]
    """dz/dy (dimensionless) of the natural cubic spline through the lane's height profile at
    y = yq (m); linear beyond the end knots (where the natural spline's curvature is zero, so
    the slope stays continuous with a continuous derivative)."""
    n = int(par[P_NPROF])
    oy = P_PROFILE  # knots y_i, then heights z_i at oy + n, then z''_i at oy + 2 n
    if yq <= par[oy]:
        i = 0
        t = 0.0
    elif yq >= par[oy + n - 1]:
        i = n - 2
        t = par[oy + n - 1] - par[oy + n - 2]
    else:
        lo = 0
        hi = n - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if par[oy + mid] <= yq:
                lo = mid
            else:
                hi = mid
        i = lo
        t = yq - par[oy + i]
    h = par[oy + i + 1] - par[oy + i]
    dz = par[oy + n + i + 1] - par[oy + n + i]
    m0 = par[oy + 2 * n + i]
    m1 = par[oy + 2 * n + i + 1]
    return dz / h - h * (2.0 * m0 + m1) / 6.0 + m0 * t + (m1 - m0) * t * t / (2.0 * h)


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def lift_coefficient_per_spin(s, model):  # type: ignore[no-untyped-def]
    """C_L(S) / S of the Magnus lift model ``model`` (LIFT_* code) at the spin parameter
    S = R |w_perp| / |v| (dimensionless); finite at S = 0. LIFT_SAWICKI (Sawicki, Hubbard &
    Stronge, Am. J. Phys. 71, 1152 (2003), their fit to baseball lift data): C_L = 1.5 S for
    S <= 0.1, 0.09 + 0.6 S above (continuous at S = 0.1)."""
    if model == LIFT_SAWICKI:
        if s <= 0.1:
            return 1.5
        return 0.09 / s + 0.6
    return 0.0


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def external_accel(y, par):  # type: ignore[no-untyped-def]
    """The optional external forces per unit mass at state y (m/s^2), zeros unless switched on.

    Returns (ex, ey, ez, gx, gy): e = drag + rolling resistance + Magnus lift, applied at the
    geometric center, and (gx, gy, 0) = the lateral gravity of the lane's topography, applied at
    the center of mass. With v = (v_x, v_y, 0) the velocity of the geometric center (the air is
    still) and w the angular velocity:

    * drag: -k_D |v| v, k_D = C_D rho A / (2 M) (P_DRAG);
    * rolling resistance: -C_rr g v / |v| (P_RR = C_rr g). For a rolling ball this is the
      normal force N = M g acting a distance d = C_rr R ahead of the contact point: its moment
      about the contact, d N = C_rr R M g, equals that of C_rr M g at the center, R C_rr M g,
      and both resist the motion. The static load M g stands for N: the normal force differs
      from it by the offset's a_alpha + a_w and the lift's -e_z (per unit mass), a few per
      cent of g for real balls (docs/lane-and-air.md);
    * Magnus lift: k_L C_L(S) |v|^2 (w x v) / |w x v|, k_L = rho A / (2 M) (P_LIFT),
      S = R |w x v| / |v|^2 = R |w_perp| / |v|; written as k_L (C_L / S) R (w x v), finite
      when w x v -> 0;
    * topography: g_h = (0, -g dz/dy, 0), dz/dy = the cross slope (P_SLOPE) plus the height
      profile's slope (:func:`profile_slope`) at the contact's y (= the center's y).

    A ball at rest (|v| = 0) feels no drag, rolling resistance or lift."""
    vx = y[2]
    vy = y[3]
    v2 = vx * vx + vy * vy
    ex = 0.0
    ey = 0.0
    ez = 0.0
    if v2 > 0.0:
        v = math.sqrt(v2)
        kd = par[P_DRAG]
        if kd != 0.0:
            ex -= kd * v * vx
            ey -= kd * v * vy
        crr = par[P_RR]
        if crr != 0.0:
            ex -= crr * vx / v
            ey -= crr * vy / v
        kl = par[P_LIFT]
        if kl != 0.0:
            wx = y[8]
            wy = y[9]
            wz = y[10]
            # w x v with v = (vx, vy, 0)
            cx = -wz * vy
            cy = wz * vx
            cz = wx * vy - wy * vx
            c = math.sqrt(cx * cx + cy * cy + cz * cz)
            s = par[P_R] * c / v2
            f = kl * lift_coefficient_per_spin(s, int(par[P_LIFTMODEL])) * par[P_R]
            ex += f * cx
            ey += f * cy
            ez += f * cz
    slope = par[P_SLOPE]
    if par[P_NPROF] > 0.0:
        slope += profile_slope(par, y[1])
    return ex, ey, ez, 0.0, -par[P_G] * slope


@njit(cache=True, error_model="numpy", forceinline=True)
def _dev_torque(iw, wx, wy, wz, scalar):  # type: ignore[no-untyped-def]
    """tau_dev = (I_dev w) x w = (I w) x w (the isotropic part is parallel to w)."""
    if scalar:
        return 0.0, 0.0, 0.0
    ixx, iyy, izz, ixy, ixz, iyz = iw
    lx = ixx * wx + ixy * wy + ixz * wz
    ly = ixy * wx + iyy * wy + iyz * wz
    lz = ixz * wx + iyz * wy + izz * wz
    return cross(lx, ly, lz, wx, wy, wz)


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def slide_accel(y, par, mu, ux, uy):  # type: ignore[no-untyped-def]
    """Sliding with friction along the unit direction (ux, uy) of the slip.

    Returns (ax, ay, alpha_x, alpha_y, alpha_z, n): the acceleration of the geometric center
    (m/s^2), the angular acceleration (rad/s^2) and the normal force per unit mass (m/s^2).
    """
    return _slide_accel_frame(y, par, _slide_frame(y, par), mu, ux, uy)


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _slide_frame(y, par):  # type: ignore[no-untyped-def]
    """The parts of ``slide_accel`` that do not depend on the friction direction: world inertia,
    r_Delta in the lane frame and tau_dev (computed once when several directions are tried)."""
    iw, rd = ball_frame(y, par)
    td = _dev_torque(iw, y[8], y[9], y[10], par[P_SCALAR] != 0.0)
    return iw, rd, td


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _slide_accel_frame(y, par, frame, mu, ux, uy):  # type: ignore[no-untyped-def]
    """``slide_accel`` given ``_slide_frame(y, par)``."""
    if par[P_EXT] != 0.0:
        return _slide_accel_external(y, par, frame, mu, ux, uy)
    R = par[P_R]
    g = par[P_G]
    wx = y[8]
    wy = y[9]
    wz = y[10]
    iw, rd, td = frame
    ixx, iyy, izz, ixy, ixz, iyz = iw
    rdx, rdy, rdz = rd
    mx = mu * ux
    my = mu * uy
    tdx, tdy, tdz = td
    # c = rho x mu_vec with rho = r_Delta + R_con = (rdx, rdy, rdz - R), mu_vec = (mx, my, 1)
    cx, cy, cz = cross(rdx, rdy, rdz - R, mx, my, 1.0)
    if par[P_OFFSET] == 0.0:
        aw = 0.0
        ax_, ay_, az_ = solve3(
            ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz,
            tdx + g * cx, tdy + g * cy, tdz + g * cz,
        )  # fmt: skip
        n = g
        return n * mx, n * my, ax_, ay_, az_, n
    w2 = wx * wx + wy * wy + wz * wz
    wr = wx * rdx + wy * rdy + wz * rdz
    aw = w2 * rdz - wz * wr
    # e_a = z x r_Delta = (-rdy, rdx, 0); A = I - c e_a^T
    ex = -rdy
    ey = rdx
    k = g + aw
    ax_, ay_, az_ = solve3(
        ixx - cx * ex, ixy - cx * ey, ixz,
        ixy - cy * ex, iyy - cy * ey, iyz,
        ixz - cz * ex, iyz - cz * ey, izz,
        tdx + k * cx, tdy + k * cy, tdz + k * cz,
    )  # fmt: skip
    n = k + ex * ax_ + ey * ay_
    # acceleration of the center: friction + (alpha x r_Delta + w x (w x r_Delta))_h
    px, py, _ = cross(ax_, ay_, az_, rdx, rdy, rdz)
    # w x (w x r) = w (w.r) - r |w|^2
    accx = n * mx + px + wx * wr - rdx * w2
    accy = n * my + py + wy * wr - rdy * w2
    return accx, accy, ax_, ay_, az_, n


@njit(cache=True, error_model="numpy", **NO_NRT)
def _slide_accel_external(y, par, frame, mu, ux, uy):  # type: ignore[no-untyped-def]
    """``_slide_accel_frame`` with the external forces of :func:`external_accel`.

    With e (at the geometric center) and g_h (at the center of mass) per unit mass, the
    vertical force equation gives n = g - e_z + a_alpha + a_w, the torque about the center of
    mass gains r_Delta x e (g_h has no moment about the center of mass), so

        (I - (rho x mu_vec) e_a^T) alpha = (I_dev w) x w + (g - e_z + a_w) rho x mu_vec
                                           + r_Delta x e,

    and the center of mass (and with it the geometric center) accelerates by e_h + g_h more."""
    R = par[P_R]
    g = par[P_G]
    wx = y[8]
    wy = y[9]
    wz = y[10]
    iw, rd, td = frame
    ixx, iyy, izz, ixy, ixz, iyz = iw
    rdx, rdy, rdz = rd
    mx = mu * ux
    my = mu * uy
    tdx, tdy, tdz = td
    fex, fey, fez, gx, gy = external_accel(y, par)
    cx, cy, cz = cross(rdx, rdy, rdz - R, mx, my, 1.0)
    if par[P_OFFSET] == 0.0:
        k = g - fez
        ax_, ay_, az_ = solve3(
            ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz,
            tdx + k * cx, tdy + k * cy, tdz + k * cz,
        )  # fmt: skip
        return k * mx + fex + gx, k * my + fey + gy, ax_, ay_, az_, k
    w2 = wx * wx + wy * wy + wz * wz
    wr = wx * rdx + wy * rdy + wz * rdz
    aw = w2 * rdz - wz * wr
    ex = -rdy
    ey = rdx
    k = g - fez + aw
    # r_Delta x e
    qx, qy, qz = cross(rdx, rdy, rdz, fex, fey, fez)
    ax_, ay_, az_ = solve3(
        ixx - cx * ex, ixy - cx * ey, ixz,
        ixy - cy * ex, iyy - cy * ey, iyz,
        ixz - cz * ex, iyz - cz * ey, izz,
        tdx + k * cx + qx, tdy + k * cy + qy, tdz + k * cz + qz,
    )  # fmt: skip
    n = k + ex * ax_ + ey * ay_
    px, py, _ = cross(ax_, ay_, az_, rdx, rdy, rdz)
    accx = n * mx + px + wx * wr - rdx * w2 + fex + gx
    accy = n * my + py + wy * wr - rdy * w2 + fey + gy
    return accx, accy, ax_, ay_, az_, n


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def roll_accel(y, par):  # type: ignore[no-untyped-def]
    """Rolling without slipping.

    Returns (ax, ay, alpha_x, alpha_y, alpha_z, fx, fy, n): center acceleration (m/s^2), angular
    acceleration (rad/s^2), the horizontal contact (friction) force per unit mass (m/s^2) and the
    normal force per unit mass (m/s^2). With the external terms on (P_EXT), see
    :func:`_roll_accel_external`.
    """
    if par[P_EXT] != 0.0:
        return _roll_accel_external(y, par)
    R = par[P_R]
    g = par[P_G]
    wx = y[8]
    wy = y[9]
    wz = y[10]
    iw, rd = ball_frame(y, par)
    ixx, iyy, izz, ixy, ixz, iyz = iw
    rdx, rdy, rdz = rd
    tx, ty, tz = _dev_torque(iw, wx, wy, wz, par[P_SCALAR] != 0.0)
    pz = rdz - R  # rho = (rdx, rdy, pz)
    if par[P_OFFSET] != 0.0:
        w2 = wx * wx + wy * wy + wz * wz
        wr = wx * rdx + wy * rdy + wz * rdz
        # tau_Delta^r = g r x z + R [w^2 r x z + (w.r) z x w]
        # with r x z = (ry, -rx, 0) and z x w = (-wy, wx, 0)
        tx += g * rdy + R * (w2 * rdy - wr * wy)
        ty += -g * rdx + R * (-w2 * rdx + wr * wx)
        # tau_DeltaDelta^r = (w.r) w x r
        qx, qy, qz = cross(wx, wy, wz, rdx, rdy, rdz)
        tx += wr * qx
        ty += wr * qy
        tz += wr * qz
    else:
        w2 = 0.0
        wr = 0.0
    p2 = rdx * rdx + rdy * rdy + pz * pz
    ax_, ay_, az_ = solve3(
        ixx + p2 - rdx * rdx, ixy - rdx * rdy, ixz - rdx * pz,
        ixy - rdx * rdy, iyy + p2 - rdy * rdy, iyz - rdy * pz,
        ixz - rdx * pz, iyz - rdy * pz, izz + p2 - pz * pz,
        tx, ty, tz,
    )  # fmt: skip
    # F/M = g z + rho x alpha + (w x r) x w, with (w x r) x w = r |w|^2 - w (w.r)
    hx, hy, hz = cross(rdx, rdy, pz, ax_, ay_, az_)
    fx = hx + rdx * w2 - wx * wr
    fy = hy + rdy * w2 - wy * wr
    n = g + hz + rdz * w2 - wz * wr
    # a_cb = R_con x alpha = (R alpha_y, -R alpha_x, 0)
    return R * ay_, -R * ax_, ax_, ay_, az_, fx, fy, n


@njit(cache=True, error_model="numpy", **NO_NRT)
def _roll_accel_external(y, par):  # type: ignore[no-untyped-def]
    """``roll_accel`` with the external forces of :func:`external_accel` (kept apart so that the
    flat-lane right-hand side compiles to the same code with one branch more).

    With e at the geometric center and g_h at the center of mass (per unit mass), the contact
    force is F/M = a_com + g z - e - g_h = g z + rho x alpha + (w x r_Delta) x w - e - g_h and
    its moment plus that of e about the center of mass gives

        (I + |rho|^2 1 - rho rho^T) alpha = (I_dev w) x w + tau_Delta^r + tau_DeltaDelta^r
                                            - R_con x e - rho x g_h.
    """
    R = par[P_R]
    g = par[P_G]
    wx = y[8]
    wy = y[9]
    wz = y[10]
    iw, rd = ball_frame(y, par)
    ixx, iyy, izz, ixy, ixz, iyz = iw
    rdx, rdy, rdz = rd
    tx, ty, tz = _dev_torque(iw, wx, wy, wz, par[P_SCALAR] != 0.0)
    pz = rdz - R  # rho = (rdx, rdy, pz)
    if par[P_OFFSET] != 0.0:
        w2 = wx * wx + wy * wy + wz * wz
        wr = wx * rdx + wy * rdy + wz * rdz
        tx += g * rdy + R * (w2 * rdy - wr * wy)
        ty += -g * rdx + R * (-w2 * rdx + wr * wx)
        qx, qy, qz = cross(wx, wy, wz, rdx, rdy, rdz)
        tx += wr * qx
        ty += wr * qy
        tz += wr * qz
    else:
        w2 = 0.0
        wr = 0.0
    fex, fey, fez, gx, gy = external_accel(y, par)
    # -R_con x e = (-R e_y, R e_x, 0) and -rho x g_h = (pz g_y, -pz g_x, r_y g_x - r_x g_y)
    tx += -R * fey + pz * gy
    ty += R * fex - pz * gx
    tz += rdy * gx - rdx * gy
    p2 = rdx * rdx + rdy * rdy + pz * pz
    ax_, ay_, az_ = solve3(
        ixx + p2 - rdx * rdx, ixy - rdx * rdy, ixz - rdx * pz,
        ixy - rdx * rdy, iyy + p2 - rdy * rdy, iyz - rdy * pz,
        ixz - rdx * pz, iyz - rdy * pz, izz + p2 - pz * pz,
        tx, ty, tz,
    )  # fmt: skip
    hx, hy, hz = cross(rdx, rdy, pz, ax_, ay_, az_)
    fx = hx + rdx * w2 - wx * wr - fex - gx
    fy = hy + rdy * w2 - wy * wr - fey - gy
    n = g + hz + rdz * w2 - wz * wr - fez
    return R * ay_, -R * ax_, ax_, ay_, az_, fx, fy, n


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def slip(y, par):  # type: ignore[no-untyped-def]
    """Slip velocity s = R_con x w - v_cb (m/s): the floor's velocity relative to the contact."""
    R = par[P_R]
    return R * y[9] - y[2], -R * y[8] - y[3]


@njit(cache=True, error_model="numpy", **NO_NRT)
def slip_rate(y, par, mu, ux, uy):  # type: ignore[no-untyped-def]
    """ds/dt (m/s^2) while sliding with friction along (ux, uy)."""
    return _slip_rate_frame(y, par, _slide_frame(y, par), mu, ux, uy)


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _slip_rate_frame(y, par, frame, mu, ux, uy):  # type: ignore[no-untyped-def]
    """``slip_rate`` given ``_slide_frame(y, par)``."""
    ax, ay, alx, aly, _alz, _n = _slide_accel_frame(y, par, frame, mu, ux, uy)
    R = par[P_R]
    return R * aly - ax, -R * alx - ay


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def _angle_newton(y, par, frame, mu, phi0, fx, fy, slaved, max_iter, max_turn):  # type: ignore[no-untyped-def]
    """Newton's method on the friction angle phi for h(phi) = a x ds/dt(phi) = 0, where
    ds/dt(phi) is the slip rate with friction along (cos phi, sin phi) and a is that same
    direction (``slaved``) or the fixed unit (fx, fy). dh/dphi by a 1e-7 rad difference.

    Returns (status, phi, ax, ay), (ax, ay) = ds/dt at the last phi evaluated: status 1
    converged (|h| <= 1e-13 |ds/dt| or a step below 1e-14 rad), 2 out of iterations, 0 flat
    (|dh/dphi| < 1e-3 |ds/dt|: the root is ill-defined), -1 wandered more than max_turn rad."""
    phi = phi0
    ax = 0.0
    ay = 0.0
    for _ in range(max_iter):
        cx = math.cos(phi)
        cy = math.sin(phi)
        ax, ay = _slip_rate_frame(y, par, frame, mu, cx, cy)
        px = cx if slaved else fx
        py = cy if slaved else fy
        h0 = px * ay - py * ax
        scale = abs(ax) + abs(ay) + 1e-300
        if abs(h0) <= 1e-13 * scale:
            return 1, phi, ax, ay
        d = 1e-7
        c2 = math.cos(phi + d)
        s2 = math.sin(phi + d)
        tx, ty = _slip_rate_frame(y, par, frame, mu, c2, s2)
        qx = c2 if slaved else fx
        qy = s2 if slaved else fy
        h1 = qx * ty - qy * tx
        dh = (h1 - h0) / d
        if abs(dh) < 1e-3 * scale:
            return 0, phi, ax, ay
        step = -h0 / dh
        if step > 0.5:
            step = 0.5
        elif step < -0.5:
            step = -0.5
        phi += step
        if abs(phi - phi0) > max_turn:
            return -1, phi, ax, ay
        if abs(step) < 1e-14:
            return 1, phi, ax, ay
    return 2, phi, ax, ay


@njit(cache=True, error_model="numpy", **NO_NRT)
def slaved_direction(y, par, mu, ux, uy):  # type: ignore[no-untyped-def]
    """Unit friction direction u with ds/dt(u) parallel to u (Newton on the angle from (ux, uy)).

    Right after a rolling ball starts slipping, the slip is tiny and its direction relaxes toward
    this direction at a rate |d(u x ds/dt)/d angle| / |s| (stiff). In that boundary layer bowlrec
    lets friction act along this slaved direction (the limit |s| -> 0 of the exact dynamics)
    instead of integrating the stiff relaxation; see ``bowlrec.core.integrator``. Where that rate
    is negligible (below 1e-3 of |ds/dt|: e.g. a nearly uniform ball, whose slip direction is not
    stiff and for which every direction is nearly slaved) the root is ill-defined and the start
    direction is returned unchanged, as it is if Newton wanders more than 1 rad away.
    """
    frame = _slide_frame(y, par)
    status, phi, _, _ = _angle_newton(y, par, frame, mu, math.atan2(uy, ux), 0.0, 0.0, True, 8, 1.0)
    if status <= 0:
        return ux, uy
    return math.cos(phi), math.sin(phi)


@njit(cache=True, error_model="numpy", **NO_NRT)
def radial_direction(y, par, mu, sx, sy):  # type: ignore[no-untyped-def]
    """Friction direction that makes a small slip along the unit (sx, sy) shrink straight to zero.

    Returns (ok, ux, uy): the unit u with ds/dt(u) = -kappa (sx, sy), kappa > 0 (Newton on the
    angle of u, started at the slip's own direction). ``ok`` is False when the rolling ball would
    need more friction than mu n (then no slip can be driven to zero and the slip restarts along
    the slaved direction) or when Newton fails.

    Why: when rolling is possible, |f_roll| <= mu n, every small slip reaches zero in finite
    time (V = s^T W^-1 s, W the contact mobility, decreases at a rate >= 2 |s| (mu n - |f_roll|)),
    but its direction turns at a rate ~ |ds/dt| / |s| on the way: stiff. Below slip_layer / 2
    bowlrec lets friction (still of size mu n) act along this direction instead, so the slip
    runs straight into zero and the slide->roll root is an ordinary, non-stiff sign change. The
    total friction impulse up to the root is fixed by the end condition s = 0, so the motion
    after it is unchanged to O(|s|^2); the root itself moves by at most the layer's crossing time
    ~ slip_layer / (2 kappa) (over the 218 benchmark deliveries the whole slide error at rtol
    1e-6 is <= 0.27 mm).
    """
    r = roll_accel(y, par)
    if mu * r[7] < math.sqrt(r[5] * r[5] + r[6] * r[6]):
        return False, sx, sy
    frame = _slide_frame(y, par)
    status, phi, ax, ay = _angle_newton(
        y, par, frame, mu, math.atan2(sy, sx), sx, sy, False, 12, 4.0
    )
    if status == 1 and sx * ax + sy * ay < 0.0:
        return True, math.cos(phi), math.sin(phi)
    return False, sx, sy


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def friction_direction(y, par, phase, mu, ux_ref, uy_ref, sx, sy, s):  # type: ignore[no-untyped-def]
    """Unit direction of the friction force while sliding, given the slip (sx, sy), |s| = s.

    Above slip_layer / 2 (PHASE_SLIDE): along the slip, continued through s = 0 on the side of
    the reference direction when the slip points back past the root, so the right-hand side
    stays smooth across the slide->roll root (located by the event s . u_ref = 0).

    For a small slip, where rolling is possible, friction acts along ``radial_direction`` of the
    slip's own direction (continued through zero like the plain law), which drives the slip
    straight to zero. Otherwise the slaved direction is searched from the slip's direction. It
    is used only when it lies within 15 degrees of it:
    where the slip direction is stiff it has relaxed onto the slaved direction, and where it has
    not (or where the slaved direction is ill-defined, as for a nearly uniform ball whose slip
    direction is not stiff at all) the plain Coulomb direction is exact. A slip
    indistinguishable from zero (the start of a re-slip, or a stage landing on the slide->roll
    root) starts from the reference direction.
    """
    s_layer = par[P_SLAYER]
    if phase == PHASE_LAYER or s < 0.5 * s_layer:
        if s > 1e-2 * s_layer:
            ux0 = sx / s
            uy0 = sy / s
            if ux0 * ux_ref + uy0 * uy_ref < -0.5:
                ux0 = -ux0
                uy0 = -uy0
        else:
            ux0 = ux_ref
            uy0 = uy_ref
        ok, ux, uy = radial_direction(y, par, mu, ux0, uy0)
        if ok:
            return ux, uy
        if s > 1e-2 * s_layer:
            ux, uy = slaved_direction(y, par, mu, ux0, uy0)
            if ux * ux0 + uy * uy0 < 0.966:
                return ux0, uy0
            return ux, uy
        return slaved_direction(y, par, mu, ux_ref, uy_ref)
    ux = sx / s
    uy = sy / s
    # past the slide->roll root the slip points back along -u_ref: continue smoothly. (A slip
    # that merely turned by ~90 degrees within a step is not flipped: friction stays Coulomb.)
    if ux * ux_ref + uy * uy_ref < -0.5:
        return -ux, -uy
    return ux, uy


@njit(cache=True, error_model="numpy", **NO_NRT, forceinline=True)
def rhs(y, par, phase, mu, ux_ref, uy_ref, orient, dy):  # type: ignore[no-untyped-def]
    """Write dy/dt into ``dy``; return (n, margin, ux, uy).

    n is the normal force per unit mass (m/s^2). margin is, while rolling, the friction reserve
    mu n - |f| (m/s^2; negative means the ball must start sliding) and, while sliding, |s| (m/s).
    (ux, uy) is the friction direction used (zeros while rolling). ``orient`` False skips the
    quaternion (its derivative is set to zero) when nothing depends on the orientation.
    """
    wx = y[8]
    wy = y[9]
    wz = y[10]
    dy[0] = y[2]
    dy[1] = y[3]
    if phase == PHASE_ROLL:
        ax, ay, alx, aly, alz, fx, fy, n = roll_accel(y, par)
        margin = mu * n - math.sqrt(fx * fx + fy * fy)
        ux = 0.0
        uy = 0.0
    else:
        sx, sy = slip(y, par)
        margin = math.sqrt(sx * sx + sy * sy)
        ux, uy = friction_direction(y, par, phase, mu, ux_ref, uy_ref, sx, sy, margin)
        ax, ay, alx, aly, alz, n = slide_accel(y, par, mu, ux, uy)
    dy[2] = ax
    dy[3] = ay
    if orient:
        qw = y[4]
        qx = y[5]
        qy = y[6]
        qz = y[7]
        # dq/dt = 1/2 (0, w) (x) q with w in the lane frame
        dy[4] = -0.5 * (wx * qx + wy * qy + wz * qz)
        dy[5] = 0.5 * (qw * wx + wy * qz - wz * qy)
        dy[6] = 0.5 * (qw * wy + wz * qx - wx * qz)
        dy[7] = 0.5 * (qw * wz + wx * qy - wy * qx)
    else:
        dy[4] = 0.0
        dy[5] = 0.0
        dy[6] = 0.0
        dy[7] = 0.0
    dy[8] = alx
    dy[9] = aly
    dy[10] = alz
    return n, margin, ux, uy


@njit(cache=True, error_model="numpy")
def energy_per_mass(y, par):  # type: ignore[no-untyped-def]
    """Total mechanical energy per unit mass (J/kg): translation of the center of mass, rotation
    about it, and gravity with z = 0 at the geometric center."""
    iw, rd = ball_frame(y, par)
    ixx, iyy, izz, ixy, ixz, iyz = iw
    rdx, rdy, rdz = rd
    wx = y[8]
    wy = y[9]
    wz = y[10]
    # v_com = v_cb - w x r_Delta
    cx, cy, cz = cross(wx, wy, wz, rdx, rdy, rdz)
    vx = y[2] - cx
    vy = y[3] - cy
    vz = -cz
    lx = ixx * wx + ixy * wy + ixz * wz
    ly = ixy * wx + iyy * wy + iyz * wz
    lz = ixz * wx + iyz * wy + izz * wz
    return (
        0.5 * (vx * vx + vy * vy + vz * vz) + 0.5 * (wx * lx + wy * ly + wz * lz) - par[P_G] * rdz
    )

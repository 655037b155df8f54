"""Every term of the paper's Eqs. (6) and (7), separately (per unit mass).

Sliding, Eq. (6):  (I_o + I_dev + I_Delta^s + I_DeltaDelta^s) alpha
                       = tau_fric + tau_dev + tau_Delta^s + tau_DeltaDelta^s
Rolling, Eq. (7):  (I_o + I_dev + I_Roll + I_Delta^r) alpha = tau_dev + tau_Delta^r + tau_DeltaDelta^r

Derived afresh (the OCR'd Appendix A has sign slips; e.g. Eq. (A9) row 2 prints +r_y mu_x where
the derivation gives -r_y mu_x). With e_a = z x r_Delta (so a_alpha = e_a . alpha),
mu_vec = (mu u_x, mu u_y, 1), R_con = (0, 0, -R) and a_w = [(w x r_Delta) x w]_z:

    I_Delta^s       = -(R_con  x mu_vec) e_a^T        tau_fric         = g R_con x mu_vec
    I_DeltaDelta^s  = -(r_Delta x mu_vec) e_a^T       tau_Delta^s      = g r_Delta x mu_vec + a_w R_con x mu_vec
                                                       tau_DeltaDelta^s = a_w r_Delta x mu_vec
    I_Roll          = diag(R^2, R^2, 0)               tau_Delta^r      = g r_Delta x z + R [w^2 r_Delta x z + (w.r_Delta) z x w]
    I_Delta^r       = |rho|^2 1 - rho rho^T - I_Roll  tau_DeltaDelta^r = (w.r_Delta) w x r_Delta
    (rho = r_Delta + R_con)                            tau_dev          = (I_dev w) x w

The arrays are indexed by the TERM_* / TORQUE_* constants; terms that do not belong to the phase
are zero. Units: inertia terms m^2 (per unit mass), torques m^2/s^2 (per unit mass).

The optional external forces (``dynamics.external_accel``: e at the geometric center, the
topography's g_h at the center of mass; none in the paper) add one torque, ``EXTERNAL_TERM``
(row 6 of the torques, zero when they are off):

    sliding: tau_ext^s = r_Delta x e - e_z rho x mu_vec   (e's moment and its change of n)
    rolling: tau_ext^r = -R_con x e - rho x g_h
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .codes import PHASE_ROLL
from .dynamics import P_EXT, P_G, P_K1, P_K2, P_K3, P_R, P_RDX, P_RDY, P_RDZ, external_accel
from .vec import quat_matrix, solve3

INERTIA_TERMS = ("I_o", "I_dev", "I_Delta_s", "I_DeltaDelta_s", "I_Roll", "I_Delta_r")
TORQUE_TERMS = (
    "tau_fric",
    "tau_dev",
    "tau_Delta_s",
    "tau_DeltaDelta_s",
    "tau_Delta_r",
    "tau_DeltaDelta_r",
)
#: the torque of the optional external forces (row 6 of ``equation_terms``' torques)
EXTERNAL_TERM = "tau_ext"


@njit(cache=True, error_model="numpy")
def matvec(m, v):  # type: ignore[no-untyped-def]
    """m @ v for a 3x3 matrix and a 3-vector (no BLAS: numba's @ needs scipy)."""
    out = np.zeros(3)
    for i in range(3):
        for j in range(3):
            out[i] += m[i, j] * v[j]
    return out


@njit(cache=True, error_model="numpy")
def _dot(a, b):  # type: ignore[no-untyped-def]
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, error_model="numpy")
def _crossv(a, b):  # type: ignore[no-untyped-def]
    out = np.empty(3)
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


@njit(cache=True, error_model="numpy")
def equation_terms(y, par, phase, mu, ux, uy):  # type: ignore[no-untyped-def]
    """All inertia matrices and torques of the phase's equation at state y.

    Returns (mats (6, 3, 3), taus (7, 3), alpha (3,)) with alpha solving the summed equation.
    (ux, uy) is the unit friction direction (used while sliding). taus[6] is ``EXTERNAL_TERM``
    (zero, and left out of the sum, when the external forces are off).
    """
    R = par[P_R]
    g = par[P_G]
    m = quat_matrix(y[4], y[5], y[6], y[7])
    rot = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            rot[i, j] = m[3 * i + j]
    kdiag = np.zeros((3, 3))
    kdiag[0, 0] = par[P_K1]
    kdiag[1, 1] = par[P_K2]
    kdiag[2, 2] = par[P_K3]
    inertia = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for m_ in range(3):
                inertia[i, j] += rot[i, m_] * kdiag[m_, m_] * rot[j, m_]
    rd_body = np.array([par[P_RDX], par[P_RDY], par[P_RDZ]])
    rd = matvec(rot, rd_body)
    w = np.array([y[8], y[9], y[10]])
    zhat = np.array([0.0, 0.0, 1.0])
    rcon = np.array([0.0, 0.0, -R])
    mats = np.zeros((6, 3, 3))
    taus = np.zeros((7, 3))
    external = par[P_EXT] != 0.0
    if external:
        fe = external_accel(y, par)
        e = np.array([fe[0], fe[1], fe[2]])
        gh = np.array([fe[3], fe[4], 0.0])
    iave = (par[P_K1] + par[P_K2] + par[P_K3]) / 3.0
    for i in range(3):
        mats[0, i, i] = iave
    mats[1] = inertia - mats[0]
    taus[1] = _crossv(matvec(mats[1], w), w)
    w2 = _dot(w, w)
    wr = _dot(w, rd)
    if phase != PHASE_ROLL:
        muv = np.array([mu * ux, mu * uy, 1.0])
        ea = np.array([-rd[1], rd[0], 0.0])
        rcm = _crossv(rcon, muv)
        rdm = _crossv(rd, muv)
        aw = _crossv(_crossv(w, rd), w)[2]
        for i in range(3):
            for j in range(3):
                mats[2, i, j] = -rcm[i] * ea[j]
                mats[3, i, j] = -rdm[i] * ea[j]
        taus[0] = g * rcm
        taus[2] = g * rdm + aw * rcm
        taus[3] = aw * rdm
        if external:
            taus[6] = _crossv(rd, e) - e[2] * (rcm + rdm)
    else:
        rho = rd + rcon
        mats[4, 0, 0] = R * R
        mats[4, 1, 1] = R * R
        full = np.zeros((3, 3))
        for i in range(3):
            full[i, i] = _dot(rho, rho)
            for j in range(3):
                full[i, j] -= rho[i] * rho[j]
        mats[5] = full - mats[4]
        taus[4] = g * _crossv(rd, zhat) + R * (w2 * _crossv(rd, zhat) + wr * _crossv(zhat, w))
        taus[5] = wr * _crossv(w, rd)
        if external:
            taus[6] = -_crossv(rcon, e) - _crossv(rho, gh)
    a = mats[0] + mats[1] + mats[2] + mats[3] + mats[4] + mats[5]
    tau = taus[0] + taus[1] + taus[2] + taus[3] + taus[4] + taus[5]
    if external:
        tau = tau + taus[6]
    al = solve3(
        a[0, 0], a[0, 1], a[0, 2], a[1, 0], a[1, 1], a[1, 2], a[2, 0], a[2, 1], a[2, 2],
        tau[0], tau[1], tau[2],
    )  # fmt: skip
    alpha = np.array([al[0], al[1], al[2]])
    return mats, taus, alpha

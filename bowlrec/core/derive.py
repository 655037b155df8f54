"""Quantities derived from recorded samples: forces, slip, energy and the per-term torques."""

from __future__ import annotations

import numpy as np
from numba import njit

from .codes import COL_MU, COL_PHASE, COL_STATE, COL_UX, COL_UY, N_STATE, PHASE_ROLL, PHASE_SLIDE
from .dynamics import energy_per_mass, roll_accel, slide_accel, slip
from .terms import equation_terms, matvec


@njit(cache=True, error_model="numpy")
def derive_samples(rec, par, record_terms):  # type: ignore[no-untyped-def]
    """Per-sample derived quantities, all per unit mass (multiply by M for forces/energies).

    Returns (normal (n,), friction (n, 2), slip (n, 2), energy (n,), alpha (n, 3),
    inertia_alpha (n, 6, 3), torques (n, 6, 3)). The last two are filled only when
    ``record_terms``: inertia_alpha[k] = I_k alpha (the left-hand-side terms applied to the
    solution) and torques[k] the right-hand-side terms, in the order of ``terms.INERTIA_TERMS``
    and ``terms.TORQUE_TERMS`` followed by ``terms.EXTERNAL_TERM`` (torques has 7 rows); for
    every sample sum(inertia_alpha) == sum(torques).
    """
    n = rec.shape[0]
    normal = np.empty(n)
    friction = np.empty((n, 2))
    slips = np.empty((n, 2))
    energy = np.empty(n)
    alpha = np.empty((n, 3))
    m_terms = 6 if record_terms else 0
    inertia_alpha = np.zeros((n if record_terms else 0, m_terms, 3))
    torques = np.zeros((n if record_terms else 0, m_terms + 1 if record_terms else 0, 3))
    y = np.empty(N_STATE)
    for k in range(n):
        for i in range(N_STATE):
            y[i] = rec[k, COL_STATE + i]
        phase = PHASE_ROLL if rec[k, COL_PHASE] == PHASE_ROLL else PHASE_SLIDE
        mu = rec[k, COL_MU]
        ux = rec[k, COL_UX]
        uy = rec[k, COL_UY]
        if phase == PHASE_ROLL:
            r = roll_accel(y, par)
            alpha[k, 0] = r[2]
            alpha[k, 1] = r[3]
            alpha[k, 2] = r[4]
            friction[k, 0] = r[5]
            friction[k, 1] = r[6]
            normal[k] = r[7]
        else:
            r2 = slide_accel(y, par, mu, ux, uy)
            alpha[k, 0] = r2[2]
            alpha[k, 1] = r2[3]
            alpha[k, 2] = r2[4]
            normal[k] = r2[5]
            friction[k, 0] = r2[5] * mu * ux
            friction[k, 1] = r2[5] * mu * uy
        sx, sy = slip(y, par)
        slips[k, 0] = sx
        slips[k, 1] = sy
        energy[k] = energy_per_mass(y, par)
        if record_terms:
            mats, taus, al = equation_terms(y, par, phase, mu, ux, uy)
            for j in range(6):
                inertia_alpha[k, j] = matvec(mats[j], al)
            for j in range(7):
                torques[k, j] = taus[j]
    return normal, friction, slips, energy, alpha, inertia_alpha, torques

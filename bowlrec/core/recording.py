"""The sample and event tables a kernel fills (columns in :mod:`bowlrec.core.codes`).

Both grow by doubling; a push returns the table (possibly a new, larger one) and the new row count.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .codes import (
    COL_MU,
    COL_PHASE,
    COL_STATE,
    COL_T,
    COL_UX,
    COL_UY,
    EV_KIND,
    EV_MU,
    EV_PHASE,
    EV_T,
    EV_X,
    EV_Y,
    N_STATE,
    PHASE_ROLL,
    ROLLING,
    S_QW,
    S_X,
    S_Y,
    SLIDING,
)


@njit(cache=True, error_model="numpy")
def push_sample(rec, nrec, t, y, phase, mu, ux, uy):  # type: ignore[no-untyped-def]
    """Append the sample at time t (s): state y, kernel phase, friction mu and its direction."""
    if nrec >= rec.shape[0]:
        bigger = np.empty((2 * rec.shape[0], rec.shape[1]))
        bigger[: rec.shape[0]] = rec
        rec = bigger
    rec[nrec, COL_T] = t
    for i in range(N_STATE):
        rec[nrec, COL_STATE + i] = y[i]
    # report a unit quaternion even between renormalizations
    qn = math.sqrt(y[S_QW] ** 2 + y[S_QW + 1] ** 2 + y[S_QW + 2] ** 2 + y[S_QW + 3] ** 2)
    for i in range(4):
        rec[nrec, COL_STATE + S_QW + i] = y[S_QW + i] / qn
    rec[nrec, COL_PHASE] = float(phase)
    rec[nrec, COL_MU] = mu
    rec[nrec, COL_UX] = ux
    rec[nrec, COL_UY] = uy
    return rec, nrec + 1


@njit(cache=True, error_model="numpy")
def push_event(ev, nev, t, kind, y, mu, phase):  # type: ignore[no-untyped-def]
    """Append the event ``kind`` (EVENT_*) at time t (s) in state y, with the friction mu and
    kernel phase after it."""
    if nev >= ev.shape[0]:
        bigger = np.empty((2 * ev.shape[0], ev.shape[1]))
        bigger[: ev.shape[0]] = ev
        ev = bigger
    ev[nev, EV_T] = t
    ev[nev, EV_KIND] = kind
    ev[nev, EV_X] = y[S_X]
    ev[nev, EV_Y] = y[S_Y]
    ev[nev, EV_MU] = mu
    ev[nev, EV_PHASE] = float(ROLLING) if phase == PHASE_ROLL else float(SLIDING)
    return ev, nev + 1

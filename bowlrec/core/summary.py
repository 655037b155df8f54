"""The summary of a kernel result (Table III metrics), computed in one place for one run
(:func:`bowlrec.core.solver.solve`) and for many (:mod:`bowlrec.core.batch`).

The compiled helpers run inside the kernels' loops (:func:`first_slide_x`,
:func:`released_rolling`); :func:`summary_columns` turns the final states of n runs into metric
columns with NumPy (one run is n = 1), so both paths give the same bits.

Conventions: slide_m is the x where rolling first starts (the release x for a ball released
rolling, NaN if it never rolls); hook_m is the leftward (+y) deflection at the pins from the
straight line along the initial velocity and pocket_deg the angle of the velocity to the x axis
there (both NaN unless the outcome is "pins"); speed_end_mps and rev_rate_end_rpm are those of
the final state.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .codes import (
    EV_KIND,
    EV_X,
    EVENT_SLIDE_TO_ROLL,
    OUTCOMES,
    PHASE_ROLL,
    STATUS_PINS,
)
from .contact import release_law
from .trajectory import FLOAT_METRICS, INT_METRICS

__all__ = [
    "FLOAT_METRICS",
    "INT_METRICS",
    "first_slide_x",
    "released_rolling",
    "summary_columns",
]


@njit(cache=True, error_model="numpy")
def first_slide_x(ev, nev):  # type: ignore[no-untyped-def]
    """x (m) of the first slide -> roll event among the first ``nev`` rows of the event table
    (NaN when there is none)."""
    for k in range(nev):
        if ev[k, EV_KIND] == EVENT_SLIDE_TO_ROLL:
            return ev[k, EV_X]
    return math.nan


@njit(cache=True, error_model="numpy")
def released_rolling(y0, par, x_edges, y_edges, grid, rtol, g):  # type: ignore[no-untyped-def]
    """True when the kernel starts the run rolling: zero slip at release and friction enough to
    hold it (the integrator's own initial-phase test on the same compiled helpers)."""
    ix = np.searchsorted(x_edges, y0[0], side="right")
    iy = np.searchsorted(y_edges, y0[1], side="right")
    return release_law(y0, par, grid[ix, iy], rtol * g).phase == PHASE_ROLL


def summary_columns(
    status: NDArray[Any],
    t_end: NDArray[np.float64],
    y_end: NDArray[np.float64],
    y0: NDArray[np.float64],
    slide_x: NDArray[np.float64],
    rolling_at_release: NDArray[np.bool_],
    n_steps: NDArray[Any],
    n_rhs: NDArray[Any],
    n_events: NDArray[Any],
) -> dict[str, NDArray[Any]]:
    """Metric columns of n runs from their final states ``y_end`` (n, N_STATE), initial
    states ``y0`` (n, N_STATE), first slide -> roll x ``slide_x`` (NaN: none) and
    release-rolling flags.

    Returns ``outcome`` (str array), :data:`FLOAT_METRICS` (float64, NaN for no value) and
    :data:`INT_METRICS` (int64)."""
    status = np.asarray(status).astype(np.int64)
    x0, yy0, vx0, vy0 = y0[:, 0], y0[:, 1], y0[:, 2], y0[:, 3]
    pins = status == STATUS_PINS
    with np.errstate(divide="ignore", invalid="ignore"):
        hook = y_end[:, 1] - (yy0 + (y_end[:, 0] - x0) * vy0 / vx0)
    wx, wy, wz = y_end[:, 8], y_end[:, 9], y_end[:, 10]
    return {
        "outcome": np.array([OUTCOMES.get(int(s), "error") for s in status], dtype=object),
        "slide_m": np.where(np.isnan(slide_x) & rolling_at_release, x0, slide_x),
        "hook_m": np.where(pins, hook, np.nan),
        "pocket_deg": np.where(pins, np.degrees(np.arctan2(y_end[:, 3], y_end[:, 2])), np.nan),
        "time_s": np.asarray(t_end, dtype=np.float64),
        "x_end_m": y_end[:, 0].copy(),
        "y_end_m": y_end[:, 1].copy(),
        "speed_end_mps": np.hypot(y_end[:, 2], y_end[:, 3]),
        "rev_rate_end_rpm": np.sqrt(wx * wx + wy * wy + wz * wz) * 60.0 / (2.0 * np.pi),
        "n_steps": np.asarray(n_steps, dtype=np.int64),
        "n_rhs": np.asarray(n_rhs, dtype=np.int64),
        "n_events": np.asarray(n_events, dtype=np.int64),
    }

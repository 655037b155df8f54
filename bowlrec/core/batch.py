"""Many deliveries in one compiled call: summary only, optionally on all cores (numba prange).

Plans are packed into flat arrays (ragged friction grids with offsets) so the loop over
deliveries runs without Python objects; each delivery picks its kernel once (the closed form for
uniform balls, the integrator otherwise).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from .closed_form import closed_form_kernel
from .integrator import EVENT_SLIDE_TO_ROLL, STATUS_PINS, simulate_kernel
from .plan import Plan
from .solver import initial_state, kernel_params, needs_orientation, use_closed_form
from .trajectory import OUTCOMES

# columns of the batch result
B_STATUS, B_T, B_X, B_Y, B_VX, B_VY, B_WX, B_WY, B_WZ, B_SLIDE, B_STEPS, B_RHS, B_EVENTS = range(13)
N_BCOL = 13


@dataclass(frozen=True)
class PackedPlans:
    """Plans as flat arrays for :func:`run_batch` (see :func:`pack_plans`)."""

    par: np.ndarray
    y0: np.ndarray
    x_edges: np.ndarray
    x_off: np.ndarray
    y_edges: np.ndarray
    y_off: np.ndarray
    mu: np.ndarray
    mu_off: np.ndarray
    lane: np.ndarray  # (n, 3): length, width, max_time
    opts: np.ndarray  # (n, 4): rtol, slide_mode, slip_threshold, max_steps
    flags: np.ndarray  # (n, 2) bool: closed form, orient

    @property
    def n(self) -> int:
        return int(self.par.shape[0])


def pack_plans(plans: Sequence[Plan]) -> PackedPlans:
    """Pack plans (summary-only semantics: no samples are recorded) into flat arrays."""
    n = len(plans)
    xs, ys, mus = [], [], []
    x_off = np.zeros(n + 1, dtype=np.int64)
    y_off = np.zeros(n + 1, dtype=np.int64)
    mu_off = np.zeros(n + 1, dtype=np.int64)
    par = np.empty((n, kernel_params(plans[0]).shape[0]))
    y0 = np.empty((n, 11))
    lane = np.empty((n, 3))
    opts = np.empty((n, 4))
    flags = np.zeros((n, 2), dtype=np.bool_)
    for i, p in enumerate(plans):
        par[i] = kernel_params(p)
        y0[i] = initial_state(p)
        xe = np.asarray(p.friction_x_edges_m, dtype=np.float64)
        ye = np.asarray(p.friction_y_edges_m, dtype=np.float64)
        mu = np.asarray(p.friction_mu, dtype=np.float64)
        xs.append(xe)
        ys.append(ye)
        mus.append(mu.ravel())
        x_off[i + 1] = x_off[i] + xe.size
        y_off[i + 1] = y_off[i] + ye.size
        mu_off[i + 1] = mu_off[i] + mu.size
        lane[i] = (p.lane_length_m, p.lane_width_m, p.max_time_s)
        opts[i] = (p.rtol, p.slide_to_roll, p.slip_threshold_mps, p.max_steps)
        flags[i] = (use_closed_form(p), needs_orientation(p))
    return PackedPlans(
        par=par,
        y0=y0,
        x_edges=np.concatenate(xs) if xs else np.zeros(0),
        x_off=x_off,
        y_edges=np.concatenate(ys) if ys else np.zeros(0),
        y_off=y_off,
        mu=np.concatenate(mus),
        mu_off=mu_off,
        lane=lane,
        opts=opts,
        flags=flags,
    )


@njit(cache=True, error_model="numpy")
def _one(i, par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out):  # type: ignore[no-untyped-def]
    x_edges = xe[xo[i] : xo[i + 1]]
    y_edges = ye[yo[i] : yo[i + 1]]
    grid = mu[mo[i] : mo[i + 1]].reshape((x_edges.shape[0] + 1, y_edges.shape[0] + 1))
    if flags[i, 0]:
        r = closed_form_kernel(
            par[i], y0[i], x_edges, y_edges, grid, lane[i, 0], lane[i, 1], lane[i, 2]
        )
    else:
        r = simulate_kernel(
            par[i],
            y0[i],
            x_edges,
            y_edges,
            grid,
            lane[i, 0],
            lane[i, 1],
            opts[i, 0],
            0,
            1e-3,
            int(opts[i, 1]),
            opts[i, 2],
            lane[i, 2],
            int(opts[i, 3]),
            flags[i, 1],
        )
    ev = r[2]
    nev = r[3]
    y = r[6]
    out[i, B_STATUS] = r[4]
    out[i, B_T] = r[5]
    out[i, B_X] = y[0]
    out[i, B_Y] = y[1]
    out[i, B_VX] = y[2]
    out[i, B_VY] = y[3]
    out[i, B_WX] = y[8]
    out[i, B_WY] = y[9]
    out[i, B_WZ] = y[10]
    out[i, B_SLIDE] = math.nan
    for k in range(nev):
        if ev[k, 1] == EVENT_SLIDE_TO_ROLL:
            out[i, B_SLIDE] = ev[k, 2]
            break
    out[i, B_STEPS] = r[7]
    out[i, B_RHS] = r[8]
    out[i, B_EVENTS] = nev


@njit(cache=True, parallel=True)
def _run_parallel(par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out):  # type: ignore[no-untyped-def]
    for i in prange(par.shape[0]):
        _one(i, par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out)


@njit(cache=True)
def _run_serial(par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out):  # type: ignore[no-untyped-def]
    for i in range(par.shape[0]):
        _one(i, par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out)


def run_batch(packed: PackedPlans, parallel: bool = True) -> np.ndarray:
    """Simulate every packed delivery; returns an (n, N_BCOL) array (see the B_* columns).

    ``parallel`` uses all numba threads (``numba.set_num_threads`` limits them)."""
    out = np.empty((packed.n, N_BCOL))
    fn = _run_parallel if parallel else _run_serial
    fn(
        packed.par,
        packed.y0,
        packed.x_edges,
        packed.x_off,
        packed.y_edges,
        packed.y_off,
        packed.mu,
        packed.mu_off,
        packed.lane,
        packed.opts,
        packed.flags,
        out,
    )
    return out


def batch_metrics(packed: PackedPlans, out: np.ndarray) -> dict[str, np.ndarray]:
    """Table III metrics for a batch result: outcome, slide_m (nan if never rolls), hook_m and
    pocket_deg (nan unless the ball reached the pins), time_s, x_end_m, y_end_m."""
    x0 = packed.y0[:, 0]
    y0 = packed.y0[:, 1]
    slope = packed.y0[:, 3] / packed.y0[:, 2]
    pins = out[:, B_STATUS] == STATUS_PINS
    hook = np.where(pins, out[:, B_Y] - (y0 + (out[:, B_X] - x0) * slope), np.nan)
    pocket = np.where(pins, np.degrees(np.arctan2(out[:, B_VY], out[:, B_VX])), np.nan)
    outcome = np.array([OUTCOMES.get(int(s), "error") for s in out[:, B_STATUS]])
    return {
        "outcome": outcome,
        "slide_m": out[:, B_SLIDE],
        "hook_m": hook,
        "pocket_deg": pocket,
        "time_s": out[:, B_T],
        "x_end_m": out[:, B_X],
        "y_end_m": out[:, B_Y],
    }

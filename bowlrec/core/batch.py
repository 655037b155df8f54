"""Many deliveries in one compiled call: summary only, optionally on all cores (numba prange).

Plans are packed into flat arrays (ragged friction grids with offsets) so the loop over
deliveries runs without Python objects; each delivery picks its kernel once (the closed form for
uniform balls on a flat lane without external terms, the integrator otherwise, which computes
the external terms a delivery's parameters switch on).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from .arguments import initial_state, kernel_params, needs_orientation, use_closed_form
from .closed_form import closed_form_kernel
from .codes import N_EVCOL, N_STATE
from .integrator import simulate_kernel
from .plan import Plan
from .summary import first_slide_x, released_rolling, summary_columns

# columns of the batch result: status, end time (s), final state (11 values, see
# bowlrec.core.dynamics), x of the first slide -> roll event (NaN: none), 1.0 if released rolling,
# accepted steps, right-hand sides, events
B_STATUS, B_T = 0, 1
B_STATE = 2
B_SLIDE, B_ROLLING, B_STEPS, B_RHS, B_EVENTS = range(B_STATE + N_STATE, B_STATE + N_STATE + 5)
N_BCOL = B_EVENTS + 1

#: events kept per delivery in the batch result (the event table's first rows); runs with more
#: events (rare: a fine oil grid) report them all through :func:`bowlrec.core.solver.solve`
EVENT_CAP = 32


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
    opts: np.ndarray  # (n, 5): rtol, slide_mode, slip_threshold, max_steps, g
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
    pars = [kernel_params(p) for p in plans]
    # one width for all rows: the longest (a height profile adds its spline); shorter rows are
    # padded with zeros the kernels do not read
    par = np.zeros((n, max(q.shape[0] for q in pars)))
    y0 = np.empty((n, N_STATE))
    lane = np.empty((n, 3))
    opts = np.empty((n, 5))
    flags = np.zeros((n, 2), dtype=np.bool_)
    for i, p in enumerate(plans):
        par[i, : pars[i].shape[0]] = pars[i]
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
        opts[i] = (p.rtol, p.slide_to_roll, p.slip_threshold_mps, p.max_steps, p.g_mps2)
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


def take(packed: PackedPlans, rows: np.ndarray) -> PackedPlans:
    """The packed deliveries ``rows`` (in that order)."""

    def ragged(values: np.ndarray, off: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lengths = off[rows + 1] - off[rows]
        new_off = np.zeros(rows.size + 1, dtype=np.int64)
        np.cumsum(lengths, out=new_off[1:])
        if rows.size and np.all(lengths == lengths[0]) and np.all(np.diff(off) == lengths[0]):
            width = int(lengths[0])  # equal widths: one gather
            return values.reshape(-1, width)[rows].ravel() if width else values[:0], new_off
        parts = [values[off[i] : off[i + 1]] for i in rows]
        return (np.concatenate(parts) if parts else values[:0]), new_off

    x_edges, x_off = ragged(packed.x_edges, packed.x_off)
    y_edges, y_off = ragged(packed.y_edges, packed.y_off)
    mu, mu_off = ragged(packed.mu, packed.mu_off)
    return PackedPlans(
        par=packed.par[rows],
        y0=packed.y0[rows],
        x_edges=x_edges,
        x_off=x_off,
        y_edges=y_edges,
        y_off=y_off,
        mu=mu,
        mu_off=mu_off,
        lane=packed.lane[rows],
        opts=packed.opts[rows],
        flags=packed.flags[rows],
    )


@njit(cache=True, error_model="numpy")
def _one(i, par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out, events):  # type: ignore[no-untyped-def]
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
            None,  # nothing observed
            False,
        )
    ev = r[2]
    nev = r[3]
    y = r[6]
    out[i, B_STATUS] = r[4]
    out[i, B_T] = r[5]
    for k in range(N_STATE):
        out[i, B_STATE + k] = y[k]
    slide = first_slide_x(ev, nev)
    out[i, B_SLIDE] = slide
    rolling = False
    if math.isnan(slide):
        rolling = released_rolling(y0[i], par[i], x_edges, y_edges, grid, opts[i, 0], opts[i, 4])
    out[i, B_ROLLING] = 1.0 if rolling else 0.0
    out[i, B_STEPS] = r[7]
    out[i, B_RHS] = r[8]
    out[i, B_EVENTS] = nev
    for k in range(min(nev, events.shape[1])):
        for c in range(N_EVCOL):
            events[i, k, c] = ev[k, c]


@njit(cache=True, parallel=True)
def _run_parallel(par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out, events):  # type: ignore[no-untyped-def]
    for i in prange(par.shape[0]):
        _one(i, par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out, events)


@njit(cache=True)
def _run_serial(par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out, events):  # type: ignore[no-untyped-def]
    for i in range(par.shape[0]):
        _one(i, par, y0, xe, xo, ye, yo, mu, mo, lane, opts, flags, out, events)


@dataclass(frozen=True)
class BatchOutput:
    """What :func:`run_batch` returns: ``out`` (n, N_BCOL) with the B_* columns and ``events``
    (n, EVENT_CAP, N_EVCOL): each delivery's first event rows (see ``simulate_kernel``)."""

    out: np.ndarray
    events: np.ndarray

    @property
    def n_events(self) -> np.ndarray:
        return self.out[:, B_EVENTS].astype(np.int64)


def run_batch(packed: PackedPlans, parallel: bool = True) -> BatchOutput:
    """Simulate every packed delivery (summary only).

    ``parallel`` uses all numba threads (``numba.set_num_threads`` limits them)."""
    out = np.empty((packed.n, N_BCOL))
    events = np.zeros((packed.n, EVENT_CAP, N_EVCOL))
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
        events,
    )
    return BatchOutput(out, events)


def batch_metrics(packed: PackedPlans, result: BatchOutput) -> dict[str, np.ndarray]:
    """Table III metrics of a batch result, computed as :func:`~bowlrec.core.solver.solve`
    computes them (:func:`bowlrec.core.summary.summary_columns`): ``outcome`` and the float
    and integer metric columns (NaN: no value)."""
    out = result.out
    return summary_columns(
        out[:, B_STATUS],
        out[:, B_T],
        out[:, B_STATE : B_STATE + N_STATE],
        packed.y0,
        out[:, B_SLIDE],
        out[:, B_ROLLING] == 1.0,
        out[:, B_STEPS],
        out[:, B_RHS],
        out[:, B_EVENTS],
    )

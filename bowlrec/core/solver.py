"""Run one :class:`~bowlrec.core.plan.Plan` through the compiled kernel into a Trajectory."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ._kernel_cache import load_lean
from .arguments import (
    initial_state,
    kernel_params,
    needs_orientation,
    use_closed_form,
)
from .closed_form import closed_form_kernel
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
    EVENT_KINDS,
    N_COL,
    OBS_STATE,
    OBS_T,
    OBS_WHAT,
    PHASE_NAMES,
    PHASE_ROLL,
    PHASE_SLIDE,
    S_QW,
    S_VX,
    S_WX,
    S_X,
)
from .derive import derive_samples
from .integrator import simulate_kernel
from .outcome import described
from .plan import Plan
from .summary import first_slide_x, summary_columns
from .summary import released_rolling as rolling_at_release
from .terms import EXTERNAL_TERM, INERTIA_TERMS, TORQUE_TERMS
from .trajectory import Event, Observation, Summary, Trajectory, summary_trajectory

# the kernels this module calls load from numba's cache without the full refresh of numba's
# target context (bowlrec.core._kernel_cache.load_lean): what a fresh process's first delivery
# waits for
load_lean(closed_form_kernel, simulate_kernel, derive_samples, rolling_at_release)


def kernel_call(
    plan: Plan, method: str = "auto", stations_m: Sequence[float] = (), turns: bool = False
) -> tuple[Any, tuple[Any, ...]]:
    """The compiled kernel for a plan and its prepared arguments: ``fn(*args)`` runs it.

    ``method``: "auto" (the closed form where it applies, else the integrator), "integrator"
    or "closed_form". ``stations_m`` (x, m) and ``turns``: observations (integrator only; see
    :func:`solve`). Separating the two lets callers time the kernel alone."""
    observing = len(stations_m) > 0 or turns
    grid = (
        np.ascontiguousarray(plan.friction_x_edges_m, dtype=np.float64),
        np.ascontiguousarray(plan.friction_y_edges_m, dtype=np.float64),
        np.ascontiguousarray(plan.friction_mu, dtype=np.float64),
    )
    if method == "closed_form" or (method == "auto" and use_closed_form(plan, observing)):
        if not (plan.scalar_inertia and not plan.has_offset):
            raise ValueError("the closed form needs a uniform ball (scalar inertia, no offset)")
        if plan.external_terms:
            raise ValueError(
                "the closed form needs a flat lane without drag, rolling resistance or lift "
                "(use method 'auto' or 'integrator')"
            )
        if observing:
            raise ValueError("observations need the integrator (method 'auto' or 'integrator')")
        args: tuple[Any, ...] = (
            kernel_params(plan),
            initial_state(plan),
            *grid,
            float(plan.lane_length_m),
            float(plan.lane_width_m),
            float(plan.max_time_s),
        )
        return closed_form_kernel, args
    args = (
        kernel_params(plan),
        initial_state(plan),
        *grid,
        float(plan.lane_length_m),
        float(plan.lane_width_m),
        float(plan.rtol),
        int(plan.record_mode),
        float(plan.record_dt_s),
        int(plan.slide_to_roll),
        float(plan.slip_threshold_mps),
        float(plan.max_time_s),
        int(plan.max_steps),
        needs_orientation(plan),
        _stations(stations_m) if observing else None,
        bool(turns),
    )
    return simulate_kernel, args


def _stations(stations_m: Sequence[float]) -> np.ndarray:
    """Observed stations as the kernel takes them: finite and strictly ascending (m)."""
    x = np.ascontiguousarray(stations_m, dtype=np.float64).reshape(-1)
    if not (np.all(np.isfinite(x)) and np.all(np.diff(x) > 0.0)):
        raise ValueError(f"stations_m = {x.tolist()} must be finite and strictly ascending (m)")
    return x


def run_kernel(plan: Plan, method: str = "auto") -> tuple:  # type: ignore[type-arg]
    """Run the compiled kernel for a plan; returns its raw tuple (see ``simulate_kernel``)."""
    fn, args = kernel_call(plan, method)
    return fn(*args)  # type: ignore[no-any-return]


def solve(
    plan: Plan, method: str = "auto", stations_m: Sequence[float] = (), turns: bool = False
) -> Trajectory:
    """Simulate one delivery from release to its outcome (pins, gutter, stop, loss of contact).

    ``method`` as in :func:`run_kernel`. ``stations_m``: x positions (m) where the state is
    observed as the path reaches them (stations at or behind the release point are not), and
    ``turns``: also where it turns across the lane (v_y = 0); both land in
    ``Trajectory.observations`` and change no other result (:mod:`bowlrec.core.observe`)."""
    events, summary, rec, par, observations = _run(plan, method, stations_m, turns)
    arrays, torque_arrays = sample_arrays(rec, par, plan.mass_kg, bool(plan.record_terms), plan)
    return Trajectory(
        **arrays,
        events=events,
        summary=summary,
        torques_Nm=torque_arrays,
        observations=observations,
    ).mark_derived_from_state()


def solve_state(plan: Plan) -> tuple[Trajectory, dict[str, np.ndarray]]:
    """:func:`run_plan` without deriving the forces, slip, energy and alpha of the samples:
    the run's events and summary (a Trajectory without samples, its message set) and its
    recorded state (:func:`state_arrays`, bit for bit the arrays :func:`solve` gives): what an
    archive stores of a run that records samples (segment format 3.0). A plan recording
    per-term torques derives them: it needs :func:`run_plan`."""
    if plan.record_terms:
        raise ValueError("a plan recording per-term torques needs run_plan()")
    events, summary, rec, _, _ = _run(plan, "auto", (), False)
    return described(summary_trajectory(events, summary), plan), state_arrays(rec)


def _run(
    plan: Plan, method: str, stations_m: Sequence[float], turns: bool
) -> tuple[list[Event], Summary, np.ndarray, np.ndarray, list[Observation]]:
    """The kernel run on a plan: its events, summary, sample rows, kernel parameters and
    observations."""
    fn, args = kernel_call(plan, method, stations_m, turns)
    rec, nrec, ev, nev, status, t_end, y_end, nsteps, nfev, obs, nobs = fn(*args)
    par, y0, x_edges, y_edges, mu_grid = args[:5]  # the kernel does not change them
    rec = rec[:nrec]
    ev = ev[:nev]
    events = [
        Event(
            t_s=float(row[EV_T]),
            kind=EVENT_KINDS[int(row[EV_KIND])],
            x_m=float(row[EV_X]),
            y_m=float(row[EV_Y]),
            mu=float(row[EV_MU]),
            phase=PHASE_NAMES[int(row[EV_PHASE])],
        )
        for row in ev
    ]
    # the compiled helpers' Python bodies where the compiled code would buy nothing: a scan of
    # the few event rows, and no samples to derive from (a summary-only run): each compiled
    # helper called costs its load from numba's cache in a fresh process; same bits either way
    slide_x = float(first_slide_x.py_func(ev, nev))
    rolling = math.isnan(slide_x) and bool(
        rolling_at_release(y0, par, x_edges, y_edges, mu_grid, float(plan.rtol), plan.g_mps2)
    )
    summary = summarize(y0, slide_x, rolling, int(status), float(t_end), y_end, nev, nsteps, nfev)
    return events, summary, rec, par, _observations(obs[:nobs])


def state_arrays(rec: np.ndarray) -> dict[str, np.ndarray]:
    """The recorded state of a kernel's sample rows (``rec``) as the trajectory's arrays:
    ``t_s``, ``position_m`` and ``velocity_mps`` (z = 0), ``quaternion_wxyz``,
    ``omega_radps``, ``phase`` (int8, 1 rolling), ``mu`` and ``friction_dir`` (each a new
    array)."""
    n = rec.shape[0]
    position = np.zeros((n, 3))
    position[:, :2] = rec[:, COL_STATE + S_X : COL_STATE + S_X + 2]
    velocity = np.zeros((n, 3))
    velocity[:, :2] = rec[:, COL_STATE + S_VX : COL_STATE + S_VX + 2]
    return {
        "t_s": rec[:, COL_T].copy(),
        "position_m": position,
        "velocity_mps": velocity,
        "quaternion_wxyz": rec[:, COL_STATE + S_QW : COL_STATE + S_QW + 4].copy(),
        "omega_radps": rec[:, COL_STATE + S_WX : COL_STATE + S_WX + 3].copy(),
        "phase": (rec[:, COL_PHASE] == PHASE_ROLL).astype(np.int8),
        "mu": rec[:, COL_MU].copy(),
        "friction_dir": rec[:, COL_UX : COL_UY + 1].copy(),
    }


def sample_arrays(
    rec: np.ndarray, par: np.ndarray, mass: float, record_terms: bool, plan: Plan | None = None
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """A kernel's sample rows (``rec``, columns in :mod:`bowlrec.core.codes`) as the
    trajectory's per-sample arrays (the :class:`Trajectory` fields by name, with
    ``friction_dir``) and its per-term torques (when ``record_terms``): the state as recorded,
    forces, slip, energy and alpha derived from it (:func:`derive_samples`). ``par``: the kernel
    parameters of the run (:func:`bowlrec.core.arguments.kernel_params`); ``plan`` tells whether
    the external torque term exists (None: it does not)."""
    derive = derive_samples if rec.shape[0] else derive_samples.py_func
    normal, friction, slips, energy, alpha, inertia_alpha, torques = derive(rec, par, record_terms)
    n = rec.shape[0]
    slip3 = np.zeros((n, 3))
    slip3[:, :2] = slips
    fric3 = np.zeros((n, 3))
    fric3[:, :2] = friction * mass
    torque_arrays: dict[str, np.ndarray] = {}
    if record_terms:
        for j, name in enumerate(INERTIA_TERMS):
            torque_arrays[name] = inertia_alpha[:, j, :] * mass
        for j, name in enumerate(TORQUE_TERMS):
            torque_arrays[name] = torques[:, j, :] * mass
        if plan is not None and plan.external_terms:
            torque_arrays[EXTERNAL_TERM] = torques[:, len(TORQUE_TERMS), :] * mass
    arrays = state_arrays(rec)
    arrays.update(
        normal_force_N=normal * mass,
        friction_force_N=fric3,
        slip_mps=slip3,
        energy_J=energy * mass,
        alpha_radps2=alpha,
    )
    return arrays, torque_arrays


def sample_rows(state: dict[str, np.ndarray]) -> np.ndarray:
    """The kernel's sample rows again from the recorded state (``t_s``, ``position_m``,
    ``velocity_mps``, ``quaternion_wxyz``, ``omega_radps``, ``phase`` 0/1, ``mu`` and
    ``friction_dir``, as :func:`sample_arrays` gives them): :func:`sample_arrays` of the result
    gives the same arrays, the derived ones computed anew."""
    n = int(state["t_s"].shape[0])
    rec = np.empty((n, N_COL))
    rec[:, COL_T] = state["t_s"]
    rec[:, COL_STATE + S_X : COL_STATE + S_X + 2] = state["position_m"][:, :2]
    rec[:, COL_STATE + S_VX : COL_STATE + S_VX + 2] = state["velocity_mps"][:, :2]
    rec[:, COL_STATE + S_QW : COL_STATE + S_QW + 4] = state["quaternion_wxyz"]
    rec[:, COL_STATE + S_WX : COL_STATE + S_WX + 3] = state["omega_radps"]
    rec[:, COL_PHASE] = np.where(state["phase"] == 1, float(PHASE_ROLL), float(PHASE_SLIDE))
    rec[:, COL_MU] = state["mu"]
    rec[:, COL_UX : COL_UY + 1] = state["friction_dir"]
    return rec


def _observations(rows: np.ndarray) -> list[Observation]:
    """The kernel's observation table as Observations."""
    return [
        Observation(
            t_s=float(r[OBS_T]),
            station=int(r[OBS_WHAT]),
            position_m=(float(r[OBS_STATE + S_X]), float(r[OBS_STATE + S_X + 1])),
            velocity_mps=(float(r[OBS_STATE + S_VX]), float(r[OBS_STATE + S_VX + 1])),
            omega_radps=(
                float(r[OBS_STATE + S_WX]),
                float(r[OBS_STATE + S_WX + 1]),
                float(r[OBS_STATE + S_WX + 2]),
            ),
        )
        for r in rows
    ]


def summarize(
    y0: np.ndarray,
    slide_x: float,
    released_rolling: bool,
    status: int,
    t_end: float,
    y_end: np.ndarray,
    n_events: int,
    nsteps: int,
    nfev: int,
) -> Summary:
    """Table III metrics from the initial and final states and the event table
    (:func:`bowlrec.core.summary.summary_columns` for one run); ``released_rolling``: the
    kernel started the run rolling (:func:`bowlrec.core.summary.released_rolling`); slide_x: x
    (m) of the first slide -> roll event (NaN: none)."""
    cols = summary_columns(
        np.array([status]),
        np.array([t_end], dtype=np.float64),
        np.asarray(y_end, dtype=np.float64).reshape(1, -1),
        np.asarray(y0, dtype=np.float64).reshape(1, -1),
        np.array([slide_x]),
        np.array([math.isnan(slide_x) and released_rolling]),
        np.array([nsteps]),
        np.array([nfev]),
        np.array([n_events]),
    )
    return summary_from_columns(cols, 0)


def run_plan(
    plan: Plan, method: str = "auto", stations_m: Sequence[float] = (), turns: bool = False
) -> Trajectory:
    """Simulate a resolved scene (:func:`solve`, ``method``, observed ``stations_m`` and
    ``turns`` as there) and tell its outcome in words (the summary's ``message``,
    :func:`bowlrec.core.outcome.described`)."""
    return described(solve(plan, method, stations_m, turns), plan)


def summary_from_columns(cols: dict[str, Any], i: int, message: str = "") -> Summary:
    """Row ``i`` of :func:`~bowlrec.core.summary.summary_columns` as a Summary (NaN -> None)
    with ``message`` (the outcome in words: :func:`bowlrec.core.outcome.outcome_message`)."""

    def opt(name: str) -> float | None:
        v = float(cols[name][i])
        return None if math.isnan(v) else v

    outcome = str(cols["outcome"][i])
    t_end = float(cols["time_s"][i])
    x_end = float(cols["x_end_m"][i])
    return Summary(
        outcome=outcome,
        message=message,
        slide_m=opt("slide_m"),
        hook_m=opt("hook_m"),
        pocket_deg=opt("pocket_deg"),
        time_s=t_end,
        x_end_m=x_end,
        y_end_m=float(cols["y_end_m"][i]),
        speed_end_mps=float(cols["speed_end_mps"][i]),
        rev_rate_end_rpm=float(cols["rev_rate_end_rpm"][i]),
        n_steps=int(cols["n_steps"][i]),
        n_rhs=int(cols["n_rhs"][i]),
        n_events=int(cols["n_events"][i]),
    )

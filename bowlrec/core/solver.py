"""Run one :class:`~bowlrec.core.plan.Plan` through the compiled kernel into a Trajectory."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .closed_form import closed_form_kernel
from .codes import (
    COL_MU,
    COL_PHASE,
    COL_STATE,
    COL_T,
    EV_KIND,
    EV_MU,
    EV_PHASE,
    EV_T,
    EV_X,
    EV_Y,
    EVENT_KINDS,
    LIFT_NONE,
    N_STATE,
    OBS_STATE,
    OBS_T,
    OBS_WHAT,
    PHASE_NAMES,
    PHASE_ROLL,
    RECORD_SUMMARY,
    S_QW,
    S_VX,
    S_WX,
    S_X,
    SLIDE_TO_ROLL_EXACT,
)
from .derive import derive_samples
from .dynamics import pack_params
from .integrator import simulate_kernel
from .outcome import described
from .plan import Plan
from .summary import first_slide_x, summary_columns
from .summary import released_rolling as rolling_at_release
from .terms import EXTERNAL_TERM, INERTIA_TERMS, TORQUE_TERMS
from .topography import natural_spline
from .trajectory import Event, Observation, Summary, Trajectory


def initial_state(plan: Plan) -> np.ndarray:
    """The 11-component state vector at release (see ``bowlrec.core.dynamics``)."""
    y = np.empty(N_STATE)
    y[S_X : S_X + 2] = plan.position0_m
    y[S_VX : S_VX + 2] = plan.velocity0_mps
    q = np.asarray(plan.q0, dtype=np.float64)
    y[S_QW : S_QW + 4] = q / np.linalg.norm(q)
    y[S_WX : S_WX + 3] = plan.omega0_radps
    return y


def kernel_params(plan: Plan) -> np.ndarray:
    """The kernels' parameter vector (``dynamics.pack_params``); N_PAR values, plus the height
    profile's spline (3 values per knot) when the plan has one."""
    if not plan.external_terms:
        return pack_params(
            plan.radius_m,
            plan.g_mps2,
            plan.inertia_per_mass_m2,
            plan.r_delta_body_m,
            slip_layer(plan),
            orientation_weight(plan),
        )
    # per unit mass: (1/2) rho A / M with A = pi R^2 the ball's cross-section (1/m)
    air = 0.5 * plan.air_density_kg_m3 * math.pi * plan.radius_m**2 / plan.mass_kg
    profile = None
    if plan.profile_y_m is not None and plan.profile_z_m is not None:
        py = np.asarray(plan.profile_y_m, dtype=np.float64)
        pz = np.asarray(plan.profile_z_m, dtype=np.float64)
        profile = (py, pz, natural_spline(py, pz))
    return pack_params(
        plan.radius_m,
        plan.g_mps2,
        plan.inertia_per_mass_m2,
        plan.r_delta_body_m,
        slip_layer(plan),
        orientation_weight(plan),
        drag_per_m=plan.drag_coefficient * air,
        rolling_resistance_mps2=plan.rolling_resistance * plan.g_mps2,
        lift_per_m=air if plan.lift_model != LIFT_NONE else 0.0,
        lift_model=int(plan.lift_model),
        cross_slope=plan.cross_slope,
        profile=profile,
    )


def needs_orientation(plan: Plan) -> bool:
    """The quaternion is integrated only when the motion or the output depends on it."""
    return not (plan.scalar_inertia and not plan.has_offset and plan.record_mode == RECORD_SUMMARY)


def orientation_weight(plan: Plan) -> float:
    """Weight of the quaternion in the error norm (dimensionless).

    When samples are recorded the orientation is an output: full weight. For summary-only runs
    the orientation matters only through the anisotropy of the inertia and the offset, so an
    orientation error d theta perturbs the forces by ~ d theta * max(dI/I, |r_Delta|/R); the
    quaternion is weighted by ``ORIENTATION_GAIN`` times that factor, at most 1 (0 for a uniform
    ball: it is then not integrated).
    """
    if plan.record_mode != RECORD_SUMMARY:
        return 1.0
    k = np.asarray(plan.inertia_per_mass_m2, dtype=np.float64)
    anisotropy = float((k.max() - k.min()) / k.mean())
    offset = float(np.linalg.norm(plan.r_delta_body_m)) / plan.radius_m
    return min(1.0, ORIENTATION_GAIN * max(anisotropy, offset))


#: An orientation error is never corrected: it acts on the forces for the rest of the run, while
#: velocity errors are what the error control limits step by step. Weighted by its bare
#: influence (gain 1), the quaternion's error dominates the hook error of offset balls: over the
#: 218 benchmark deliveries at rtol 1e-4, a worst hook error of 5.6 mm for the offset balls
#: against 0.19 mm for the rest (Table III case 15: 4.3 mm). A gain of 1000 gives full weight to
#: any real ball (influence >= 1e-3). Hook error and right-hand sides at each tolerance:
#: benchmarks/results/work_precision.md.
ORIENTATION_GAIN = 1000.0


def slip_layer(plan: Plan) -> float:
    """Slip speed (m/s) below which the slip direction is not integrated (not stiff): 1e4 rtol,
    within [1e-8, 3e-4] m/s.

    A wider layer spares more of the stiff re-slip after each roll -> slide event (fewer
    right-hand sides), but above the cap its own error shows: over the 218 benchmark deliveries
    at rtol 3e-6, a 1e-3 m/s layer gives worst errors of 0.00033 deg of pocket and 1.1 mm of
    slide, against 0.00025 deg and 1.0 mm at 3e-4 m/s. Time and errors per tolerance:
    benchmarks/results/work_precision.md."""
    if plan.slip_layer_mps is not None:
        return float(plan.slip_layer_mps)
    return min(3e-4, max(1e-8, 1e4 * plan.rtol))


def use_closed_form(plan: Plan, observing: bool = False) -> bool:
    """A uniform ball needs no integrator when only the summary is asked for (exact rule),
    nothing is observed on the way and no external term (drag, rolling resistance, lift,
    topography) acts: the closed form knows only friction and gravity on a flat lane."""
    return (
        not observing
        and not plan.external_terms
        and plan.scalar_inertia
        and not plan.has_offset
        and plan.record_mode == RECORD_SUMMARY
        and plan.slide_to_roll == SLIDE_TO_ROLL_EXACT
    )


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
    fn, args = kernel_call(plan, method, stations_m, turns)
    rec, nrec, ev, nev, status, t_end, y_end, nsteps, nfev, obs, nobs = fn(*args)
    par, y0, x_edges, y_edges, mu_grid = args[:5]  # the kernel does not change them
    rec = rec[:nrec]
    ev = ev[:nev]
    mass = plan.mass_kg
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
    slide_x = float(first_slide_x(ev, nev))
    rolling = math.isnan(slide_x) and bool(
        rolling_at_release(y0, par, x_edges, y_edges, mu_grid, float(plan.rtol), plan.g_mps2)
    )
    summary = summarize(y0, slide_x, rolling, int(status), float(t_end), y_end, nev, nsteps, nfev)
    normal, friction, slips, energy, alpha, inertia_alpha, torques = derive_samples(
        rec, par, bool(plan.record_terms)
    )
    n = rec.shape[0]
    position = np.zeros((n, 3))
    position[:, :2] = rec[:, COL_STATE + S_X : COL_STATE + S_X + 2]
    velocity = np.zeros((n, 3))
    velocity[:, :2] = rec[:, COL_STATE + S_VX : COL_STATE + S_VX + 2]
    slip3 = np.zeros((n, 3))
    slip3[:, :2] = slips
    fric3 = np.zeros((n, 3))
    fric3[:, :2] = friction * mass
    torque_arrays: dict[str, np.ndarray] = {}
    if plan.record_terms:
        for j, name in enumerate(INERTIA_TERMS):
            torque_arrays[name] = inertia_alpha[:, j, :] * mass
        for j, name in enumerate(TORQUE_TERMS):
            torque_arrays[name] = torques[:, j, :] * mass
        if plan.external_terms:
            torque_arrays[EXTERNAL_TERM] = torques[:, len(TORQUE_TERMS), :] * mass
    return Trajectory(
        t_s=rec[:, COL_T].copy(),
        position_m=position,
        velocity_mps=velocity,
        quaternion_wxyz=rec[:, COL_STATE + S_QW : COL_STATE + S_QW + 4].copy(),
        omega_radps=rec[:, COL_STATE + S_WX : COL_STATE + S_WX + 3].copy(),
        phase=(rec[:, COL_PHASE] == PHASE_ROLL).astype(np.int8),
        mu=rec[:, COL_MU].copy(),
        normal_force_N=normal * mass,
        friction_force_N=fric3,
        slip_mps=slip3,
        energy_J=energy * mass,
        alpha_radps2=alpha,
        events=events,
        summary=summary,
        torques_Nm=torque_arrays,
        observations=_observations(obs[:nobs]),
    )


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

"""What the kernels take for a :class:`~bowlrec.core.plan.Plan`: the state at release, the
parameter vector, the orientation's error weight and the slip layer, and which kernel runs it.

Python only. Kept apart from :mod:`bowlrec.core.solver` (which turns the kernels' output into
results) because the many-delivery kernel module ``batch`` imports these at module level: by
the rule of :mod:`bowlrec.core._kernel_cache`, an edit of a module ``batch`` imports drops its
compiled kernels, and ``solver`` and ``outcome`` change more often than these.
"""

from __future__ import annotations

import math

import numpy as np

from .codes import (
    LIFT_NONE,
    N_STATE,
    RECORD_SUMMARY,
    S_QW,
    S_VX,
    S_WX,
    S_X,
    SLIDE_TO_ROLL_EXACT,
)
from .dynamics import pack_params
from .plan import Plan
from .topography import natural_spline


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
            restart_layer_mps=restart_layer(plan),
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
        restart_layer_mps=restart_layer(plan),
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
    right-hand sides), but above the cap its own error shows where a slide ends: over the 218
    work-precision deliveries at rtol 3e-6, against rtol 1e-12, a 1e-3 m/s layer gives a worst
    slide error of 0.19 mm against 0.06 mm at 3e-4 m/s (pocket 5.5e-5 against 5.4e-5 deg).
    The exit of a restarted slip is widened separately (:func:`restart_layer`). Time and errors
    per tolerance: benchmarks/results/work_precision.md."""
    if plan.slip_layer_mps is not None:
        return float(plan.slip_layer_mps)
    return min(3e-4, max(1e-8, 1e4 * plan.rtol))


#: the restart layer grows as sqrt(rtol) from the slip layer's 3e-4 m/s at rtol 7.5e-7 up to
#: RESTART_LAYER_MAX_MPS
RESTART_LAYER_FROM_RTOL = 7.5e-7
RESTART_LAYER_MAX_MPS = 6e-3


def restart_layer(plan: Plan) -> float:
    """Slip speed (m/s) up to which a slip that restarted from rolling stays in the slip layer
    (friction along the slaved direction, not stiff): :func:`slip_layer` up to rtol 7.5e-7, then
    growing as sqrt(rtol) to 6e-3 m/s at rtol 3e-4 (6e-4 m/s at rtol 3e-6, 1.9e-3 m/s at 3e-5,
    4.2e-3 m/s at 1.5e-4). A slip that falls from a slide enters the layer at half
    :func:`slip_layer`.

    After a roll -> slide event (the friction cone of a rolling ball, stick-slip) the slip grows
    from zero to several mm/s and back, and above the layer its direction is stiff (it relaxes at
    a rate ~ mu g (1 + R^2/k^2) / |s|): explicit steps are held near the stability limit
    there. Over the speed-limit benchmark's 2,218 deliveries at rtol 1.5e-4 the wider exit
    takes 548 right-hand sides a delivery on average instead of 686, with the worst hook,
    pocket and slide errors unchanged (benchmarks/results/speed_limit.md); over the
    work-precision set the worst errors stay those of the exit at s_layer from rtol 1e-6 to
    1e-4 (pocket at rtol 3e-5: 5.7e-4 against 5.6e-4 deg). Twice this exit, the worst pocket
    error there grows to 6.4e-4 deg. Widening the entry where a slide ends as well would move
    the slide end where rolling is marginal: random063 of that set rolls 0.3 m before the
    gutter with a 7.7e-4 m/s layer at rtol 2e-5, and does not roll at all in the exact
    dynamics."""
    layer = slip_layer(plan)
    if plan.slip_layer_mps is not None:
        return layer
    grown = layer * math.sqrt(max(1.0, plan.rtol / RESTART_LAYER_FROM_RTOL))
    return min(RESTART_LAYER_MAX_MPS, grown)


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

"""Scene (validated, SI) -> Plan (plain numbers for the compiled kernels)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.core.codes import (
    LIFT_SAWICKI,
    RECORD_RATE,
    RECORD_STEPS,
    RECORD_SUMMARY,
    SLIDE_TO_ROLL_EXACT,
    SLIDE_TO_ROLL_THRESHOLD,
)
from bowlrec.core.plan import PinPlan, Plan
from bowlrec.versions import PIN_MODEL_VERSION

from .friction_grid import build_friction_grid, clip_to_lane
from .rotation import frame_from_axes, matrix_to_quaternion, normalized, quaternion_to_matrix

if TYPE_CHECKING:
    from .ball import Ball
    from .delivery import Delivery
    from .pins import PinOptions
    from .scene import Scene

__all__ = ["external_terms", "initial_rotation", "release_state", "resolve_scene"]

_RECORD_MODES = {"steps": RECORD_STEPS, "rate": RECORD_RATE, "summary": RECORD_SUMMARY}
_LIFT_MODELS = {"sawicki2003": LIFT_SAWICKI}
_SLIDE_TO_ROLL = {"exact": SLIDE_TO_ROLL_EXACT, "threshold": SLIDE_TO_ROLL_THRESHOLD}


def initial_rotation(ball: Ball) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(q0, R0): the release orientation as a unit quaternion (w, x, y, z) with w >= 0 and as
    the rotation matrix (body -> lane) whose columns are the principal axes 1, 2, 3."""
    if ball.orientation_wxyz is not None:
        q = normalized(ball.orientation_wxyz)
        q = -q if q[0] < 0.0 else q
        return q, quaternion_to_matrix(q)
    r = frame_from_axes(ball.axis_1, ball.axis_2)
    return matrix_to_quaternion(r), r


def release_state(ball: Ball, delivery: Delivery, lane_width_m: float) -> dict[str, Any]:
    """The Plan fields the release fixes: orientation ``q0``, ``r_delta_body_m`` (the paper's
    r_Delta = -com_offset_m in the body frame), ``position0_m``, ``velocity0_mps`` and
    ``omega0_radps`` (SI). Replacing them in a Plan of the same ball, lane and options gives the
    Plan of the new release (what aiming does, without rebuilding the friction grid)."""
    q0, r0 = initial_rotation(ball)
    com_offset = np.asarray(ball.com_offset_m, dtype=np.float64)
    r_delta_body = -(r0.T @ com_offset) + 0.0  # + 0.0 turns -0.0 into 0.0
    position0 = (0.0, 0.5 * lane_width_m) if delivery.position_m is None else delivery.position_m
    angle = math.radians(delivery.takeoff_angle_deg)
    velocity0 = (delivery.speed_mps * math.cos(angle), delivery.speed_mps * math.sin(angle))
    return {
        "q0": q0,
        "r_delta_body_m": r_delta_body,
        "position0_m": np.asarray(position0, dtype=np.float64),
        "velocity0_mps": np.asarray(velocity0, dtype=np.float64),
        "omega0_radps": np.asarray(delivery.omega_radps, dtype=np.float64),
    }


def resolve_scene(scene: Scene) -> Plan:
    """The :class:`~bowlrec.core.plan.Plan` of a scene (all SI; see Plan for the conventions)."""
    ball, lane, delivery, options = scene.ball, scene.lane, scene.delivery, scene.options
    grid = clip_to_lane(
        build_friction_grid(lane.friction, lane.width_m), lane.length_m, lane.width_m
    )
    return Plan(
        mass_kg=float(ball.mass_kg),
        radius_m=float(ball.radius_m),
        inertia_per_mass_m2=np.asarray(ball.rg_m, dtype=np.float64) ** 2,
        **release_state(ball, delivery, lane.width_m),
        lane_length_m=float(lane.length_m),
        lane_width_m=float(lane.width_m),
        friction_x_edges_m=grid.x_edges_m,
        friction_y_edges_m=grid.y_edges_m,
        friction_mu=grid.mu,
        g_mps2=float(options.g_mps2),
        rtol=float(options.rtol),
        record_mode=_RECORD_MODES[options.record],
        record_dt_s=float(options.record_dt_s),
        record_terms=bool(options.record_terms),
        slide_to_roll=_SLIDE_TO_ROLL[options.slide_to_roll],
        slip_threshold_mps=float(options.slip_threshold_mps),
        max_time_s=float(options.max_time_s),
        labels={"scene": scene.name},
        pins=pin_plan(options.pin_options),
        **external_terms(scene),
    )


def pin_plan(pins: PinOptions | None) -> PinPlan | None:
    """The Plan's pin action (the pin model's version and parameters), None without it."""
    if pins is None:
        return None
    return PinPlan(
        model_version=PIN_MODEL_VERSION,
        ball_pin_restitution=float(pins.ball_pin_restitution),
        ball_pin_friction=float(pins.ball_pin_friction),
        pin_pin_restitution=float(pins.pin_pin_restitution),
        pin_pin_friction=float(pins.pin_pin_friction),
        pin_deck_restitution=float(pins.pin_deck_restitution),
        pin_deck_friction=float(pins.pin_deck_friction),
        pin_kickback_restitution=float(pins.pin_kickback_restitution),
        pin_kickback_friction=float(pins.pin_kickback_friction),
        timestep_s=float(pins.timestep_s),
        contact_timeconst_s=float(pins.contact_timeconst_s),
        max_time_s=float(pins.max_time_s),
        record_dt_s=float(pins.record_dt_s),
        seed=pins.seed,
        standing=tuple(pins.standing),
        moved=tuple((pin, float(dx), float(dy)) for pin, (dx, dy) in pins.moved.items()),
        hand=pins.hand,
    )


def external_terms(scene: Scene) -> dict[str, Any]:
    """The Plan fields of the optional external terms, only those that are on (the rest keep
    the Plan's defaults, so scenes without them resolve as they do without these fields)."""
    out: dict[str, Any] = {}
    air, lane = scene.air, scene.lane
    if air.drag:
        out["drag_coefficient"] = float(air.drag_coefficient)
    if air.magnus:
        out["lift_model"] = _LIFT_MODELS[air.lift_model]
    if (air.drag or air.magnus) and air.density_kg_m3 != 1.204:
        out["air_density_kg_m3"] = float(air.density_kg_m3)
    if lane.rolling_resistance != 0.0:
        out["rolling_resistance"] = float(lane.rolling_resistance)
    topo = lane.topography
    if topo is not None:
        if topo.cross_slope != 0.0:
            out["cross_slope"] = float(topo.cross_slope)
        if topo.profile_m is not None:
            pts = np.asarray(topo.profile_m, dtype=np.float64)
            out["profile_y_m"] = pts[:, 0].copy()
            out["profile_z_m"] = pts[:, 1].copy()
    return out

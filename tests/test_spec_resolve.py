"""Scene.resolve() -> Plan: orientation, offset sign, initial state, options."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bowlrec.core.codes import (
    RECORD_RATE,
    RECORD_STEPS,
    RECORD_SUMMARY,
    SLIDE_TO_ROLL_EXACT,
    SLIDE_TO_ROLL_THRESHOLD,
)
from bowlrec.core.plan import Plan
from bowlrec.spec import Ball, Delivery, Lane, Options, Scene
from bowlrec.spec.rotation import matrix_to_quaternion, perpendicular, quaternion_to_matrix


def _plan(**parts: object) -> Plan:
    return Scene.model_validate(parts).resolve()


def test_default_scene_resolves() -> None:
    plan = Scene().resolve()
    assert isinstance(plan, Plan)
    np.testing.assert_array_equal(plan.position0_m, [0.0, 1.0668 / 2])
    np.testing.assert_array_equal(plan.velocity0_mps, [8.0, 0.0])
    np.testing.assert_array_equal(plan.omega0_radps, [0.0, 30.0, 0.0])
    np.testing.assert_array_equal(plan.q0, [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(plan.inertia_per_mass_m2, [0.067**2] * 3)
    assert plan.scalar_inertia and not plan.has_offset and not plan.constant_friction
    assert plan.labels == {"scene": "scene"}
    for name in ("inertia_per_mass_m2", "r_delta_body_m", "q0", "position0_m", "friction_mu"):
        assert getattr(plan, name).dtype == np.float64


def test_default_position_is_lane_center() -> None:
    plan = Scene(lane=Lane(width_m=1.0541)).resolve()
    np.testing.assert_array_equal(plan.position0_m, [0.0, 1.0541 / 2])
    plan = Scene(delivery=Delivery(position_m=(0.5, 0.2))).resolve()
    np.testing.assert_array_equal(plan.position0_m, [0.5, 0.2])


def test_velocity_from_takeoff_angle() -> None:
    plan = Scene(delivery=Delivery(speed_mps=7.0, takeoff_angle_deg=-3.0)).resolve()
    a = math.radians(-3.0)
    np.testing.assert_allclose(plan.velocity0_mps, [7 * math.cos(a), 7 * math.sin(a)], rtol=0)
    assert plan.velocity0_mps[1] < 0  # negative angles head right (-y)


def _body_to_lane(plan: Plan, v: list[float]) -> np.ndarray:
    return quaternion_to_matrix(plan.q0) @ np.asarray(v, dtype=float)


@pytest.mark.parametrize(
    ("axis_1", "axis_2"),
    [
        ((0.0, 1.0, 0.0), None),
        ((math.sin(1.3), math.cos(1.3), 0.0), None),
        ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0)),
        ((1.0, 2.0, 3.0), (3.0, 0.0, -1.0)),
        ((0.0, 0.0, -2.0), (0.0, 1.0, 0.0)),
    ],
)
def test_quaternion_maps_body_axes_to_given_axes(
    axis_1: tuple[float, float, float], axis_2: tuple[float, float, float] | None
) -> None:
    rg = (0.06, 0.065, 0.065) if axis_2 is None else (0.06, 0.063, 0.066)
    plan = Scene(ball=Ball(rg_m=rg, axis_1=axis_1, axis_2=axis_2)).resolve()
    assert plan.q0[0] >= 0.0
    assert np.linalg.norm(plan.q0) == pytest.approx(1.0, abs=1e-15)
    a1 = np.asarray(axis_1) / np.linalg.norm(axis_1)
    np.testing.assert_allclose(_body_to_lane(plan, [1, 0, 0]), a1, atol=1e-15)
    e2 = _body_to_lane(plan, [0, 1, 0])
    assert abs(e2 @ a1) < 1e-15
    if axis_2 is not None:
        np.testing.assert_allclose(e2, np.asarray(axis_2) / np.linalg.norm(axis_2), atol=1e-15)
    # right-handed: body axis 3 = axis 1 x axis 2
    np.testing.assert_allclose(_body_to_lane(plan, [0, 0, 1]), np.cross(a1, e2), atol=1e-15)


def test_given_quaternion_is_normalized_with_positive_w() -> None:
    plan = Scene(ball=Ball(orientation_wxyz=(-2.0, 0.0, 0.0, -2.0))).resolve()
    np.testing.assert_allclose(plan.q0, [math.sqrt(0.5), 0, 0, math.sqrt(0.5)], atol=1e-16)
    np.testing.assert_allclose(_body_to_lane(plan, [1, 0, 0]), [0, 1, 0], atol=1e-15)


def test_perpendicular_is_deterministic_and_unit() -> None:
    np.testing.assert_array_equal(perpendicular([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(perpendicular([0.0, 0.0, 5.0]), [1.0, 0.0, 0.0])
    p = perpendicular([1.0, 2.0, 3.0])
    assert abs(p @ [1, 2, 3]) < 1e-14 and np.linalg.norm(p) == pytest.approx(1.0)


_unit = st.floats(-1.0, 1.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(st.tuples(_unit, _unit, _unit, _unit).filter(lambda q: sum(x * x for x in q) > 1e-3))
def test_matrix_quaternion_round_trip(q: tuple[float, float, float, float]) -> None:
    qn = np.asarray(q) / np.linalg.norm(q)
    qn = -qn if qn[0] < 0 else qn
    r = quaternion_to_matrix(qn)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-14)
    back = matrix_to_quaternion(r)
    assert back[0] >= 0.0
    # q and -q are the same rotation; w == 0 leaves the sign to the vector part
    assert min(np.abs(back - qn).max(), np.abs(back + qn).max()) < 1e-12


@pytest.mark.parametrize("angle", [0.0, math.pi, math.pi / 2, 3.0])
@pytest.mark.parametrize("axis", [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)])
def test_matrix_to_quaternion_near_half_turns(angle: float, axis: tuple[int, int, int]) -> None:
    u = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    q = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * u])
    r = quaternion_to_matrix(q)
    np.testing.assert_allclose(quaternion_to_matrix(matrix_to_quaternion(r)), r, atol=1e-15)


def test_r_delta_is_minus_com_offset() -> None:
    # identity orientation: the body frame is the lane frame
    plan = Scene(ball=Ball(com_offset_m=(0.0, 0.001, 0.0))).resolve()
    np.testing.assert_array_equal(plan.r_delta_body_m, [0.0, -0.001, 0.0])
    assert plan.has_offset


def test_r_delta_in_body_frame() -> None:
    # axis 1 along +y: a center of mass displaced along +y is along body +1, r_Delta along -1
    ball = Ball(axis_1=(0.0, 1.0, 0.0), axis_2=(0.0, 0.0, 1.0), com_offset_m=(0.0, 0.002, 0.0))
    plan = Scene(ball=ball).resolve()
    np.testing.assert_allclose(plan.r_delta_body_m, [-0.002, 0.0, 0.0], atol=1e-18)
    lane_r_delta = quaternion_to_matrix(plan.q0) @ plan.r_delta_body_m
    np.testing.assert_allclose(lane_r_delta, [0.0, -0.002, 0.0], atol=1e-18)


def test_no_offset_has_exact_zeros() -> None:
    plan = Scene(ball=Ball(axis_1=(1.0, 2.0, 3.0))).resolve()
    assert not plan.has_offset
    assert not np.signbit(plan.r_delta_body_m).any()


@pytest.mark.parametrize(
    ("record", "mode"),
    [("steps", RECORD_STEPS), ("rate", RECORD_RATE), ("summary", RECORD_SUMMARY)],
)
def test_record_modes(record: str, mode: int) -> None:
    assert _plan(options={"record": record}).record_mode == mode


def test_options_map_to_plan() -> None:
    options = Options(
        rtol=1e-7,
        record="rate",
        record_dt_s=0.01,
        record_terms=True,
        slide_to_roll="threshold",
        slip_threshold_mps=0.02,
        max_time_s=10.0,
        g_mps2=9.8,
    )
    plan = Scene(name="x", options=options).resolve()
    assert plan.rtol == 1e-7 and plan.record_dt_s == 0.01 and plan.record_terms is True
    assert plan.slide_to_roll == SLIDE_TO_ROLL_THRESHOLD and plan.slip_threshold_mps == 0.02
    assert plan.max_time_s == 10.0 and plan.g_mps2 == 9.8 and plan.labels == {"scene": "x"}
    assert Scene().resolve().slide_to_roll == SLIDE_TO_ROLL_EXACT


def test_ball_and_lane_numbers() -> None:
    ball = Ball(mass_kg=7.2, radius_m=0.108, rg_m=(0.06, 0.065, 0.065))
    plan = Scene(ball=ball, lane=Lane(length_m=18.0, width_m=1.05)).resolve()
    assert plan.mass_kg == 7.2 and plan.radius_m == 0.108
    np.testing.assert_array_equal(plan.inertia_per_mass_m2, np.square([0.06, 0.065, 0.065]))
    assert plan.lane_length_m == 18.0 and plan.lane_width_m == 1.05
    assert not plan.scalar_inertia


_finite = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False).filter(lambda x: x != 0.0)


@settings(max_examples=300, deadline=None)
@given(st.lists(_finite, min_size=3, max_size=3), st.lists(_finite, min_size=3, max_size=3))
def test_the_frame_helpers_give_numpys_bits(a: list[float], b: list[float]) -> None:
    """rotation._norm and rotation._cross stand in for np.linalg.norm and np.cross on
    float64 3-vectors (a resolved Plan, and so every run ID, depends on their bits): the same
    bits on any finite vectors."""
    from bowlrec.spec.rotation import _cross, _norm

    u, v = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    assert _norm(u).tobytes() == np.linalg.norm(u).tobytes()
    assert _cross(u, v).tobytes() == np.cross(u, v).tobytes()


def test_canonical_float_arrays_hash_each_element_exactly() -> None:
    """The canonical form of a float64 array is each element's float.hex() (the fast path for
    float arrays); other arrays go element by element."""
    from bowlrec.archive.run_id import _canonical

    values = np.array([[0.1, -0.0], [1e-310, 2.0**60]])
    assert _canonical(values) == {
        "shape": [2, 2],
        "data": [float(x).hex() for x in values.ravel()],
    }
    assert _canonical(np.array([1, 2], dtype=np.int64)) == {"shape": [2], "data": [1, 2]}
    assert _canonical(np.float64(0.5)) == _canonical(0.5) == (0.5).hex()

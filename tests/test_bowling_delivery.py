"""Bowlers' delivery and lane geometry: exact units, boards, conversions, mirroring, signs."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from pydantic import ValidationError

from bowlrec.api import simulate
from bowlrec.bowling.delivery import (
    BowlerDelivery,
    axis_angles_deg,
    hooking_delivery,
    mirror_delivery,
    mirror_omega,
    omega_from_axis,
)
from bowlrec.bowling.lane import BowlerLane, Handedness
from bowlrec.core.codes import N_STATE
from bowlrec.core.dynamics import N_PAR, P_R, slip
from bowlrec.spec import Ball, Delivery, Scene
from bowlrec.units import FT_M, IN_M, MPH_MPS, RPM_RADPS

LANE = BowlerLane()
RADIUS_M = 0.1085
HANDS: tuple[Handedness, ...] = ("right", "left")


# --- units and lane geometry -----------------------------------------------------------------


def test_exact_unit_numbers() -> None:
    assert BowlerDelivery(speed_mph=17.0).speed_mps == pytest.approx(7.59968, abs=1e-15)
    assert BowlerDelivery(rev_rate_rpm=300.0).rev_rate_radps == pytest.approx(
        31.41592653589793, abs=1e-14
    )
    assert math.isclose(300.0 * RPM_RADPS, 10.0 * math.pi, rel_tol=0.0, abs_tol=1e-14)
    assert LANE.length_m == pytest.approx(18.288, abs=1e-15)
    assert LANE.width_m == pytest.approx(41.5 * 0.0254, abs=1e-15)
    assert BowlerLane(width_in=42.0).width_m == pytest.approx(1.0668, abs=1e-15)
    assert LANE.arrows_x_m == pytest.approx(4.572, abs=1e-15)


@pytest.mark.parametrize("width_in", [41.5, 42.0])
def test_board_positions(width_in: float) -> None:
    lane = BowlerLane(width_in=width_in)
    w = width_in * IN_M / 39
    assert lane.board_width_m == pytest.approx(w, rel=1e-15)
    # board 20 (head pin) center: 19.5 boards from either gutter = the center line
    assert lane.board_to_y_m(20) == pytest.approx(19.5 * w, abs=1e-15)
    assert lane.board_to_y_m(20, "left") == pytest.approx(lane.width_m / 2, abs=1e-15)
    assert lane.head_pin_y_m == pytest.approx(lane.width_m / 2, abs=1e-15)
    # board 1 is at the right gutter for a right-hander, at the left one for a left-hander
    assert lane.board_to_y_m(1, "right") == pytest.approx(0.5 * w, abs=1e-15)
    assert lane.board_to_y_m(1, "left") == pytest.approx(lane.width_m - 0.5 * w, abs=1e-15)
    # edges: board n spans [(n - 1) w, n w]; 17.5 is the edge between boards 17 and 18
    assert lane.board_edges_y_m(1) == pytest.approx((0.0, w), abs=1e-15)
    assert lane.board_edges_y_m(39) == pytest.approx((38 * w, lane.width_m), abs=1e-15)
    lo, hi = lane.board_edges_y_m(17, "left")
    assert (lo, hi) == pytest.approx((lane.width_m - 17 * w, lane.width_m - 16 * w), abs=1e-15)
    assert lane.board_to_y_m(17.5) == pytest.approx(17 * w, abs=1e-15)
    assert lane.board_to_y_m(0.5) == 0.0
    assert lane.board_to_y_m(39.5) == pytest.approx(lane.width_m, abs=1e-15)
    for hand, board in itertools.product(HANDS, [0.5, 1.0, 7.25, 17.5, 20.0, 39.5]):
        y = lane.board_to_y_m(board, hand)
        assert lane.y_to_board(y, hand) == pytest.approx(board, abs=1e-12)
        # the same board number of the two hands is a mirror pair
        right_y = lane.board_to_y_m(board, "right")
        assert lane.board_to_y_m(board, "left") == lane.mirror_y_m(right_y)
    with pytest.raises(ValueError, match="board = 40"):
        lane.board_edges_y_m(40)


def test_lane_round_trip_and_range() -> None:
    for lane in (BowlerLane(), BowlerLane(width_in=42.0)):
        back = BowlerLane.from_physical(lane.to_physical())
        assert back.width_in == pytest.approx(lane.width_in, abs=1e-12)
        assert back.length_ft == pytest.approx(lane.length_ft, abs=1e-12)
    with pytest.raises(ValidationError, match="width_in"):
        BowlerLane(width_in=43.0)


# --- the delivery's fields -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("fields", "pieces"),
    [
        ({"speed_mph": 0.0}, ["speed_mph", "greater than 0"]),
        ({"rev_rate_rpm": -1.0}, ["rev_rate_rpm", "greater than or equal to 0"]),
        ({"rev_rate_rpm": 9501.0}, ["rev_rate_rpm", "less than or equal to 9500"]),
        ({"speed_mph": 221.0}, ["speed_mph", "less than or equal to 220"]),
        ({"laydown_board": 40.0}, ["laydown_board", "less than or equal to 39.5", "40"]),
        ({"axis_rotation_deg": 181.0}, ["axis_rotation_deg", "181"]),
        ({"axis_tilt_deg": -91.0}, ["axis_tilt_deg", "-91"]),
        ({"launch_angle_deg": 90.0}, ["launch_angle_deg", "less than 90"]),
        ({"target_board_at_arrows": 0.0}, ["target_board_at_arrows", "0.5"]),
        ({"handedness": "both"}, ["handedness", "'right' or 'left'"]),
        ({"laydown_ft": 15.0, "target_board_at_arrows": 10.0}, ["laydown_ft = 15.0", "< 15.0"]),
        ({"speed": 17.0}, ["speed", "Extra inputs are not permitted"]),
    ],
)
def test_invalid_fields_are_named(fields: dict[str, object], pieces: list[str]) -> None:
    with pytest.raises(ValidationError) as info:
        BowlerDelivery.model_validate(fields)
    text = str(info.value)
    for piece in pieces:
        assert piece in text


def test_the_sighting_line_to_the_arrows_target_is_where_aiming_starts() -> None:
    bd = BowlerDelivery(laydown_board=15.0, laydown_ft=2.0, target_board_at_arrows=10.0)
    expected = math.degrees(math.atan2(-5.0 * LANE.board_width_m, 13.0 * FT_M))
    assert bd.launch_angle_on(LANE) == pytest.approx(expected, abs=1e-14)
    d = bd.to_physical(LANE)
    assert d.position_m is not None
    x0, y0 = d.position_m
    y_arrows = y0 + math.tan(math.radians(d.takeoff_angle_deg)) * (LANE.arrows_x_m - x0)
    assert LANE.y_to_board(y_arrows) == pytest.approx(10.0, abs=1e-12)
    # an explicit angle replaces the sighting line
    assert bd.to_physical(LANE, -2.0).takeoff_angle_deg == -2.0
    # a target and a launch angle together are one too many
    with pytest.raises(ValidationError, match="give only one"):
        BowlerDelivery(
            laydown_board=15.0, laydown_ft=2.0, target_board_at_arrows=10.0, launch_angle_deg=-1.0
        )
    # neither given: straight down the boards
    assert BowlerDelivery().to_physical(LANE).takeoff_angle_deg == 0.0


def test_release_point_must_be_on_the_lane() -> None:
    with pytest.raises(ValueError, match="laydown_ft = 61.0"):
        BowlerDelivery(laydown_ft=61.0).to_physical(LANE)


# --- the physical angular velocity -----------------------------------------------------------


def test_axis_angles_give_the_documented_omega() -> None:
    w = 300.0 * RPM_RADPS
    cases = [
        # (rotation, tilt, hand) -> omega at heading 0
        ((0.0, 0.0, "right"), (0.0, w, 0.0)),  # end over end: forward roll about +y
        ((0.0, 0.0, "left"), (0.0, w, 0.0)),
        ((90.0, 0.0, "right"), (-w, 0.0, 0.0)),  # side roll along -x hooks left
        ((90.0, 0.0, "left"), (w, 0.0, 0.0)),  # ... and along +x hooks right
        ((0.0, 90.0, "right"), (0.0, 0.0, w)),  # a right-hander spins counter-clockwise
        ((0.0, 90.0, "left"), (0.0, 0.0, -w)),  # seen from above, a left-hander clockwise
    ]
    for (rot, tilt, hand), expected in cases:
        got = omega_from_axis(300.0, rot, tilt, 0.0, hand)  # type: ignore[arg-type]
        assert got == pytest.approx(expected, abs=1e-12)
    # the axis turns with the direction of travel
    got = omega_from_axis(300.0, 0.0, 0.0, 90.0, "right")
    assert got == pytest.approx((-w, 0.0, 0.0), abs=1e-12)


@pytest.mark.parametrize("launch_deg", [0.0, -2.0, 3.5])
def test_forward_roll_at_v_equals_omega_r_does_not_slip(launch_deg: float) -> None:
    # slip = R_con x omega - v with R_con = (0, 0, -R): (R w_y - v_x, -R w_x - v_y)
    speed_mph = 17.0
    rpm = speed_mph * MPH_MPS / RADIUS_M / RPM_RADPS  # omega R = v
    bd = BowlerDelivery(
        speed_mph=speed_mph,
        rev_rate_rpm=rpm,
        axis_rotation_deg=0.0,
        axis_tilt_deg=0.0,
        launch_angle_deg=launch_deg,
    )
    d = bd.to_physical(LANE)
    theta = math.radians(d.takeoff_angle_deg)
    state = np.zeros(N_STATE)
    state[2:4] = d.speed_mps * math.cos(theta), d.speed_mps * math.sin(theta)
    state[8:11] = d.omega_radps
    par = np.zeros(N_PAR)
    par[P_R] = RADIUS_M
    sx, sy = slip(state, par)
    assert abs(sx) < 1e-12
    assert abs(sy) < 1e-12
    # omega points to the left of the travel direction (+y at launch 0)
    assert d.omega_radps[1] > 0.0
    assert d.omega_radps == pytest.approx(
        (-math.sin(theta) * d.speed_mps / RADIUS_M, math.cos(theta) * d.speed_mps / RADIUS_M, 0),
        abs=1e-12,
    )


# --- round trips ----------------------------------------------------------------------------


_GRID = list(
    itertools.product(
        HANDS,
        [13.5, 17.0, 21.25],  # mph
        [0.0, 250.0, 436.0],  # rpm
        [-30.0, 0.0, 45.0, 90.0, 135.0],  # axis rotation
        [-20.0, 0.0, 15.0, 60.0],  # axis tilt
        [3.0, 20.0, 32.75],  # laydown board
        [0.0, 2.5],  # laydown ft
        [-4.0, 0.0, 1.7],  # launch angle
    )
)


def _assert_same(a: BowlerDelivery, b: BowlerDelivery, *, angles: bool = True) -> None:
    da, db = a.model_dump(), b.model_dump()
    for key in da:
        va, vb = da[key], db[key]
        if isinstance(va, float) and isinstance(vb, float):
            if not angles and key.startswith("axis_"):
                continue
            assert va == pytest.approx(vb, abs=1e-12), key
        else:
            assert va == vb, key


def _grid_delivery(
    hand: Handedness,
    mph: float,
    rpm: float,
    rot: float,
    tilt: float,
    board: float,
    ft: float,
    launch: float,
) -> BowlerDelivery:
    return BowlerDelivery(
        handedness=hand,
        speed_mph=mph,
        rev_rate_rpm=rpm,
        axis_rotation_deg=rot,
        axis_tilt_deg=tilt,
        laydown_board=board,
        laydown_ft=ft,
        launch_angle_deg=launch,
    )


def test_bowler_physics_bowler_round_trip() -> None:
    for hand, *row in _GRID:
        bd = _grid_delivery(hand, *row)
        back = BowlerDelivery.from_physical(bd.to_physical(LANE), LANE, hand)
        # with no rotation the axis is undefined (both angles come back as 0)
        _assert_same(bd, back, angles=bd.rev_rate_rpm > 0.0)


def test_physics_bowler_physics_round_trip() -> None:
    rng = np.random.default_rng(5)
    for _ in range(200):
        hand: Handedness = "right" if rng.random() < 0.5 else "left"
        omega = tuple(float(v) for v in rng.normal(0.0, 30.0, 3))
        d = Delivery(
            position_m=(float(rng.uniform(0, 3)), float(rng.uniform(0, LANE.width_m))),
            speed_mps=float(rng.uniform(5, 10)),
            takeoff_angle_deg=float(rng.uniform(-10, 10)),
            omega_radps=(omega[0], omega[1], omega[2]),
        )
        back = BowlerDelivery.from_physical(d, LANE, hand).to_physical(LANE)
        assert back.position_m == pytest.approx(d.position_m, abs=1e-12)
        assert back.speed_mps == pytest.approx(d.speed_mps, abs=1e-12)
        assert back.takeoff_angle_deg == pytest.approx(d.takeoff_angle_deg, abs=1e-12)
        assert back.omega_radps == pytest.approx(d.omega_radps, abs=1e-12)


def test_default_release_position_is_the_lane_center() -> None:
    bd = BowlerDelivery.from_physical(Delivery(), LANE, "left")
    assert bd.laydown_board == pytest.approx(20.0, abs=1e-12)
    assert bd.laydown_ft == 0.0


# --- mirroring -------------------------------------------------------------------------------


def test_mirror_of_an_axial_vector() -> None:
    # torque r x F of mirrored r and F is the mirrored torque: (a, b, c) -> (-a, b, -c)
    s = np.diag([1.0, -1.0, 1.0])
    rng = np.random.default_rng(1)
    for _ in range(20):
        r, f = rng.normal(size=3), rng.normal(size=3)
        tau = np.cross(r, f)
        mirrored = np.cross(s @ r, s @ f)
        expected = mirror_omega((float(tau[0]), float(tau[1]), float(tau[2])))
        assert tuple(mirrored) == pytest.approx(expected, abs=1e-15)


def test_left_hander_is_the_exact_mirror_of_a_right_hander() -> None:
    for _, *row in _GRID[:: len(HANDS) * 7]:
        rh = _grid_delivery("right", *row)
        lh = rh.mirrored()
        assert lh.handedness == "left"
        assert lh.mirrored() == rh
        assert lh.to_physical(LANE) == mirror_delivery(rh.to_physical(LANE), LANE)
        twice = mirror_delivery(mirror_delivery(rh.to_physical(LANE), LANE), LANE)
        once = rh.to_physical(LANE)
        assert twice.omega_radps == once.omega_radps
        assert twice.takeoff_angle_deg == once.takeoff_angle_deg
        assert twice.position_m == pytest.approx(once.position_m, abs=1e-15)


def test_axis_angles_are_relative_to_the_travel() -> None:
    for hand, heading in itertools.product(HANDS, [-5.0, 0.0, 12.0]):
        omega = omega_from_axis(400.0, 35.0, 12.0, heading, hand)
        assert axis_angles_deg(omega, heading, hand) == pytest.approx((35.0, 12.0), abs=1e-12)


# --- what the signs do -----------------------------------------------------------------------


def _uniform_scene(bd: BowlerDelivery, record: str = "summary") -> Scene:
    return Scene(
        ball=Ball(radius_m=RADIUS_M),
        lane=LANE.to_physical(),
        delivery=bd.to_physical(LANE),
        options={"record": record},  # type: ignore[arg-type]
    )


def test_right_handed_rotation_hooks_left_and_the_left_hander_mirrors_it() -> None:
    rh = hooking_delivery()
    right = simulate(_uniform_scene(rh)).summary
    left = simulate(_uniform_scene(rh.mirrored())).summary
    assert right.outcome == left.outcome == "pins"
    assert right.hook_m is not None and left.hook_m is not None
    assert right.pocket_deg is not None and left.pocket_deg is not None
    assert right.hook_m > 0.1  # toward +y, the left
    assert right.pocket_deg > 1.0
    assert left.hook_m == pytest.approx(-right.hook_m, abs=1e-9)
    assert left.pocket_deg == pytest.approx(-right.pocket_deg, abs=1e-9)
    assert left.y_end_m == pytest.approx(LANE.mirror_y_m(right.y_end_m), abs=1e-9)
    assert left.slide_m == pytest.approx(right.slide_m, abs=1e-9)
    # a right-handed backup ball (negative rotation and tilt) from the mirrored spot is the
    # left-hander's physical twin: it hooks right by the same amount
    backup = BowlerDelivery(
        speed_mph=17.0,
        rev_rate_rpm=300.0,
        axis_rotation_deg=-45.0,
        axis_tilt_deg=-10.0,
        laydown_board=25.0,
        launch_angle_deg=-rh.launch_angle_on(LANE),
    )
    assert backup.to_physical(LANE).omega_radps == pytest.approx(
        rh.mirrored().to_physical(LANE).omega_radps, abs=1e-12
    )
    twin = simulate(_uniform_scene(backup)).summary
    assert twin.hook_m == pytest.approx(left.hook_m, abs=1e-9)

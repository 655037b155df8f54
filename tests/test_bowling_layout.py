"""Layouts (Dual Angle, VLS, explicit), the PAP, and their resolution to the physical Ball."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from bowlrec import simulate
from bowlrec.bowling.ball import BowlerBall, StaticWeights
from bowlrec.bowling.layout import (
    PAP,
    VLS,
    DualAngle,
    ExplicitAxes,
    dual_angle_from_axes,
    dual_angle_to_vls,
    explicit_positions,
    grip_axes,
    grip_to_lane_rotation,
    load_example_library,
    pap_lane_direction,
    resolve_ball,
    vls_to_dual_angle,
)
from bowlrec.spec import Delivery, Lane, Scene

_R = 8.595 / 2
_BALL = BowlerBall(
    name="t", weight_lb=15, rg_in=2.48, differential_in=0.05,
    intermediate_differential_in=0.02, core_type="asymmetric", coverstock="reactive_solid",
)  # fmt: skip
_PAP = PAP(over_in=4.5, up_in=1.25)
_MIRROR_Y = np.diag([1.0, -1.0, 1.0])
# Frohlich's combination delivery (Table III cases 9-18): 35 deg to the rear of left, 15 deg up
_S35, _C35, _S15, _C15 = (math.sin(math.radians(a)) for a in (35, 55, 15, 75))
_OMEGA_RH = np.array([-_C15 * _S35, _C15 * _C35, _S15])


def _mirror_axial(w: np.ndarray) -> np.ndarray:
    """Angular velocity of the y -> -y mirror image (an axial vector: -M w)."""
    return np.asarray(-(_MIRROR_Y @ w))


def _arc(a: np.ndarray, b: np.ndarray) -> float:
    return math.acos(
        max(-1.0, min(1.0, float(np.dot(a, b)) / float(np.linalg.norm(a) * np.linalg.norm(b))))
    )


# --- Dual Angle <-> VLS ------------------------------------------------------------------------
def test_dual_angle_45_4p5_30_is_vls_4p5_3p9_1p9() -> None:
    vls = dual_angle_to_vls(
        DualAngle(drilling_angle_deg=45, pin_to_pap_in=4.5, val_angle_deg=30), _R
    )
    assert vls.pin_to_pap_in == 4.5
    assert vls.psa_to_pap_in == pytest.approx(3.918343554, abs=1e-9)
    assert vls.pin_buffer_in == pytest.approx(1.924467785, abs=1e-9)
    assert round(vls.psa_to_pap_in, 1) == 3.9 and round(vls.pin_buffer_in, 1) == 1.9
    assert vls.pin_above_pap
    # on the notes' 27 in circumference ball (R = 13.5 / pi) the same rounding holds
    v27 = dual_angle_to_vls(
        DualAngle(drilling_angle_deg=45, pin_to_pap_in=4.5, val_angle_deg=30), 13.5 / math.pi
    )
    assert (round(v27.psa_to_pap_in, 1), round(v27.pin_buffer_in, 1)) == (3.9, 1.9)


_GRID = list(
    itertools.product(
        [10.0, 45.0, 70.0, 120.0, 170.0], [2.5, 3.5, 4.5, 5.5], [5.0, 30.0, 60.0, 120.0, 175.0]
    )
)


@pytest.mark.parametrize(("da", "pin", "val"), _GRID)
def test_dual_angle_vls_round_trips(da: float, pin: float, val: float) -> None:
    layout = DualAngle(drilling_angle_deg=da, pin_to_pap_in=pin, val_angle_deg=val)
    vls = dual_angle_to_vls(layout, _R)
    back = vls_to_dual_angle(vls, _R)
    assert back.drilling_angle_deg == pytest.approx(da, abs=1e-12)
    assert back.val_angle_deg == pytest.approx(val, abs=1e-12)
    assert back.pin_to_pap_in == pin
    again = dual_angle_to_vls(back, _R)
    assert again.psa_to_pap_in == pytest.approx(vls.psa_to_pap_in, abs=1e-12)
    assert again.pin_buffer_in == pytest.approx(vls.pin_buffer_in, abs=1e-12)
    assert again.pin_above_pap == vls.pin_above_pap


def test_impossible_vls_is_rejected_with_the_condition() -> None:
    with pytest.raises(ValueError, match=r"impossible.*pin_buffer / R"):
        vls_to_dual_angle(VLS(pin_to_pap_in=1.0, psa_to_pap_in=6.0, pin_buffer_in=3.0), _R)


# --- grip-frame geometry -----------------------------------------------------------------------
@pytest.mark.parametrize("hand", ["right", "left"])
@pytest.mark.parametrize(("da", "pin", "val"), _GRID[::3])
def test_dual_angle_geometry_matches_its_definitions(
    hand: str, da: float, pin: float, val: float
) -> None:
    pap = PAP(over_in=4.75, up_in=0.5, handedness=hand)  # type: ignore[arg-type]
    layout = DualAngle(drilling_angle_deg=da, pin_to_pap_in=pin, val_angle_deg=val)
    axes = grip_axes(_BALL, layout, pap)
    vls = dual_angle_to_vls(layout, _R)
    assert _arc(axes.pin, axes.pap) * _R == pytest.approx(pin, abs=1e-12)
    assert _arc(axes.pin, axes.psa) == pytest.approx(math.pi / 2, abs=1e-12)
    assert _arc(axes.psa, axes.pap) * _R == pytest.approx(vls.psa_to_pap_in, abs=1e-12)
    # pin buffer: distance from the pin to the VAL great circle (through the PAP and y_g)
    normal = np.cross(axes.pap, [0.0, 1.0, 0.0])
    normal /= np.linalg.norm(normal)
    assert abs(math.asin(float(axes.pin @ normal))) * _R == pytest.approx(
        vls.pin_buffer_in, abs=1e-12
    )
    # the inverse construction and the explicit positions give back the same layout
    back = dual_angle_from_axes(axes, _R, pap.handedness)
    assert (back.drilling_angle_deg, back.pin_to_pap_in, back.val_angle_deg) == pytest.approx(
        (da, pin, val), abs=1e-12
    )
    pos = explicit_positions(axes, _R, pap.handedness)
    again = grip_axes(_BALL, pos, pap)
    assert again.pin == pytest.approx(axes.pin, abs=1e-14)
    assert again.psa == pytest.approx(axes.psa, abs=1e-14)
    # a VLS layout resolves to the same axes as its Dual Angle equivalent
    via_vls = grip_axes(_BALL, vls, pap)
    assert via_vls.pin == pytest.approx(axes.pin, abs=1e-12)
    assert via_vls.psa == pytest.approx(axes.psa, abs=1e-12)


def test_drilling_and_val_angle_directions_for_a_right_hander() -> None:
    """VAL 0: pin straight up the VAL from the PAP; VAL 90: pin toward the grip; DA 90: the PSA
    below the pin (the CG below the pin, the PAP counterclockwise from it, [DA-TS])."""
    pap = PAP(over_in=5.0, up_in=0.0)
    up = grip_axes(_BALL, DualAngle(drilling_angle_deg=0, pin_to_pap_in=3, val_angle_deg=0), pap)
    assert up.pin[1] > 0 and up.pin[0] == pytest.approx(up.pap[0] * math.cos(3 / _R), abs=1e-12)
    side = grip_axes(
        _BALL, DualAngle(drilling_angle_deg=90, pin_to_pap_in=3, val_angle_deg=90), pap
    )
    assert side.pin[1] == pytest.approx(0.0, abs=1e-15) and side.pin[0] < side.pap[0]
    assert side.psa[1] == pytest.approx(-1.0, abs=1e-12)  # straight down
    straight = grip_axes(
        _BALL, DualAngle(drilling_angle_deg=0, pin_to_pap_in=3, val_angle_deg=90), pap
    )
    assert _arc(straight.psa, straight.pap) * _R == pytest.approx(_R * math.pi / 2 - 3, abs=1e-12)


def test_left_hander_layout_is_the_mirror_image() -> None:
    layout = DualAngle(drilling_angle_deg=50, pin_to_pap_in=4, val_angle_deg=35)
    rh = grip_axes(_BALL, layout, PAP(over_in=5, up_in=0.75, handedness="right"))
    lh = grip_axes(_BALL, layout, PAP(over_in=5, up_in=0.75, handedness="left"))
    m = np.diag([-1.0, 1.0, 1.0])
    for a, b in ((rh.pap, lh.pap), (rh.pin, lh.pin), (rh.psa, lh.psa)):
        assert b == pytest.approx(m @ a, abs=1e-15)


def test_explicit_axes_are_orthogonalized() -> None:
    axes = grip_axes(_BALL, ExplicitAxes(low_rg_axis=(0, 2, 1), high_rg_axis=(1, 0.1, 0)), _PAP)
    assert np.linalg.norm(axes.pin) == pytest.approx(1.0) and axes.pin @ axes.psa == pytest.approx(
        0.0, abs=1e-15
    )


# --- lane frame ---------------------------------------------------------------------------------
def test_pap_is_at_plus_omega_for_a_right_hander_and_mirrors_for_a_left_hander() -> None:
    """Forward roll (omega along +y, zero slip at v = omega R along +x): a right-hander's PAP is
    on the ball's left (+y, at +omega_hat), a left-hander's on its right (-y, -omega_hat)."""
    assert pap_lane_direction(np.array([0.0, 30.0, 0.0]), "right") == pytest.approx([0, 1, 0])
    assert pap_lane_direction(np.array([0.0, 30.0, 0.0]), "left") == pytest.approx([0, -1, 0])
    r = 0.1085
    slip = np.cross([0.0, 0.0, -r], [0.0, 30.0, 0.0]) - np.array([30.0 * r, 0.0, 0.0])
    assert slip == pytest.approx([0.0, 0.0, 0.0], abs=1e-15)


@pytest.mark.parametrize("roll", [0.0, 37.0, -120.0])
def test_resolved_ball_preserves_pin_to_pap_and_the_spec(roll: float) -> None:
    layout = DualAngle(drilling_angle_deg=45, pin_to_pap_in=4.5, val_angle_deg=30)
    ball = resolve_ball(_BALL, layout, _PAP, 30.0 * _OMEGA_RH, roll_about_pap_deg=roll)
    w = _OMEGA_RH / np.linalg.norm(_OMEGA_RH)
    a1, a2 = np.array(ball.axis_1), np.array(ball.axis_2)
    assert _arc(a1, w) == pytest.approx(4.5 / _R, abs=1e-12)  # the right-hander's PAP is +omega
    assert _arc(a2, w) * _R == pytest.approx(dual_angle_to_vls(layout, _R).psa_to_pap_in, abs=1e-12)
    assert (
        ball.rg_m == _BALL.rg_m
        and ball.mass_kg == _BALL.mass_kg
        and ball.radius_m == _BALL.radius_m
    )
    assert float(a1 @ a2) == pytest.approx(0.0, abs=1e-15)


def test_roll_about_pap_rotates_about_the_pap_and_defaults_to_grip_facing_the_bowler() -> None:
    axes = grip_axes(
        _BALL, DualAngle(drilling_angle_deg=45, pin_to_pap_in=4.5, val_angle_deg=30), _PAP
    )
    p_lane = pap_lane_direction(_OMEGA_RH, "right")
    travel = np.array([math.cos(0.02), math.sin(0.02), 0.0])
    backward = []
    for roll in np.linspace(-180, 180, 73):
        rot = grip_to_lane_rotation(axes.pap, p_lane, float(roll), "right", travel)
        assert rot @ rot.T == pytest.approx(np.eye(3), abs=1e-14) and np.linalg.det(
            rot
        ) == pytest.approx(1.0)
        assert rot @ axes.pap == pytest.approx(p_lane, abs=1e-14)
        backward.append(
            float(-(rot @ [0.0, 0.0, 1.0]) @ travel)
        )  # center of grip toward the bowler
    assert int(np.argmax(backward)) == 36  # roll 0


@pytest.mark.parametrize("hand", ["right", "left"])
def test_static_weights_point_the_documented_way_in_the_lane(hand: str) -> None:
    pap = PAP(over_in=4.5, up_in=1.25, handedness=hand)  # type: ignore[arg-type]
    omega = _OMEGA_RH if hand == "right" else _mirror_axial(_OMEGA_RH)
    layout = DualAngle(drilling_angle_deg=45, pin_to_pap_in=4.5, val_angle_deg=30)
    p_lane = pap_lane_direction(omega, hand)  # type: ignore[arg-type]
    rot = grip_to_lane_rotation(pap.point(_R), p_lane, 0.0, hand)  # type: ignore[arg-type]
    grip_lane = rot @ [0.0, 0.0, 1.0]
    pos = resolve_ball(_BALL, layout, pap, omega, balance=StaticWeights(side_oz=1.0))
    neg = resolve_ball(_BALL, layout, pap, omega, balance=StaticWeights(side_oz=-1.0))
    top = resolve_ball(_BALL, layout, pap, omega, balance=StaticWeights(top_oz=2.0))
    assert float(np.dot(pos.com_offset_m, p_lane)) > 0  # positive side weight: toward the PAP
    assert float(np.dot(neg.com_offset_m, p_lane)) < 0
    expected = 0.162 * 2.0 * (0.45359237 / 16) / (2 * _BALL.mass_kg)
    assert np.array(top.com_offset_m) == pytest.approx(expected * grip_lane, abs=1e-18)


def test_left_hander_resolves_to_the_exact_mirror() -> None:
    layout = VLS(pin_to_pap_in=3.5, psa_to_pap_in=3.5, pin_buffer_in=1.0)
    balance = StaticWeights(top_oz=2.0, side_oz=0.5, finger_oz=-0.5)
    rh = resolve_ball(
        _BALL,
        layout,
        PAP(over_in=5, up_in=0.5),
        30 * _OMEGA_RH,
        roll_about_pap_deg=25,
        balance=balance,
    )
    lh = resolve_ball(
        _BALL, layout, PAP(over_in=5, up_in=0.5, handedness="left"), 30 * _mirror_axial(_OMEGA_RH),
        roll_about_pap_deg=25, balance=balance,
    )  # fmt: skip
    for a, b in ((rh.axis_1, lh.axis_1), (rh.axis_2, lh.axis_2)):
        mirrored = _MIRROR_Y @ np.array(a)
        sign = 1.0 if float(mirrored @ np.array(b)) > 0 else -1.0
        assert np.array(b) == pytest.approx(sign * mirrored, abs=1e-15)
    assert np.array(lh.com_offset_m) == pytest.approx(
        _MIRROR_Y @ np.array(rh.com_offset_m), abs=1e-19
    )


def _scene(hand: str) -> Scene:
    lib = load_example_library()
    ball_spec = lib.ball("illustrative-max-legal-asymmetric")
    layout = lib.layout("vls-max-flare-3.5x3.5x1")  # pin 3.5 in from the PAP
    sign = 1.0 if hand == "right" else -1.0
    omega = 30.0 * (_OMEGA_RH if hand == "right" else _mirror_axial(_OMEGA_RH))
    pap = PAP(over_in=5.25, up_in=0.5, handedness=hand)  # type: ignore[arg-type]
    ball = resolve_ball(
        ball_spec, layout, pap, omega, balance=StaticWeights(top_oz=2.0, side_oz=1.0)
    )
    delivery = Delivery(speed_mps=8.0, takeoff_angle_deg=-1.0 * sign, omega_radps=tuple(omega))
    return Scene(name=f"{hand}-hander", ball=ball, lane=Lane(), delivery=delivery)


def test_right_hander_hooks_left_and_left_hander_mirrors_exactly() -> None:
    rh, lh = simulate(_scene("right")).summary, simulate(_scene("left")).summary
    assert rh.outcome == "pins" and lh.outcome == "pins"
    assert rh.hook_m is not None and lh.hook_m is not None
    assert rh.hook_m > 0.2  # hooks left (+y) by tens of cm on the typical pattern
    assert lh.hook_m == pytest.approx(-rh.hook_m, abs=1e-9)
    assert lh.slide_m == pytest.approx(rh.slide_m, abs=1e-9)


# --- 2LS <-> Dual Angle <-> VLS ----------------------------------------------------------------
from bowlrec.bowling.layout import (  # noqa: E402  (2LS tests appended below the others)
    TwoLS,
    convert_layout,
    dual_angle_to_two_ls,
    two_ls_to_dual_angle,
    two_ls_to_vls,
    vls_to_two_ls,
)

_R27 = 13.5 / math.pi  # the 27 in circumference ball of Storm's sheets and of [LA]


def _la_pin_to_grip(pin: float, val_deg: float, over: float, up: float) -> float:
    """[LA]'s independent formula (layout-math.js pinToCogDistance): the pin to the center of
    grip on a sphere with the PAP at longitude over / R, latitude up / R (right-hander)."""
    a, lam, phi, v = pin / _R27, over / _R27, up / _R27, math.radians(val_deg)
    c = math.cos(a) * math.cos(phi) * math.cos(lam) + math.sin(a) * (
        -math.sin(phi) * math.cos(lam) * math.cos(v) + math.sin(lam) * math.sin(v)
    )
    return _R27 * math.acos(c)


def _finger_side(axes_pin: np.ndarray, pap: np.ndarray) -> bool:
    """The pin on the same side of the PAP / center-of-grip great circle as the finger pole."""
    n = np.cross(pap, [0.0, 0.0, 1.0])
    return bool(np.sign(axes_pin @ n) == np.sign(n[1]))


@pytest.mark.parametrize("hand", ["right", "left"])
@pytest.mark.parametrize(("da", "pin", "val"), _GRID)
def test_two_ls_dual_angle_vls_round_trips(hand: str, da: float, pin: float, val: float) -> None:
    pap = PAP(over_in=4.75, up_in=0.5, handedness=hand)  # type: ignore[arg-type]
    layout = DualAngle(drilling_angle_deg=da, pin_to_pap_in=pin, val_angle_deg=val)
    tls = dual_angle_to_two_ls(layout, pap, _R)
    back = two_ls_to_dual_angle(tls, pap, _R)
    assert (back.drilling_angle_deg, back.pin_to_pap_in, back.val_angle_deg) == pytest.approx(
        (da, pin, val), abs=1e-9
    )
    vls = dual_angle_to_vls(layout, _R)
    via_vls = vls_to_two_ls(vls, pap, _R)
    for field in ("pin_to_pap_in", "psa_to_pap_in", "pin_to_grip_center_in"):
        assert getattr(via_vls, field) == pytest.approx(getattr(tls, field), abs=1e-9)
    assert via_vls.pin_toward_fingers == tls.pin_toward_fingers
    again = two_ls_to_vls(tls, pap, _R)
    assert (again.psa_to_pap_in, again.pin_buffer_in) == pytest.approx(
        (vls.psa_to_pap_in, vls.pin_buffer_in), abs=1e-9
    )
    assert again.pin_above_pap == vls.pin_above_pap
    # every system pair through convert_layout lands on the same axes
    ref = grip_axes(_BALL, layout, pap)
    for source in (layout, vls, tls):
        for system in ("dual_angle", "vls", "2ls"):
            out = convert_layout(source, system, pap, _R)  # type: ignore[arg-type]
            assert out.system == system
            axes = grip_axes(_BALL, out, pap)
            assert axes.pin == pytest.approx(ref.pin, abs=1e-9)
            assert axes.psa == pytest.approx(ref.psa, abs=1e-9)


@pytest.mark.parametrize("hand", ["right", "left"])
@pytest.mark.parametrize(
    ("pin", "psa", "grip", "fingers"),
    [(5.5, 5.0, 2.0, True), (4.0, 4.0, 5.0, True), (3.5, 4.0, 6.5, True), (4.0, 3.5, 3.0, False)],
)
def test_two_ls_geometry_matches_its_definition(
    hand: str, pin: float, psa: float, grip: float, fingers: bool
) -> None:
    pap = PAP(over_in=5.0, up_in=1.0, handedness=hand)  # type: ignore[arg-type]
    tls = TwoLS(
        pin_to_pap_in=pin, psa_to_pap_in=psa, pin_to_grip_center_in=grip, pin_toward_fingers=fingers
    )
    axes = grip_axes(_BALL, tls, pap)
    assert _arc(axes.pin, axes.pap) * _R == pytest.approx(pin, abs=1e-12)
    assert _arc(axes.pin, np.array([0.0, 0.0, 1.0])) * _R == pytest.approx(grip, abs=1e-12)
    assert _arc(axes.psa, axes.pap) * _R == pytest.approx(psa, abs=1e-12)
    assert _arc(axes.pin, axes.psa) == pytest.approx(math.pi / 2, abs=1e-12)
    assert _finger_side(axes.pin, axes.pap) is fingers


def test_two_ls_left_hander_is_the_mirror_image() -> None:
    tls = TwoLS(pin_to_pap_in=5.0, psa_to_pap_in=4.0, pin_to_grip_center_in=3.5)
    rh = grip_axes(_BALL, tls, PAP(over_in=5, up_in=1, handedness="right"))
    lh = grip_axes(_BALL, tls, PAP(over_in=5, up_in=1, handedness="left"))
    m = np.diag([-1.0, 1.0, 1.0])
    for a, b in ((rh.pap, lh.pap), (rh.pin, lh.pin), (rh.psa, lh.psa)):
        assert b == pytest.approx(m @ a, abs=1e-15)


def test_dual_angle_to_two_ls_matches_the_layout_adapter_formula() -> None:
    """45 x 4.5 x 30 for a PAP 5 over x 1 up on the 27 in ball: [LA]'s independent formula gives
    the pin 4.391048900139 in from the center of grip; the PSA is 3.917906707 in from the PAP."""
    pap = PAP(over_in=5.0, up_in=1.0)
    tls = dual_angle_to_two_ls(
        DualAngle(drilling_angle_deg=45, pin_to_pap_in=4.5, val_angle_deg=30), pap, _R27
    )
    assert tls.pin_to_grip_center_in == pytest.approx(_la_pin_to_grip(4.5, 30, 5, 1), abs=1e-12)
    assert tls.pin_to_grip_center_in == pytest.approx(4.391048900139, abs=1e-11)
    assert tls.psa_to_pap_in == pytest.approx(3.917906706972, abs=1e-11)
    assert tls.pin_toward_fingers


#: Storm's 2LS example layouts (pin-to-PAP x PSA-to-PAP x pin-to-grip, in), as [LA] lists them
#: from Storm's 2LS drilling instructions, and their Dual Angle form for a PAP 5 over x 1 up on
#: the 27 in ball (this module's arithmetic; the sixth puts the pin past the VAL)
_STORM_2LS = [
    ((5.5, 5.0, 2.0), (65.58, 68.04)),
    ((2.0, 6.0, 5.0), (67.24, 12.85)),
    ((5.0, 4.0, 3.5), (49.43, 44.71)),
    ((4.5, 3.0, 4.5), (27.80, 28.30)),
    ((4.0, 4.0, 5.0), (41.89, 18.64)),
    ((3.5, 4.0, 6.5), None),
]


@pytest.mark.parametrize(("numbers", "dual"), _STORM_2LS)
def test_storm_2ls_examples(
    numbers: tuple[float, float, float], dual: tuple[float, float] | None
) -> None:
    pap = PAP(over_in=5.0, up_in=1.0)
    tls = TwoLS(
        pin_to_pap_in=numbers[0], psa_to_pap_in=numbers[1], pin_to_grip_center_in=numbers[2]
    )
    ball = _BALL.model_copy(update={"diameter_in": 2 * _R27})
    axes = grip_axes(ball, tls, pap)
    assert _arc(axes.pin, axes.pap) * _R27 == pytest.approx(numbers[0], abs=1e-12)
    assert _arc(axes.psa, axes.pap) * _R27 == pytest.approx(numbers[1], abs=1e-12)
    assert _arc(axes.pin, np.array([0.0, 0.0, 1.0])) * _R27 == pytest.approx(numbers[2], abs=1e-12)
    if dual is None:
        with pytest.raises(ValueError, match=r"VAL angle -12\.2\d* deg .*far side of the VAL"):
            two_ls_to_dual_angle(tls, pap, _R27)
        return
    da = two_ls_to_dual_angle(tls, pap, _R27)
    assert (da.drilling_angle_deg, da.val_angle_deg) == pytest.approx(dual, abs=0.005)
    assert _la_pin_to_grip(da.pin_to_pap_in, da.val_angle_deg, 5, 1) == pytest.approx(numbers[2])


def test_impossible_two_ls_is_rejected_with_the_reason() -> None:
    pap = PAP(over_in=5.0, up_in=0.5)
    with pytest.raises(ValueError, match=r"impossible for this PAP.*circles miss"):
        two_ls_to_dual_angle(
            TwoLS(pin_to_pap_in=1.0, psa_to_pap_in=6.0, pin_to_grip_center_in=1.0), pap, _R
        )
    with pytest.raises(ValueError, match=r"\|cos\(psa_to_pap / R\)\| <= sin\(pin_to_pap / R\)"):
        two_ls_to_dual_angle(
            TwoLS(pin_to_pap_in=1.0, psa_to_pap_in=1.0, pin_to_grip_center_in=5.0), pap, _R
        )

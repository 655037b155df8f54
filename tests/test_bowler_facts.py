"""The bowler-facing facts of the PAP convention, pinned through the whole bowler layer.

A right-hander's positive axis point (PAP) is at +omega_hat at release: to the ball's left and
back toward the bowler, the raised end of the axis for positive tilt. The grip faces the bowler
with the thumb above the fingers (the layout sheet turned 180 deg), the track is the small circle
90 deg + tilt from the PAP, and weight moved toward the PAP (positive side weight) makes the ball
hook more and enter at a steeper angle, for either hand (Frohlich 2004, P2 and Table III case 4:
a center of mass displaced toward +omega_0 hooks left). A left-hander is the exact mirror.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bowlrec import simulate
from bowlrec.bowling.layout import grip_axes, grip_to_lane_rotation, pap_lane_direction
from bowlrec.bowling.scene import BowlerScene


def _scene(hand: str = "right", tilt: float = 10.0, side_oz: float = 0.0) -> BowlerScene:
    return BowlerScene.model_validate(
        {
            "pap": {"over_in": 5.0, "up_in": 0.5, "handedness": hand},
            "delivery": {"handedness": hand, "axis_tilt_deg": tilt, "launch_angle_deg": -1.0},
            "balance": {"side_oz": side_oz},
            "options": {"record": "summary"},
        }
    )


def _release_frame(scene: BowlerScene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(PAP, center of grip, finger direction) in the lane frame at release."""
    delivery = scene.delivery.to_physical(scene.lane)
    axes = grip_axes(scene.ball, scene.layout, scene.pap)
    p = pap_lane_direction(np.array(delivery.omega_radps), scene.pap.handedness)
    a = math.radians(delivery.takeoff_angle_deg)
    rot = grip_to_lane_rotation(
        axes.pap, p, 0.0, scene.pap.handedness, (math.cos(a), math.sin(a), 0.0)
    )
    return p, rot @ np.array([0.0, 0.0, 1.0]), rot @ np.array([0.0, 1.0, 0.0])


def test_right_handers_pap_is_left_back_and_raised_with_the_grip_facing_the_bowler() -> None:
    p, grip, fingers = _release_frame(_scene("right", tilt=10.0))
    assert p[1] > 0.5  # on the ball's left (higher boards for a right-hander)
    assert p[0] < -0.5  # back toward the bowler (45 deg of axis rotation)
    assert p[2] == pytest.approx(math.sin(math.radians(10.0)), abs=1e-12)  # raised by the tilt
    assert grip[0] < -0.9  # the center of grip faces the bowler
    assert fingers[2] < -0.9  # the thumb above the fingers


def test_left_handers_pap_is_the_mirror_and_sits_at_minus_omega() -> None:
    scene = _scene("left", tilt=10.0)
    p_left, _, fingers = _release_frame(scene)
    p_right, _, _ = _release_frame(_scene("right", tilt=10.0))
    assert p_left == pytest.approx(p_right * np.array([1.0, -1.0, 1.0]), abs=1e-12)
    omega = np.array(scene.delivery.to_physical(scene.lane).omega_radps)
    assert p_left == pytest.approx(-omega / np.linalg.norm(omega), abs=1e-12)
    assert p_left[1] < -0.5 and p_left[2] > 0.0  # the bowler's right, raised
    assert fingers[2] < -0.9


@pytest.mark.parametrize("tilt", [0.0, 10.0, 20.0, 35.0])
def test_track_is_the_small_circle_ninety_plus_tilt_from_the_pap(tilt: float) -> None:
    """The contact point (straight down) is 90 + tilt deg from the PAP, so the track, the ring
    it traces on the ball, has radius R cos(tilt): more tilt, a smaller and lower track."""
    p, _, _ = _release_frame(_scene("right", tilt=tilt))
    assert math.degrees(math.acos(-p[2])) == pytest.approx(90.0 + tilt, abs=1e-9)


def _hook_and_entry(scene: BowlerScene) -> tuple[float, float]:
    summary = simulate(scene.to_scene()).summary
    assert summary.outcome == "pins", summary.message
    assert summary.hook_m is not None and summary.pocket_deg is not None
    sign = 1.0 if scene.delivery.handedness == "right" else -1.0
    return sign * summary.hook_m, sign * summary.pocket_deg


@pytest.mark.parametrize("hand", ["right", "left"])
def test_side_weight_toward_the_pap_hooks_more_and_enters_steeper(hand: str) -> None:
    neg, zero, pos = (_hook_and_entry(_scene(hand, side_oz=oz)) for oz in (-1.0, 0.0, 1.0))
    assert neg[0] < zero[0] < pos[0]  # hook toward the bowler's own higher boards
    assert neg[1] < zero[1] < pos[1]  # entry angle
    assert pos[0] - neg[0] > 0.01  # by centimetres for 2 oz, not by rounding


def test_left_hander_is_the_exact_mirror_of_the_right_hander() -> None:
    right = simulate(_scene("right", side_oz=1.0).to_scene()).summary
    left = simulate(_scene("left", side_oz=1.0).to_scene()).summary
    assert right.hook_m is not None and left.hook_m is not None
    assert left.hook_m == pytest.approx(-right.hook_m, abs=1e-9)
    assert left.slide_m == pytest.approx(right.slide_m, abs=1e-9)

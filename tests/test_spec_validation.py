"""Every class of invalid scene input raises a ValidationError naming field, value and range."""

from __future__ import annotations

import math
from typing import Any

import pytest
from pydantic import ValidationError

from bowlrec.spec import Ball, Scene, format_validation_error


def _error_text(data: dict[str, Any]) -> str:
    with pytest.raises(ValidationError) as info:
        Scene.model_validate(data)
    return format_validation_error(info.value)


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        ({"ball": {"mass_kg": 0.0}}, ["ball.mass_kg", "greater than 0", "got 0.0"]),
        ({"ball": {"radius_m": -0.1}}, ["ball.radius_m", "greater than 0", "-0.1"]),
        ({"delivery": {"speed_mps": -8}}, ["delivery.speed_mps", "greater than 0", "-8"]),
        ({"lane": {"width_m": 0}}, ["lane.width_m", "greater than 0"]),
        ({"options": {"record_dt_s": 0}}, ["options.record_dt_s", "greater than 0"]),
        ({"ball": {"rg_m": [0.067, -0.01, 0.067]}}, ["ball.rg_m[1]", "greater than 0"]),
        ({"options": {"rtol": 1e-2}}, ["options.rtol", "less than or equal to 0.001", "0.01"]),
        ({"options": {"rtol": 1e-16}}, ["options.rtol", "greater than or equal to", "1e-16"]),
    ],
)
def test_non_positive_and_out_of_range_numbers(data: dict[str, Any], expected: list[str]) -> None:
    text = _error_text(data)
    for piece in expected:
        assert piece in text


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize(
    ("path", "make"),
    [
        ("ball.mass_kg", lambda v: {"ball": {"mass_kg": v}}),
        ("ball.com_offset_m[2]", lambda v: {"ball": {"com_offset_m": [0, 0, v]}}),
        ("delivery.omega_radps[0]", lambda v: {"delivery": {"omega_radps": [v, 30, 0]}}),
        ("delivery.takeoff_angle_deg", lambda v: {"delivery": {"takeoff_angle_deg": v}}),
        ("options.rtol", lambda v: {"options": {"rtol": v}}),
        (
            "lane.friction.typical.oil_width_fraction",
            lambda v: {"lane": {"friction": {"kind": "typical", "oil_width_fraction": v}}},
        ),
    ],
)
def test_non_finite_numbers(path: str, make: Any, bad: float) -> None:
    text = _error_text(make(bad))
    assert path in text
    assert "finite number" in text


def test_rg_not_below_radius() -> None:
    text = _error_text({"ball": {"rg_m": [0.067, 0.2, 0.2]}})
    assert "ball.rg_m: rg_m[1] = 0.2 must be < radius_m = 0.1085" in text
    text = _error_text({"ball": {"radius_m": 0.05}})  # the default rg 0.067 is now too large
    assert "rg_m[0] = 0.067 must be < radius_m = 0.05" in text


def test_triangle_inequality() -> None:
    text = _error_text({"ball": {"rg_m": [0.02, 0.02, 0.067], "axis_2": [0, 1, 0]}})
    assert "ball.rg_m" in text
    assert "triangle inequality" in text
    assert "I_1 + I_2" in text and "I_3" in text
    assert "must be in [" in text
    # the equality case (a thin disk) is allowed
    k = 0.05
    Ball(rg_m=(k, k, math.sqrt(2) * k), axis_2=(0, 1, 0))


def test_offset_not_inside_ball() -> None:
    text = _error_text({"ball": {"com_offset_m": [0.1, 0.05, 0.0]}})
    assert "ball.com_offset_m" in text
    assert "must be < radius_m = 0.1085" in text
    assert "(0.1, 0.05, 0.0)" in text


@pytest.mark.parametrize(
    ("friction", "path"),
    [
        ({"kind": "constant", "mu": -0.1}, "lane.friction.constant.mu"),
        ({"kind": "typical", "mu_oil": -0.01}, "lane.friction.typical.mu_oil"),
        ({"kind": "zones", "default_mu": -1}, "lane.friction.zones.default_mu"),
        (
            {
                "kind": "zones",
                "default_mu": 0.1,
                "zones": [{"x_min_m": 0, "x_max_m": 1, "y_min_m": 0, "y_max_m": 1, "mu": -2}],
            },
            "lane.friction.zones.zones[0].mu",
        ),
    ],
)
def test_negative_friction(friction: dict[str, Any], path: str) -> None:
    text = _error_text({"lane": {"friction": friction}})
    assert path in text
    assert "greater than or equal to 0" in text


@pytest.mark.parametrize(
    ("ball", "path", "piece"),
    [
        ({"axis_1": [0, 0, 0]}, "ball.axis_1", "must be a nonzero vector"),
        ({"axis_2": [0, 0, 0]}, "ball.axis_2", "must be a nonzero vector"),
        ({"orientation_wxyz": [0, 0, 0, 0]}, "ball.orientation_wxyz", "nonzero quaternion"),
    ],
)
def test_zero_length_directions(ball: dict[str, Any], path: str, piece: str) -> None:
    text = _error_text({"ball": ball})
    assert path in text and piece in text


def test_non_orthogonal_axes() -> None:
    text = _error_text({"ball": {"axis_1": [1, 0, 0], "axis_2": [1, 1, 0]}})
    assert "ball.axis_2" in text
    assert "45 deg" in text
    # within tolerance is fine, and axes need not be unit length
    Ball(axis_1=(2.0, 0.0, 0.0), axis_2=(1e-10, 3.0, 0.0))


def test_missing_axis_2_when_needed() -> None:
    text = _error_text({"ball": {"rg_m": [0.06, 0.061, 0.062]}})
    assert "axis_2 is required when rg_m[1] != rg_m[2]" in text
    Ball(rg_m=(0.06, 0.062, 0.062))  # symmetric about axis 1: fine without axis_2
    Ball(rg_m=(0.06, 0.061, 0.062), orientation_wxyz=(1, 0, 0, 0))  # quaternion: fine


def test_quaternion_exclusive_with_axes() -> None:
    text = _error_text({"ball": {"orientation_wxyz": [1, 0, 0, 0], "axis_2": [0, 1, 0]}})
    assert "mutually exclusive" in text
    text = _error_text({"ball": {"orientation_wxyz": [1, 0, 0, 0], "axis_1": [0, 1, 0]}})
    assert "mutually exclusive" in text


@pytest.mark.parametrize("axis", ["x", "y"])
def test_zone_min_not_below_max(axis: str) -> None:
    zone = {"x_min_m": 0.0, "x_max_m": 1.0, "y_min_m": 0.0, "y_max_m": 1.0, "mu": 0.1}
    zone[f"{axis}_min_m"] = 1.0
    friction = {"kind": "zones", "default_mu": 0.2, "zones": [zone]}
    text = _error_text({"lane": {"friction": friction}})
    assert f"lane.friction.zones.zones[0].{axis}_max_m" in text
    assert f"{axis}_min_m = 1.0 must be < {axis}_max_m = 1.0" in text


@pytest.mark.parametrize(
    ("position", "piece"),
    [
        ([0.0, -0.01], "position_m[1] = y = -0.01 must be in [0, lane.width_m = 1.0668]"),
        ([0.0, 1.07], "position_m[1] = y = 1.07 must be in [0, lane.width_m = 1.0668]"),
        ([-1.0, 0.5], "position_m[0] = x = -1.0 must be in [0, lane.length_m = 18.288)"),
        ([18.288, 0.5], "position_m[0] = x = 18.288 must be in [0, lane.length_m = 18.288)"),
    ],
)
def test_position_off_lane(position: list[float], piece: str) -> None:
    text = _error_text({"delivery": {"position_m": position}})
    assert text.startswith("delivery: ")
    assert piece in text


def test_position_checked_against_the_given_lane() -> None:
    Scene.model_validate({"lane": {"width_m": 2.0}, "delivery": {"position_m": [0.0, 1.9]}})
    Scene.model_validate({"delivery": {"position_m": [0.0, 0.0]}})
    Scene.model_validate({"delivery": {"position_m": [0.0, 1.0668]}})


@pytest.mark.parametrize("angle", [90.0, -90.0, 135.0])
def test_takeoff_angle_out_of_range(angle: float) -> None:
    text = _error_text({"delivery": {"takeoff_angle_deg": angle}})
    assert "delivery.takeoff_angle_deg" in text
    assert "90" in text and repr(angle) in text


@pytest.mark.parametrize(
    ("data", "path"),
    [
        ({"colour": "red"}, "colour"),
        ({"ball": {"weight_lb": 15}}, "ball.weight_lb"),
        ({"lane": {"friction": {"kind": "constant", "mu": 0.1, "x": 1}}}, "lane.friction"),
        ({"options": {"rtoll": 1e-6}}, "options.rtoll"),
    ],
)
def test_unknown_field(data: dict[str, Any], path: str) -> None:
    text = _error_text(data)
    assert path in text
    assert "Extra inputs are not permitted" in text


def test_bad_friction_kind() -> None:
    text = _error_text({"lane": {"friction": {"kind": "oily", "mu": 0.1}}})
    assert "lane.friction" in text
    assert "'oily'" in text and "'constant', 'zones', 'typical'" in text
    text = _error_text({"lane": {"friction": {"mu": 0.1}}})
    assert "kind" in text


def test_bad_literal_option() -> None:
    text = _error_text({"options": {"record": "everything"}})
    assert "options.record" in text and "'steps'" in text


def test_models_are_immutable() -> None:
    scene = Scene()
    with pytest.raises(ValidationError):
        scene.ball.mass_kg = -1.0  # type: ignore[misc]


def test_defaults_are_valid() -> None:
    scene = Scene()
    assert scene.ball.mass_kg == 6.8
    assert scene.lane.width_m == 1.0668
    assert scene.lane.length_m == 18.288
    assert scene.lane.friction.kind == "typical"
    assert scene.delivery.omega_radps == (0.0, 30.0, 0.0)

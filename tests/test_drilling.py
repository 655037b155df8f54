"""Drilled holes -> mass properties (bowlrec.bowling.drilling) and the hole rules of legality."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

import bowlrec
from bowlrec.bowling.ball import BowlerBall, CenterOfMassMark, StaticWeights
from bowlrec.bowling.drilling import (
    DrillingSpec,
    ExtraHole,
    GripDrilling,
    HoleSpec,
    drill_ball,
    drill_holes,
    mean_density_g_cm3,
    place_hole,
    place_holes,
)
from bowlrec.bowling.layout import PAP, DualAngle, TwoLS
from bowlrec.bowling.legality import check_legality
from bowlrec.bowling.scene import BowlerScene
from bowlrec.errors import IllegalBallError

_R = 8.595 / 2
#: a uniform sphere: RG = sqrt(2/5) R about every axis
_UNIFORM = BowlerBall(
    name="uniform",
    weight_lb=15,
    rg_in=math.sqrt(0.4) * _R,
    differential_in=0.0,
    coverstock="polyester",
)
_PEARL = BowlerBall(
    name="pearl", weight_lb=15, rg_in=2.50, differential_in=0.050, coverstock="reactive_pearl"
)
_ASYM = BowlerBall(
    name="asym",
    weight_lb=15,
    rg_in=2.48,
    differential_in=0.052,
    intermediate_differential_in=0.018,
    core_type="asymmetric",
    coverstock="reactive_solid",
)
_LAYOUT = DualAngle(drilling_angle_deg=45, pin_to_pap_in=4.5, val_angle_deg=30)
_PAP = PAP(over_in=5.0, up_in=0.5)
_FINGER = HoleSpec(diameter_in=0.875, depth_in=2.5)
#: a typical fingertip grip (the layout_adapter example chart: 7/8 in fingers 2 1/2 in deep,
#: 1 in thumb 2 3/4 in deep, 4 in spans, 1/4 in bridge)
_GRIP = GripDrilling(
    middle=_FINGER,
    ring=_FINGER,
    thumb=HoleSpec(diameter_in=1.0, depth_in=2.75),
    bridge_in=0.25,
    middle_span_in=4.0,
    ring_span_in=4.0,
)


def _centered_hole(over: float = 0.0, up: float = 0.0) -> ExtraHole:
    return ExtraHole(name="one", diameter_in=1.0, depth_in=2.5, over_in=over, up_in=up)


# --- closed form: a uniform sphere with one hole on an axis through its center -------------------
def test_uniform_sphere_with_one_centered_hole_matches_the_closed_form() -> None:
    """M0 = 15 lb, R = 4.2975 in, hole a = 0.5 in, d = 2.5 in along -z_g from the center of grip,
    drilled at the sphere's own density. By hand (lb, in):
    m = M0 3 a^2 d / (4 R^3) = 0.0885900371 lb = 1.4174405941 oz; M = M0 - m = 14.9114099629 lb;
    the hole's centroid at z_c = R - d/2 = 3.0475 in, so the center of mass moves to
    z = -m z_c / M = -0.018105473515 in, top weight 2 M z / L = -1.3545569796 oz (L = 0.162 m);
    I_zz = (2/5) M0 R^2 - m a^2 / 2 (about the center, which the shift along z leaves unchanged),
    I_xx = (2/5) M0 R^2 - m (3 a^2 + d^2) / 12 - m z_c^2 - M z^2 (parallel axis twice), so
    RG_max = sqrt(I_zz / M) = 2.725903353205 in (the hole axis), RG_min = RG_int =
    sqrt(I_xx / M) = 2.715201991098 in, diff = 0.010701362107 in (undrilled: 2.717977648915)."""
    hole = place_hole(_centered_hole(), _R, "right")
    d = drill_holes(_UNIFORM, _LAYOUT, _PAP, [hole])
    assert d.shell_density_g_cm3 == pytest.approx(mean_density_g_cm3(15, 8.595), rel=1e-15)
    assert d.removed_oz == pytest.approx(1.4174405941, abs=1e-9)
    assert d.weight_lb == pytest.approx(14.9114099629, abs=1e-9)
    assert d.com_offset_m / 0.0254 == pytest.approx([0.0, 0.0, -0.018105473515], abs=1e-12)
    w = d.computed_weights
    assert (w.top_oz, w.side_oz, w.finger_oz) == pytest.approx((-1.3545569796, 0, 0), abs=1e-9)
    lo, mid, hi = d.rg_in
    assert hi == pytest.approx(2.725903353205, abs=1e-11)
    assert lo == pytest.approx(2.715201991098, abs=1e-11)
    assert mid == pytest.approx(lo, abs=1e-11)
    assert d.differential_in == pytest.approx(0.010701362107, abs=1e-11)
    assert abs(d.principal_axes[2][2]) == pytest.approx(1.0, abs=1e-12)  # high RG along the hole


@pytest.mark.parametrize(("over", "up"), [(2.0, 1.0), (-3.0, 2.5), (0.5, -4.0)])
def test_one_hole_anywhere_is_the_same_hole_rotated(over: float, up: float) -> None:
    """On a uniform sphere only the hole's direction changes: same mass, same |offset| opposite
    the hole, same RGs; the static weights are the offset's components."""
    hole = place_hole(_centered_hole(over, up), _R, "right")
    d = drill_holes(_UNIFORM, _LAYOUT, _PAP, [hole])
    assert d.removed_oz == pytest.approx(1.4174405941, abs=1e-9)
    assert d.com_offset_m / 0.0254 == pytest.approx(-0.018105473515 * hole.entry, abs=1e-12)
    assert d.rg_in == pytest.approx((2.715201991098, 2.715201991098, 2.725903353205), abs=1e-11)
    total = math.hypot(
        *(getattr(d.computed_weights, f) for f in ("top_oz", "side_oz", "finger_oz"))
    )
    assert total == pytest.approx(1.3545569796, abs=1e-9)


def test_pitch_tilts_the_axis_by_atan_pitch_over_radius_toward_the_named_side() -> None:
    entry = {"over_in": 0.0, "up_in": 2.0, "diameter_in": 0.875, "depth_in": 2.5}
    fwd = place_hole(ExtraHole(**entry, forward_pitch_in=0.5), _R, "right")
    radial = -fwd.entry
    assert math.acos(float(fwd.axis @ radial)) == pytest.approx(math.atan(0.5 / _R), abs=1e-14)
    assert fwd.axis[1] < radial[1]  # forward: the bottom leans toward the center of grip (below)
    for hand, sign in (("right", 1.0), ("left", -1.0)):
        lat = place_hole(ExtraHole(**entry, lateral_pitch_in=-0.25), _R, hand)  # type: ignore[arg-type]
        assert math.acos(float(lat.axis @ -lat.entry)) == pytest.approx(math.atan(0.25 / _R))
        assert sign * lat.axis[0] < 0.0  # away from the PAP side: x_g < 0 for a right-hander


# --- grip geometry -----------------------------------------------------------------------------
def _arc_in(a: np.ndarray, b: np.ndarray) -> float:
    return _R * math.acos(max(-1.0, min(1.0, float(a @ b))))


def _edge(diameter: float) -> float:
    return _R * math.asin(0.5 * diameter / _R)


def test_spans_and_bridge_are_edge_to_edge_and_the_grip_center_is_between_them() -> None:
    grip = _GRIP.model_copy(update={"ring_span_in": 4.25})
    holes = {h.name: h for h in place_holes(grip, _R, "right")}
    m, r, t = holes["middle"].entry, holes["ring"].entry, holes["thumb"].entry
    assert _arc_in(m, r) - 2 * _edge(0.875) == pytest.approx(0.25, abs=1e-12)
    assert _arc_in(m, t) - _edge(0.875) - _edge(1.0) == pytest.approx(4.0, abs=1e-12)
    assert _arc_in(r, t) - _edge(0.875) - _edge(1.0) == pytest.approx(4.25, abs=1e-12)
    assert m[0] < 0 < r[0] and m[1] > 0 and r[1] > 0 > t[1]  # middle left, ring right, thumb down
    # the center of grip (z_g) is the mean of the two spans' midpoints (near edges' midpoints)
    mids = [_along(f, t, _edge(0.875) + 0.5 * span) for f, span in ((m, 4.0), (r, 4.25))]
    center = mids[0] + mids[1]
    assert center / np.linalg.norm(center) == pytest.approx([0.0, 0.0, 1.0], abs=1e-15)


def _along(a: np.ndarray, b: np.ndarray, arc_in: float) -> np.ndarray:
    t = b - float(a @ b) * a
    return math.cos(arc_in / _R) * a + math.sin(arc_in / _R) * t / np.linalg.norm(t)


def test_thumbless_grip_center_is_the_bridge_center_or_the_marked_point_below_it() -> None:
    thumbless = GripDrilling(middle=_FINGER, ring=_FINGER, bridge_in=0.5)
    holes = place_holes(thumbless, _R, "right")
    coords = [c for h in holes for c in h.coords(_R, "right")]
    assert coords == pytest.approx(
        [-(0.25 + _edge(0.875)), 0.0, 0.25 + _edge(0.875), 0.0], abs=1e-12
    )
    lower = thumbless.model_copy(update={"thumbless_grip_center_down_in": 2.0})
    m, r = (h.entry for h in place_holes(lower, _R, "right"))
    bridge_center = (m + r) / np.linalg.norm(m + r)
    assert _arc_in(bridge_center, np.array([0.0, 0.0, 1.0])) == pytest.approx(2.0, abs=1e-12)
    assert bridge_center[0] == pytest.approx(0.0, abs=1e-15) and bridge_center[1] > 0


def test_bad_grips_are_rejected_with_the_reason() -> None:
    with pytest.raises(ValidationError, match="middle_span_in and ring_span_in are required"):
        GripDrilling(middle=_FINGER, ring=_FINGER, thumb=_FINGER, bridge_in=0.25)
    with pytest.raises(ValidationError, match="need a thumb hole"):
        GripDrilling(middle=_FINGER, ring=_FINGER, bridge_in=0.25, middle_span_in=4.0)
    with pytest.raises(ValueError, match="cannot both reach one thumb hole"):
        place_holes(_GRIP.model_copy(update={"ring_span_in": 1.0}), _R, "right")
    deep = _GRIP.model_copy(update={"thumb": HoleSpec(diameter_in=1.0, depth_in=8.59)})
    with pytest.raises(ValueError, match="hole 'thumb'.*past the ball's radius"):
        place_holes(deep, _R, "right")
    crowded = _GRIP.model_copy(update={"extra_holes": [_centered_hole(0.0, 2.4)]})
    with pytest.raises(ValueError, match="holes 'middle' and 'one' overlap"):
        place_holes(crowded, _R, "right")


# --- symmetry ----------------------------------------------------------------------------------
@pytest.mark.parametrize("ball", [_PEARL, _ASYM])
def test_a_grip_symmetric_about_the_vertical_midline_has_no_side_weight(ball: BowlerBall) -> None:
    grip = _GRIP.model_copy(
        update={
            "middle": _FINGER.model_copy(update={"lateral_pitch_in": -0.375}),
            "ring": _FINGER.model_copy(update={"lateral_pitch_in": 0.375}),
        }
    )
    cg = CenterOfMassMark(over_in=0.0, up_in=1.5, static_oz=3.0)
    d = drill_ball(ball, _LAYOUT, _PAP, grip, undrilled_cg=cg)
    assert d.computed_weights.side_oz == pytest.approx(0.0, abs=1e-12)
    assert d.com_offset_m[0] == pytest.approx(0.0, abs=1e-16)
    # the undrilled top weight (3 oz on the CG mark 1.5 in up) minus what the holes took
    assert d.undrilled_weights.top_oz == pytest.approx(3.0 * math.cos(1.5 / _R), rel=1e-12)
    assert d.computed_weights.top_oz < d.undrilled_weights.top_oz - 2.0


def test_a_left_handers_grip_is_the_mirror_and_keeps_the_pap_side_sign() -> None:
    """Unequal spans, an extra gripping hole on the PAP side and the CG mark over: the same
    numbers for a left-hander mirror the holes (x_g -> -x_g) and the center of mass, and the side
    weight (positive toward the PAP) keeps its value and sign."""
    grip = _GRIP.model_copy(
        update={
            "ring_span_in": 4.25,
            "extra_holes": [
                ExtraHole(name="pinky", diameter_in=0.625, depth_in=1.5, over_in=2.0, up_in=1.0)
            ],
        }
    )
    cg = CenterOfMassMark(over_in=1.0, up_in=0.5, static_oz=2.5)
    rh = drill_ball(_ASYM, _LAYOUT, _PAP, grip, undrilled_cg=cg)
    lh_pap = _PAP.model_copy(update={"handedness": "left"})
    lh = drill_ball(_ASYM, _LAYOUT, lh_pap, grip, undrilled_cg=cg)
    mirror = np.diag([-1.0, 1.0, 1.0])
    for a, b in zip(rh.placed, lh.placed, strict=True):
        assert b.entry == pytest.approx(mirror @ a.entry, abs=1e-15)
        assert b.axis == pytest.approx(mirror @ a.axis, abs=1e-15)
    assert lh.com_offset_m == pytest.approx(mirror @ rh.com_offset_m, abs=1e-18)
    assert rh.com_offset_m[0] != pytest.approx(0.0, abs=1e-6)
    for f in ("top_oz", "side_oz", "finger_oz"):
        assert getattr(lh.computed_weights, f) == pytest.approx(getattr(rh.computed_weights, f))
    assert lh.rg_in == pytest.approx(rh.rg_in, abs=1e-14)


# --- a typical grip ----------------------------------------------------------------------------
def test_typical_three_hole_grip_on_a_15_lb_ball_matches_the_rules_of_thumb() -> None:
    """Drilling removes a few ounces ("roughly 2.5 ounces", bowlingball.com [BBC-CG]), mostly
    from the top half (the CG's extra weight under the punch makes up for it [BBC-CG]), so the
    top weight drops by a few oz; RG and differential move by thousandths of an inch, within the
    "up to about +-5 %" USBC reports for drilling [RID]. The numbers are this model's (15 lb
    mean density); docs/drilling.md has the sources."""
    d = drill_ball(_PEARL, _LAYOUT, _PAP, _GRIP)
    assert d.removed_oz == pytest.approx(3.72964, abs=1e-5)
    assert d.computed_weights.top_oz == pytest.approx(-2.93059, abs=1e-5)
    assert d.computed_weights.side_oz == pytest.approx(0.0, abs=1e-12)
    assert d.computed_weights.finger_oz == pytest.approx(-0.32685, abs=1e-5)
    assert 2.0 < d.removed_oz < 5.0 and -4.0 < d.computed_weights.top_oz < -2.0
    assert d.rg_in[0] - _PEARL.rg_in == pytest.approx(0.00264, abs=1e-5)
    assert d.differential_in - _PEARL.differential_in == pytest.approx(0.00299, abs=1e-5)
    assert 0.001 < abs(d.rg_in[0] - _PEARL.rg_in) < 0.05 * _PEARL.rg_in
    # a symmetric core drilled this way gains an intermediate differential
    assert d.intermediate_differential_in == pytest.approx(0.01463, abs=1e-5)
    assert 0.1 < d.axis_moved_in("pin") < 1.0
    assert d.legality().is_legal


def test_drilled_ball_resolves_to_a_physical_ball_with_the_drilled_axes() -> None:
    d = drill_ball(_ASYM, _LAYOUT, _PAP, _GRIP)
    ball = d.to_ball(_PAP, (0.0, 1.0, 0.0))
    lo, mid, hi = (x * 0.0254 for x in d.rg_in)
    assert ball.rg_m == pytest.approx((lo, hi, mid), rel=1e-15)
    assert ball.mass_kg == d.mass_kg
    assert np.linalg.norm(ball.com_offset_m) == pytest.approx(np.linalg.norm(d.com_offset_m))
    # a spec-sheet undrilled ball resolved the same way keeps the pin-to-PAP distance
    pin = np.array(ball.axis_1)
    assert math.acos(float(pin @ [0.0, 1.0, 0.0])) * _R == pytest.approx(
        _arc_in(d.principal_axes[0], _PAP.point(_R))
    )


# --- precedence and legality -------------------------------------------------------------------
def test_measured_static_weights_win_over_the_computed_ones() -> None:
    d = drill_ball(_PEARL, _LAYOUT, _PAP, _GRIP)
    measured = StaticWeights(top_oz=0.5, side_oz=3.5)
    assert d.static_weights() == d.computed_weights
    assert d.static_weights(measured) == measured
    assert d.legality().is_legal
    report = d.legality("current", measured)
    assert report.rules_violated == ("side_weight",)
    ball = d.to_ball(_PAP, (0.0, 1.0, 0.0), measured=measured)
    k = 0.162 * (0.45359237 / 16) / (2 * d.mass_kg)
    assert np.linalg.norm(ball.com_offset_m) == pytest.approx(k * math.hypot(0.5, 3.5))


def test_hole_rules_name_the_field_the_value_and_the_limit() -> None:
    extra = [
        ExtraHole(name=f"x{i}", diameter_in=0.5, depth_in=1.0, over_in=-3.0, up_in=-2.0 + 1.2 * i)
        for i in range(3)
    ]
    many = drill_ball(_PEARL, _LAYOUT, _PAP, _GRIP.model_copy(update={"extra_holes": extra}))
    assert many.gripping_holes == 6
    report = many.legality()
    assert "gripping_holes" in report.rules_violated
    assert "gripping_holes: 6 holes (limit 5 holes, rule set 'current')" in str(report)
    weight = ExtraHole(
        name="weight", purpose="balance", diameter_in=1.5, depth_in=0.5, over_in=-4, up_in=-1
    )
    grip = _GRIP.model_copy(update={"extra_holes": [weight]})
    cg = CenterOfMassMark(over_in=0.0, up_in=0.0, static_oz=2.5)
    balanced = drill_ball(_PEARL, _LAYOUT, _PAP, grip, undrilled_cg=cg)
    assert balanced.legality("current").rules_violated == ("balance_hole",)
    assert "balance_hole: 1 holes (limit 0 holes" in str(balanced.legality("current"))
    paper = balanced.legality("paper_era")
    assert "balance_hole_diameter" in paper.rules_violated
    assert "balance_hole_diameter: 1.5 in (limit 1.25 in" in str(paper)


def test_check_legality_counts_holes() -> None:
    assert check_legality(_PEARL, gripping_holes=5).is_legal
    assert check_legality(_PEARL, gripping_holes=6).rules_violated == ("gripping_holes",)
    two = check_legality(_PEARL, "paper_era", balance_hole_diameters_in=(1.0, 1.0))
    assert two.rules_violated == ("balance_hole",)
    assert check_legality(_PEARL, "paper_era", balance_hole_diameters_in=(1.25,)).is_legal


def test_too_much_top_weight_after_drilling_is_illegal() -> None:
    """A 5 oz top-weight blank keeps more than 3 oz after a thumbless grip."""
    cg = CenterOfMassMark(over_in=0.0, up_in=0.0, static_oz=5.0)
    d = drill_ball(
        _PEARL,
        _LAYOUT,
        _PAP,
        GripDrilling(
            middle=_FINGER, ring=_FINGER, bridge_in=0.25, thumbless_grip_center_down_in=3.0
        ),
        undrilled_cg=cg,
    )
    assert d.computed_weights.top_oz > 3.0
    assert d.legality().rules_violated == ("top_bottom_weight",)


# --- the spec file -----------------------------------------------------------------------------
def test_drilling_spec_round_trips_and_accepts_a_2ls_layout() -> None:
    spec = DrillingSpec(
        ball=_ASYM,
        layout=TwoLS(pin_to_pap_in=5.0, psa_to_pap_in=4.0, pin_to_grip_center_in=3.5),
        pap=PAP(over_in=4.5, up_in=0.75),
        grip=GripDrilling(middle=_FINGER, ring=_FINGER, bridge_in=0.25),
        undrilled_cg=CenterOfMassMark(over_in=0.5, up_in=1.0, static_oz=3.0),
    )
    again = DrillingSpec.model_validate(json.loads(spec.model_dump_json()))
    assert again == spec
    d = spec.drill()
    assert d.gripping_holes == 2
    assert d.weight_lb < 15.0
    with pytest.raises(ValidationError, match="extra"):
        DrillingSpec.model_validate({**json.loads(spec.model_dump_json()), "holes": []})


# --- command line ------------------------------------------------------------------------------
def test_cli_drill_prints_the_drilled_ball_and_measured_weights_win(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from bowlrec.cli import app

    runner = CliRunner()
    example = runner.invoke(app, ["drill", "--example"])
    assert example.exit_code == 0, example.output
    spec = json.loads(example.output)
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    out = runner.invoke(app, ["drill", str(path), "--json"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.output)
    assert rep["removed_oz"] == pytest.approx(3.72964, abs=1e-5)
    assert rep["static_weights_oz"]["used"] == "computed"
    assert rep["legality"] == {"rule_set": "current", "legal": True, "violations": []}
    spec["measured_static_weights"] = {"top_oz": 1.0, "side_oz": -3.5}
    path.write_text(json.dumps(spec))
    text = runner.invoke(app, ["drill", str(path)])
    assert text.exit_code == 0, text.output
    assert "side -3.50 oz" in text.output and "(measured)" in text.output
    assert "side_weight: 3.5 oz (limit 3 oz" in text.output
    path.write_text(json.dumps({**spec, "grip": {**spec["grip"], "ring_span_in": 0.5}}))
    bad = runner.invoke(app, ["drill", str(path)])
    assert bad.exit_code == 2
    assert bad.output.count("\n") == 1 and "cannot both reach one thumb hole" in bad.output


def test_cli_layout_convert() -> None:
    from typer.testing import CliRunner

    from bowlrec.cli import app

    runner = CliRunner()
    args = [
        "layout",
        "convert",
        "dual_angle",
        "45",
        "4.5",
        "30",
        "--pap-over",
        "5",
        "--pap-up",
        "1",
    ]
    out = runner.invoke(app, [*args, "--diameter", str(27 / math.pi), "--json"])
    assert out.exit_code == 0, out.output
    rows = json.loads(out.output)
    assert rows["2ls"]["pin_to_grip_center_in"] == pytest.approx(4.391048900139, abs=1e-11)
    assert rows["vls"]["pin_buffer_in"] == pytest.approx(1.9244677849, abs=1e-2)
    text = runner.invoke(app, [*args, "--to", "2ls"])
    assert text.exit_code == 0 and text.output.startswith("2LS         4.500 x 3.918 x")
    bad = runner.invoke(
        app,
        [
            "layout",
            "convert",
            "2ls",
            "3.5",
            "4",
            "6.5",
            "--to",
            "vls",
            "--pap-over",
            "5",
            "--pap-up",
            "1",
        ],
    )
    assert bad.exit_code == 2 and bad.output.count("\n") == 1
    assert "far side of the VAL" in bad.output


# --- the drilled ball in a bowler scene --------------------------------------------------------
def _drilled_scene(**extra: object) -> BowlerScene:
    return BowlerScene.model_validate(
        {
            "ball": _ASYM.model_dump(),
            "layout": _LAYOUT.model_dump(),
            "pap": _PAP.model_dump(),
            "drilling": _GRIP.model_dump(),
            "undrilled_cg": {"over_in": 0.0, "up_in": 0.0, "static_oz": 3.0},
            "options": {"record": "summary"},
            **extra,
        }
    )


def test_a_bowler_scene_with_drilling_simulates_the_drilled_ball() -> None:
    scene = _drilled_scene()
    drilled = scene.drilled()
    assert drilled is not None
    physical = scene.to_scene()
    assert physical.ball.mass_kg == pytest.approx(drilled.mass_kg, rel=1e-15)
    assert physical.ball.mass_kg < _ASYM.mass_kg  # the holes took weight out
    lo, mid, hi = (x * 0.0254 for x in drilled.rg_in)
    assert physical.ball.rg_m == pytest.approx((lo, hi, mid), rel=1e-15)
    # the computed static weights set the offset: |offset| = L dm / (2 M) of their resultant
    w = drilled.static_weights()
    dm = math.sqrt(w.top_oz**2 + w.side_oz**2 + w.finger_oz**2) * 0.45359237 / 16
    expected = 0.162 * dm / (2 * drilled.mass_kg)
    assert float(np.linalg.norm(physical.ball.com_offset_m)) == pytest.approx(expected, rel=1e-9)
    assert bowlrec.simulate(physical).summary.outcome == "pins"


def test_measured_static_weights_win_in_a_bowler_scene() -> None:
    measured = {"top_oz": 1.0, "side_oz": 0.5, "finger_oz": 0.0}
    scene = _drilled_scene(balance=measured)
    drilled = scene.drilled()
    assert drilled is not None
    offset = float(np.linalg.norm(scene.to_scene().ball.com_offset_m))
    dm = math.sqrt(1.0 + 0.25) * 0.45359237 / 16
    assert offset == pytest.approx(0.162 * dm / (2 * drilled.mass_kg), rel=1e-9)


def test_a_sixth_gripping_hole_is_illegal_in_a_bowler_scene() -> None:
    extra = [
        {"name": f"x{i}", "diameter_in": 0.5, "depth_in": 1.0, "over_in": 2.0 + i, "up_in": -2.0}
        for i in range(3)
    ]
    grip = {**_GRIP.model_dump(), "extra_holes": extra}
    scene = _drilled_scene(drilling=grip)
    assert not scene.legality().is_legal
    with pytest.raises(IllegalBallError, match="gripping_holes"):
        scene.to_scene()

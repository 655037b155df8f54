"""The calibration of the bowlers' layer: the data file's facts are sourced, the page and the
package's default levels are the committed fit's, the rolling angle is the kernel's, and the
calibration's lines do what they say."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from bowlrec.bowling import calibration as cal
from bowlrec.bowling.aim import BREAKPOINT_TOL, aim
from bowlrec.bowling.delivery import BowlerDelivery
from bowlrec.bowling.friction_levels import PAPER, calibrated
from bowlrec.bowling.oil_friction import OilFrictionMapping
from bowlrec.bowling.pocket import POCKET
from bowlrec.bowling.scene import BowlerScene, Shot
from bowlrec.errors import AimError

ROOT = Path(__file__).resolve().parents[1]
RESULTS = json.loads((ROOT / "benchmarks" / "results" / "calibration.json").read_text())


def test_every_fact_names_its_source_and_the_line_relied_on() -> None:
    facts = cal.load_observables()
    assert len(facts) >= 40
    assert len({f.id for f in facts}) == len(facts)
    for f in facts:
        assert f.publisher and f.title and f.quote.strip(), f.id
        assert f.address.startswith(("http://", "https://", "doi:")), f.id
        assert f.kind in {"measurement", "rule_of_thumb", "definition", "range"}, f.id
        assert f.looseness, f.id
        for c in f.compare:
            assert c.low is not None or c.high is not None, f.id
            if c.low is not None and c.high is not None:
                assert c.low < c.high, f.id
    roles = {c.role for f in facts for c in f.compare}
    assert roles == {"fit", "held_out"}


def test_the_fit_never_sees_the_held_out_patterns() -> None:
    for _, c in cal.comparisons(cal.load_observables(), "fit"):
        assert not set(c.patterns) & set(cal.HELD_OUT_PATTERNS)


def test_the_default_levels_are_the_committed_fit() -> None:
    fit = RESULTS["fit"]["default"]
    levels = calibrated()
    assert (levels.mu_oil, levels.mu_dry) == (fit["mu_oil"], fit["mu_dry"])
    assert levels.oiled_at_or_above_um == fit["ramp_um"]
    # the default is the best point at the thickest film the fit's interval allows
    assert fit["ramp_um"] == RESULTS["fit"]["ramp_um_interval"][1]
    assert levels.mu_oil_interval[0] <= levels.mu_oil <= levels.mu_oil_interval[1]
    assert levels.mu_dry_interval[0] <= levels.mu_dry <= levels.mu_dry_interval[1]
    m = OilFrictionMapping()
    assert (m.mu_oil, m.mu_dry) == (levels.mu_oil, levels.mu_dry)
    assert BowlerScene().oil_friction == m
    # the page shows the same numbers
    page = (ROOT / "docs" / "calibration.md").read_text()
    assert f"**{fit['mu_oil']:.4g}**" in page and f"**{fit['mu_dry']:.3g}**" in page


def test_a_bowler_scene_can_ask_for_the_papers_levels() -> None:
    paper = BowlerScene(oil_friction="paper").oil_friction
    assert (paper.mu_oil, paper.mu_dry) == (PAPER.mu_oil, PAPER.mu_dry) == (0.04, 0.20)
    lane = BowlerScene(oil_friction="paper").physical_lane()
    mus = {v for row in lane.friction.mu for v in row}  # type: ignore[union-attr]
    # the default ball (pearl at 1500 grit) scales both levels by its factors
    oil, dry = OilFrictionMapping.paper().levels("reactive_pearl", 1500)
    assert mus == {oil, dry}
    with pytest.raises(ValueError, match="oil_friction = 'papr'"):
        BowlerScene.model_validate({"oil_friction": "papr"})


@pytest.mark.parametrize(
    ("value", "low", "high", "z"),
    [(5.0, 4.0, 6.0, 0.0), (7.0, 4.0, 6.0, 2.0), (3.0, 4.0, 6.0, -2.0), (-1.0, None, 0.0, 0.0),
     (2.5, None, 0.0, 2.5), (-0.5, 0.0, None, -0.5), (3.0, 0.0, None, 0.0)],
)  # fmt: skip
def test_z_is_the_distance_in_the_facts_own_looseness(
    value: float, low: float | None, high: float | None, z: float
) -> None:
    assert cal.z_score(value, low, high) == pytest.approx(z)


@pytest.mark.parametrize("style", ["stroker", "cranker"])
def test_the_rolling_angle_is_the_kernels_for_an_isotropic_ball(style: str) -> None:
    """An isotropic ball without mass offset or air drag, rolling before the pins, enters at
    exactly the angle conserved angular momentum about the contact point gives (to rounding:
    the kernel integrates the slide and the closed form knows only the release)."""
    ball = {
        **BowlerScene().ball.model_dump(),
        "differential_in": 0.0,
        "coverstock": "reactive_solid",
        "surface": 1000,
    }
    scene = BowlerScene.model_validate(
        {
            "ball": ball,
            "pattern": "house_shot_approx",
            "oil_friction": {"mu_oil": 0.01, "mu_dry": 0.4},
            "delivery": {"style": style, "laydown_board": 25.0, "launch_angle_deg": -2.5},
        }
    )
    from bowlrec.bowling.aim import evaluate

    shot = Shot(scene)
    r = evaluate(shot, scene.delivery)
    assert r.report.slide_ft is not None and r.report.slide_ft < 59.0  # rolls before the pins
    expected = cal.rolling_angle_deg(scene, scene.delivery, -2.5)
    assert r.report.entry_angle_deg == pytest.approx(expected, abs=1e-9)
    # with a differential the angle moves only by hundredths of a degree
    ball = scene.ball.model_copy(update={"differential_in": 0.05})
    r2 = evaluate(Shot(scene.model_copy(update={"ball": ball})), scene.delivery)
    assert r2.report.entry_angle_deg is not None
    assert abs(r2.report.entry_angle_deg - expected) < 0.2


def test_a_style_fills_only_what_the_delivery_does_not_give() -> None:
    d = BowlerDelivery.model_validate({"style": "two-handed", "speed_mph": 16.0})
    assert (d.speed_mph, d.rev_rate_rpm, d.axis_tilt_deg) == (16.0, 500.0, 8.0)
    plain = BowlerDelivery()
    assert plain.style is None and plain.rev_rate_rpm == 300.0
    with pytest.raises(ValueError, match="style"):
        BowlerDelivery.model_validate({"style": "power"})


def test_aim_places_the_breakpoint_on_the_rule_of_31_board() -> None:
    case = cal.Case("tweener", "house_shot_approx")
    scene = cal.case_scene(case, OilFrictionMapping())
    board = cal.breakpoint_board_for(40.0)
    assert board == 8.0
    result = aim(scene, ("laydown", "launch"), POCKET, breakpoint_board=board)
    assert result.found, result.message
    assert abs(result.shot.breakpoint_board - board) <= BREAKPOINT_TOL
    assert POCKET.board_ok(result.shot.entry_board)
    assert "breakpoint on board" in result.message


def test_a_breakpoint_needs_two_free_variables() -> None:
    with pytest.raises(AimError, match="free two variables"):
        aim(BowlerScene(), ("target",), breakpoint_board=9.0)
    with pytest.raises(AimError, match="between 0 and 39"):
        aim(BowlerScene(), ("laydown", "target"), breakpoint_board=45.0)


def test_pattern_lengths_and_the_rule_of_31() -> None:
    from bowlrec.bowling.oil import preset

    assert cal.pattern_length_ft(preset("house_shot_approx")) == 40.0
    assert cal.pattern_length_ft(preset("kegel_big_ben")) == 44.0
    assert cal.breakpoint_board_for(36.0) == 4.0
    assert cal.breakpoint_board_for(20.0) == 1.0  # kept on the lane


def test_the_committed_results_score_what_the_facts_say() -> None:
    """Every committed comparison's z's follow from its values and the fact's range."""
    by_id = {f.id: f for f in cal.load_observables()}
    for which in ("calibrated", "paper"):
        for row in RESULTS[which]["comparisons"]:
            assert row["id"] in by_id
            zs = [
                cal.z_score(v, row["low"], row["high"]) for _, v in row["values"] if v is not None
            ]
            assert zs == pytest.approx(row["zs"])
            assert row["within"] == sum(abs(z) <= 1.0 for z in zs)
    assert not math.isnan(RESULTS["fit"]["objective"])


def test_runs_of_an_older_bowler_layer_are_flagged() -> None:
    from bowlrec.provenance import bowler_layer_warning
    from bowlrec.versions import BOWLER_LAYER_VERSION

    assert BOWLER_LAYER_VERSION == 3
    assert bowler_layer_warning({"bowler_layer_version": "3"}) is None
    two = bowler_layer_warning({"bowler_layer_version": "2"})
    assert two is not None and "calibrated" in two and "PAP" not in two
    one = bowler_layer_warning({})
    assert one is not None and "PAP" in one and "calibrated" in one


@pytest.mark.parametrize(
    ("style", "pattern"),
    [("tweener", "house_shot_approx"), ("cranker", "sport_medium_41ft_approx"),
     ("two-handed", "sport_long_45ft_approx"), ("stroker", "kegel_stonehenge")],
)  # fmt: skip
def test_the_pages_lines_are_what_the_code_gives(style: str, pattern: str) -> None:
    """docs/calibration.md's lines table, rerun at the default levels: the same line, the same
    breakpoint and entry (the committed results are not stale)."""
    case = cal.Case(style, pattern)
    fresh = cal.run_case(case, OilFrictionMapping())
    committed = next(r for r in RESULTS["calibrated"]["lines"] if r["case"] == case.label())
    for key in ("found", "laydown_board", "launch_angle_deg", "breakpoint_board"):
        assert getattr(fresh, key) == pytest.approx(committed[key], abs=1e-9), key
    assert fresh.entry_angle_deg == pytest.approx(committed["entry_angle_deg"], abs=1e-9)
    if fresh.found:  # a found line breaks on the rule-of-31 board, to the search's tolerance
        assert abs(fresh.breakpoint_board - cal.breakpoint_board_for(fresh.length_ft)) <= 0.1


def test_a_hook_bowlers_house_line_in_cliftons_zone_enters_the_pocket() -> None:
    """A line breaking on board 5 at about 40 ft (Clifton's best-carry zone on a house shot)
    enters the pocket window for a tweener, as the house-shot example does."""
    scene = cal.case_scene(cal.Case("tweener", "house_shot_approx"), OilFrictionMapping())
    scene = scene.model_copy(
        update={
            "ball": scene.ball.model_copy(update={"coverstock": "reactive_pearl", "surface": 1500})
        }
    )
    result = aim(scene, ("laydown", "launch"), POCKET, breakpoint_board=5.0)
    shot = result.shot
    assert result.found, result.message
    assert POCKET.contains(shot.entry_board, shot.entry_angle_deg), result.message
    assert 35.0 <= shot.breakpoint_ft <= 45.0  # "40 feet or so down the lane"

"""Ball spec sheets, markings, static weights and USBC legality (bowling.ball, bowling.legality)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from pydantic import ValidationError

from bowlrec.bowling.ball import (
    FROHLICH_LEVER_ARM_M,
    BowlerBall,
    CenterOfMassMark,
    Marking,
    StaticWeights,
    grip_point,
    grip_point_coords,
    spec_from_moments,
)
from bowlrec.bowling.layout import load_example_library
from bowlrec.bowling.legality import (
    RULE_SETS,
    IllegalBallError,
    check_legality,
    ensure_legal,
)
from bowlrec.spec import Ball
from bowlrec.units import IN_M, LB_KG, OZ_KG

_BASE: dict[str, Any] = {
    "name": "Test",
    "weight_lb": 15,
    "rg_in": 2.5,
    "differential_in": 0.05,
    "coverstock": "reactive_pearl",
}


def _ball(**update: Any) -> BowlerBall:
    return BowlerBall(**{**_BASE, **update})


def _error(**update: Any) -> str:
    with pytest.raises(ValidationError) as info:
        _ball(**update)
    return str(info.value)


# --- spec sheet -> physics -------------------------------------------------------------------
def test_principal_moments_follow_the_spec_sheet_formulas() -> None:
    b = _ball(intermediate_differential_in=0.02, core_type="asymmetric")
    m = 15 * LB_KG
    i_min, i_int, i_max = b.principal_moments_kg_m2
    assert i_min == pytest.approx(m * (2.5 * IN_M) ** 2, rel=1e-15)
    assert i_max == pytest.approx(m * (2.55 * IN_M) ** 2, rel=1e-15)
    assert i_int == pytest.approx(m * (2.53 * IN_M) ** 2, rel=1e-15)
    assert b.rg_m == pytest.approx((2.5 * IN_M, 2.55 * IN_M, 2.53 * IN_M), rel=1e-15)
    assert b.diff_ratio == pytest.approx(0.4)
    # the domain notes' worked example: I_min = 0.0274 kg m^2, I_max / I_min = 1.040
    sym = _ball()
    assert sym.principal_moments_kg_m2[0] == pytest.approx(0.0274, abs=5e-5)
    assert sym.principal_moments_kg_m2[2] / sym.principal_moments_kg_m2[0] == pytest.approx(
        1.0404, abs=1e-12
    )


@pytest.mark.parametrize(
    ("rg", "diff", "idiff"),
    [(2.5, 0.05, 0.0), (2.46, 0.06, 0.03), (2.8, 0.0, 0.0), (2.53, 0.048, 0.02)],
)
def test_moments_round_trip_to_the_spec_sheet(rg: float, diff: float, idiff: float) -> None:
    core = "asymmetric" if idiff > 0 else "symmetric"
    b = _ball(rg_in=rg, differential_in=diff, intermediate_differential_in=idiff, core_type=core)
    back = spec_from_moments(b.mass_kg, *b.principal_moments_kg_m2)
    assert back == pytest.approx((rg, diff, idiff), abs=1e-12)


def test_legal_balls_satisfy_the_triangle_inequality_with_a_wide_margin() -> None:
    """Most anisotropic legal ball (RG 2.46, diff 0.060): I_max / (I_min + I_int) ~ 0.52."""
    b = _ball(rg_in=2.46, differential_in=0.06, intermediate_differential_in=0.06,
              core_type="asymmetric")  # fmt: skip
    i_min, i_int, i_max = b.principal_moments_kg_m2
    assert i_max / (i_min + i_int) < 0.53
    Ball(mass_kg=b.mass_kg, radius_m=b.radius_m, rg_m=b.rg_m, axis_2=(0.0, 1.0, 0.0))


@pytest.mark.parametrize(
    ("update", "expected"),
    [
        ({"intermediate_differential_in": 0.01}, ["must be 0 for core_type = 'symmetric'", "0.01"]),
        ({"core_type": "asymmetric"}, ["must be > 0 for core_type = 'asymmetric'"]),
        (
            {"core_type": "asymmetric", "intermediate_differential_in": 0.06},
            ["intermediate_differential_in = 0.06", "<= differential_in = 0.05"],
        ),
        ({"differential_in": 1.2}, ["differential_in = 1.2", "sqrt(2) - 1", "I_max > I_min"]),
        ({"rg_in": 4.3}, ["rg_in + differential_in = 4.35", "4.2975"]),
        ({"surface": 0}, ["surface = 0", "grit number > 0"]),
        ({"weight_lb": -1}, ["weight_lb", "greater than 0"]),
        ({"coverstock": "rubber"}, ["coverstock", "polyester", "particle"]),
    ],
)  # fmt: skip
def test_invalid_specs_name_field_value_and_range(
    update: dict[str, Any], expected: list[str]
) -> None:
    text = _error(**update)
    for piece in expected:
        assert piece in text


def test_markings_and_spec_sheet() -> None:
    assert _ball().markings == (Marking.PIN, Marking.CG)
    asym = _ball(core_type="asymmetric", intermediate_differential_in=0.02, surface=2000)
    assert asym.markings == (Marking.PIN, Marking.CG, Marking.PSA)
    sheet = asym.spec_sheet()
    for piece in ("RG              2.500 in", "Int. diff (MB)  0.020 in", "2000 grit"):
        assert piece in sheet
    assert "Int. diff" not in _ball().spec_sheet()


# --- grip frame and static weights -----------------------------------------------------------
def test_grip_point_round_trip_and_mirror() -> None:
    r = 4.2975
    for over, up in [(4.5, 1.25), (5.25, -0.5), (0.3, 2.0), (6.0, 0.0)]:
        p_r = grip_point(over, up, r, "right")
        p_l = grip_point(over, up, r, "left")
        assert np.linalg.norm(p_r) == pytest.approx(1.0, abs=1e-15)
        assert p_l == pytest.approx(p_r * np.array([-1.0, 1.0, 1.0]), abs=0.0)
        assert p_r[0] > 0  # a right-hander's "over" is to the viewer's right
        for hand, p in (("right", p_r), ("left", p_l)):
            assert grip_point_coords(p, r, hand) == pytest.approx((over, up), abs=1e-12)  # type: ignore[arg-type]
        # "up" is the arc distance to the horizontal midline great circle (z_g-x_g plane)
        assert math.asin(p_r[1]) * r == pytest.approx(up, abs=1e-12)


def test_balance_scale_model_reproduces_frohlich_one_millimetre() -> None:
    """Fig. 3: component = L dm / (2 M); 3 oz on a 16 lb ball is Frohlich's "1 mm or less"."""
    m16 = 16 * LB_KG
    off = StaticWeights(top_oz=3.0).com_offset_grip_m(m16, "right")
    expected = FROHLICH_LEVER_ARM_M * 3 * OZ_KG / (2 * m16)
    assert off == pytest.approx([0.0, 0.0, expected], abs=1e-18)
    assert expected == pytest.approx(0.000949, abs=5e-7)
    assert expected <= 0.001
    one_oz = StaticWeights(side_oz=1.0).com_offset_grip_m(m16, "right")
    assert np.linalg.norm(one_oz) == pytest.approx(0.0003164, abs=5e-8)


def test_static_weight_directions_and_handedness() -> None:
    m = 15 * LB_KG
    k = FROHLICH_LEVER_ARM_M * OZ_KG / (2 * m)
    w = StaticWeights(top_oz=2.0, side_oz=1.0, finger_oz=-0.5)  # top, positive side, thumb
    right = w.com_offset_grip_m(m, "right")
    left = w.com_offset_grip_m(m, "left")
    assert right == pytest.approx([k, -0.5 * k, 2 * k], rel=1e-15)
    assert left == pytest.approx([-k, -0.5 * k, 2 * k], rel=1e-15)
    # positive side weight is on the PAP side: the PAP is at +h x_g
    for hand, off in (("right", right), ("left", left)):
        pap = grip_point(4.5, 0.0, 4.2975, hand)  # type: ignore[arg-type]
        assert float(pap @ (off - np.array([0.0, off[1], off[2]]))) > 0


def test_static_weights_round_trip_from_the_offset() -> None:
    m = 14 * LB_KG
    for hand in ("right", "left"):
        w = StaticWeights(top_oz=2.5, side_oz=-0.75, finger_oz=1.0)
        back = StaticWeights.from_com_offset_grip(w.com_offset_grip_m(m, hand), m, hand)  # type: ignore[arg-type]
        assert (back.top_oz, back.side_oz, back.finger_oz) == pytest.approx(
            (2.5, -0.75, 1.0), abs=1e-12
        )


def test_center_of_mass_mark_matches_static_weights() -> None:
    m, r = 15 * LB_KG, 4.2975
    mark = CenterOfMassMark(over_in=0.0, up_in=0.0, static_oz=2.0)  # at the center of grip
    assert mark.as_static_weights(m, r, "right").top_oz == pytest.approx(2.0, abs=1e-12)
    side = CenterOfMassMark(over_in=r * math.pi / 2, up_in=0.0, static_oz=1.5)  # 90 deg over
    w = side.as_static_weights(m, r, "left")
    assert (w.top_oz, w.side_oz, w.finger_oz) == pytest.approx((0.0, 1.5, 0.0), abs=1e-12)


# --- legality --------------------------------------------------------------------------------
_LEGAL = {"weight_lb": 15, "rg_in": 2.5, "differential_in": 0.05}

_RULE_CASES = [
    # rule set, rule, legal update, illegal update
    ("current", "weight_max", {"weight_lb": 16.0}, {"weight_lb": 16.01}),
    ("current", "diameter_min", {"diameter_in": 8.5}, {"diameter_in": 8.499}),
    ("current", "diameter_max", {"diameter_in": 8.595}, {"diameter_in": 8.596}),
    ("current", "rg_min", {"rg_in": 2.46}, {"rg_in": 2.459}),
    ("current", "rg_max", {"rg_in": 2.74, "differential_in": 0.06},
     {"rg_in": 2.75, "differential_in": 0.051}),
    ("current", "differential_max", {"differential_in": 0.06}, {"differential_in": 0.061}),
    ("paper_era", "weight_max", {"weight_lb": 16.0}, {"weight_lb": 16.5}),
    ("paper_era", "diameter_min", {"diameter_in": 8.5}, {"diameter_in": 8.49}),
    ("paper_era", "diameter_max", {"diameter_in": 8.595}, {"diameter_in": 8.6}),
    ("paper_era", "rg_min", {"rg_in": 2.43}, {"rg_in": 2.429}),
    ("paper_era", "rg_max", {"rg_in": 2.72, "differential_in": 0.08},
     {"rg_in": 2.73, "differential_in": 0.08}),
    ("paper_era", "differential_max", {"differential_in": 0.08}, {"differential_in": 0.081}),
]  # fmt: skip


@pytest.mark.parametrize(("rules", "rule", "legal", "illegal"), _RULE_CASES)
def test_each_ball_rule_on_both_sides_of_its_limit(
    rules: str, rule: str, legal: dict[str, float], illegal: dict[str, float]
) -> None:
    ok = check_legality(_ball(**{**_LEGAL, **legal}), rules)  # type: ignore[arg-type]
    assert ok.is_legal, str(ok)
    bad = check_legality(_ball(**{**_LEGAL, **illegal}), rules)  # type: ignore[arg-type]
    assert not bad.is_legal
    assert bad.rules_violated == (rule,)
    v = bad.violations[0]
    assert v.rule_set == rules
    assert rule in str(bad) and rules in str(bad)


_STATIC_CASES = [
    ("current", "top_bottom_weight", "top_oz", 3.0, 3.01),
    ("current", "top_bottom_weight", "top_oz", -3.0, -3.01),  # bottom weight
    ("current", "side_weight", "side_oz", 3.0, 3.01),
    ("current", "side_weight", "side_oz", -3.0, -3.01),
    ("current", "finger_thumb_weight", "finger_oz", 3.0, 3.01),
    ("current", "finger_thumb_weight", "finger_oz", -3.0, -3.01),  # thumb weight
    ("paper_era", "top_bottom_weight", "top_oz", 3.0, 3.01),
    ("paper_era", "side_weight", "side_oz", 1.0, 1.01),
    ("paper_era", "finger_thumb_weight", "finger_oz", -1.0, -1.01),
]


@pytest.mark.parametrize(("rules", "rule", "field", "legal", "illegal"), _STATIC_CASES)
def test_each_static_weight_rule_on_both_sides_of_its_limit(
    rules: str, rule: str, field: str, legal: float, illegal: float
) -> None:
    ball = _ball(**_LEGAL)
    ok = check_legality(ball, rules, static_weights=StaticWeights(**{field: legal}))  # type: ignore[arg-type]
    assert ok.is_legal, str(ok)
    bad = check_legality(ball, rules, static_weights=StaticWeights(**{field: illegal}))  # type: ignore[arg-type]
    assert bad.rules_violated == (rule,)
    assert bad.violations[0].value == pytest.approx(abs(illegal))


def test_side_weight_of_two_ounces_is_legal_now_but_not_in_the_paper_era() -> None:
    ball, w = _ball(**_LEGAL), StaticWeights(side_oz=2.0)
    assert check_legality(ball, "current", static_weights=w).is_legal
    assert check_legality(ball, "paper_era", static_weights=w).rules_violated == ("side_weight",)


def test_balance_hole_and_light_balls() -> None:
    ball = _ball(**_LEGAL)
    assert check_legality(ball, "current", balance_hole=True).rules_violated == ("balance_hole",)
    assert check_legality(ball, "paper_era", balance_hole=True).is_legal
    light = _ball(weight_lb=10, rg_in=2.5, differential_in=0.05)  # static limits: > 10 lb only
    assert check_legality(light, static_weights=StaticWeights(side_oz=5.0)).is_legal


def test_ensure_legal_raises_unless_allowed() -> None:
    bad = _ball(rg_in=2.44, differential_in=0.07)  # the paper era's ball, illegal today
    with pytest.raises(IllegalBallError) as info:
        ensure_legal(bad)
    text = str(info.value)
    for piece in ("rg_min", "2.44", "2.46", "differential_max", "0.07", "current", "allow_illegal"):
        assert piece in text
    assert (info.value.ball_name, info.value.rule_set) == (bad.name, "current")
    assert [v.split()[0] for v in info.value.violations] == ["rg_min", "differential_max"]
    report = ensure_legal(bad, allow_illegal=True)
    assert not report.is_legal
    assert ensure_legal(bad, "paper_era").is_legal
    with pytest.raises(ValueError, match="must be one of"):
        check_legality(bad, "1990")  # type: ignore[arg-type]


def test_rule_sets_hold_the_sourced_limits() -> None:
    cur, old = RULE_SETS["current"], RULE_SETS["paper_era"]
    assert (cur.rg_min_in, cur.rg_max_in, cur.differential_max_in) == (2.46, 2.8, 0.06)
    assert (old.rg_min_in, old.rg_max_in, old.differential_max_in) == (2.43, 2.8, 0.08)
    assert (cur.side_max_oz, old.side_max_oz, cur.top_bottom_max_oz) == (3.0, 1.0, 3.0)


# --- the example library ---------------------------------------------------------------------
def test_example_library_loads_with_sources_and_expected_legality() -> None:
    lib = load_example_library()
    for kind in (lib.balls, lib.layouts, lib.paps, lib.static_weights):
        assert kind
        for e in kind:
            assert e.source.strip()
    for e in lib.balls:
        report = check_legality(e.ball, "current")
        if e.id.startswith("frohlich-2004"):
            assert not report.is_legal
            assert check_legality(e.ball, "paper_era").is_legal
        else:
            assert report.is_legal, str(report)
    road = lib.ball("storm-the-road-15lb")
    assert (road.rg_in, road.differential_in, road.intermediate_differential_in) == (
        2.55,
        0.045,
        0.0,
    )
    paper = lib.ball("frohlich-2004-high-rg-nonscalar")
    assert paper.rg_m[0] == pytest.approx(0.069, abs=1e-15)
    assert paper.rg_m[1] == pytest.approx(0.071, abs=1e-15)
    assert paper.radius_m == pytest.approx(0.1085, abs=1e-15)
    assert paper.mass_kg == pytest.approx(6.8, abs=1e-12)
    with pytest.raises(KeyError, match="known"):
        lib.ball("nope")

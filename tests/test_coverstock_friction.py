"""Coverstock and surface grit -> friction: the sourced ranking in the factors, the reference
ball's exact paper levels, user overrides, bad input, and the physics the factors cause
(docs/coverstock.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import ValidationError

import bowlrec
from bowlrec.archive.run_id import run_id
from bowlrec.bowling.oil import preset
from bowlrec.bowling.oil_friction import OilFrictionMapping, mu_of_film, pattern_friction
from bowlrec.bowling.report import bowler_report
from bowlrec.bowling.scene import BowlerScene
from bowlrec.bowling.surface import (
    COVER_FACTORS,
    COVERSTOCKS,
    DRY_RANKING,
    GRIT_EXPONENT_DRY,
    GRIT_EXPONENT_OIL,
    GRIT_MAX,
    GRIT_MIN,
    OIL_RANKING,
    POLISHED_DRY,
    POLISHED_OIL,
    REFERENCE_COVERSTOCK,
    REFERENCE_GRIT,
    Coverstock,
    FactorRange,
    Surface,
    check_surface,
)
from bowlrec.errors import SceneInputError
from bowlrec.scene_input import parse_scene
from bowlrec.spec import format_validation_error
from bowlrec.units import IN_M
from tools.readme_blocks import read_block

ROOT = Path(__file__).resolve().parents[1]
W415 = 41.5 * IN_M
REACTIVES: tuple[Coverstock, ...] = ("reactive_solid", "reactive_pearl", "reactive_hybrid")


def _scene(coverstock: Coverstock, surface: Surface, **mapping: Any) -> BowlerScene:
    """The default bowler scene with another ball cover / surface, at the paper's levels (and
    mapping fields): the cover and surface mechanism, written in the paper's numbers."""
    base = BowlerScene()
    ball = {**base.ball.model_dump(), "coverstock": coverstock, "surface": surface}
    levels = OilFrictionMapping.paper(**mapping).model_dump()
    return BowlerScene.model_validate({**base.model_dump(), "ball": ball, "oil_friction": levels})


def _report(scene: BowlerScene) -> Any:
    traj = bowlrec.simulate(scene.to_scene())
    return bowler_report(traj, scene.lane, scene.delivery.handedness)


# --- the reference ball and the paper's levels ------------------------------------------------


def test_the_reference_ball_sees_the_papers_levels_exactly() -> None:
    m = OilFrictionMapping.paper()
    assert (REFERENCE_COVERSTOCK, REFERENCE_GRIT) == ("reactive_solid", 1000)
    assert m.cover_factors(REFERENCE_COVERSTOCK) == (1.0, 1.0)
    assert m.surface_factors(REFERENCE_GRIT) == (1.0, 1.0)
    assert m.levels(REFERENCE_COVERSTOCK, REFERENCE_GRIT) == (0.20, 0.04)
    assert m.levels() == m.levels(None, None) == (0.20, 0.04)  # no ball given: no factor
    # its friction grid on the paper's typical pattern is the one without any ball, bit for bit
    p = preset("paper_typical")
    a = pattern_friction(p, lane_width_m=W415, coverstock="reactive_solid", surface=1000, mapping=m)
    b = pattern_friction(p, lane_width_m=W415, mapping=m)
    assert a.mu == b.mu and a.x_edges_m == b.x_edges_m and a.y_edges_m == b.y_edges_m
    assert {v for row in a.mu for v in row} == {0.04, 0.2}
    # the calibrated default treats the reference ball the same way: its own levels, exactly
    c = OilFrictionMapping()
    assert c.levels(REFERENCE_COVERSTOCK, REFERENCE_GRIT) == (c.mu_dry, c.mu_oil)


def test_cover_model_none_is_the_same_friction_for_every_ball() -> None:
    """'none' (no explicit entries) gives every coverstock and surface the mapping's levels:
    the friction grid of a ball-less call, exactly."""
    none = OilFrictionMapping.paper(cover_model="none")
    p = preset("kegel_chromium_6742")
    plain = pattern_friction(p, lane_width_m=W415, mapping=OilFrictionMapping.paper()).mu
    for cover in COVERSTOCKS:
        for surface in (500, 4000, "polished"):
            assert none.levels(cover, surface) == (0.20, 0.04)  # type: ignore[arg-type]
            f = pattern_friction(
                p,
                lane_width_m=W415,
                coverstock=cover,  # type: ignore[arg-type]
                surface=surface,
                mapping=none,
            )
            assert f.mu == plain


# --- the sourced ranking ------------------------------------------------------------------------


def _assumed(level: str) -> dict[str, float]:
    m = OilFrictionMapping()
    i = 0 if level == "dry" else 1
    return {c: m.cover_factors(c)[i] for c in COVERSTOCKS}  # type: ignore[arg-type]


@pytest.mark.parametrize(("level", "ranking"), [("oil", OIL_RANKING), ("dry", DRY_RANKING)])
def test_the_factors_follow_the_sourced_ranking(level: str, ranking: tuple[str, ...]) -> None:
    """Strictly decreasing along the ranking (most traction first), for every coverstock."""
    assert sorted(ranking) == sorted(COVERSTOCKS)
    f = _assumed(level)
    values = [f[c] for c in ranking]
    assert all(a > b for a, b in zip(values, values[1:], strict=False)), (level, values)


def test_the_sourced_pairs() -> None:
    """The claims of docs/coverstock.md's table, one by one."""
    oil, dry = _assumed("oil"), _assumed("dry")
    # least to most traction: polyester < urethane < reactive, on oil and on the dry lane
    for level in (oil, dry):
        assert level["polyester"] < level["urethane"]
        assert level["polyester"] == min(level.values())
        assert level["particle"] == max(level.values())
    assert all(dry["urethane"] < dry[r] for r in REACTIVES)
    # among reactives: solid > hybrid > pearl; particle above solid on oil
    for level in (oil, dry):
        assert level["reactive_solid"] > level["reactive_hybrid"] > level["reactive_pearl"]
    assert oil["particle"] > oil["reactive_solid"]
    # modern solid covers have more traction in oil than urethane; pearl skids more
    assert oil["reactive_solid"] > oil["urethane"] > oil["reactive_pearl"]
    # reactive: low on oil, high on the dry lane; urethane has the smallest contrast of all
    # hooking covers (it reads the lane earlier and is smoother on the backend)
    contrast = {c: dry[c] / oil[c] for c in COVERSTOCKS}
    assert all(contrast["urethane"] < contrast[c] for c in (*REACTIVES, "particle"))
    assert contrast["reactive_pearl"] > contrast["reactive_hybrid"] > contrast["reactive_solid"]


def test_every_assumed_factor_lies_in_its_plausible_range() -> None:
    for cover, f in COVER_FACTORS.items():
        for r in (f.oil, f.dry):
            assert r.low <= r.assumed <= r.high, cover
    assert COVER_FACTORS[REFERENCE_COVERSTOCK].oil == FactorRange(1.0, 1.0, 1.0)
    assert COVER_FACTORS[REFERENCE_COVERSTOCK].dry == FactorRange(1.0, 1.0, 1.0)
    # the dry level stays under USBC's ball friction limit of 0.32 at every end of every range
    worst_surface = (GRIT_MIN / REFERENCE_GRIT) ** -GRIT_EXPONENT_DRY.high
    assert max(f.dry.high for f in COVER_FACTORS.values()) * worst_surface * 0.20 < 0.32
    with pytest.raises(ValueError, match="low <= assumed <= high"):
        FactorRange(1.0, 0.9, 1.1)


# --- surface grit -------------------------------------------------------------------------------


def test_a_rougher_surface_has_more_friction_on_oil_than_a_polished_one() -> None:
    m = OilFrictionMapping()
    for cover in COVERSTOCKS:
        dry500, oil500 = m.levels(cover, 500)  # type: ignore[arg-type]
        dry_pol, oil_pol = m.levels(cover, "polished")  # type: ignore[arg-type]
        assert oil500 > oil_pol and dry500 > dry_pol
        # sanding moves the oiled friction more than the dry friction
        assert oil500 / oil_pol > dry500 / dry_pol


@pytest.mark.parametrize("setting", ["low", "assumed", "high"])
def test_friction_falls_with_grit_and_polished_is_lowest(setting: str) -> None:
    """Non-increasing from GRIT_MIN to GRIT_MAX, polished below every grit: for the assumed
    surface model and for both ends of its range (the ends the sensitivity table uses)."""
    end = {"low": "low", "assumed": "assumed", "high": "high"}[setting]
    pol = {"low": "high", "assumed": "assumed", "high": "low"}[setting]
    m = OilFrictionMapping(
        grit_exponent_oil=getattr(GRIT_EXPONENT_OIL, end),
        grit_exponent_dry=getattr(GRIT_EXPONENT_DRY, end),
        polished_oil_factor=getattr(POLISHED_OIL, pol),
        polished_dry_factor=getattr(POLISHED_DRY, pol),
    )
    grits = [GRIT_MIN, 180, 360, 500, 1000, 1500, 2000, 3000, 4000, 6000, GRIT_MAX]
    factors = np.array([m.surface_factors(g) for g in grits])
    assert (np.diff(factors, axis=0) <= 0).all()
    assert (np.array(m.surface_factors("polished")) <= factors.min(axis=0)).all()


def test_a_surface_changes_the_friction_grid_and_the_run_id() -> None:
    p = preset("paper_typical")
    grids = {
        s: pattern_friction(p, lane_width_m=W415, coverstock="reactive_pearl", surface=s).mu
        for s in (500, 1500, 4000, "polished")
    }
    assert len({json.dumps(g) for g in grids.values()}) == 4
    oiled = {s: min(v for row in g for v in row) for s, g in grids.items()}
    assert oiled[500] > oiled[1500] > oiled[4000] > oiled["polished"]


# --- overrides ------------------------------------------------------------------------------------


def test_explicit_factors_win_over_the_ranking() -> None:
    m = OilFrictionMapping.paper(oil_factor={"particle": 2.0}, dry_factor={"polyester": 0.3})
    assert m.cover_factors("particle") == (COVER_FACTORS["particle"].dry.assumed, 2.0)
    assert m.cover_factors("polyester") == (0.3, COVER_FACTORS["polyester"].oil.assumed)
    ranked = OilFrictionMapping()
    for cover in ("urethane", "reactive_pearl"):  # no entry: the ranked factors
        assert m.cover_factors(cover) == ranked.cover_factors(cover)
    # the surface factor still multiplies an explicit cover factor
    dry, oil = m.levels("particle", 500)
    assert oil == pytest.approx(2.0 * (0.5**-0.1) * 0.04, rel=1e-15)
    assert dry == pytest.approx(1.05 * (0.5**-0.02) * 0.20, rel=1e-15)


def test_the_surface_model_is_overridable() -> None:
    off = OilFrictionMapping(
        grit_exponent_oil=0.0,
        grit_exponent_dry=0.0,
        polished_oil_factor=1.0,
        polished_dry_factor=1.0,
    )
    ranked = OilFrictionMapping()
    for s in (100, 500, 4000, "polished"):
        assert off.surface_factors(s) == (1.0, 1.0)
        assert off.levels("urethane", s) == ranked.levels("urethane", REFERENCE_GRIT)
    m = OilFrictionMapping(grit_reference=2000.0, grit_exponent_oil=0.2)
    assert m.surface_factors(2000) == (1.0, 1.0)
    assert m.surface_factors(500)[1] == pytest.approx(4.0**0.2, rel=1e-15)
    assert OilFrictionMapping(polished_oil_factor=0.5).surface_factors("polished")[1] == 0.5


def test_mu_of_film_blends_the_balls_levels() -> None:
    m = OilFrictionMapping(dry_at_or_below_um=1.0, oiled_at_or_above_um=3.0, ramp="linear")
    dry, oil = m.levels("urethane", 2000)
    np.testing.assert_allclose(
        mu_of_film([0.0, 2.0, 9.0], m, "urethane", 2000), [dry, 0.5 * (dry + oil), oil]
    )


# --- bad input ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("surface", "line"),
    [
        (50, "surface = 50 is outside the grits the friction model covers: 100-10000 "),
        (20000, "surface = 20000 is outside the grits the friction model covers: 100-10000 "),
        ("matte", "surface = 'matte' must be a grit number (100-10000) or 'polished'"),
    ],
)
def test_a_grit_outside_the_model_is_one_clear_line(surface: Any, line: str) -> None:
    with pytest.raises(ValueError) as exc:
        pattern_friction(preset("paper_typical"), lane_width_m=W415, surface=surface)
    assert str(exc.value).startswith(line) and "\n" not in str(exc.value)
    check_surface(GRIT_MIN)
    check_surface(GRIT_MAX)
    check_surface("polished")
    # outside the ranked model the surface plays no part
    none = OilFrictionMapping(cover_model="none")
    assert none.surface_factors(surface) == (1.0, 1.0)


@pytest.mark.parametrize(
    ("field", "value", "line"),
    [
        ("grit_reference", 50, "grit_reference: Input should be greater than or equal to 100"),
        ("grit_exponent_oil", -0.1, "grit_exponent_oil: Input should be greater than or equal"),
        ("grit_exponent_dry", 2.0, "grit_exponent_dry: Input should be less than or equal to 1"),
        ("polished_oil_factor", 0.0, "polished_oil_factor: Input should be greater than 0"),
        ("cover_model", "sanded", "cover_model: Input should be 'ranked' or 'none'"),
        ("oil_factor", {"urethane": -1.0}, "oil_factor.urethane: Input should be greater than"),
    ],
)
def test_bad_mapping_fields_name_field_value_and_range(field: str, value: Any, line: str) -> None:
    with pytest.raises(ValidationError) as exc:
        OilFrictionMapping.model_validate({field: value})
    text = format_validation_error(exc.value)
    assert text.startswith(line) and len(text.splitlines()) == 1, text


def test_a_bowler_scene_with_a_grit_outside_the_model_says_so_in_one_line() -> None:
    ball = {**BowlerScene().ball.model_dump(), "surface": 50}
    with pytest.raises(SceneInputError) as exc:
        parse_scene({"format": "bowler", "ball": ball})
    text = str(exc.value)
    assert "surface = 50 is outside the grits the friction model covers: 100-10000" in text
    assert len(text.splitlines()) == 1, text


# --- through the bowler scene: physical scenes, run IDs, and the physics ----------------------


def test_the_bowler_scene_gives_its_ball_the_covers_and_surfaces_friction() -> None:
    """BowlerScene.to_scene() passes the ball's coverstock and surface to pattern_friction."""
    for cover, surface in (("urethane", 500), ("reactive_pearl", "polished"), ("particle", 3000)):
        scene = _scene(cover, surface)  # type: ignore[arg-type]
        expected = pattern_friction(
            scene.pattern_model(),
            lane_width_m=scene.lane.width_m,
            length_m=scene.lane.length_m,
            coverstock=scene.ball.coverstock,
            surface=scene.ball.surface,
            mapping=scene.oil_friction,
        )
        assert scene.to_scene().lane.friction.mu == expected.mu  # type: ignore[union-attr]


def test_covers_and_surfaces_give_different_physical_scenes_and_run_ids() -> None:
    variants = [(c, 1500) for c in COVERSTOCKS] + [("reactive_pearl", s) for s in (500, 4000)]
    ids = {run_id(_scene(c, s).to_scene().resolve()) for c, s in variants}  # type: ignore[arg-type]
    assert len(ids) == len(variants)
    # under cover_model 'none' the cover is a label only: one physical scene, one ID
    none = {
        run_id(_scene(c, 1500, cover_model="none").to_scene().resolve())  # type: ignore[arg-type]
        for c in ("urethane", "reactive_solid", "reactive_pearl")
    }
    assert len(none) == 1


def test_more_traction_on_oil_hooks_earlier() -> None:
    """Simulated, not assumed: with the dry friction held, more friction on the oil turns the
    ball's slide into roll sooner, so the path turns back toward the pocket earlier (the
    breakpoint is closer to the foul line) and enters on a higher board."""
    bp_ft, entry = [], []
    for f in (0.6, 0.8, 1.0, 1.2, 1.4):
        r = _report(
            _scene("urethane", 1000, cover_model="none", oil_factor={"urethane": f})  # type: ignore[arg-type]
        )
        bp_ft.append(r.breakpoint_ft)
        entry.append(r.entry_board)
    assert all(a > b for a, b in zip(bp_ft, bp_ft[1:], strict=False)), bp_ft
    assert all(a < b for a, b in zip(entry, entry[1:], strict=False)), entry


def test_the_ranked_covers_and_grits_hook_in_their_order() -> None:
    """The ranking's consequence on the default scene: a cover or surface with more traction
    on the oil breaks earlier (solid before pearl, particle before polyester, 500 grit before
    polished)."""
    solid, pearl = _report(_scene("reactive_solid", 1500)), _report(_scene("reactive_pearl", 1500))
    assert solid.breakpoint_ft < pearl.breakpoint_ft
    assert solid.entry_board > pearl.entry_board  # type: ignore[operator]
    particle, poly = _report(_scene("particle", 1500)), _report(_scene("polyester", 1500))
    assert particle.breakpoint_ft < poly.breakpoint_ft
    assert particle.entry_board > poly.entry_board  # type: ignore[operator]
    rough, polished = (
        _report(_scene("reactive_pearl", 500)),
        _report(_scene("reactive_pearl", "polished")),
    )
    assert rough.breakpoint_ft < polished.breakpoint_ft
    assert rough.entry_board > polished.entry_board  # type: ignore[operator]


# --- the committed sensitivity table ----------------------------------------------------------


def test_the_doc_shows_the_committed_sensitivity_table() -> None:
    """docs/coverstock.md's block is benchmarks/results/coverstock_sensitivity.md, and the
    JSON was made with the model's current factors."""
    results = ROOT / "benchmarks" / "results"
    table = (results / "coverstock_sensitivity.md").read_text(encoding="utf-8")
    assert read_block(ROOT / "docs" / "coverstock.md", "coverstock") == table
    doc = json.loads((results / "coverstock_sensitivity.json").read_text(encoding="utf-8"))
    assert doc["cover_factors"] == {
        c: {
            "oil": [f.oil.low, f.oil.assumed, f.oil.high],
            "dry": [f.dry.low, f.dry.assumed, f.dry.high],
        }
        for c, f in COVER_FACTORS.items()
    }
    assert doc["reference"] == {"coverstock": REFERENCE_COVERSTOCK, "grit": REFERENCE_GRIT}
    assert doc["distinct_run_ids_of_the_six_covers"] == len(COVERSTOCKS)

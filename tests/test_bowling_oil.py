"""Oil patterns (Kegel sheets), their oil grid and statistics, oil -> friction, GridFriction."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import ValidationError

import bowlrec
from bowlrec.bowling.oil import (
    KegelPattern,
    KegelStep,
    RectanglePattern,
    board_from_notation,
    board_volumes_ul,
    load_pattern,
    oil_grid,
    parse_pattern,
    pattern_statistics,
    preset,
    preset_names,
    ratio,
)
from bowlrec.bowling.oil_friction import (
    OilFrictionMapping,
    film_thickness_um,
    mirror_friction,
    mu_of_film,
    pattern_friction,
    pattern_lane,
)
from bowlrec.paper import paper_scene
from bowlrec.spec import Lane, Scene, TypicalFriction, format_validation_error
from bowlrec.spec.friction import GridFriction
from bowlrec.spec.friction_grid import build_friction_grid, mu_at
from bowlrec.units import FT_M, IN_M

W42 = 42 * IN_M  # the paper's lane width (m)
W415 = 41.5 * IN_M  # USBC nominal width (m)

#: the paper's two levels (0.04 / 0.20): the mechanism tests below are written in them
PAPER = OilFrictionMapping.paper()


def _step(a: str, b: str, loads: int, mics: float, s: float, e: float, **kw: Any) -> KegelStep:
    return KegelStep(
        start_board=a, stop_board=b, loads=loads, mics_ul=mics, start_ft=s, end_ft=e, **kw
    )


def _small_sheet(**kw: Any) -> KegelPattern:
    """A made-up 2-step sheet: forward 2L-2R x 2 loads x 40 µL over 0-10 ft, reverse
    18L-18R x 3 loads x 50 µL from 20 ft back to 10 ft."""
    return KegelPattern(
        name="two steps",
        distance_ft=20.0,
        forward=[_step("2L", "2R", 2, 40.0, 0.0, 10.0)],
        reverse=[_step("18L", "18R", 3, 50.0, 20.0, 10.0)],
        **kw,
    )


def _errors(exc: pytest.ExceptionInfo[ValidationError]) -> str:
    return format_validation_error(exc.value)


# --- board notation -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "board"),
    [("1R", 1), ("2R", 2), ("2L", 38), ("1L", 39), ("20L", 20), ("20R", 20), ("18L", 22)],
)
def test_board_notation(text: str, board: int) -> None:
    assert board_from_notation(text) == board


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("40L", "board number 40 must be in 1..39"),
        ("0R", "board number 0 must be in 1..39"),
        ("2X", "is not in Kegel board notation"),
        ("L2", "is not in Kegel board notation"),
        ("", "is not in Kegel board notation"),
    ],
)
def test_board_notation_errors_name_field_value_and_range(text: str, needle: str) -> None:
    with pytest.raises(ValueError, match="start_board") as info:
        board_from_notation(text, "start_board")
    assert needle in str(info.value) and repr(text) in str(info.value)
    with pytest.raises(ValidationError) as exc:
        _step(text, "2R", 1, 50.0, 0.0, 5.0)
    assert _errors(exc).startswith(f"start_board: start_board = {text!r}")
    assert "1..39" in _errors(exc)


def test_step_boards_and_crossed() -> None:
    s = _step("2L", "2R", 3, 50.0, 0.0, 5.1)
    assert s.board_range == (2, 38) and s.boards == 37
    assert s.derived_crossed == 111 and s.oil_ul == 5550.0  # Kegel's own example row
    assert _step("18L", "18R", 1, 50.0, 0.0, 5.0).board_range == (18, 22)
    assert _step("7R", "7L", 1, 50.0, 0.0, 5.0).board_range == (7, 33)  # either order


# --- statistics by hand arithmetic ------------------------------------------------------------


def test_small_sheet_statistics_by_hand() -> None:
    st = pattern_statistics(_small_sheet())
    # forward: boards 2..38 = 37 boards x 2 loads = 74 crossed; 74 x 40 µL = 2960 µL
    # reverse: boards 18..22 = 5 boards x 3 loads = 15 crossed; 15 x 50 µL = 750 µL
    assert (st.forward_crosses, st.reverse_crosses, st.total_crosses) == (74, 15, 89)
    assert st.forward_ml == pytest.approx(2.96, abs=1e-12)
    assert st.reverse_ml == pytest.approx(0.75, abs=1e-12)
    assert st.total_ml == pytest.approx(3.71, abs=1e-12)
    # ratio: boards 18-22 get 2 x 40 + 3 x 50 = 230 µL each; boards 3-7 / 33-37 get 80 µL
    assert st.ratio == pytest.approx(230.0 / 80.0, rel=1e-15)
    assert st.distance_ft == 20.0 and st.oil_end_ft == 20.0


def test_small_sheet_grid_by_hand() -> None:
    g = oil_grid(_small_sheet())
    np.testing.assert_array_equal(g.x_edges_ft, [0.0, 10.0, 20.0])
    np.testing.assert_array_equal(g.board_edges, np.arange(40.0))
    assert g.volume_ul.shape == (2, 39)
    # row 0 (0-10 ft): 80 µL on boards 2..38, none on boards 1 and 39
    np.testing.assert_array_equal(g.volume_ul[0], [0.0] + [80.0] * 37 + [0.0])
    # row 1 (10-20 ft): 150 µL on boards 18..22 only
    expected = np.zeros(39)
    expected[17:22] = 150.0
    np.testing.assert_array_equal(g.volume_ul[1], expected)
    assert g.volume_ul.sum() == pytest.approx(3710.0, rel=1e-15)
    np.testing.assert_allclose(board_volumes_ul(g)[[0, 1, 17, 21, 22]], [0, 80, 230, 230, 80])


def test_ratio_at_a_distance() -> None:
    g = oil_grid(_small_sheet())
    # at 5 ft: 8 µL/ft on every board 2..38 -> flat 1:1; at 15 ft: boards 3-7 dry -> undefined
    assert ratio(g, at_ft=5.0) == pytest.approx(1.0, rel=1e-15)
    np.testing.assert_allclose(board_volumes_ul(g, at_ft=15.0)[17:22], 15.0)
    assert ratio(g, at_ft=15.0) is None
    assert ratio(g, at_ft=25.0) is None  # beyond the oil


def test_oil_spread_uniformly_over_a_step() -> None:
    p = KegelPattern(
        name="split",
        distance_ft=10.0,
        forward=[_step("2L", "2R", 1, 60.0, 0.0, 6.0), _step("18L", "18R", 1, 30.0, 2.0, 8.0)],
    )
    g = oil_grid(p)
    np.testing.assert_array_equal(g.x_edges_ft, [0.0, 2.0, 6.0, 8.0])
    # board 20: 60 µL over 6 ft (10 µL/ft) + 30 µL over 6 ft (5 µL/ft)
    np.testing.assert_allclose(g.volume_ul[:, 19], [20.0, 40.0 + 20.0, 10.0])
    np.testing.assert_allclose(g.volume_ul[:, 2], [20.0, 40.0, 0.0])  # board 3


def test_travel_steps_lay_no_oil() -> None:
    p = _small_sheet()
    q = KegelPattern(
        name="with travel",
        distance_ft=30.0,
        forward=[*p.forward, _step("2L", "2R", 0, 40.0, 10.0, 30.0)],
        reverse=[_step("2L", "2R", 0, 50.0, 30.0, 20.0), *p.reverse],
    )
    a, b = pattern_statistics(p), pattern_statistics(q)
    assert (b.total_ml, b.total_crosses, b.ratio) == (a.total_ml, a.total_crosses, a.ratio)
    assert b.distance_ft == 30.0 and b.oil_end_ft == 20.0


# --- sheet validation -------------------------------------------------------------------------


def test_printed_columns_are_checked() -> None:
    _step("2L", "2R", 3, 50.0, 0.0, 5.1, crossed=111, total_oil_ul=5550.0)
    with pytest.raises(ValidationError) as exc:
        _step("2L", "2R", 3, 50.0, 0.0, 5.1, crossed=99)
    assert "crossed = 99 must equal boards x loads = 37 x 3 = 111" in _errors(exc)
    with pytest.raises(ValidationError) as exc:
        _step("2L", "2R", 3, 50.0, 0.0, 5.1, total_oil_ul=5500.0)
    assert "total_oil_ul = 5500.0 must equal crossed x mics_ul = 111 x 50.0 = 5550.0" in (
        _errors(exc)
    )


def test_printed_totals_are_checked() -> None:
    _small_sheet(forward_oil_total_ml=2.96, reverse_oil_total_ml=0.75, volume_oil_total_ml=3.71)
    _small_sheet(ratio_stated=2.88)  # 2.875 printed to 2 decimals
    with pytest.raises(ValidationError) as exc:
        _small_sheet(volume_oil_total_ml=3.8)
    assert "volume_oil_total_ml = 3.8 must equal the value derived from the steps, 3.71" in (
        _errors(exc)
    )
    with pytest.raises(ValidationError) as exc:
        _small_sheet(ratio_stated=3.0)
    assert "ratio_stated = 3.0 must equal" in _errors(exc)


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        (
            {"forward": [_step("2L", "2R", 1, 50.0, 10.0, 0.0)]},
            "forward[0]: start_ft = 10.0 must be <= end_ft = 0.0 (the forward pass travels",
        ),
        (
            {"reverse": [_step("2L", "2R", 1, 50.0, 0.0, 10.0)]},
            "reverse[0]: start_ft = 0.0 must be >= end_ft = 10.0 (the reverse pass travels",
        ),
        (
            {"forward": [_step("2L", "2R", 1, 50.0, 0.0, 25.0)]},
            "forward[0]: oil up to 25.0 ft must lie within distance_ft = 20.0",
        ),
    ],
)
def test_pass_direction_and_extent(change: dict[str, Any], needle: str) -> None:
    data: dict[str, Any] = {"name": "x", "distance_ft": 20.0, "forward": [], **change}
    with pytest.raises(ValidationError) as exc:
        KegelPattern(**data)
    assert needle in _errors(exc)


def test_step_field_ranges() -> None:
    with pytest.raises(ValidationError) as exc:
        _step("2L", "2R", -1, 50.0, 0.0, 5.0)
    assert "loads: Input should be greater than or equal to 0 (got -1)" in _errors(exc)
    with pytest.raises(ValidationError) as exc:
        _step("2L", "2R", 1, 50.0, 0.0, 61.0)
    assert "end_ft: Input should be less than or equal to 60" in _errors(exc)
    with pytest.raises(ValidationError) as exc:
        _step("2L", "2R", 1, 50.0, 5.0, 5.0)
    assert "start_ft = end_ft = 5.0: a step that lays oil (1850.0 µL)" in _errors(exc)
    with pytest.raises(ValidationError) as exc:
        KegelStep.model_validate({**_step("2L", "2R", 1, 50, 0, 5).model_dump(), "junk": 1})
    assert "junk: Extra inputs are not permitted" in _errors(exc)


def test_load_from_json(tmp_path: Path) -> None:
    path = tmp_path / "p.json"
    path.write_text(json.dumps(_small_sheet().model_dump(mode="json")), encoding="utf-8")
    assert load_pattern(path) == _small_sheet()
    with pytest.raises(ValidationError):
        parse_pattern({"kind": "nope", "name": "x"})


# --- presets --------------------------------------------------------------------------------


def test_presets_load_and_are_labelled() -> None:
    names = preset_names()
    assert {"paper_typical", "house_shot_approx", "kegel_chromium_6742"} <= set(names)
    for name in names:
        p = preset(name)
        assert p.source
        if name.endswith("_approx"):
            assert p.approximation and "APPROXIMATION" in p.source
        else:
            assert not p.approximation
    with pytest.raises(KeyError, match="no oil pattern preset 'nope'"):
        preset("nope")


@pytest.mark.parametrize(
    ("name", "forward_ml", "reverse_ml", "total_ml", "crosses", "ratio_", "distance_ft"),
    [
        # Kegel sheets: the printed totals (and Big Ben's printed ratio 7.33:1)
        ("kegel_chromium_6742", 15.41, 10.15, 25.56, (333, 203), 1140 / 170, 42.0),
        ("kegel_big_ben", 16.22, 8.48, 24.7, (343, 212), 1100 / 150, 44.0),
        ("kegel_stonehenge", 15.95, 7.8, 23.75, (319, 156), 1050 / 160, 40.0),
        # approximations built to a length and a ratio
        ("house_shot_approx", 10.9, 10.9, 21.8, (218, 218), 10.0, 40.0),
        ("sport_short_36ft_approx", 10.79, 10.79, 21.58, (166, 166), 3.0, 36.0),
        ("sport_medium_41ft_approx", 11.94, 9.18, 21.12, (199, 153), 2.0, 41.0),
        ("sport_long_45ft_approx", 11.475, 9.9, 21.375, (153, 132), 1.5, 45.0),
    ],
)
def test_kegel_presets_statistics(
    name: str,
    forward_ml: float,
    reverse_ml: float,
    total_ml: float,
    crosses: tuple[int, int],
    ratio_: float,
    distance_ft: float,
) -> None:
    st = pattern_statistics(preset(name))
    assert st.forward_ml == pytest.approx(forward_ml, abs=1e-9)
    assert st.reverse_ml == pytest.approx(reverse_ml, abs=1e-9)
    assert st.total_ml == pytest.approx(total_ml, abs=1e-9)
    assert (st.forward_crosses, st.reverse_crosses) == crosses
    assert st.ratio == pytest.approx(ratio_, rel=1e-12)
    assert st.distance_ft == distance_ft


def test_big_ben_ratio_by_hand() -> None:
    """Boards 18-22 get every load: forward 3x50 + 2x50 + 3x45 x 3 + 1x45 = 700 µL, reverse
    (1 + 2 + 3 + 3 + 1) x 40 = 400 µL; boards 3-7 only the first 2L-2R step, 3 x 50 = 150 µL."""
    p = preset("kegel_big_ben")
    assert isinstance(p, KegelPattern) and p.ratio_stated == 7.33
    per_board = board_volumes_ul(oil_grid(p))
    np.testing.assert_allclose(per_board[17:22], 1100.0)
    np.testing.assert_allclose(per_board[2:7], 150.0)
    np.testing.assert_allclose(per_board[32:37], 150.0)
    assert ratio(oil_grid(p)) == pytest.approx(7.3333333333, rel=1e-10)


def test_paper_typical_preset_statistics() -> None:
    p = preset("paper_typical")
    assert isinstance(p, RectanglePattern)
    st = pattern_statistics(p)
    # 31.2 boards x 40 ft x 18 µL per board-foot (nominal depth)
    assert st.total_ml == pytest.approx(22.464, abs=1e-12) and st.total_crosses is None
    # boards 18-22: 720 µL; boards 3..7: 0, 72 (board 4 is 0.1 oiled), 720 x 3; same mirrored
    assert st.ratio == pytest.approx(720.0 / ((0 + 72 + 3 * 720) * 2 / 10), rel=1e-12)


# --- grid orientation and oil -> friction ------------------------------------------------------


def test_board_one_is_at_the_right_gutter() -> None:
    """Oil only on board 1 (counted from the right) lands at small y, 1L at large y."""
    w = W415 / 39
    for notation, (y_lo, y_hi) in {"1R": (0.0, w), "1L": (38 * w, W415)}.items():
        p = KegelPattern(
            name="one board",
            distance_ft=10.0,
            forward=[_step(notation, notation, 1, 50.0, 0.0, 10.0)],
        )
        f = pattern_friction(p, lane_width_m=W415, mapping=PAPER)
        assert mu_at(build_friction_grid(f, W415), 1.0, 0.5 * (y_lo + y_hi)) == 0.04
        assert mu_at(build_friction_grid(f, W415), 1.0, W415 / 2) == 0.20
    # a 3R-5R band covers y in [2w, 5w]
    p = KegelPattern(name="band", distance_ft=10.0, forward=[_step("3R", "5R", 1, 50, 0, 10)])
    f = pattern_friction(p, lane_width_m=W415, mapping=PAPER)
    np.testing.assert_allclose(f.y_edges_m, [2 * w, 5 * w], rtol=1e-15)
    np.testing.assert_allclose(f.x_edges_m, [10 * FT_M], rtol=1e-15)
    assert f.mu == [[0.2, 0.04, 0.2], [0.2, 0.2, 0.2]]


def test_outside_the_lane_continues_the_edge_cells() -> None:
    """Oil from the foul line on every board: no break point at x = 0 or at the gutters."""
    p = KegelPattern(name="full", distance_ft=30.0, forward=[_step("1L", "1R", 1, 50, 0, 30)])
    f = pattern_friction(p, lane_width_m=W42, mapping=PAPER)
    assert f.x_edges_m == [30 * FT_M] and f.y_edges_m == []
    assert f.mu == [[0.04], [0.2]]
    # a pattern that reaches past the head pin puts no break point there
    p = KegelPattern(name="long", distance_ft=60.0, forward=[_step("2L", "2R", 1, 50, 0, 60)])
    f = pattern_friction(p, lane_width_m=W42, length_m=50 * FT_M, mapping=PAPER)
    assert f.x_edges_m == []


def test_paper_typical_preset_equals_typical_friction() -> None:
    """The preset's friction grid is exactly the spec's TypicalFriction grid on 42 in."""
    f = pattern_friction(preset("paper_typical"), lane_width_m=W42, mapping=PAPER)
    a = build_friction_grid(f, W42)
    b = build_friction_grid(TypicalFriction(), W42)
    np.testing.assert_allclose(a.x_edges_m, b.x_edges_m, rtol=0, atol=1e-15)
    np.testing.assert_allclose(a.y_edges_m, b.y_edges_m, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(a.mu, b.mu)
    # and on the USBC width, the band is still the central 80 %
    a = build_friction_grid(
        pattern_friction(preset("paper_typical"), lane_width_m=W415, mapping=PAPER), W415
    )
    np.testing.assert_allclose(a.y_edges_m, [0.1 * W415, 0.9 * W415], rtol=1e-14)


def test_paper_mapping_is_the_papers_two_levels() -> None:
    """OilFrictionMapping.paper() gives the paper's two levels to a ball without coverstock or
    surface and to the reference ball (reactive_solid at 1000 grit); cover_model 'none' gives
    them to every ball. The default mapping is the calibrated one (tests/test_calibration.py)."""
    m = PAPER
    assert (m.mu_oil, m.mu_dry, m.cover_model, m.oiled_at_or_above_um) == (
        0.04, 0.20, "ranked", 0.0
    )  # fmt: skip
    films = np.array([0.0, 1e-9, 0.5, 100.0])
    np.testing.assert_array_equal(mu_of_film(films, m), [0.20, 0.04, 0.04, 0.04])
    np.testing.assert_array_equal(
        mu_of_film(films, m, "reactive_solid", 1000), [0.20, 0.04, 0.04, 0.04]
    )
    none = OilFrictionMapping.paper(cover_model="none")
    for cover in ("polyester", "urethane", "reactive_solid", "particle"):
        for surface in (None, 500, "polished"):
            np.testing.assert_array_equal(
                mu_of_film(films, none, cover, surface), [0.20, 0.04, 0.04, 0.04]
            )


def test_mapping_ramp_and_coverstock_factors() -> None:
    """Explicit factors on top of cover_model 'none': each multiplies its level, a coverstock
    without an entry keeps the mapping's levels."""
    m = OilFrictionMapping.paper(
        dry_at_or_below_um=1.0,
        oiled_at_or_above_um=3.0,
        ramp="linear",
        cover_model="none",
        dry_factor={"particle": 1.5},
        oil_factor={"particle": 2.0, "polyester": 0.5},
    )
    np.testing.assert_allclose(
        mu_of_film([0.5, 1.0, 2.0, 3.0, 9.0], m), [0.2, 0.2, 0.12, 0.04, 0.04]
    )
    # particle: dry 0.30, oil 0.08; halfway 0.19
    np.testing.assert_allclose(mu_of_film([0.0, 2.0, 5.0], m, "particle"), [0.3, 0.19, 0.08])
    np.testing.assert_allclose(mu_of_film([5.0], m, "polyester"), [0.02])
    np.testing.assert_allclose(mu_of_film([0.0], m, "urethane"), [0.2])  # no factor given
    with pytest.raises(ValidationError) as exc:
        OilFrictionMapping(dry_at_or_below_um=2.0, oiled_at_or_above_um=1.0)
    assert "oiled_at_or_above_um = 1.0 must be >= dry_at_or_below_um = 2.0" in _errors(exc)
    with pytest.raises(ValidationError) as exc:
        OilFrictionMapping(oil_factor={"wood": 1.0})  # type: ignore[dict-item]
    assert "oil_factor.wood" in _errors(exc)


def test_film_thickness() -> None:
    """50 µL on one board over 1 ft of a 39-in-wide lane (board = 1 in): 50e-9 m^3 /
    (0.3048 m x 0.0254 m) = 6.4584 µm."""
    p = KegelPattern(name="f", distance_ft=1.0, forward=[_step("20R", "20R", 1, 50, 0, 1)])
    film = film_thickness_um(oil_grid(p), 39 * IN_M)
    assert film[0, 19] == pytest.approx(50e-9 / (FT_M * IN_M) * 1e6, rel=1e-14)
    assert film.sum() == film[0, 19]


def test_ramp_mapping_gives_a_finer_grid() -> None:
    p = preset("kegel_chromium_6742")
    coarse = pattern_friction(p, lane_width_m=W415, mapping=PAPER)
    fine = pattern_friction(
        p, lane_width_m=W415, mapping=OilFrictionMapping.paper(oiled_at_or_above_um=8)
    )
    assert len(fine.x_edges_m) > len(coarse.x_edges_m)
    assert {v for row in coarse.mu for v in row} == {0.04, 0.2}
    assert 0.04 < min(v for row in fine.mu for v in row) < 0.2


def test_mirror_friction() -> None:
    f = pattern_friction(
        KegelPattern(name="r", distance_ft=10.0, forward=[_step("1R", "3R", 1, 50, 0, 10)]),
        lane_width_m=W42,
        mapping=PAPER,
    )
    g = build_friction_grid(mirror_friction(f, W42), W42)
    assert mu_at(g, 1.0, W42 - 0.01) == 0.04 and mu_at(g, 1.0, 0.01) == 0.2


# --- GridFriction ---------------------------------------------------------------------------


def test_grid_friction_builds_the_same_grid() -> None:
    f = GridFriction(x_edges_m=[1.0, 2.0], y_edges_m=[0.5], mu=[[0.1, 0.2], [0.1, 0.2], [0.3, 0.3]])
    g = build_friction_grid(f, W42)
    np.testing.assert_array_equal(g.x_edges_m, [2.0])  # x = 1 separates equal rows: merged
    np.testing.assert_array_equal(g.y_edges_m, [0.5])
    np.testing.assert_array_equal(g.mu, [[0.1, 0.2], [0.3, 0.3]])
    assert build_friction_grid(GridFriction(mu=[[0.07]]), W42).mu.tolist() == [[0.07]]
    assert Lane.model_validate({"friction": f.model_dump()}).friction == f


@pytest.mark.parametrize(
    ("data", "line"),
    [
        (
            {"x_edges_m": [1.0, 1.0], "mu": [[0.1], [0.1], [0.1]]},
            "friction.grid.x_edges_m: x_edges_m[1] = 1.0 must be > x_edges_m[0] = 1.0 "
            "(break points must be strictly increasing)",
        ),
        (
            {"y_edges_m": [0.5, 0.2], "mu": [[0.1, 0.1, 0.1]]},
            "friction.grid.y_edges_m: y_edges_m[1] = 0.2 must be > y_edges_m[0] = 0.5",
        ),
        (
            {"x_edges_m": [1.0], "mu": [[0.1]]},
            "friction.grid.mu: mu has 1 rows; it must have len(x_edges_m) + 1 = 2 "
            "(one row per x cell)",
        ),
        (
            {"y_edges_m": [0.5], "mu": [[0.1, 0.2, 0.3]]},
            "friction.grid.mu: mu[0] has 3 values; it must have len(y_edges_m) + 1 = 2 "
            "(one value per y cell)",
        ),
        (
            {"mu": [[-0.1]]},
            "friction.grid.mu[0][0]: Input should be greater than or equal to 0 (got -0.1)",
        ),
        ({"x_edges_m": [float("nan")], "mu": [[0.1], [0.1]]}, "friction.grid.x_edges_m[0]"),
        ({}, "friction.grid.mu: Field required"),
    ],
)
def test_grid_friction_validation(data: dict[str, Any], line: str) -> None:
    with pytest.raises(ValidationError) as exc:
        Lane.model_validate({"friction": {"kind": "grid", **data}})
    assert _errors(exc).startswith(line), _errors(exc)


# --- simulation -----------------------------------------------------------------------------


def _with_friction(scene: Scene, friction: GridFriction | TypicalFriction) -> Scene:
    data = scene.model_dump()
    data["lane"]["friction"] = friction.model_dump()
    return Scene.model_validate(data)


@pytest.mark.parametrize("case", [8, 9])
def test_typical_preset_simulates_like_typical_friction(case: int) -> None:
    """Paper cases 8 and 9 (typical pattern, hooking) on the preset's grid: same summary."""
    scene = paper_scene(case)
    grid = pattern_friction(preset("paper_typical"), lane_width_m=scene.lane.width_m, mapping=PAPER)
    a = bowlrec.simulate(scene).summary
    b = bowlrec.simulate(_with_friction(scene, grid)).summary
    assert a.outcome == b.outcome == "pins"
    for key in ("slide_m", "hook_m", "x_end_m", "y_end_m"):
        assert getattr(b, key) == pytest.approx(getattr(a, key), abs=1e-9), key
    assert b.pocket_deg == pytest.approx(a.pocket_deg, abs=1e-9)


def test_simulate_on_an_oil_pattern_lane() -> None:
    lane = pattern_lane(preset("kegel_chromium_6742"), width_m=W42, mapping=PAPER)
    assert lane.width_m == W42 and isinstance(lane.friction, GridFriction)
    traj = bowlrec.simulate(_with_friction(paper_scene(9), lane.friction))
    s = traj.summary
    assert s.outcome == "pins" and s.slide_m is not None
    assert sum(e.kind == "zone" for e in traj.events) >= 2  # the ball crossed oil boundaries
    # on the oil the ball sees 0.04, behind the pattern 0.20
    assert {float(m) for m in np.unique(traj.mu)} <= {0.04, 0.2}
    assert bowlrec.simulate(Scene(lane=lane)).summary.outcome == "pins"

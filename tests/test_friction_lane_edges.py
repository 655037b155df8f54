"""Friction break points on the lane's edges (pins line, gutters) must not hide the end of the
run: a zone covering exactly the whole lane must still end case 8 at the pins, not at max_time."""

from __future__ import annotations

import pytest

import bowlrec
from bowlrec.paper import paper_scene
from bowlrec.spec import Scene
from bowlrec.spec.friction_grid import FrictionGrid, clip_to_lane


def _case8(friction: dict) -> Scene:  # type: ignore[type-arg]
    doc = paper_scene(8).model_dump(mode="json")
    doc["lane"]["friction"] = friction
    doc["options"] = {"record": "summary"}
    return Scene.model_validate(doc)


def test_break_points_on_the_lane_edges_do_not_hide_the_gutter() -> None:
    width = paper_scene(8).lane.width_m
    reference = bowlrec.simulate(_case8({"kind": "constant", "mu": 0.2})).summary
    assert reference.outcome == "gutter"
    variants = [
        {"kind": "grid", "x_edges_m": [], "y_edges_m": [width], "mu": [[0.2, 0.2001]]},
        {"kind": "grid", "x_edges_m": [18.288], "y_edges_m": [0.0, width],
         "mu": [[0.3, 0.2, 0.4], [0.1, 0.1, 0.1]]},
        {"kind": "zones", "default_mu": 0.2001,
         "zones": [{"x_min_m": 0, "x_max_m": 18.288, "y_min_m": 0, "y_max_m": width, "mu": 0.2}]},
    ]  # fmt: skip
    for friction in variants:
        s = bowlrec.simulate(_case8(friction)).summary
        assert (s.outcome, s.x_end_m, s.y_end_m) == (
            reference.outcome,
            pytest.approx(reference.x_end_m, abs=1e-12),
            pytest.approx(reference.y_end_m, abs=1e-12),
        ), friction


def test_clip_to_lane_keeps_the_friction_on_the_lane() -> None:
    import numpy as np

    grid = FrictionGrid(
        np.array([-1.0, 0.0, 5.0, 18.288, 20.0]),
        np.array([0.0, 0.5, 1.0668]),
        np.arange(24, dtype=float).reshape(6, 4) / 100,
    )
    clipped = clip_to_lane(grid, 18.288, 1.0668)
    assert clipped.x_edges_m.tolist() == [5.0] and clipped.y_edges_m.tolist() == [0.5]
    # cell (x in [0, 5), y in [0, 0.5)) was row 2, column 1 of the original grid
    assert clipped.mu.tolist() == [[0.09, 0.10], [0.13, 0.14]]


def test_a_ball_released_rolling_has_zero_slide() -> None:
    """slide_m is where rolling first starts: the release point for a ball released rolling
    (it has no slide -> roll event); a ball that never rolls keeps None."""
    rolling = Scene.model_validate(
        {"delivery": {"position_m": [0.5, 0.5334], "omega_radps": [0.0, 8.0 / 0.1085, 0.0]}}
    )
    for record in ("summary", "steps"):
        options = rolling.options.model_copy(update={"record": record})
        s = bowlrec.simulate(rolling.model_copy(update={"options": options})).summary
        assert s.slide_m == 0.5
    never = Scene.model_validate(
        {"lane": {"friction": {"kind": "constant", "mu": 0.001}}, "options": {"record": "summary"}}
    )
    assert bowlrec.simulate(never).summary.slide_m is None

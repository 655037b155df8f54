"""The session's figures render, as SVG that parses and is the same bytes for the same input,
and as PNG."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from bowlrec.bowling.oil import preset
from bowlrec.bowling.oil_transfer import TransferModel, apply_track, session_oil_grid
from bowlrec.figures.render import figure_bytes
from bowlrec.figures.session import drift_figure, oil_before_after_figure
from bowlrec.units import FT_M, IN_M, LANE_WIDTH_IN

W = LANE_WIDTH_IN * IN_M


def _worn() -> tuple[object, object]:
    before = session_oil_grid(preset("house_shot_approx"))
    x = np.linspace(0.0, 60 * FT_M, 200)
    after = before
    for k in range(5):
        y = 0.25 + 0.02 * k + 0.25 * (x / x[-1]) ** 2
        after, _, _ = apply_track(
            after, x, y, lane_width_m=W, model=TransferModel(pickup_fraction=0.3),
            ball_load_ul=0.0,
        )  # fmt: skip
    return before, after


def _shots() -> list[dict[str, object]]:
    rng = np.random.default_rng(1)
    out: list[dict[str, object]] = []
    for i in range(24):
        out.append(
            {
                "shot": i + 1,
                "game": i // 8 + 1,
                "bowler": ("Ann", "Bo")[i % 2],
                "breakpoint_board": 7.0 + 0.05 * i + rng.normal(0, 0.3),
                "breakpoint_ft": 40.0 - 0.1 * i,
                "entry_board": float("nan") if i == 5 else 17.5 + rng.normal(0, 1.0),
                "entry_angle_deg": 5.0 + rng.normal(0, 0.4),
                "outcome": "gutter" if i == 5 else "pins",
            }
        )
    return out


def _svg_ok(data: bytes) -> None:
    root = ET.fromstring(data)
    assert root.tag.endswith("svg")


def test_oil_before_after_renders_deterministically() -> None:
    before, after = _worn()
    a = figure_bytes(oil_before_after_figure(before, after, title="after 5 shots"), "svg")  # type: ignore[arg-type]
    b = figure_bytes(oil_before_after_figure(before, after, title="after 5 shots"), "svg")  # type: ignore[arg-type]
    _svg_ok(a)
    assert a == b
    png = figure_bytes(oil_before_after_figure(before, after, title="x"), "png")  # type: ignore[arg-type]
    assert png.startswith(b"\x89PNG")


def test_oil_before_after_on_other_cells() -> None:
    before = session_oil_grid(preset("house_shot_approx"))
    after = session_oil_grid(preset("house_shot_approx"), cell_ft=2.0, cell_boards=3.0)
    _svg_ok(figure_bytes(oil_before_after_figure(before, after, title="t"), "svg"))


def test_drift_renders_deterministically() -> None:
    shots = _shots()
    a = figure_bytes(drift_figure(shots), "svg")
    assert a == figure_bytes(drift_figure(shots, by="game"), "svg")
    _svg_ok(a)
    assert figure_bytes(drift_figure(shots), "png").startswith(b"\x89PNG")
    _svg_ok(figure_bytes(drift_figure([]), "svg"))


def test_unknown_format() -> None:
    with pytest.raises(ValueError, match="fmt"):
        figure_bytes(drift_figure(_shots()), "pdf")

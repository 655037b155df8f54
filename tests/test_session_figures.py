"""The session's figures: what they show (the data of every artist of the returned matplotlib
Figure: the meshes' arrays, the bars' heights, the lines' points, colours and texts, read from
the objects, not from pixels), and that they render as SVG that parses and is the same bytes for
the same input, and as PNG.

The expected values are computed here from the inputs (the oil grids' volumes per cell and per
board, the shots' values, their means per game), independently of the figure code; for a real
session, from the ``shots.csv`` the session writes next to its figures.
"""

from __future__ import annotations

import csv
import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.collections import QuadMesh
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure

from bowlrec.bowling.oil import OilGrid, preset
from bowlrec.bowling.oil_transfer import TransferModel, apply_track, session_oil_grid
from bowlrec.figures import render
from bowlrec.figures.render import figure_bytes
from bowlrec.figures.session import drift_figure, oil_before_after_figure
from bowlrec.units import FT_M, IN_M, LANE_WIDTH_IN

W = LANE_WIDTH_IN * IN_M
BOARDS = 39
#: the drift figure's panels, top to bottom: (shot key, y label)
PANELS = (
    ("breakpoint_board", "breakpoint board"),
    ("breakpoint_ft", "breakpoint distance (ft)"),
    ("entry_board", "entry board at the pins"),
    ("entry_angle_deg", "entry angle (deg)"),
)


def _worn() -> tuple[OilGrid, OilGrid]:
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


# --- reading the figures -----------------------------------------------------------------------


def _mesh(ax: Axes) -> QuadMesh:
    (mesh,) = [c for c in ax.collections if isinstance(c, QuadMesh)]
    return mesh


def _per_cell_density(grid: OilGrid) -> np.ndarray:
    """µL per board per ft of every cell, from the grid's volumes and cell sizes."""
    dx = grid.x_edges_ft[1:] - grid.x_edges_ft[:-1]
    db = grid.board_edges[1:] - grid.board_edges[:-1]
    return grid.volume_ul / dx[:, None] / db[None, :]


def _per_board(grid: OilGrid) -> np.ndarray:
    """µL on boards 1..39 of a grid whose columns are ``k`` whole boards wide each (its oil
    spread evenly over a column's boards)."""
    widths = np.diff(grid.board_edges)
    k = int(widths[0])
    assert np.all(widths == k) and grid.board_edges[0] == 0.0 and grid.board_edges[-1] == BOARDS
    return np.repeat(grid.volume_ul.sum(axis=0) / k, k)


def _check_oil_figure(
    fig: Figure, before: OilGrid, shown_after: OilGrid, per_board_after: Any
) -> None:
    """``fig`` shows ``before`` and ``shown_after`` (the after grid on before's cells) as
    densities on one scale, their difference on a symmetric scale, and the per-board volumes
    of ``before`` and ``per_board_after`` as bars left and right of each board."""
    ax_before, ax_after, ax_diff, ax_bars = fig.axes[:4]
    d0, d1 = _per_cell_density(before), _per_cell_density(shown_after)
    for ax, dens, grid, name in ((ax_before, d0, before, "before"), (ax_after, d1, shown_after,
                                                                      "after")):  # fmt: skip
        mesh = _mesh(ax)
        assert np.allclose(np.asarray(mesh.get_array()), dens, rtol=1e-12, atol=1e-12), name
        corners = np.asarray(mesh.get_coordinates())
        assert np.array_equal(corners[0, :, 0], before.board_edges + 0.5)  # board 1 on 0.5-1.5
        assert np.array_equal(corners[:, 0, 1], before.x_edges_ft)
        assert mesh.get_cmap().name == "YlOrBr"
        assert (mesh.norm.vmin, mesh.norm.vmax) == (0.0, pytest.approx(max(d0.max(), d1.max())))
        assert ax.get_title() == f"{name}: {grid.volume_ul.sum() / 1000:.2f} mL"
    diff = _mesh(ax_diff)
    assert np.allclose(np.asarray(diff.get_array()), d1 - d0, rtol=1e-12, atol=1e-12)
    assert diff.get_cmap().name == "RdBu"
    span = np.abs(d1 - d0).max()
    assert (diff.norm.vmin, diff.norm.vmax) == (pytest.approx(-span), pytest.approx(span))
    # no change: the middle of the scale (white)
    assert np.asarray(diff.norm(np.array([0.0])))[0] == 0.5

    bars_before, bars_after = ax_bars.containers
    boards = np.arange(1, BOARDS + 1)
    for bars, label, offset, volumes, color in (
        (bars_before, "before", -0.2, _per_board(before), "#b07a2a"),
        (bars_after, "after", 0.2, per_board_after, "#4a6fa5"),
    ):
        assert bars.get_label() == label
        rects = list(bars)
        assert len(rects) == BOARDS
        heights = np.array([r.get_height() for r in rects])
        assert np.allclose(heights, volumes, rtol=1e-12, atol=1e-9), label
        centers = np.array([r.get_x() + r.get_width() / 2 for r in rects])
        assert np.allclose(centers, boards + offset, atol=1e-12), label
        assert all(r.get_facecolor() == to_rgba(color) for r in rects), label
    assert ax_bars.get_title() == "oil per board"


def _points(fig: Figure) -> dict[tuple[str, str], np.ndarray]:
    """(panel key, bowler) -> the bowler's (shot, value) points in that panel."""
    out = {}
    for ax, (key, label) in zip(fig.axes, PANELS, strict=True):
        assert ax.get_ylabel() == label
        for line in ax.get_lines():
            if line.get_marker() == "o":
                out[key, str(line.get_label())] = np.asarray(line.get_xydata())
    return out


def _means(fig: Figure) -> dict[str, list[tuple[float, float, float]]]:
    """Panel key -> its mean lines as (x from, x to, y), in drawing order."""
    out: dict[str, list[tuple[float, float, float]]] = {}
    for ax, (key, _) in zip(fig.axes, PANELS, strict=True):
        lines = [ln for ln in ax.get_lines() if ln.get_linestyle() == "-"]
        assert all(ln.get_color() == "#222222" for ln in lines)
        out[key] = []
        for ln in lines:
            (x0, y0), (x1, y1) = np.asarray(ln.get_xydata(), dtype=float)
            assert y0 == y1
            out[key].append((float(x0), float(x1), float(y0)))
    return out


def _expected_drift(
    shots: list[dict[str, Any]], by: str
) -> tuple[dict[tuple[str, str], np.ndarray], dict[str, list[tuple[float, float, float]]]]:
    """What the drift figure should show, from the shots: each bowler's finite points and, per
    group of ``by`` in order of first appearance, the mean of its finite values drawn over its
    shots +- 0.4."""
    points: dict[tuple[str, str], np.ndarray] = {}
    means: dict[str, list[tuple[float, float, float]]] = {}
    bowlers = list(dict.fromkeys(str(s["bowler"]) for s in shots))
    groups = list(dict.fromkeys(s[by] for s in shots))
    for key, _ in PANELS:
        for name in bowlers:
            points[key, name] = np.array(
                [
                    (float(s["shot"]), float(s[key]))
                    for s in shots
                    if s["bowler"] == name and math.isfinite(float(s[key]))
                ]
            ).reshape(-1, 2)
        means[key] = []
        for g in groups:
            mine = [s for s in shots if s[by] == g]
            vals = [float(s[key]) for s in mine if math.isfinite(float(s[key]))]
            shots_of = [float(s["shot"]) for s in mine]
            if vals:
                means[key].append((min(shots_of) - 0.4, max(shots_of) + 0.4, float(np.mean(vals))))
    return points, means


def _check_drift(fig: Figure, shots: list[dict[str, Any]], by: str = "game") -> None:
    points, means = _expected_drift(shots, by)
    drawn = _points(fig)
    assert drawn.keys() == points.keys()
    for k, xy in points.items():
        assert np.allclose(drawn[k], xy, rtol=1e-15, atol=0.0), k
    got = _means(fig)
    for key, _ in PANELS:
        assert len(got[key]) == len(means[key]), key
        assert np.allclose(got[key], means[key], rtol=1e-12, atol=1e-12), key
    # a colour per bowler, in order of first appearance
    bowlers = list(dict.fromkeys(str(s["bowler"]) for s in shots))
    for ax in fig.axes:
        dots = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
        assert [ln.get_label() for ln in dots] == bowlers
        assert [ln.get_color() for ln in dots] == [f"C{k % 10}" for k in range(len(bowlers))]
    assert [t.get_text() for t in fig.legends[0].get_texts()] == [*bowlers, f"mean per {by}"]


# --- the oil before and after --------------------------------------------------------------------


def test_oil_before_after_renders_deterministically() -> None:
    before, after = _worn()
    fig = oil_before_after_figure(before, after, title="after 5 shots")
    a = figure_bytes(fig, "svg")
    b = figure_bytes(oil_before_after_figure(before, after, title="after 5 shots"), "svg")
    _svg_ok(a)
    assert a == b
    png = figure_bytes(oil_before_after_figure(before, after, title="x"), "png")
    assert png.startswith(b"\x89PNG")


def test_oil_before_after_shows_the_grids() -> None:
    """Worn by five tracks: 21.80 mL before, less after, every cell and board as the grids
    hold them."""
    before, after = _worn()
    assert not np.array_equal(before.volume_ul, after.volume_ul)
    fig = oil_before_after_figure(before, after, title="after 5 shots")
    _check_oil_figure(fig, before, after, _per_board(after))
    assert fig.get_suptitle() == "after 5 shots"
    assert fig.axes[0].get_title() == "before: 21.80 mL"
    assert fig.axes[1].get_title() == f"after: {after.volume_ul.sum() / 1000:.2f} mL"
    assert after.volume_ul.sum() < before.volume_ul.sum() - 100.0  # the tracks took oil


def test_oil_before_after_on_other_cells() -> None:
    """An after grid of 2 ft x 3 board cells is shown on before's 1 ft x 1 board cells, its
    volume conserved, each 3-board column spread evenly over its boards."""
    before = session_oil_grid(preset("house_shot_approx"))
    after = session_oil_grid(preset("house_shot_approx"), cell_ft=2.0, cell_boards=3.0)
    fig = oil_before_after_figure(before, after, title="t")
    _svg_ok(figure_bytes(fig, "svg"))
    shown = np.asarray(_mesh(fig.axes[1]).get_array())
    assert shown.shape == before.volume_ul.shape
    assert float(shown.sum()) == pytest.approx(after.volume_ul.sum(), rel=1e-12)  # 1 ft x 1 board
    assert fig.axes[1].get_title() == f"after: {after.volume_ul.sum() / 1000:.2f} mL"
    heights = np.array([r.get_height() for r in fig.axes[3].containers[1]])
    assert np.allclose(heights, _per_board(after), rtol=1e-12)
    assert np.allclose(heights.reshape(13, 3), heights.reshape(13, 3)[:, :1])  # even per column


# --- the drift -----------------------------------------------------------------------------------


def test_drift_renders_deterministically() -> None:
    shots = _shots()
    a = figure_bytes(drift_figure(shots), "svg")
    assert a == figure_bytes(drift_figure(shots, by="game"), "svg")
    _svg_ok(a)
    assert figure_bytes(drift_figure(shots), "png").startswith(b"\x89PNG")
    _svg_ok(figure_bytes(drift_figure([]), "svg"))


def test_drift_shows_the_shots() -> None:
    """Ann (C0) and Bo (C1), 12 shots each; shot 6 (Bo's) went in the gutter: no entry board,
    so 11 of Bo's entry boards and game 1's entry mean of 7 shots."""
    shots: list[dict[str, Any]] = _shots()
    fig = drift_figure(shots)
    _check_drift(fig, shots)
    assert len(_points(fig)["entry_board", "Bo"]) == 11
    assert len(_means(fig)["entry_board"]) == 3  # games 1-3
    assert fig.axes[-1].get_xlabel() == "shot in the session"


def test_drift_means_per_bowler() -> None:
    shots: list[dict[str, Any]] = _shots()
    fig = drift_figure(shots, by="bowler")
    _check_drift(fig, shots, by="bowler")


def test_drift_of_no_shots_says_so() -> None:
    fig = drift_figure([])
    assert [t.get_text() for t in fig.axes[0].texts] == ["no shots"]
    assert all(not ax.get_lines() for ax in fig.axes)


def test_unknown_format() -> None:
    with pytest.raises(ValueError, match="fmt"):
        figure_bytes(drift_figure(_shots()), "pdf")


# --- a session's figures against its table ------------------------------------------------------


def test_a_sessions_figures_show_its_table(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Six shots of two bowlers (B, laid down on board 2 and launched outward, goes in the
    gutter): the figures the session writes show the shots of its shots.csv and the oil of its
    fresh and final lane."""
    from bowlrec.cli.session import write_outputs
    from bowlrec.session.runner import run_session
    from bowlrec.session.spec import parse_session

    spec = parse_session(
        {
            "name": "t",
            "games": 1,
            "seed": 3,
            "pins": False,
            "grid": {"cell_ft": 3.0, "cell_boards": 1.0},
            "record_dt_s": 0.01,
            "bowlers": [
                {"name": "A", "scene": {}, "scatter": "robot", "aim": False},
                {
                    "name": "B",
                    "scene": {
                        "delivery": {
                            "rev_rate_rpm": 250.0,
                            "laydown_board": 2.0,
                            "launch_angle_deg": -4.0,
                            "target_board_at_arrows": None,
                        }
                    },
                    "scatter": "league",
                    "aim": False,
                },
            ],
        }
    )
    result = run_session(spec, None, max_shots=6)
    rendered: list[Figure] = []
    svgs: list[bytes] = []
    real = figure_bytes

    def spy(fig: Figure, fmt: str = "svg") -> bytes:
        if not any(fig is f for f in rendered):
            rendered.append(fig)
        data = real(fig, fmt)
        if fmt == "svg":
            svgs.append(data)
        return data

    monkeypatch.setattr(render, "figure_bytes", spy)
    write_outputs(result, tmp_path)
    oil, drift = rendered
    with open(tmp_path / "shots.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [r["shot"] for r in table] == ["1", "2", "3", "4", "5", "6"]
    assert {r["bowler"] for r in table} == {"A", "B"}
    assert any(r["entry_board"] == "" for r in table)  # a gutter ball: no entry
    shots = [
        {
            "shot": int(r["shot"]),
            "game": int(r["game"]),
            "bowler": r["bowler"],
            **{key: float(r[key]) if r[key] else math.nan for key, _ in PANELS},
        }
        for r in table
    ]
    _check_drift(drift, shots)
    _check_oil_figure(oil, result.fresh, result.final, _per_board(result.final))
    assert oil.get_suptitle() == "t: oil before and after"
    final_ul = float(table[-1]["lane_oil_ul"])  # the lane's oil after the last shot
    assert oil.axes[1].get_title() == f"after: {final_ul / 1000:.2f} mL"
    # the files written are these figures
    assert [(tmp_path / "oil.svg").read_bytes(), (tmp_path / "drift.svg").read_bytes()] == svgs

"""`bowlrec plot` figures: files written (PNG/SVG), what is drawn, errors and atomic writes."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.image import imread
from matplotlib.lines import Line2D
from matplotlib.quiver import Quiver

import bowlrec
from bowlrec.errors import SamplesRequiredError
from bowlrec.figures.series import plot_series, series_figure
from bowlrec.figures.trajectory import (
    N_AXIS_ARROWS,
    PAPER_EXAGGERATION,
    axis_arrow_samples,
    plot_runs,
    runs_figure,
)
from bowlrec.paper import paper_scene
from bowlrec.spec import Scene
from bowlrec.spec.run import RunData

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
FIG6_CASES = (9, 10, 14, 16)


def _run(scene: Scene, record: str = "rate") -> RunData:
    options = scene.options.model_copy(update={"record": record, "record_dt_s": 0.01})
    scene = scene.model_copy(update={"options": options})
    return RunData(scene=scene, plan=scene.resolve(), trajectory=bowlrec.simulate(scene))


@pytest.fixture(scope="module")
def fig6_runs() -> list[RunData]:
    return [_run(paper_scene(case)) for case in FIG6_CASES]


@pytest.fixture(scope="module")
def case06() -> RunData:
    """Sideways rotation on constant mu = 0.04: slides all the way (never rolls)."""
    return _run(paper_scene(6))


@pytest.fixture(scope="module")
def case04() -> RunData:
    """Forward rotation only: omega along +y."""
    return _run(paper_scene(4))


def _lane_axes(fig: Figure) -> Axes:
    (ax,) = [a for a in fig.axes if a.get_gid() == "lane"]
    return ax


def _lines_by_gid(ax: Axes, prefix: str) -> list[Line2D]:
    return [ln for ln in ax.get_lines() if str(ln.get_gid() or "").startswith(prefix)]


def _only_file(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


# --- files ------------------------------------------------------------------------------------


def test_png_is_written_and_not_blank(fig6_runs: list[RunData], tmp_path: Path) -> None:
    out = plot_runs(fig6_runs[:1], tmp_path / "one.png")
    assert out == tmp_path / "one.png"
    data = out.read_bytes()
    assert data[:8] == PNG_MAGIC
    img = imread(out)
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 800
    rgb = np.round(img[..., :3] * 255).astype(np.int64)
    assert float(rgb.std()) > 10.0
    colors = np.unique(rgb.reshape(-1, 3), axis=0)
    assert colors.shape[0] > 50  # lane shades, gutters, path, text: far from blank


def test_svg_is_written_with_named_artists(fig6_runs: list[RunData], tmp_path: Path) -> None:
    out = plot_runs(fig6_runs[:2], tmp_path / "two.SVG")
    text = out.read_text()
    assert "<svg" in text and text.rstrip().endswith("</svg>")
    for gid in ("path:0", "path:1", "slide_to_roll:0", "slide_to_roll:1", "friction"):
        assert f'id="{gid}"' in text
    assert _only_file(tmp_path) == ["two.SVG"]
    umask = os.umask(0o022)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask  # not the temp file's 0o600


def test_existing_file_is_replaced_and_no_temp_files_remain(
    fig6_runs: list[RunData], tmp_path: Path
) -> None:
    out = tmp_path / "fig.png"
    out.write_bytes(b"old")
    plot_runs(fig6_runs[:1], out)
    assert out.read_bytes()[:8] == PNG_MAGIC
    plot_series(fig6_runs[0], tmp_path / "series.svg")
    assert _only_file(tmp_path) == ["fig.png", "series.svg"]


def test_failed_write_leaves_nothing(
    fig6_runs: list[RunData], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(self: Figure, *args: object, **kwargs: object) -> None:
        raise RuntimeError("disk full")

    monkeypatch.setattr(Figure, "savefig", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        plot_runs(fig6_runs[:1], tmp_path / "fig.png")
    assert _only_file(tmp_path) == []


@pytest.mark.parametrize("name", ["fig.pdf", "fig.jpg", "fig", "fig.png.txt"])
def test_unsupported_suffix_raises(fig6_runs: list[RunData], tmp_path: Path, name: str) -> None:
    with pytest.raises(ValueError, match=r"\.png or \.svg"):
        plot_runs(fig6_runs[:1], tmp_path / name)
    with pytest.raises(ValueError, match=r"\.png or \.svg"):
        plot_series(fig6_runs[0], tmp_path / name)
    assert _only_file(tmp_path) == []


def test_summary_only_run_raises(tmp_path: Path) -> None:
    run = _run(Scene.model_validate({}), record="summary")
    assert run.trajectory.n_samples == 0
    with pytest.raises(SamplesRequiredError, match="plot needs samples"):
        plot_runs([run], tmp_path / "fig.png")
    with pytest.raises(SamplesRequiredError, match="record"):
        plot_series(run, tmp_path / "series.png")
    assert _only_file(tmp_path) == []


def test_no_runs_or_bad_exaggeration_raise(fig6_runs: list[RunData]) -> None:
    with pytest.raises(ValueError, match="at least one run"):
        runs_figure([])
    for bad in (0.0, -1.0, float("nan"), float("inf"), 1e9):
        with pytest.raises(ValueError, match=r"exaggerate = .* must be in \(0, 100\]"):
            runs_figure(fig6_runs[:1], exaggerate=bad)


# --- what the lane figure shows -------------------------------------------------------------


def test_fig6_overlay_has_one_legend_entry_per_run(fig6_runs: list[RunData]) -> None:
    fig = runs_figure(fig6_runs, title="Fig. 6")
    ax = _lane_axes(fig)
    legend = ax.get_legend()
    assert legend is not None
    texts = [t.get_text() for t in legend.get_texts()]
    assert len(texts) == len(FIG6_CASES)
    for run, text in zip(fig6_runs, texts, strict=True):
        s = run.trajectory.summary
        assert s.hook_m is not None and s.pocket_deg is not None and s.slide_m is not None
        assert text.startswith(run.name)
        assert f"hook {s.hook_m * 100:.0f} cm" in text
        assert f"pocket {s.pocket_deg:.1f}°" in text
        assert f"slide {s.slide_m:.2f} m" in text
    colors = {ln.get_color() for ln in _lines_by_gid(ax, "path:")}
    assert len(colors) == len(FIG6_CASES)
    assert ax.get_title() == "Fig. 6"


def test_path_is_the_trajectory(fig6_runs: list[RunData]) -> None:
    ax = _lane_axes(runs_figure(fig6_runs))
    for k, run in enumerate(fig6_runs):
        (line,) = _lines_by_gid(ax, f"path:{k}")
        np.testing.assert_array_equal(line.get_xdata(), run.trajectory.position_m[:, 0])
        np.testing.assert_array_equal(line.get_ydata(), run.trajectory.position_m[:, 1])


def test_slide_to_roll_tick_is_at_slide_m(fig6_runs: list[RunData]) -> None:
    ax = _lane_axes(runs_figure(fig6_runs))
    for k, run in enumerate(fig6_runs):
        (tick,) = _lines_by_gid(ax, f"slide_to_roll:{k}")
        slide = run.trajectory.summary.slide_m
        assert slide is not None
        (x,), (y,) = np.asarray(tick.get_xdata()), np.asarray(tick.get_ydata())
        assert x == pytest.approx(slide, abs=1e-9)
        pos = run.trajectory.position_m
        assert y == pytest.approx(np.interp(slide, pos[:, 0], pos[:, 1]), abs=2e-3)
        assert tick.get_marker() == "|"


def test_never_rolling_run_has_no_tick(case06: RunData) -> None:
    assert case06.trajectory.summary.slide_m is None
    ax = _lane_axes(runs_figure([case06]))
    assert _lines_by_gid(ax, "slide_to_roll") == []
    legend = ax.get_legend()
    assert legend is not None
    assert "no roll" in legend.get_texts()[0].get_text()


def test_other_outcomes_and_differing_lanes_are_labeled(
    fig6_runs: list[RunData], case06: RunData
) -> None:
    gutter = _run(
        Scene.model_validate({"name": "gutterball", "delivery": {"takeoff_angle_deg": -4}})
    )
    assert gutter.trajectory.summary.outcome == "gutter"
    legend = _lane_axes(runs_figure([fig6_runs[0], case06, gutter])).get_legend()
    assert legend is not None
    assert "lanes differ" in legend.get_title().get_text()
    x_end = gutter.trajectory.summary.x_end_m
    assert legend.get_texts()[2].get_text().endswith(f"gutter at x = {x_end:.2f} m")
    same = _lane_axes(runs_figure(fig6_runs)).get_legend()
    assert same is not None and same.get_title().get_text() == ""


def test_width_is_exaggerated(fig6_runs: list[RunData]) -> None:
    assert _lane_axes(runs_figure(fig6_runs[:1])).get_aspect() == PAPER_EXAGGERATION
    assert _lane_axes(runs_figure(fig6_runs[:1], exaggerate=2.0)).get_aspect() == 2.0


def test_axis_arrows_show_horizontal_omega_in_page_angles(
    case04: RunData, fig6_runs: list[RunData]
) -> None:
    pts, uv = axis_arrow_samples(case04, phase=0.0)
    assert pts.shape == uv.shape == (N_AXIS_ARROWS, 2)
    assert np.all(np.diff(pts[:, 0]) > 0.0)  # spread along the path
    np.testing.assert_allclose(pts[0], case04.trajectory.position_m[0, :2])
    # forward rotation: omega0 along +y (leftward), horizontal: a unit arrow pointing up
    np.testing.assert_allclose(uv[0], [0.0, 1.0], atol=1e-9)
    assert np.all(np.linalg.norm(uv, axis=1) <= 1.0 + 1e-12)
    # cases 9-16: omega inclined 15 deg above horizontal at release
    _, uv9 = axis_arrow_samples(fig6_runs[0], phase=0.0)
    assert np.linalg.norm(uv9[0]) == pytest.approx(np.cos(np.radians(15.0)), abs=1e-6)
    ax = _lane_axes(runs_figure(fig6_runs))
    quivers = [c for c in ax.collections if isinstance(c, Quiver)]
    assert len(quivers) == len(fig6_runs)
    assert all(q.angles == "uv" for q in quivers)  # drawn at true angles on the page


# --- the time-series figure -----------------------------------------------------------------


def test_series_figure_panels_and_events(fig6_runs: list[RunData], tmp_path: Path) -> None:
    run = fig6_runs[3]
    fig = series_figure(run)
    panels = [a for a in fig.axes if a.get_gid() is not None]
    assert [a.get_gid() for a in panels] == [
        "speed_mps",
        "rev_rate_rpm",
        "slip_speed_mps",
        "mu",
    ]
    kinds = [e.kind for e in run.trajectory.events]
    for ax in panels:
        lines = _lines_by_gid(ax, "event:")
        assert [ln.get_gid() for ln in lines] == [f"event:{k}" for k in kinds]
    (roll,) = [e for e in run.trajectory.events if e.kind == "slide_to_roll"]
    (roll_line,) = _lines_by_gid(panels[0], "event:slide_to_roll")
    assert np.asarray(roll_line.get_xdata())[0] == pytest.approx(roll.t_s)
    out = plot_series(run, tmp_path / "series.png")
    assert out.read_bytes()[:8] == PNG_MAGIC
    assert float(imread(out)[..., :3].std()) > 0.02

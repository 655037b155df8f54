"""`bowlrec plot` of many runs: distinct colors and styles, numbered paths, a numbered legend
in columns below the lane, and a lane of the same size as for a few runs."""

from __future__ import annotations

import dataclasses
import itertools
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.image import imread
from matplotlib.lines import Line2D
from matplotlib.text import Annotation, Text
from matplotlib.transforms import Bbox
from typer.testing import CliRunner

import bowlrec
from bowlrec.cli import app
from bowlrec.figures.numbered import NUMBERED_LEGEND_WIDTH_IN, NUMBERED_LINE_STYLES
from bowlrec.figures.trajectory import (
    MAX_PLAIN_RUNS,
    N_AXIS_ARROWS,
    axis_arrow_samples,
    runs_figure,
)
from bowlrec.spec import Scene
from bowlrec.spec.run import RunData

ROOT = Path(__file__).resolve().parents[1]
CASE16 = ROOT / "examples/paper/case16.json"
runner = CliRunner()
#: the lane's oil shade (lowest mu of case 16's two values), as the PNG's 8-bit RGB
OIL_RGB = (0xB6, 0x96, 0x65)


def _scene_dict(k: int) -> dict[str, Any]:
    """Paper case 16 released at 6.0 + 0.2 k m/s (k < 5 end in the left gutter), 10 ms samples."""
    data: dict[str, Any] = json.loads(CASE16.read_text())
    speed = 6.0 + 0.2 * k
    data["name"] = f"case16-v{speed:.1f}"
    data["delivery"]["speed_mps"] = speed
    data["options"].update(record="rate", record_dt_s=0.01)
    return data


@pytest.fixture(scope="module")
def forty() -> list[RunData]:
    runs = []
    for k in range(40):
        scene = Scene.model_validate(_scene_dict(k))
        runs.append(RunData(scene=scene, plan=scene.resolve(), trajectory=bowlrec.simulate(scene)))
    return runs


def _lane_axes(fig: Figure) -> Axes:
    (ax,) = [a for a in fig.axes if a.get_gid() == "lane"]
    return ax


def _paths(ax: Axes) -> list[Line2D]:
    paths = [ln for ln in ax.get_lines() if str(ln.get_gid() or "").startswith("path:")]
    return sorted(paths, key=lambda ln: int(str(ln.get_gid()).split(":")[1]))


def _numbers(ax: Axes) -> dict[int, Annotation]:
    """Run index -> its number on the lane."""
    return {
        int(str(t.get_gid()).split(":")[1]): t
        for t in ax.texts
        if isinstance(t, Annotation) and str(t.get_gid() or "").startswith("run_number:")
    }


def _drawn(fig: Figure) -> FigureCanvasAgg:
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas


def _size_in(fig: Figure, box: Bbox) -> tuple[float, float]:
    return box.width / fig.dpi, box.height / fig.dpi


def _text_box(text: Text, canvas: FigureCanvasAgg) -> Bbox:
    """The box of the text itself (an annotation's box would include its line)."""
    return Text.get_window_extent(text, canvas.get_renderer())


@pytest.mark.parametrize("n", [18, 40])
def test_every_run_has_its_own_color_and_style(forty: list[RunData], n: int) -> None:
    paths = _paths(_lane_axes(runs_figure(forty[:n])))
    assert len(paths) == n
    pairs = [(ln.get_color(), ln.get_linestyle()) for ln in paths]
    assert len(set(pairs)) == n
    assert {style for _, style in pairs} <= set(NUMBERED_LINE_STYLES)
    # neighbours in the list differ in color
    assert all(a[0] != b[0] for a, b in itertools.pairwise(pairs))


@pytest.mark.parametrize("n", [18, 40])
def test_every_run_is_numbered_on_the_lane_and_in_the_legend(forty: list[RunData], n: int) -> None:
    runs = forty[:n]
    ax = _lane_axes(runs_figure(runs))
    numbers = _numbers(ax)
    assert sorted(numbers) == list(range(n))
    texts = [t.get_text() for t in ax.texts]
    paths = _paths(ax)
    for k, run in enumerate(runs):
        number = numbers[k]
        assert number.get_text() == str(k + 1) and str(k + 1) in texts
        assert number.get_color() == paths[k].get_color()
        # joined to the end of its path
        end = run.trajectory.position_m[-1, :2]
        np.testing.assert_allclose(number.xy, end)
    legend = ax.get_legend()
    assert legend is not None
    entries = [t.get_text() for t in legend.get_texts()]
    assert len(entries) == n
    for k, (run, entry, handle) in enumerate(
        zip(runs, entries, legend.legend_handles, strict=True)
    ):
        assert entry.startswith(f"{k + 1}. {run.name}: ")
        assert isinstance(handle, Line2D)
        assert (handle.get_color(), handle.get_linestyle()) == (
            paths[k].get_color(),
            paths[k].get_linestyle(),
        )
    s = runs[-1].trajectory.summary
    assert s.hook_m is not None and f"hook {s.hook_m * 100:.0f} cm" in entries[-1]
    assert entries[0].endswith(f"gutter at x = {runs[0].trajectory.summary.x_end_m:.2f} m")


@pytest.mark.parametrize("n", [18, 40])
def test_lane_keeps_its_size_and_nothing_overlaps_it(forty: list[RunData], n: int) -> None:
    few = runs_figure(forty[5:7])
    few_ax = _lane_axes(few)
    _drawn(few)
    few_size = _size_in(few, few_ax.get_window_extent())

    fig = runs_figure(forty[:n])
    ax = _lane_axes(fig)
    canvas = _drawn(fig)
    lane = ax.get_window_extent()
    assert _size_in(fig, lane) == pytest.approx(few_size, abs=1e-6)
    assert ax.get_xlim() == few_ax.get_xlim() and ax.get_ylim() == few_ax.get_ylim()
    page = fig.bbox
    legend = ax.get_legend()
    assert legend is not None
    box = legend.get_window_extent(canvas.get_renderer())
    assert not box.overlaps(lane) and box.y1 < lane.y0  # below the lane
    assert page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0  # inside the figure
    assert box.width <= NUMBERED_LEGEND_WIDTH_IN * fig.dpi
    columns = {round(t.get_window_extent().x0) for t in legend.get_texts()}
    assert len(columns) >= 2  # in columns, not one long list
    # the mu colorbar, the title and the symbol key are beside or above the lane
    (colorbar,) = [c for c in ax.child_axes if c.get_label() == "inset_axes"]
    assert colorbar.get_window_extent().x0 > lane.x1
    assert ax.title.get_window_extent().y0 >= lane.y1
    (key,) = [t for t in ax.texts if t.get_text().startswith("|  start of rolling")]
    assert key.get_window_extent().y0 >= lane.y1
    # the run numbers lie inside the lane axes, none on top of another
    boxes = [_text_box(t, canvas) for t in _numbers(ax).values()]
    for b in boxes:
        assert lane.x0 <= b.x0 and b.x1 <= lane.x1 and lane.y0 <= b.y0 and b.y1 <= lane.y1
    for a, b in itertools.combinations(boxes, 2):
        assert not a.overlaps(b), (a, b)


def test_numbers_past_two_columns_widen_the_space_beyond_the_lane(
    forty: list[RunData],
) -> None:
    # 70 paths reaching the pins (each of 35 twice, under other names): three columns of numbers
    reaching = [r for r in forty if r.trajectory.summary.outcome == "pins"]
    assert len(reaching) == 35
    runs = reaching + [
        dataclasses.replace(r, scene=r.scene.model_copy(update={"name": f"{r.name}-again"}))
        for r in reaching
    ]
    fig = runs_figure(runs)
    ax = _lane_axes(fig)
    canvas = _drawn(fig)
    lane = ax.get_window_extent()
    length = float(runs[0].plan.lane_length_m)
    assert ax.get_xlim()[1] > length + 0.9  # the usual 0.9 m beyond the lane end is too narrow
    numbers = _numbers(ax)
    assert sorted(numbers) == list(range(70))
    boxes = [_text_box(t, canvas) for t in numbers.values()]
    assert len({round(b.x0) for b in boxes}) >= 3
    for b in boxes:
        assert lane.x0 <= b.x0 and b.x1 <= lane.x1 and lane.y0 <= b.y0 and b.y1 <= lane.y1
    for a, b in itertools.combinations(boxes, 2):
        assert not a.overlaps(b), (a, b)


def test_up_to_eight_runs_keep_the_plain_figure(forty: list[RunData]) -> None:
    ax = _lane_axes(runs_figure(forty[:MAX_PLAIN_RUNS]))
    paths = _paths(ax)
    assert {ln.get_linestyle() for ln in paths} == {"-"}
    assert len({ln.get_color() for ln in paths}) == MAX_PLAIN_RUNS
    assert _numbers(ax) == {}
    legend = ax.get_legend()
    assert legend is not None
    assert [t.get_text() for t in legend.get_texts()][0].startswith(f"{forty[0].name}: ")
    assert "head\npin" in [t.get_text() for t in ax.texts]
    assert "head\npin" not in [t.get_text() for t in _lane_axes(runs_figure(forty[:9])).texts]


def test_many_runs_draw_fewer_axis_arrows_each(forty: list[RunData]) -> None:
    pts, uv = axis_arrow_samples(forty[10], phase=0.25, count=3)
    assert pts.shape == uv.shape == (3, 2)
    full, _ = axis_arrow_samples(forty[10], phase=0.25)
    assert full.shape == (N_AXIS_ARROWS, 2)
    ax = _lane_axes(runs_figure(forty))
    arrows = sum(
        np.asarray(c.get_offsets()).shape[0]
        for c in ax.collections
        if c.get_gid() == "omega_arrows"
    )
    assert len(forty) <= arrows <= 2 * len(forty)


# --- the command line -----------------------------------------------------------------------


def _oil_columns(png: Path) -> int:
    """How many pixel columns of the PNG show the oil shade: the oiled length on the page."""
    rgb = np.round(imread(png)[..., :3] * 255).astype(np.int64)
    oil = np.all(rgb == np.array(OIL_RGB), axis=2)
    return int(np.count_nonzero(oil.any(axis=0)))


def test_cli_plot_of_18_scene_files_keeps_the_lane_readable(tmp_path: Path) -> None:
    files = []
    for k in range(18):
        path = tmp_path / f"scene{k:02d}.json"
        path.write_text(json.dumps(_scene_dict(k)))
        files.append(str(path))

    def plot(names: list[str], out: Path) -> Path:
        result = runner.invoke(app, ["plot", *names, "-o", str(out)])
        assert result.exit_code == 0, result.output
        assert result.output.strip() == str(out)
        return out

    two = imread(plot(files[5:7], tmp_path / "two.png"))
    many_png = plot(files, tmp_path / "eighteen.png")
    many = imread(many_png)
    # the figure grows downward for the legend; the lane is as wide as for two runs
    assert many.shape[1] == pytest.approx(two.shape[1], abs=40)
    assert many.shape[1] >= 1700
    assert two.shape[0] < many.shape[0] <= 2 * two.shape[0]
    assert _oil_columns(many_png) == pytest.approx(_oil_columns(tmp_path / "two.png"), abs=2)
    assert _oil_columns(many_png) > 800  # 12.2 m of oil at about 0.49 in/m and 150 dpi

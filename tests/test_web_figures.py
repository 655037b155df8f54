"""Figures of the web pages as bytes: :mod:`bowlrec.figures` rendered by
:func:`bowlrec.figures.render.figure_bytes`, as the web API serves them."""

from __future__ import annotations

import io
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from typing import Any

import pytest
from helpers.scene_builders import scene as scene_dict

from bowlrec.archive.replay import simulate_sampled
from bowlrec.bowling.ball import BowlerBall
from bowlrec.bowling.layout import PAP, DualAngle
from bowlrec.bowling.oil import preset, preset_names
from bowlrec.figures import ball as ball_map
from bowlrec.figures import oil, sweep, trajectory
from bowlrec.figures.render import figure_bytes
from bowlrec.spec import Scene
from bowlrec.spec.run import RunData

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run_figure(run: RunData, fmt: str) -> bytes:
    return figure_bytes(trajectory.runs_figure([run]), fmt)


def compare_figure(runs: list[RunData], fmt: str) -> bytes:
    return figure_bytes(trajectory.runs_figure(runs), fmt)


def pattern_figure(pattern: Any, fmt: str, *, title: str | None = None) -> bytes:
    return figure_bytes(oil.pattern_figure(pattern, title=title), fmt)


def sweep_figure(x: list[float], y: list[float | None], *, fmt: str, **labels: Any) -> bytes:
    return figure_bytes(sweep.sweep_figure(x, y, **labels), fmt)


def ball_figure(entry_or_ball: Any, fmt: str, **layout: Any) -> bytes | None:
    fig = ball_map.ball_figure(entry_or_ball, **layout)
    return None if fig is None else figure_bytes(fig, fmt)


def _svg_root(data: bytes) -> ET.Element:
    root = ET.fromstring(data)
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    assert b"<image" not in data  # no embedded rasters
    return root


def _png_size(data: bytes) -> tuple[int, int]:
    from PIL import Image

    assert data.startswith(PNG_MAGIC)
    with Image.open(io.BytesIO(data)) as im:
        im.load()
        return im.size


@pytest.fixture(scope="module")
def runs() -> list[RunData]:
    out = []
    for k in range(12):
        d = scene_dict(omega=(-3.0 * k, 30.0, 0.0), record="summary", name=f"run{k}")
        d["name"] = f"run{k}"
        d["options"].pop("name")
        out.append(simulate_sampled(Scene.model_validate(d), 0.02))
    return out


@pytest.mark.process  # a fresh interpreter's modules
def test_import_does_not_import_matplotlib() -> None:
    """The figures package, and the layers that call it, import matplotlib only when a figure
    is drawn."""
    code = (
        "import sys, bowlrec.figures, bowlrec.web.api, bowlrec.sinks.registry, "
        "bowlrec.bowling.variance, bowlrec.session.runner, bowlrec.cli.aim, bowlrec.cli.session; "
        "print('matplotlib' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_matplotlib_only_in_the_figures_package_and_never_pyplot() -> None:
    """Only ``bowlrec/figures/`` imports matplotlib, and nothing imports pyplot or switches
    matplotlib's global backend (the service draws in several threads)."""
    import ast
    from pathlib import Path

    import bowlrec

    package = Path(bowlrec.__file__).parent
    found = []
    for path in sorted(package.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        inside = path.relative_to(package).parts[0] == "figures"
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Attribute) and node.attr == "use":
                names = [ast.unparse(node)]
            for name in names:
                global_state = "pyplot" in name or name == "matplotlib.use"
                outside = name.split(".")[0] == "matplotlib" and not inside
                if global_state or outside:
                    found.append(f"{path.relative_to(package)}:{node.lineno}: {name}")
    assert found == []


def test_figures_render_the_same_bytes_in_threads_at_once() -> None:
    """Threads drawing and rendering at once (as the service's do) get the bytes a single
    render gives: nothing global is left half set."""
    from concurrent.futures import ThreadPoolExecutor

    def draw(k: int) -> bytes:
        fmt = "svg" if k % 2 == 0 else "png"
        return sweep_figure([1.0, 2.0, 3.0], [3.0, 1.0, 2.0], x_label="a", y_label="b", fmt=fmt)

    expected = {0: draw(0), 1: draw(1)}
    with ThreadPoolExecutor(8) as pool:
        got = list(pool.map(draw, range(32)))
    assert all(data == expected[k % 2] for k, data in enumerate(got))


def test_run_figure_svg_is_deterministic_and_png_decodes(runs: list[RunData]) -> None:
    svg = run_figure(runs[0], "svg")
    _svg_root(svg)
    assert run_figure(runs[0], "svg") == svg
    assert b"<dc:date>" not in svg
    w, h = _png_size(run_figure(runs[0], "png"))
    assert 600 < w < 1600 and 100 < h < 1000


@pytest.mark.parametrize("n", [2, 12])
def test_compare_figure(runs: list[RunData], n: int) -> None:
    svg = compare_figure(runs[:n], "svg")
    root = _svg_root(svg)
    gids = {el.get("id") for el in root.iter()}
    if n > 8:
        assert len({g for g in gids if g and g.startswith("run_number:")}) == n
    assert compare_figure(runs[:n], "svg") == svg
    _png_size(compare_figure(runs[:n], "png"))


def test_bad_format_raises(runs: list[RunData]) -> None:
    with pytest.raises(ValueError, match="fmt"):
        run_figure(runs[0], "pdf")


@pytest.mark.parametrize("name", preset_names())
def test_pattern_figure_every_preset(name: str) -> None:
    pattern = preset(name)
    svg = pattern_figure(pattern, "svg")
    _svg_root(svg)
    assert pattern_figure(pattern, "svg") == svg
    assert pattern_figure(pattern, "svg", title="other") != svg
    w, h = _png_size(pattern_figure(pattern, "png"))
    assert w > h > 200


def test_sweep_figure_skips_nan_and_none() -> None:
    x = [3.0, 1.0, 2.0, 4.0, 5.0]
    y = [0.3, 0.1, math.nan, None, 0.5]
    svg = sweep_figure(x, y, x_label="speed (m/s)", y_label="hook (m)", title="t", fmt="svg")
    _svg_root(svg)
    assert svg == sweep_figure(
        x, y, x_label="speed (m/s)", y_label="hook (m)", title="t", fmt="svg"
    )
    _png_size(sweep_figure(x, y, x_label="a", y_label="b", fmt="png"))
    _svg_root(sweep_figure([1.0], [None], x_label="a", y_label="b", fmt="svg"))
    with pytest.raises(ValueError):
        sweep_figure([1.0, 2.0], [1.0], x_label="a", y_label="b", fmt="svg")


def test_sweep_joins_points_in_x_order(monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.axes import Axes

    seen: list[tuple[list[float], list[float]]] = []
    real = Axes.plot

    def spy(self: Axes, *args: object, **kwargs: object) -> object:
        seen.append((list(args[0]), list(args[1])))  # type: ignore[call-overload]
        return real(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(Axes, "plot", spy)
    sweep_figure([3.0, 1.0, 2.0], [30.0, 10.0, math.nan], x_label="a", y_label="b", fmt="svg")
    assert seen == [([1.0, 3.0], [10.0, 30.0])]


def test_ball_figure() -> None:
    ball = BowlerBall(
        name="asym",
        weight_lb=15.0,
        rg_in=2.48,
        differential_in=0.05,
        intermediate_differential_in=0.015,
        core_type="asymmetric",
        coverstock="reactive_solid",
        surface=2000,
    )
    layout = DualAngle(drilling_angle_deg=45.0, pin_to_pap_in=4.5, val_angle_deg=30.0)
    svg = ball_figure(ball, "svg", layout=layout, pap=PAP(over_in=5.0, up_in=0.5))
    assert svg is not None
    _svg_root(svg)
    assert ball_figure(ball, "svg", layout=layout) == svg
    png = ball_figure(ball, "png", layout=layout)
    assert png is not None
    _png_size(png)
    assert ball_figure(ball, "svg") is None
    assert ball_figure(Scene.model_validate(scene_dict()).ball, "svg", layout=layout) is None

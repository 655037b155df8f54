"""Release scatter: repeats of a shot with a bowler's spread, and the share in the pocket."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from matplotlib.patches import Rectangle
from typer.testing import CliRunner

import bowlrec
from bowlrec.bowling.pocket import POCKET
from bowlrec.bowling.scene import BowlerScene, Shot
from bowlrec.bowling.variance import PRESETS, ReleaseScatter, draw_releases, release_scatter
from bowlrec.cli import app

EXAMPLE = Path(__file__).parents[1] / "examples" / "bowler" / "pocket-right.json"


def _scene() -> BowlerScene:
    return BowlerScene.model_validate(json.loads(EXAMPLE.read_text()))


def test_no_scatter_repeats_the_aimed_shot_exactly() -> None:
    scene = _scene()
    result = release_scatter(
        scene, ReleaseScatter(**dict.fromkeys(ReleaseScatter.model_fields, 0.0)), n=3
    )
    single = bowlrec.simulate(
        scene.to_scene().model_copy(
            update={"options": scene.options.model_copy(update={"record": "summary"})}
        )
    ).summary
    assert single.y_end_m is not None
    board = scene.lane.y_to_board(single.y_end_m, "right")
    assert result.entry_board == pytest.approx([board] * 3, abs=1e-9)
    assert result.pocket_share == 1.0  # the example is aimed into the window


def test_more_scatter_fewer_strikes_and_a_wider_spread() -> None:
    scene = _scene()
    shares, spreads = [], []
    for name in ("robot", "pro", "league"):
        r = release_scatter(scene, PRESETS[name], n=400, seed=1)
        shares.append(r.pocket_share)
        spreads.append(float(np.nanstd(r.entry_board)))
    assert shares[0] > shares[1] > shares[2]
    assert spreads[0] < spreads[1] < spreads[2]
    # the spread of the entry board grows with the launch-angle sigma roughly in proportion
    assert 2.0 < spreads[1] / spreads[0] < 30.0


def test_same_seed_same_result() -> None:
    a = release_scatter(_scene(), PRESETS["pro"], n=50, seed=7)
    b = release_scatter(_scene(), PRESETS["pro"], n=50, seed=7)
    assert np.array_equal(a.entry_board, b.entry_board, equal_nan=True)


def _independent_entries(
    scene: BowlerScene, preset: str, n: int, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """Entry board and angle of the command's repeats (the same draws), each run on its own
    through the public path (``BowlerScene.to_scene`` and ``bowlrec.simulate``), not through
    :class:`~bowlrec.bowling.shot.Shot`'s plans and the many-delivery kernel."""
    launch = Shot(scene).launch_angle(scene.delivery)
    repeats = draw_releases(scene.delivery, launch, PRESETS[preset], np.random.default_rng(seed), n)
    summary_only = scene.options.model_copy(update={"record": "summary"})
    boards, angles = [], []
    for repeat in repeats:
        one = scene.model_copy(update={"delivery": repeat, "options": summary_only})
        s = bowlrec.simulate(one.to_scene()).summary
        assert s.outcome == "pins" and s.y_end_m is not None and s.pocket_deg is not None
        boards.append(s.y_end_m / (41.5 * 0.0254 / 39.0) + 0.5)  # right-hander: board 1 at y=0
        angles.append(s.pocket_deg)  # a right-hander's entry angle: toward +y
    return np.array(boards), np.array(angles)


def _in_window(
    board: np.ndarray, angle: np.ndarray, boards: tuple[float, float], degs: tuple[float, float]
) -> np.ndarray:
    return (board >= boards[0]) & (board <= boards[1]) & (angle >= degs[0]) & (angle <= degs[1])


def test_variance_command(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The command's shares, statistics and figure against an independent count of the same
    200 repeats (seed 0) run one by one: 21 of them enter the default window (boards 17-18,
    4-6 deg), 25 have the board and 139 the angle in their window, all reach the pins. The
    two paths give the same entry boards and angles to the last bit (the same plans), and the
    closest repeat to an edge of the window is 0.002 deg from it, so the count is exact."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    drawn: list[Figure] = []
    savefig = Figure.savefig

    def spy(self: Figure, *args: object, **kwargs: object) -> None:
        drawn.append(self)
        savefig(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(Figure, "savefig", spy)
    n = 200
    board, angle = _independent_entries(_scene(), "pro", n, seed=0)
    assert (POCKET.board_min, POCKET.board_max) == (17.0, 18.0)
    assert (POCKET.angle_min_deg, POCKET.angle_max_deg) == (4.0, 6.0)
    inside = _in_window(board, angle, (17.0, 18.0), (4.0, 6.0))
    k = int(inside.sum())
    assert 0 < k < n  # both kinds of repeat: the share is not trivially 0 or 1
    # the window is not decided by one of its two conditions alone
    assert int(_in_window(board, angle, (17.0, 18.0), (-90.0, 90.0)).sum()) > k
    assert int(_in_window(board, angle, (0.0, 40.0), (4.0, 6.0)).sum()) > k

    runner = CliRunner()
    fig = tmp_path / "scatter.png"
    res = runner.invoke(
        app,
        ["variance", str(EXAMPLE), "--preset", "pro", "--n", str(n), "--plot", str(fig), "--json"],
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["n"] == n and doc["seed"] == 0 and doc["preset"] == "pro"
    assert doc["scatter"] == PRESETS["pro"].model_dump()
    assert doc["pocket_share"] == k / n
    assert doc["pins_share"] == 1.0
    assert doc["pocket_share_se"] == pytest.approx(math.sqrt(k / n * (1 - k / n) / n), rel=1e-12)
    for name, x in (("entry_board", board), ("entry_angle_deg", angle)):
        assert doc[name] == pytest.approx(
            {
                "mean": x.mean(),
                "std": x.std(ddof=1),
                "p05": np.quantile(x, 0.05),
                "p95": np.quantile(x, 0.95),
            },
            rel=1e-9,
        ), name
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    # the figure: the repeats in the window green, the others gray, the window drawn
    assert len(drawn) == 1
    (ax,) = drawn[0].axes
    out_pts, in_pts = ax.collections
    assert in_pts.get_label() == "in the pocket window"
    assert out_pts.get_label() == "outside the pocket"
    assert np.allclose(np.asarray(in_pts.get_facecolor())[0, :3], to_rgb("tab:green"))
    assert np.allclose(np.asarray(out_pts.get_facecolor())[0, :3], to_rgb("tab:gray"))
    assert np.array_equal(in_pts.get_offsets(), np.column_stack([board, angle])[inside])
    assert np.array_equal(out_pts.get_offsets(), np.column_stack([board, angle])[~inside])
    (window,) = ax.patches
    assert isinstance(window, Rectangle)
    assert (window.get_xy(), window.get_width(), window.get_height()) == ((17.0, 4.0), 1.0, 2.0)
    assert ax.xaxis_inverted()
    share = f"{100 * k / n:.1f} % in the pocket"
    assert ax.get_title() == (
        f"right-hander-pocket, pro: {share} (± {100 * doc['pocket_share_se']:.1f}), "
        f"100.0 % reach the pins, n = {n}"
    )

    # the words: the same share, and another window given by options counts the same repeats
    res = runner.invoke(
        app,
        ["variance", str(EXAMPLE), "--preset", "pro", "--n", str(n), "--board-window", "16",
         "19", "--angle-window", "3.5", "5"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    k2 = int(_in_window(board, angle, (16.0, 19.0), (3.5, 5.0)).sum())
    assert k2 != k
    line = res.output.splitlines()[1]
    assert line.startswith("in the pocket (board 17.5 (16.0-19.0), 5.0 deg (3.5-5.0)): ")
    assert f": {100 * k2 / n:.1f} % " in line, (line, k2)
    assert line.endswith("reach the pins: 100.0 %")

    bad = runner.invoke(app, ["variance", str(EXAMPLE), "--preset", "wild"])
    assert bad.exit_code == 2 and "robot, pro, league" in bad.output


def test_band_of_a_linear_function_is_its_exact_interval() -> None:
    from bowlrec.bowling.variance import _band

    x = np.linspace(10.0, 14.0, 17)
    f = 4.0 * (x - 12.0) + 17.5  # entry board 4 boards per board of target
    assert _band(x, f, 8, 17.0, 18.0) == pytest.approx([11.875, 12.125], abs=1e-12)
    assert _band(x, f, 0, 17.0, 18.0) is None  # the start itself is outside


def test_a_tolerance_cell_is_the_scene_with_that_target_and_speed() -> None:
    from bowlrec.bowling.variance import tolerance_map

    scene = _scene()
    tmap = tolerance_map(
        scene, targets=np.array([13.0, 13.629, 14.0]), speeds_mph=np.array([17.0, 17.5])
    )
    assert tmap.entry_board.shape == (2, 3)
    cell = scene.model_copy(
        update={
            "delivery": scene.delivery.model_copy(
                update={"speed_mph": 17.0, "target_board_at_arrows": 14.0}
            )
        }
    )
    summary = bowlrec.simulate(
        cell.to_scene().model_copy(
            update={"options": scene.options.model_copy(update={"record": "summary"})}
        )
    ).summary
    assert tmap.entry_board[0, 2] == pytest.approx(scene.lane.y_to_board(summary.y_end_m), abs=1e-9)
    assert tmap.entry_angle_deg[0, 2] == pytest.approx(summary.pocket_deg, abs=1e-9)
    d = tmap.to_dict()
    lo, hi = d["target_range_at_scene_speed"]
    assert lo < 13.629 < hi  # the aimed shot lies inside its own band


def test_tolerance_command(tmp_path: Path) -> None:
    fig = tmp_path / "map.svg"
    res = CliRunner().invoke(app, ["tolerance", str(EXAMPLE), "--plot", str(fig), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert len(doc["targets"]) == 25 and len(doc["speeds_mph"]) == 17
    assert fig.read_text().lstrip().startswith("<?xml")

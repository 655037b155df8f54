"""Release scatter: repeats of a shot with a bowler's spread, and the share in the pocket."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import bowlrec
from bowlrec.bowling.scene import BowlerScene
from bowlrec.bowling.variance import PRESETS, ReleaseScatter, release_scatter
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


def test_variance_command(tmp_path: Path) -> None:
    runner = CliRunner()
    fig = tmp_path / "scatter.png"
    res = runner.invoke(
        app,
        ["variance", str(EXAMPLE), "--preset", "pro", "--n", "200", "--plot", str(fig), "--json"],
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["n"] == 200 and 0.0 <= doc["pocket_share"] <= 1.0
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
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

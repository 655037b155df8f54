"""Aiming: the ball crosses its target at the arrows, and `aim` finds the pocket.

The checks are on the simulated path itself, recorded at every step and read by the bowler
report (cubic Hermite between steps, independent of the kernel's observation events)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

import bowlrec
from bowlrec.bowling.aim import aim
from bowlrec.bowling.pocket import POCKET, Pocket
from bowlrec.bowling.report import bowler_report
from bowlrec.bowling.scene import BowlerScene
from bowlrec.cli import app
from bowlrec.core.solver import solve

EXAMPLE = Path(__file__).parents[1] / "examples" / "bowler" / "house-shot-right.json"


def _scene(hand: str = "right", **delivery: float) -> BowlerScene:
    return BowlerScene.model_validate(
        {
            "pap": {"over_in": 5.0, "up_in": 0.5, "handedness": hand},
            "delivery": {"handedness": hand, **delivery},
            "options": {"record": "steps"},
        }
    )


@pytest.mark.parametrize("hand", ["right", "left"])
@pytest.mark.parametrize(("laydown", "target"), [(15.0, 10.0), (25.0, 12.5), (10.0, 8.0)])
def test_the_ball_crosses_its_target_board_at_the_arrows(
    hand: str, laydown: float, target: float
) -> None:
    scene = _scene(hand, laydown_board=laydown, target_board_at_arrows=target)
    traj = bowlrec.simulate(scene.to_scene())
    report = bowler_report(traj, scene.lane, scene.delivery.handedness)
    assert report.arrows_board is not None
    assert report.arrows_board == pytest.approx(target, abs=0.001)  # required: within 0.1 board
    # and the straight sighting line would have missed it: the ball curves before the arrows
    sighted = scene.delivery.to_physical(scene.lane)
    assert abs(scene.to_scene().delivery.takeoff_angle_deg - sighted.takeoff_angle_deg) > 0.01


def test_observing_changes_no_result() -> None:
    plan = _scene(laydown_board=15.0, target_board_at_arrows=10.0).to_scene().resolve()
    plain = solve(plan)
    seen = solve(plan, stations_m=[1.0, 4.572, 15.0], turns=True)
    assert seen.summary == plain.summary
    for a, b in zip(plain.arrays().values(), seen.arrays().values(), strict=True):
        assert (a == b).all()
    assert [o.station for o in seen.observations if o.station >= 0] == [0, 1, 2]
    assert [o.position_m[0] for o in seen.observations if o.station >= 0] == [1.0, 4.572, 15.0]
    assert plain.observations == []


def test_observations_agree_with_the_recorded_path() -> None:
    scene = _scene(laydown_board=15.0, target_board_at_arrows=10.0)
    plan = scene.to_scene().resolve()
    seen = solve(plan, stations_m=[4.572, 16.0], turns=True)
    report = bowler_report(solve(plan), scene.lane, "right")
    at_arrows = next(o for o in seen.observations if o.station == 0)
    assert scene.lane.y_to_board(at_arrows.position_m[1]) == pytest.approx(
        report.arrows_board, abs=1e-6
    )
    turn = next(o for o in seen.observations if o.station == -1)
    assert turn.velocity_mps[1] == pytest.approx(0.0, abs=1e-9)
    assert scene.lane.y_to_board(turn.position_m[1]) == pytest.approx(
        report.breakpoint_board, abs=1e-4
    )


@pytest.mark.parametrize("vary", [["target"], ["launch"], ["laydown"], ["speed"]])
def test_one_free_variable_finds_the_pocket_board(vary: list[str]) -> None:
    scene = _scene(laydown_board=15.0, target_board_at_arrows=10.0)
    result = aim(scene, vary)
    assert result.found, result.message
    # check the answer by simulating the aimed scene with samples, not through the solver
    traj = bowlrec.simulate(result.scene.to_scene())
    report = bowler_report(traj, scene.lane, "right")
    assert report.entry_board == pytest.approx(POCKET.board, abs=0.01)
    assert report.entry_angle_deg == pytest.approx(result.shot.entry_angle_deg, abs=1e-3)
    assert result.seconds < 5.0  # correctness bound only; speed is measured in benchmarks/


def test_two_free_variables_find_board_and_angle() -> None:
    scene = _scene(
        laydown_board=20.0, target_board_at_arrows=11.0, rev_rate_rpm=350.0,
        axis_rotation_deg=50.0, axis_tilt_deg=12.0,
    )  # fmt: skip
    result = aim(scene, ["speed", "target"])
    assert result.found, result.message
    traj = bowlrec.simulate(result.scene.to_scene())
    report = bowler_report(traj, scene.lane, "right")
    assert report.entry_board is not None and report.entry_angle_deg is not None
    assert POCKET.contains(report.entry_board, report.entry_angle_deg)


def test_a_left_hander_aims_at_the_mirrored_pocket() -> None:
    right = aim(_scene("right", laydown_board=15.0, target_board_at_arrows=10.0))
    left = aim(_scene("left", laydown_board=15.0, target_board_at_arrows=10.0))
    assert left.found and right.found
    assert left.values["target"] == pytest.approx(right.values["target"], abs=1e-6)


def test_an_unreachable_pocket_says_so_and_shows_the_closest() -> None:
    narrow = Pocket(board=35.0, board_min=34.9, board_max=35.1)
    result = aim(_scene(laydown_board=5.0, target_board_at_arrows=3.0), ["speed"], narrow)
    assert not result.found
    assert "closest" in result.message and result.shot.entry_board is not None
    assert not narrow.board_ok(result.shot.entry_board)


def test_aim_command(tmp_path: Path) -> None:
    runner = CliRunner()
    out = tmp_path / "aimed.json"
    res = runner.invoke(app, ["aim", str(EXAMPLE), "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["found"] and math.isclose(doc["report"]["entry_board"], 17.5, abs_tol=0.01)
    aimed = json.loads(out.read_text())
    assert aimed["format"] == "bowler"
    assert aimed["delivery"]["target_board_at_arrows"] == pytest.approx(doc["values"]["target"])
    assert doc["written"] == str(out)
    # no solution: exit 1, the closest shown, nothing written
    far = tmp_path / "far.json"
    far.write_text(_scene(laydown_board=5.0, target_board_at_arrows=3.0).model_dump_json())
    missed = tmp_path / "missed.json"
    res = runner.invoke(
        app, ["aim", str(far), "-v", "speed", "--pocket-board", "35",
              "--board-window", "34.9", "35.1", "--out", str(missed)],
    )  # fmt: skip
    assert res.exit_code == 1 and "closest" in res.output and not missed.exists()
    assert "not written" in res.output
    refused = runner.invoke(app, ["aim", str(EXAMPLE), "--out", str(tmp_path / "a.txt")])
    assert refused.exit_code == 2 and "give a .json path" in refused.output
    bad = runner.invoke(app, ["aim", str(EXAMPLE), "--vary", "spin"])
    assert bad.exit_code == 2 and "vary = ['spin']" in bad.output
    physical = tmp_path / "physical.json"
    physical.write_text("{}")
    res = runner.invoke(app, ["aim", str(physical)])
    assert res.exit_code == 2 and "a bowler scene is needed" in res.output

"""BowlerScene: bowler language -> physical scene -> simulation, mirrors, legality, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError
from typer.testing import CliRunner

import bowlrec
from bowlrec.bowling.scene import BowlerScene
from bowlrec.cli import app
from bowlrec.errors import IllegalBallError
from bowlrec.scene_input import parse_scene_file

EXAMPLE = Path(__file__).parents[1] / "examples" / "bowler" / "house-shot-right.json"


def _mirrored(bs: BowlerScene) -> BowlerScene:
    hand = "left" if bs.delivery.handedness == "right" else "right"
    return bs.model_copy(
        update={
            "pap": bs.pap.model_copy(update={"handedness": hand}),
            "delivery": bs.delivery.model_copy(update={"handedness": hand}),
        }
    )


def test_default_bowler_scene_resolves_and_hooks_left_for_a_right_hander() -> None:
    scene = BowlerScene().to_scene()
    assert scene.delivery.speed_mps == pytest.approx(17 * 0.44704, rel=1e-15)
    assert np.linalg.norm(scene.delivery.omega_radps) == pytest.approx(300 * np.pi / 30, rel=1e-14)
    assert scene.ball.rg_m[0] == pytest.approx(2.50 * 0.0254, rel=1e-15)
    summary = bowlrec.simulate(scene).summary
    assert summary.outcome == "pins" and summary.hook_m is not None and summary.hook_m > 0.3


def test_a_left_hander_mirrors_a_right_hander_exactly() -> None:
    right = BowlerScene(balance={"top_oz": 1.0, "side_oz": 0.5, "finger_oz": -0.5})
    s_right = bowlrec.simulate(right.to_scene()).summary
    s_left = bowlrec.simulate(_mirrored(right).to_scene()).summary
    assert s_right.hook_m is not None and s_left.hook_m is not None
    assert s_left.hook_m == pytest.approx(-s_right.hook_m, abs=1e-9)
    assert s_left.slide_m == pytest.approx(s_right.slide_m, abs=1e-9)
    assert s_left.pocket_deg == pytest.approx(-s_right.pocket_deg, abs=1e-9)


def test_illegal_ball_needs_the_explicit_flag() -> None:
    heavy = BowlerScene().ball.model_copy(update={"weight_lb": 16.5})
    with pytest.raises(IllegalBallError, match="weight"):
        BowlerScene(ball=heavy).to_scene()
    scene = BowlerScene(ball=heavy, allow_illegal=True).to_scene()
    assert scene.ball.mass_kg == pytest.approx(16.5 * 0.45359237)
    assert not BowlerScene(ball=heavy).legality().is_legal
    assert BowlerScene(ball=heavy, rules="paper_era").legality().is_legal is False


def test_bad_combinations_name_the_fields() -> None:
    with pytest.raises(ValidationError, match="pap.handedness = 'left' must equal"):
        BowlerScene(pap={"over_in": 5.0, "handedness": "left"})
    with pytest.raises(ValidationError, match="pattern = 'nope' is not a preset"):
        BowlerScene(pattern="nope")


def test_example_file_loads_and_the_cli_reports_in_bowlers_terms(
    tmp_path: Path,
) -> None:
    scene = parse_scene_file(EXAMPLE).scene
    assert scene.name == "right-hander-house-shot"
    result = CliRunner().invoke(app, ["simulate", str(EXAMPLE), "--json", "--no-archive"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    bowler = out["bowler"]
    # the tweener's style speed (the example gives no speed of its own)
    assert bowler["launch_speed_mph"] == pytest.approx(17.5, abs=1e-9)
    assert bowler["entry_angle_deg"] == pytest.approx(out["pocket_deg"], abs=1e-9)
    assert bowler["slide_ft"] == pytest.approx(out["slide_m"] / 0.3048, abs=1e-9)
    # out to the breakpoint and back into the pocket window: the line the example was aimed on
    # (breaking on board 5 at about 40 ft, the outside end of Clifton's best-carry zone)
    assert bowler["breakpoint_board"] < min(bowler["laydown_board"], bowler["entry_board"])
    assert bowler["breakpoint_board"] == pytest.approx(5.0, abs=0.1)
    assert 38.0 <= bowler["breakpoint_ft"] <= 45.0
    assert 4.0 <= bowler["entry_angle_deg"] <= 6.0


def test_bowling_cli_commands(tmp_path: Path) -> None:
    runner = CliRunner()
    out = runner.invoke(app, ["patterns", "kegel_big_ben"])
    assert out.exit_code == 0, out.output
    stats = json.loads(out.output)
    assert stats["total_ml"] == pytest.approx(24.7) and stats["ratio"] == pytest.approx(22 / 3)
    assert runner.invoke(app, ["patterns", "nope"]).exit_code == 2
    sheet = runner.invoke(app, ["sheet", "storm-the-road-15lb"])
    assert sheet.exit_code == 0 and "RG              2.550 in" in sheet.output
    assert "rule set 'current': legal" in sheet.output
    path = tmp_path / "bowler.json"
    assert runner.invoke(app, ["bowler-scene", str(path)]).exit_code == 0
    assert parse_scene_file(path).scene == BowlerScene().to_scene()


def test_docs_table2_block_is_the_computed_one() -> None:
    import importlib.util

    root = Path(__file__).parents[1]
    spec = importlib.util.spec_from_file_location(
        "table2_sweep", root / "examples" / "table2_sweep.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    text = module.markdown(module.sweeps())
    from tools.readme_blocks import block_path, read_block

    block = read_block(block_path("table2"), "table2")
    assert block == text, "run: python examples/table2_sweep.py --update-docs"


def test_curated_library_goes_into_the_archive_and_drives_bowler_scenes(tmp_path: Path) -> None:
    from bowlrec.archive import Archive
    from bowlrec.bowling.ball import BowlerBall
    from bowlrec.bowling.layout import load_example_library

    runner = CliRunner()
    arch = str(tmp_path / "arch")
    result = runner.invoke(app, ["balls", "add-examples", "-a", arch])
    assert result.exit_code == 0, result.output
    curated = load_example_library().balls
    entries = {e.name: e for e in Archive(arch).balls.list()}
    assert set(entries) == {c.id for c in curated}
    for c in curated:
        assert isinstance(entries[c.id].ball, BowlerBall) and entries[c.id].ball == c.ball
    again = runner.invoke(app, ["balls", "add-examples", "-a", arch])
    assert again.output.count("unchanged") == len(curated)
    shown = runner.invoke(app, ["balls", "show", "storm-the-road-15lb", "-a", arch])
    assert "RG              2.550 in" in shown.output
    out = runner.invoke(
        app, ["simulate", str(EXAMPLE), "--ball", "storm-the-road-15lb", "-a", arch, "--json"]
    )
    assert out.exit_code == 0, out.output
    row = Archive(arch).row(json.loads(out.output)["run_id"])
    assert (row["ball_name"], row["ball_version"]) == ("storm-the-road-15lb", 1)
    physical = Path(__file__).parents[1] / "examples" / "paper" / "case16.json"
    bad = runner.invoke(
        app, ["simulate", str(physical), "--ball", "storm-the-road-15lb", "-a", arch]
    )
    assert bad.exit_code == 2 and "is a spec sheet" in bad.output

"""Pins from the command line, in batch jobs and in a shot's strike percentage (in process)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

import bowlrec.pins  # noqa: E402,F401  (MUJOCO_GL=disable before MuJoCo loads)

pytest.importorskip("mujoco")

from bowlrec.cli import app  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()
POCKET = str(ROOT / "examples/bowler/pocket-right.json")


def test_pins_prints_the_leave_and_the_deck() -> None:
    result = runner.invoke(app, ["pins", POCKET, "--no-archive"])
    assert result.exit_code == 0, result.output
    assert "at the pins" in result.output
    assert "right-hander's names" in result.output
    assert "ball touched" in result.output and "1-3" in result.output


def test_pins_json_and_a_spare_rack() -> None:
    result = runner.invoke(
        app, ["pins", POCKET, "--no-archive", "--json", "--standing", "6,10", "--seed", "3"]
    )
    assert result.exit_code == 0, result.output
    pins = json.loads(result.output)["pins"]
    assert pins["set_pins"] == [6, 10]
    assert 0 <= pins["pinfall"] <= 2
    assert set(pins["standing"]) <= {6, 10}
    assert pins["leave"] in ("spare", "6", "10", "6-10")
    assert pins["hand"] == "right"


def test_a_bad_standing_pin_is_one_line() -> None:
    result = runner.invoke(app, ["pins", POCKET, "--no-archive", "--standing", "2,4,11"])
    assert result.exit_code == 2
    assert "options.pins.standing: pin 11 is not a pin number" in result.output
    assert "Traceback" not in result.output


def test_simulate_without_pins_says_nothing_of_them() -> None:
    result = runner.invoke(app, ["simulate", POCKET, "--no-archive", "--json"])
    assert result.exit_code == 0
    assert "pins" not in json.loads(result.output)


def test_a_batch_job_with_pins_fills_pinfall_and_leave(tmp_path: Path) -> None:
    from bowlrec.batch import simulate_many

    scene = json.loads(Path(POCKET).read_text())
    scene.setdefault("options", {})["pins"] = {"max_time_s": 2.0}
    base = tmp_path / "base.json"
    base.write_text(json.dumps(scene))
    job = {
        "format": "bowlrec-job",
        "name": "pins",
        "base": str(base),
        "sweep": [{"kind": "grid", "axes": {"options.pins.seed": [1, 2]}}],
        "record": "summary",
    }
    table = simulate_many(job, workers=0, output="numpy")
    assert list(table["status"]) == ["ok", "ok"]
    assert all(0 <= p <= 10 for p in table["pinfall"])
    assert all(leave for leave in table["leave"])
    plain = simulate_many([POCKET], workers=0, output="numpy")
    assert plain["pinfall"][0] == -1 and plain["leave"][0] == ""


def test_shot_carry_counts_its_repeats() -> None:
    from bowlrec.bowling.shot_carry import shot_carry
    from bowlrec.bowling.variance import PRESETS
    from bowlrec.scene_input import parse_scene_input

    bowler = parse_scene_input(POCKET).bowler
    assert bowler is not None
    a = shot_carry(bowler, PRESETS["pro"], n=3, seed=2, workers=0)
    b = shot_carry(bowler, PRESETS["pro"], n=3, seed=2, workers=0)
    assert a.pinfall.tolist() == b.pinfall.tolist() and a.leaves == b.leaves
    assert a.strike_share == pytest.approx(sum(p == 10 for p in a.pinfall) / 3)
    assert sum(k for _, k in a.leave_counts()) == 3
    assert a.to_dict()["n"] == 3

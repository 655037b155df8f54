"""The command line off the tour's script: help that names what the commands do and where the
archive is, values printed as a person reads them, and rows without empty fields."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from bowlrec.api import simulate_into
from bowlrec.archive import Archive
from bowlrec.cli import app
from bowlrec.spec import Scene

ROOT = Path(__file__).resolve().parents[1]
CASE16 = ROOT / "examples/paper/case16.json"
runner = CliRunner()


def _help(*args: str) -> str:
    result = runner.invoke(app, [*args, "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    return result.output


def test_help_shows_no_type_after_a_flag() -> None:
    """A flag takes no value: no ``<bool>`` after ``--quiet`` or ``--browser/--no-browser``;
    an option that takes one still names its type."""
    for command in ([], ["ui"], ["batch"], ["runs", "list"]):
        assert "<bool>" not in _help(*command), command
    assert "<int range>" in _help("ui")


def test_help_names_the_archive_commands_and_the_user_archive() -> None:
    """``bowlrec --help`` describes ``archive`` by its commands (migrate, info), and ``ui -h``
    names the archive it serves by default: the user's, not a folder of the working directory."""
    assert "migration, info" in _help()
    archive_help = _help("archive")
    assert "migrate" in archive_help and "info" in archive_help
    ui = " ".join(_help("ui").replace("│", " ").split())
    assert "./bowlrec-archive" not in ui
    assert "$BOWLREC_ARCHIVE" in ui and "~/.local/share/bowlrec/archive" in ui


def test_validate_prints_decimal_values() -> None:
    """RG 6.9 cm gives k^2 = 0.004761 m^2, printed so, not as the binary float's
    0.0047610000000000005."""
    result = runner.invoke(app, ["validate", str(CASE16)])
    assert result.exit_code == 0, result.output
    assert "[0.004761, 0.005041, 0.005041]" in result.output
    assert "-0.0007," in result.output
    assert "0000000" not in result.output and "9999999" not in result.output


def test_runs_show_leaves_out_fields_a_run_does_not_have(tmp_path: Path) -> None:
    """A run without a library ball or pins shows no ``ball_name None`` / ``pinfall None``
    rows; its numbers print to 10 significant digits (``--json`` keeps every bit)."""
    archive = Archive(tmp_path / "a")
    stored = simulate_into(archive, Scene.model_validate_json(CASE16.read_text()))
    archive.close()
    result = runner.invoke(
        app, ["runs", "show", stored.run_id, "-a", str(tmp_path / "a")], env={"COLUMNS": "200"}
    )
    assert result.exit_code == 0, result.output
    assert "None" not in result.output
    lines = {line.split("│")[1].strip(): line for line in result.output.splitlines() if "│" in line}
    assert "ball_name" not in lines and "pinfall" not in lines and "ball_ref" not in lines
    assert "hook_m" in lines and "mass_kg" in lines
    hook = lines["hook_m"].split("│")[2].strip()
    assert len(hook.replace(".", "").lstrip("0")) <= 10, hook
    as_json = runner.invoke(
        app, ["runs", "show", stored.run_id, "-a", str(tmp_path / "a"), "--json"]
    )
    assert json.loads(as_json.output)["index"]["ball_name"] is None


def _low_rev_scene(tmp_path: Path) -> Path:
    """A right-hander's 200 rpm, 20 deg rotation release from board 12: aimed into the pocket's
    board by the target alone, it enters at about 2 deg."""
    doc = json.loads((ROOT / "examples/bowler/pocket-right.json").read_text())
    doc["delivery"].update(rev_rate_rpm=200.0, axis_rotation_deg=20.0, laydown_board=12.0)
    path = tmp_path / "low-rev.json"
    path.write_text(json.dumps(doc))
    return path


def test_aim_with_one_variable_fails_when_the_angle_is_out_of_its_window(tmp_path: Path) -> None:
    """One free variable solves the entry board; at 2 deg against the 4-6 deg window that is
    not "aimed": exit 1, --out not written, the title and --json say so."""
    scene, out = _low_rev_scene(tmp_path), tmp_path / "aimed.json"
    result = runner.invoke(app, ["aim", str(scene), "-v", "target", "-o", str(out)])
    assert result.exit_code == 1, result.output
    assert "entry board solved, entry angle outside its window" in result.output
    assert "aim: aimed" not in result.output and "not written" in result.output
    assert not out.exists()
    doc = json.loads(runner.invoke(app, ["aim", str(scene), "-v", "target", "--json"]).output)
    assert doc["found"] is True and doc["aimed"] is False and doc["in_window"] is False
    assert doc["report"]["entry_angle_deg"] < 4.0
    # two variables solve the angle as well
    both = runner.invoke(app, ["aim", str(scene), "-v", "speed", "-v", "target", "-o", str(out)])
    assert both.exit_code in (0, 1), both.output
    assert out.exists() == (both.exit_code == 0)

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

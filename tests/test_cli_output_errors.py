"""Outputs that cannot be written and arguments out of range: one ``error:`` line, no traceback.

The unwritable place is a path in ``/proc`` (where no file can be created, also for root, as the
test tiers run in CI); the tests skip where there is no ``/proc``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from bowlrec.cli import app

ROOT = Path(__file__).resolve().parents[1]
CASE16 = ROOT / "examples" / "paper" / "case16.json"

runner = CliRunner()

needs_proc = pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs /proc")


def _error_line(args: list[str], code: int) -> str:
    result = runner.invoke(app, args)
    assert result.exit_code == code, result.output
    assert "Traceback" not in result.output
    lines = [line for line in result.output.splitlines() if line.startswith("error: ")]
    assert len(lines) == 1, result.output
    return lines[0]


@needs_proc
@pytest.mark.parametrize(
    "args",
    [
        ["balls", "export", "/proc/bowlrec-x.json"],
        ["simulate", str(CASE16), "--no-archive", "--out", "/proc/bowlrec-x.mcap"],
        ["simulate", str(CASE16), "--no-archive", "--out", "/proc/bowlrec-x.h5"],
    ],
)
def test_an_output_that_cannot_be_written_is_one_line_naming_it(
    args: list[str], tmp_path: Path
) -> None:
    line = _error_line([*args, "--archive", str(tmp_path / "a")], 1)
    assert "/proc/bowlrec-x." in line and "No such file or directory" in line
    assert ".part" not in line  # the file asked for, not its temporary


def test_directories_for_outputs_are_checked_before_the_work(tmp_path: Path) -> None:
    a_file = tmp_path / "taken"
    a_file.write_text("")
    line = _error_line(["demo", "-o", str(a_file), "-q", "--archive", str(tmp_path / "a")], 2)
    assert line == f"error: --out {a_file}: a file, not a directory"
    assert not (tmp_path / "a").exists()  # nothing was simulated into the archive
    line = _error_line(["examples", str(a_file)], 2)
    assert line == f"error: OUT {a_file}: a file, not a directory"


@pytest.mark.parametrize("rtol", ["nan", "-1", "0.01"])
def test_paper_rtol_outside_its_range_is_refused(rtol: str) -> None:
    assert _error_line(["paper", "--rtol", rtol], 2).endswith("must be in [1e-14, 1e-3]")


def test_demo_record_dt_s_is_checked_as_the_scene_field(tmp_path: Path) -> None:
    line = _error_line(
        ["demo", "-o", str(tmp_path / "d"), "--record-dt-s", "-1", "--archive", str(tmp_path)], 2
    )
    assert line == "error: --record-dt-s -1: Input should be greater than 0 (got -1.0)"


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (
            ["aim", str(ROOT / "examples/bowler/pocket-right.json"), "--pocket-board", "100"],
            "error: --pocket-board: Input should be less than or equal to 39.5 (got 100.0)",
        ),
        (
            ["aim", str(ROOT / "examples/bowler/pocket-right.json"), "--pocket-board", "20"],
            "error: pocket board = 20.0 must lie in its window [17.0, 18.0]",
        ),
        (
            ["layout", "convert", "vls", "5", "3", "2", "--pap-over", "100"],
            "error: --pap-over: Input should be less than or equal to 13.5 (got 100.0)",
        ),
    ],
)
def test_an_option_out_of_range_is_named_as_the_option(args: list[str], line: str) -> None:
    assert _error_line(args, 2) == line


@pytest.mark.parametrize(
    ("stdout_tty", "stderr_tty", "quiet", "shown"),
    [
        (True, True, False, True),
        (False, True, False, False),  # `bowlrec variance S | cat`: the output is piped
        (True, False, False, False),
        (True, True, True, False),
    ],
)
def test_progress_shows_only_on_a_terminal_without_quiet(
    monkeypatch: pytest.MonkeyPatch, stdout_tty: bool, stderr_tty: bool, quiet: bool, shown: bool
) -> None:
    import sys

    from bowlrec.cli._common import interactive

    monkeypatch.setattr(sys.stdout, "isatty", lambda: stdout_tty)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: stderr_tty)
    assert interactive(quiet) is shown

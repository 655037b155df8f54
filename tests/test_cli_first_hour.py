"""The command line as a new user meets it: piped output keeps every character, the usual
conventions (--version, -h), refusals that protect files, the runs table, the batch's exit
status, schemas, and the demo's next steps."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from helpers.processes import run_bowlrec
from typer.testing import CliRunner

from bowlrec.api import simulate_into
from bowlrec.cli import app

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()
CASE16 = str(ROOT / "examples/paper/case16.json")


def _bowlrec(*args: str, **kw: Any) -> subprocess.CompletedProcess[str]:
    """``bowlrec ARGS`` in a real process, its stdout a pipe (not a terminal)."""
    return run_bowlrec(*args, **kw)


# -- piped tables keep every character ------------------------------------------------------


@pytest.mark.process  # stdout a pipe of a real process
def test_piped_paper_table_keeps_every_number() -> None:
    """``bowlrec paper > out.txt`` in an 80-column (or narrower) terminal: every number of the
    Markdown table (the same rows) is in the printed table, none cut to an ellipsis."""
    md = _bowlrec("paper", "--markdown", "-q")
    table = _bowlrec("paper", "-q", env={"COLUMNS": "60"})
    assert md.returncode == 0 and table.returncode == 0, table.stderr
    assert "…" not in table.stdout
    rows = [line for line in md.stdout.splitlines() if re.match(r"\| \d+ \|", line)]
    assert len(rows) == 18
    printed = {
        tuple(c.strip() for c in line.strip("│").split("│"))
        for line in table.stdout.splitlines()
        if line.startswith("│")
    }
    for row in rows:
        cells = tuple(c.strip() for c in row.strip("|").split("|"))
        assert cells in printed, f"row {cells} not printed whole"


@pytest.mark.process  # stdout a pipe of a real process
def test_piped_runs_list_keeps_long_names(tmp_path: Path) -> None:
    scene = json.loads(Path(CASE16).read_text())
    scene["name"] = "a-rather-long-scene-name-" + "x" * 60
    path = tmp_path / "long.json"
    path.write_text(json.dumps(scene))
    archive = str(tmp_path / "arch")
    assert _bowlrec("simulate", str(path), "-a", archive, "-q").returncode == 0
    listed = _bowlrec("runs", "list", "-a", archive, env={"COLUMNS": "40"})
    assert listed.returncode == 0, listed.stderr
    assert scene["name"] in listed.stdout and "…" not in listed.stdout


# -- conventions ----------------------------------------------------------------------------


def test_version_and_short_help() -> None:
    from bowlrec import PHYSICS_VERSION, __version__

    for flag in ("--version", "-V"):
        result = runner.invoke(app, [flag])
        assert result.exit_code == 0
        assert result.output.startswith(f"bowlrec {__version__} (physics {PHYSICS_VERSION}")
    for args in (["-h"], ["runs", "-h"], ["runs", "list", "-h"], ["simulate", "-h"]):
        result = runner.invoke(app, args)
        assert result.exit_code == 0, args
        assert "Usage: bowlrec" in result.output, args


def test_shell_completion_is_offered() -> None:
    result = runner.invoke(app, ["--help"])
    assert "--install-completion" in result.output and "--show-completion" in result.output


def test_validate_prints_plain_floats() -> None:
    result = runner.invoke(app, ["validate", CASE16])
    assert result.exit_code == 0, result.output
    assert "np.float64" not in result.output and "inertia per mass" in result.output
    line = next(s for s in result.output.splitlines() if "q0" in s)
    values = json.loads(line.split(":", 1)[1])
    assert len(values) == 4 and all(isinstance(v, float) for v in values)


# -- output that would lie or lose work ----------------------------------------------------


@pytest.mark.parametrize(
    ("option", "name"), [("--mcap", "x.json"), ("--rrd", "x.mcap"), ("--plot", "x.rrd")]
)
def test_wrong_extension_for_a_format_option_is_refused(
    tmp_path: Path, option: str, name: str
) -> None:
    target = tmp_path / name
    result = runner.invoke(app, ["simulate", CASE16, "--no-archive", option, str(target)])
    assert result.exit_code == 2
    assert f"{option} {target}" in result.output and "end in" in result.output
    assert not target.exists() and list(tmp_path.iterdir()) == []


def test_out_csv_is_a_csv(tmp_path: Path) -> None:
    out = tmp_path / "run.csv"
    result = runner.invoke(app, ["simulate", CASE16, "--no-archive", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv"]
    header, first = out.read_text().splitlines()[:2]
    assert header.startswith("t_s,x_m,y_m,z_m,")
    assert len(first.split(",")) == len(header.split(","))


def test_bowler_scene_keeps_an_existing_file(tmp_path: Path) -> None:
    path = tmp_path / "my-shot.json"
    path.write_text('{"edited": true}\n')
    result = runner.invoke(app, ["bowler-scene", str(path)])
    assert result.exit_code == 2 and "exists" in result.output and "--force" in result.output
    assert path.read_text() == '{"edited": true}\n'
    result = runner.invoke(app, ["bowler-scene", str(path), "--force"])
    assert result.exit_code == 0
    assert json.loads(path.read_text())["format"] == "bowler"


def test_bowler_scene_yaml_is_yaml(tmp_path: Path) -> None:
    import yaml

    path = tmp_path / "my-shot.yaml"
    result = runner.invoke(app, ["bowler-scene", str(path)])
    assert result.exit_code == 0, result.output
    text = path.read_text()
    assert not text.lstrip().startswith("{")
    assert yaml.safe_load(text)["format"] == "bowler"
    assert runner.invoke(app, ["validate", str(path)]).exit_code == 0
    result = runner.invoke(app, ["bowler-scene", str(tmp_path / "shot.txt")])
    assert result.exit_code == 2 and ".json, .yaml or .yml" in result.output


# -- the runs table -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def archive_of_25(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An archive of 25 summary-only runs, added one after another (speeds 6.0 to 8.4 m/s)."""
    from bowlrec.archive import Archive
    from bowlrec.spec import Scene

    root = tmp_path_factory.mktemp("runs25") / "arch"
    archive = Archive(root)
    for k in range(25):
        scene = Scene.model_validate(
            {
                "name": f"speed-{k:02d}",
                "delivery": {"speed_mps": 6.0 + 0.1 * k},
                "options": {"record": "summary"},
            }
        )
        simulate_into(archive, scene)
    return root


def test_runs_list_newest_first_limited_with_units(archive_of_25: Path) -> None:
    result = runner.invoke(app, ["runs", "list", "-a", str(archive_of_25)])
    assert result.exit_code == 0, result.output
    for header in ("slide (m)", "hook (cm)", "pocket (deg)"):
        assert header in result.output
    names = re.findall(r"speed-(\d\d)", result.output)
    assert names == [f"{k:02d}" for k in range(24, 4, -1)]  # 20 newest, newest first
    assert "--limit 0 for all" in result.output
    everything = runner.invoke(app, ["runs", "list", "-a", str(archive_of_25), "--limit", "0"])
    assert len(re.findall(r"speed-\d\d", everything.output)) == 25
    assert "--limit 0 for all" not in everything.output


def test_runs_list_hook_column_is_in_cm(archive_of_25: Path) -> None:
    from bowlrec.archive import Archive

    newest = Archive(archive_of_25).list_runs(order_by="-created_at", limit=1)[0]
    result = runner.invoke(app, ["runs", "list", "-a", str(archive_of_25), "-n", "1"])
    assert f"{100 * newest['hook_m']:.2f}" in result.output


def test_runs_list_ids_for_scripts(archive_of_25: Path) -> None:
    from bowlrec.archive import Archive

    result = runner.invoke(app, ["runs", "list", "-a", str(archive_of_25), "--ids", "-n", "3"])
    assert result.exit_code == 0
    newest = Archive(archive_of_25).list_runs(order_by="-created_at", limit=3)
    assert result.output.split() == [r["run_id"] for r in newest]


def test_runs_list_unknown_outcome_names_the_outcomes(archive_of_25: Path) -> None:
    result = runner.invoke(app, ["runs", "list", "-a", str(archive_of_25), "--outcome", "strike"])
    assert result.exit_code == 2
    assert "'strike'" in result.output
    for outcome in ("pins", "gutter", "stopped", "airborne", "max_time"):
        assert outcome in result.output


def test_runs_show_includes_the_scene(archive_of_25: Path) -> None:
    from bowlrec.archive import Archive
    from bowlrec.spec import Scene

    run_id = Archive(archive_of_25).list_runs(order_by="-created_at", limit=1)[0]["run_id"]
    result = runner.invoke(app, ["runs", "show", run_id[:8], "-a", str(archive_of_25)])
    assert result.exit_code == 0, result.output
    text = result.output.split("scene (as given):\n", 1)[1]
    scene = Scene.model_validate(json.loads(text))
    assert scene.name == "speed-24" and scene.delivery.speed_mps == pytest.approx(8.4)


# -- batch: failures, --quiet and Ctrl-C ----------------------------------------------------


def _job_with_a_failure(tmp_path: Path) -> Path:
    job = {
        "format": "bowlrec-job",
        "name": "one-fails",
        "base": {"name": "base", "options": {"record": "summary"}},
        "sweep": {
            "kind": "points",
            "points": [
                {"ball.com_offset_m": [0.0, 0.0, 0.0]},
                {"ball.com_offset_m": [0.02, 0.0, 0.0]},  # lifts the ball: airborne
            ],
        },
        "record": "summary",
    }
    path = tmp_path / "job.json"
    path.write_text(json.dumps(job))
    return path


def test_batch_quiet_with_failures_exits_1_and_prints_the_summary(tmp_path: Path) -> None:
    job = _job_with_a_failure(tmp_path)
    out = tmp_path / "t.csv"
    args = ["batch", str(job), "--no-archive", "-j", "0", "--out", str(out), "--quiet"]
    result = runner.invoke(app, args)
    assert result.exit_code == 1, result.stderr
    assert result.stdout == ""
    assert "2 runs: 1 simulated, 0 already archived, 1 failed" in result.stderr
    assert "first failure (ball.com_offset_m=" in result.stderr and "normal force" in result.stderr
    assert out.exists()
    allowed = runner.invoke(app, [*args, "--allow-failures"])
    assert allowed.exit_code == 0, allowed.stderr
    assert "1 failed" in allowed.stderr


@pytest.mark.process  # SIGINT to a real process
def test_batch_second_ctrl_c_stops_with_a_message(tmp_path: Path) -> None:
    """Ctrl-C asks the batch to stop after the runs in flight; a second one stops it at once,
    with one line saying what is kept and exit status 130 (no traceback, no silent exit)."""
    job = {
        "format": "bowlrec-job",
        "name": "long",
        "base": {"name": "base", "options": {"record": "steps"}},
        "sweep": {
            "kind": "random",
            "n": 4000,
            "seed": 3,
            "axes": {"delivery.speed_mps": {"low": 6.0, "high": 9.0}},
        },
        "record": "trajectory",
    }
    path = tmp_path / "long.json"
    path.write_text(json.dumps(job))
    archive = tmp_path / "arch"
    proc = subprocess.Popen(
        [sys.executable, "-m", "bowlrec.cli", "batch", str(path), "-a", str(archive)]
        + ["-j", "2", "--chunk-size", "50", "--out", str(tmp_path / "t.csv")],  # ~1 s a chunk
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while not list((archive / "segments").glob("*.h5")):  # runs are being sealed
        assert proc.poll() is None, proc.communicate()[1]
        assert time.monotonic() < deadline, "the batch made no progress"
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    time.sleep(0.2)  # the chunks in flight take longer than this
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert "interrupted again: stopped at once" in err
    assert "rerun the same command" in err


@pytest.mark.process  # SIGINT to a real process
@pytest.mark.parametrize("delay_s", [0.1, 0.25, 0.4])
def test_ctrl_c_before_work_starts_is_one_line(delay_s: float) -> None:
    """A Ctrl-C that lands before a command has set up its own handling (while typer parses
    the command line and imports its parameter types, while ``paper``'s kernels load and run)
    ends with one line and status 130. ``paper --json`` takes well under a second here, so the
    delays cover its phases; a signal that comes after the output is complete (the interpreter,
    shutting down, has restored SIGINT's default) only counts as too late."""
    start = (  # says when the command line is imported, then runs the command
        "import sys; import bowlrec.cli as cli; print('ready', file=sys.stderr, flush=True); "
        "sys.argv = ['bowlrec', 'paper', '--json']; cli.main()"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", start],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stderr is not None and proc.stderr.readline() == "ready\n"
    time.sleep(delay_s)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    if proc.returncode in (0, -signal.SIGINT) and _is_json(out):
        pytest.skip("the command finished before the signal")
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().splitlines()[-1:] == ["interrupted"]


def _is_json(text: str) -> bool:
    """Whether ``text`` is a whole JSON document."""
    try:
        json.loads(text)
    except ValueError:
        return False
    return True


# -- schemas --------------------------------------------------------------------------------


def test_schema_prints_instead_of_writing_here(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, ["schema"])
    assert result.exit_code == 0
    assert json.loads(result.stdout)["title"] == "Scene"
    assert list(tmp_path.iterdir()) == []  # nothing written where it ran
    job = runner.invoke(app, ["schema", "job"])
    assert "sweep" in json.loads(job.stdout)["properties"]
    bowler = runner.invoke(app, ["schema", "bowler-scene"])
    assert "layout" in json.loads(bowler.stdout)["properties"]
    bad = runner.invoke(app, ["schema", "lanes"])
    assert bad.exit_code == 2 and "bowler-scene" in bad.stderr and "job" in bad.stderr


def test_schema_out_writes_every_schema(tmp_path: Path) -> None:
    result = runner.invoke(app, ["schema", "--out", str(tmp_path)])
    assert result.exit_code == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert "job.schema.json" in names and "bowler-scene.schema.json" in names
    for name in names:
        assert (tmp_path / name).read_text() == (ROOT / "schemas" / name).read_text()


# -- the demo's next steps ------------------------------------------------------------------


def test_demo_says_how_to_activate_the_venv(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from bowlrec.cli.demo import activate_command

    venv = tmp_path / ".venv"
    (venv / "bin").mkdir(parents=True)
    monkeypatch.setattr(sys, "prefix", str(venv))
    monkeypatch.setattr(sys, "base_prefix", "/usr")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    assert activate_command() == "source .venv/bin/activate"
    monkeypatch.setenv("PATH", f"{venv / 'bin'}:/usr/bin")
    assert activate_command() is None  # activated: nothing to say
    monkeypatch.setattr(sys, "base_prefix", str(venv))
    assert activate_command() is None  # not a virtual environment


def test_examples_writes_where_it_is_told(tmp_path: Path) -> None:
    missing = runner.invoke(app, ["examples"])
    assert missing.exit_code == 2  # no directory given: nothing is written where it runs
    result = runner.invoke(app, ["examples", str(tmp_path / "paper")])
    assert result.exit_code == 0, result.output
    written = sorted((tmp_path / "paper").glob("case*.json"))
    assert len(written) == 18
    for path in written:
        assert path.read_text() == (ROOT / "examples" / "paper" / path.name).read_text()

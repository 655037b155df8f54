"""The command line off the tour's script: help that names what the commands do and where the
archive is, values printed as a person reads them, and rows without empty fields."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
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


# -- the right command for a file, names that are close --------------------------------------


def _error_lines(args: list[str]) -> list[str]:
    result = runner.invoke(app, args, env={"COLUMNS": "200"})
    assert result.exit_code == 2, result.output
    return [line for line in result.output.splitlines() if line.strip()]


def test_a_file_given_to_the_wrong_command_names_the_right_one() -> None:
    """A scene to `batch`, a job to `simulate`, a session to `simulate`: one line naming what
    the file is and the command that runs it, not the other format's field errors."""
    bowler, job = (
        ROOT / "examples/bowler/pocket-right.json",
        ROOT / "examples/jobs/speed-rev-grid.json",
    )
    session = ROOT / "examples/session/league-night.yaml"
    cases = [  # (command, file, what the file is, the command that runs it)
        ("batch", bowler, "bowler scene, not a batch job", "simulate"),
        ("batch", CASE16, "physical scene, not a batch job", "simulate"),
        ("simulate", job, "batch job, not a scene", "batch"),
        ("simulate", session, "session, not a scene", "session"),
        ("session", job, "batch job, not a session", "batch"),
        ("carry", bowler, "bowler scene, not a carry map", "simulate"),
    ]
    for given, path, kind, right in cases:
        args = [given, str(path), *(["--no-archive"] if given in ("batch", "simulate") else [])]
        what, command = f"this is a {kind}", f"`bowlrec {right}`"
        lines = _error_lines(args)
        assert len(lines) == 1, lines
        assert what in lines[0] and command in lines[0], lines
        assert "Extra inputs" not in lines[0] and "Input should be" not in lines[0]


def test_close_names_for_fields_patterns_and_balls(tmp_path: Path) -> None:
    """A misspelt field, pattern or library ball gets the name it is close to; an unknown ball
    lists a few names and how many more, never a cut-off list of every one."""
    doc = json.loads((ROOT / "examples/bowler/pocket-right.json").read_text())
    doc["delivery"]["speed_mhp"] = doc["delivery"].pop("speed_mph")
    doc["pattern"] = "kegel_stonhenge"
    path = tmp_path / "typo.json"
    path.write_text(json.dumps(doc))
    text = "\n".join(_error_lines(["simulate", str(path), "--no-archive"]))
    assert (
        "delivery.speed_mhp: Extra inputs are not permitted (got 17.5); did you mean 'speed_mph'?"
        in text
    )
    assert "did you mean 'kegel_stonehenge'?" in text
    archive = tmp_path / "a"
    assert runner.invoke(app, ["balls", "add-examples", "-a", str(archive)]).exit_code == 0
    bowler = str(ROOT / "examples/bowler/pocket-right.json")
    (line,) = _error_lines(["simulate", bowler, "-a", str(archive), "--ball", "storm-the-raod"])
    assert "did you mean 'storm-the-road-15lb'" in line and "`bowlrec balls list`" in line
    (line,) = _error_lines(["simulate", bowler, "-a", str(archive), "--ball", "zzzz"])
    assert " more " in line and "more characters" not in line and len(line) < 400


def test_a_scene_file_names_a_library_ball(tmp_path: Path) -> None:
    """`ball: NAME` in a scene file is a ball of the archive's library: simulated with it and
    archived with its reference; without the archive, the line says where library balls are."""
    archive = tmp_path / "a"
    assert runner.invoke(app, ["balls", "add-examples", "-a", str(archive)]).exit_code == 0
    doc = json.loads((ROOT / "examples/bowler/pocket-right.json").read_text())
    doc["ball"] = "storm-the-road-15lb"
    path = tmp_path / "library-ball.json"
    path.write_text(json.dumps(doc))
    result = runner.invoke(app, ["simulate", str(path), "-a", str(archive), "--json", "-q"])
    assert result.exit_code == 0, result.output
    run_id = json.loads(result.output)["run_id"]
    shown = json.loads(
        runner.invoke(app, ["runs", "show", run_id, "-a", str(archive), "--json"]).output
    )
    assert shown["index"]["ball_name"] == "storm-the-road-15lb"
    (line,) = _error_lines(["simulate", str(path), "-a", str(tmp_path / "none")])
    assert "names a ball of the archive's library" in line and "not an archive" in line
    assert "not available here" not in line


def test_a_job_checks_every_listed_pattern_before_its_first_run(tmp_path: Path) -> None:
    """An unknown pattern among a sweep's values fails the job before any run, naming the
    value and the close preset."""
    job = {
        "format": "bowlrec-job",
        "base": str(ROOT / "examples/bowler/pocket-right.json"),
        "sweep": {
            "kind": "grid",
            "axes": {
                "pattern": ["house_shot_approx", "kegel_stonhenge"],
                "delivery.speed_mph": [16.0, 17.0, 18.0],
            },
        },
        "record": "summary",
    }
    path = tmp_path / "job.json"
    path.write_text(json.dumps(job))
    archive = tmp_path / "a"
    lines = _error_lines(["batch", str(path), "-a", str(archive), "-q"])
    text = "\n".join(lines)
    assert (
        "value 'kegel_stonhenge' is invalid" in text and "did you mean 'kegel_stonehenge'" in text
    )
    assert not (archive / "segments").exists() or not any((archive / "segments").iterdir())


# -- values that look typed in another unit ---------------------------------------------------


def _scene_file(tmp_path: Path, example: str, **delivery: float) -> Path:
    doc = json.loads((ROOT / example).read_text())
    doc["delivery"].update(delivery)
    path = tmp_path / f"scene-{len(list(tmp_path.iterdir()))}.json"
    path.write_text(json.dumps(doc))
    return path


def _warnings(args: list[str]) -> tuple[int, list[str]]:
    result = CliRunner().invoke(app, args, env={"COLUMNS": "300"})
    return result.exit_code, [x for x in result.stderr.splitlines() if x.startswith("warning:")]


def test_a_speed_in_the_wrong_unit_is_a_warning_not_a_refusal(tmp_path: Path) -> None:
    """speed_mps = 17 (mph typed into m/s) runs, with a warning naming the likely unit; 38 m/s
    is 38 km/h; 60 and 100 m/s are only out of range; the paper's 8 m/s says nothing."""
    case16 = "examples/paper/case16.json"
    expected = {
        17.0: "did you mean 17 mph (7.6 m/s) or 17 km/h (4.72 m/s)?",
        38.0: "did you mean 38 km/h (10.6 m/s)?",
        60.0: "above the 3.5-12 m/s bowlers throw (options",
        100.0: "above the 3.5-12 m/s bowlers throw (options",
    }
    for speed, text in expected.items():
        path = _scene_file(tmp_path, case16, speed_mps=speed)
        code, lines = _warnings(["validate", str(path)])
        assert code == 0 and len(lines) == 1, lines
        assert f"delivery.speed_mps = {speed:g}: " in lines[0] and text in lines[0], lines
        assert "options.unit_warnings: false silences this" in lines[0]
    assert _warnings(["validate", str(ROOT / case16)]) == (0, [])


def test_bowler_units_mixed_up_are_named_before_the_scene_is_converted(tmp_path: Path) -> None:
    """speed_mph = 7.2 is 7.2 m/s; 40 mph is 40 km/h; rev_rate_rpm = 30 is 30 rad/s; a 4.5 lb
    ball is 4.5 kg. The warning comes before an error of converting the scene (a 2 mph ball
    that does not reach the arrows)."""
    pocket = "examples/bowler/pocket-right.json"
    cases = {
        "delivery.speed_mph = 7.2": ({"speed_mph": 7.2}, "did you mean 7.2 m/s (16.1 mph)?"),
        "delivery.speed_mph = 40": ({"speed_mph": 40.0}, "did you mean 40 km/h (24.9 mph)?"),
        "delivery.rev_rate_rpm = 30": ({"rev_rate_rpm": 30.0}, "did you mean 30 rad/s (286 rpm)?"),
    }
    for field, (delivery, text) in cases.items():
        path = _scene_file(tmp_path, pocket, **delivery)
        _code, lines = _warnings(["simulate", str(path), "--no-archive", "-q"])
        assert len(lines) == 1 and field in lines[0] and text in lines[0], lines
    doc = json.loads((ROOT / pocket).read_text())
    doc["delivery"].update(speed_mph=2.0, laydown_board=39.0, target_board_at_arrows=1.0)
    path = tmp_path / "unreachable.json"  # a target the ball cannot reach: converting fails
    path.write_text(json.dumps(doc))
    result = CliRunner().invoke(app, ["simulate", str(path), "--no-archive"])
    assert result.exit_code == 2
    err = result.stderr
    assert "delivery.speed_mph = 2: below" in err and "does not reach the arrows" in err, err
    assert err.index("warning:") < err.index("error:")
    doc = json.loads((ROOT / pocket).read_text())
    doc["ball"]["weight_lb"] = 4.5  # no ball is that light; 4.5 kg is a 10 lb ball
    path = tmp_path / "light.json"
    path.write_text(json.dumps(doc))
    _code, lines = _warnings(["validate", str(path)])
    assert len(lines) == 1 and "did you mean 4.5 kg (9.92 lb)?" in lines[0], lines


def test_a_scene_silences_its_unit_warnings_and_keeps_its_run_id(tmp_path: Path) -> None:
    """options.unit_warnings: false silences them; the default is not stored with the scene,
    so scenes dump (and sessions hash) as before the option existed."""
    doc = json.loads(CASE16.read_text())
    doc["delivery"]["speed_mps"] = 17.0
    loud = Scene.model_validate(doc)
    doc["options"]["unit_warnings"] = False
    quiet = Scene.model_validate(doc)
    assert "unit_warnings" not in loud.model_dump_json()
    assert quiet.model_dump()["options"]["unit_warnings"] is False
    from bowlrec.archive import run_id

    assert run_id(loud.resolve()) == run_id(quiet.resolve())
    path = tmp_path / "quiet.json"
    path.write_text(json.dumps(doc))
    assert _warnings(["validate", str(path)]) == (0, [])


def test_a_job_warns_about_each_swept_value_once_before_its_first_run(tmp_path: Path) -> None:
    job = {
        "format": "bowlrec-job",
        "base": {"delivery": {"speed_mps": 8.0}, "options": {"record": "summary"}},
        "sweep": {
            "kind": "grid",
            "axes": {
                "delivery.speed_mps": [7.0, 8.0, 17.0],
                "delivery.omega_radps[1]": [30.0, 300.0],
            },
        },
        "record": "summary",
    }
    path = tmp_path / "job.json"
    path.write_text(json.dumps(job))
    code, lines = _warnings(["batch", str(path), "--no-archive", "-q", "--workers", "0"])
    assert code == 0
    assert len(lines) == 2, lines
    assert "delivery.speed_mps = 17" in lines[0] and "17 mph" in lines[0]
    assert "omega_radps (magnitude) = 300" in lines[1] and "300 rpm" in lines[1]


def test_the_examples_raise_no_unit_warning() -> None:
    """Every example scene is a delivery bowlers throw: no warning (a false alarm on the
    examples would teach users to ignore the warnings)."""
    from bowlrec.scene_input import check_scene_input
    from bowlrec.spec.unit_sense import unit_warnings

    files = [
        p
        for folder in ("paper", "bowler", "session")
        for p in sorted((ROOT / "examples" / folder).glob("*.json"))
    ]
    assert len(files) >= 25
    for path in files:
        assert unit_warnings(check_scene_input(path).model) == [], path


@pytest.mark.process  # runs git
def test_the_tours_outputs_are_ignored_by_git() -> None:
    """Every file the README's demo and tour write into the clone (their --out names) is in
    .gitignore, so following the tour leaves `git status` clean."""
    import re
    import subprocess

    readme = (ROOT / "README.md").read_text()
    written = set(re.findall(r"(?:--out|--mcap|--rrd|-o) ((?!examples/)[\w./-]+\.\w+)", readme))
    written |= {"bowlrec-demo/fig6-cases-9-10-14-16.png", "run.h5", "grid.parquet"}
    assert {"run.csv", "run.mcap", "run.rrd", "fig6.png", "grid.csv"} <= written, written
    ignored = subprocess.run(
        ["git", "check-ignore", "--no-index", *sorted(written)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    ).stdout.split()
    assert set(ignored) == written

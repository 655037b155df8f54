"""One way in for a scene (:mod:`bowlrec.scene_input`) for every front end: physical and
bowler-language scenes, library balls of both kinds, one clear message per problem, the same
for the same bad scene whichever way it came in (bowlrec.simulate, the CLI, the service, a
batch job, a session); batch jobs accept what the CLI and service accept."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from pydantic import ValidationError
from typer.testing import CliRunner

import bowlrec
from bowlrec.api import as_scene
from bowlrec.archive import Archive
from bowlrec.batch import JobSpec, job_context, prepare_runs, run_job
from bowlrec.bowling.ball import BowlerBall
from bowlrec.bowling.scene import BowlerScene
from bowlrec.cli import app
from bowlrec.errors import InputError, JobError, SceneInputError, SpecError
from bowlrec.scene_input import check_scene, is_bowler, parse_scene, parse_scene_file
from bowlrec.service.models import parse_scene_spec
from bowlrec.session.spec import load_session, parse_session
from bowlrec.spec import Ball, Scene

ROOT = Path(__file__).resolve().parents[1]
BOWLER = json.loads((ROOT / "examples" / "bowler" / "house-shot-right.json").read_text())


@pytest.fixture()
def archive(tmp_path: Path) -> Archive:
    store = Archive(tmp_path / "a")
    store.balls.add("sheet", BowlerBall.model_validate(BOWLER["ball"]))
    store.balls.add("heavy", Ball.model_validate({"mass_kg": 7.2}))
    return store


def test_physical_and_bowler_mappings() -> None:
    physical = parse_scene({"delivery": {"speed_mps": 7.0}})
    assert physical.bowler is None and physical.scene.delivery.speed_mps == 7.0
    bowler = parse_scene(BOWLER)
    assert bowler.bowler is not None and isinstance(bowler.scene, Scene)
    assert is_bowler(BOWLER) and not is_bowler({"format": "scene"}) and not is_bowler([1])


def test_library_balls_go_into_the_scene_of_their_kind(archive: Archive) -> None:
    sheet = parse_scene({**BOWLER, "ball": "sheet"}, archive.balls)
    assert sheet.ball_ref == "sheet@1"
    assert sheet.scene == parse_scene(BOWLER).scene  # the same sheet, laid out the same way
    heavy = parse_scene({"ball": "heavy@1"}, archive.balls)
    assert heavy.ball_ref == "heavy@1" and heavy.scene.ball.mass_kg == 7.2
    with pytest.raises(SceneInputError, match=r"^ball: library ball sheet@1 is a spec sheet"):
        parse_scene({"ball": "sheet"}, archive.balls)
    with pytest.raises(SceneInputError, match=r"^ball: library ball heavy@1 is a physical"):
        parse_scene({**BOWLER, "ball": "heavy"}, archive.balls)
    with pytest.raises(SceneInputError, match=r"^ball: .*nope"):
        parse_scene({"ball": "nope"}, archive.balls)
    with pytest.raises(SceneInputError, match="^ball: library references are not available"):
        parse_scene({"ball": "heavy"})


def test_messages_name_the_field_and_the_service_says_the_same(archive: Archive) -> None:
    bad = {"delivery": {"speed_mps": -1.0}}
    with pytest.raises(SceneInputError) as cli_err:
        parse_scene(bad)
    with pytest.raises(SpecError) as service_err:
        parse_scene_spec(bad, archive.balls)
    assert str(cli_err.value) == str(service_err.value)
    assert str(cli_err.value).startswith("delivery.speed_mps:")
    with pytest.raises(SceneInputError, match="^scene: expected a mapping"):
        parse_scene([1, 2])


def test_scene_files(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text("delivery: {speed_mps: 7.5}\n")
    assert parse_scene_file(path).scene.delivery.speed_mps == 7.5
    path.write_text("delivery: {speed_mps: 0}\n")
    with pytest.raises(SceneInputError, match=r"s\.yaml: delivery\.speed_mps"):
        parse_scene_file(path)
    (tmp_path / "s.txt").write_text("{}")
    with pytest.raises(SceneInputError, match="unsupported scene file type"):
        parse_scene_file(tmp_path / "s.txt")


def test_batch_takes_a_spec_sheet_in_a_bowler_scene_as_the_cli_and_service_do(
    archive: Archive,
) -> None:
    job = JobSpec.model_validate(
        {
            "base": {**BOWLER, "options": {"record": "summary"}},
            "ball": "sheet",
            "sweep": {"kind": "grid", "axes": {"delivery.speed_mph": [16.0, 17.0]}},
        }
    )
    result = run_job(job, archive, workers=0)
    assert result.counts["ok"] == 2
    rows = archive.rows(r["run_id"] for r in result.rows)
    assert {r["ball_name"] for r in rows.values()} == {"sheet"}
    physical = JobSpec.model_validate({"ball": "sheet"})
    with pytest.raises(ValueError, match="is a spec sheet"):
        run_job(physical, archive, workers=0)


@pytest.mark.process  # a fresh interpreter's modules
def test_batch_and_scene_input_load_no_heavy_module() -> None:
    """Importing the batch package, simulate_many and the scene parser loads neither numba,
    h5py, dask nor pyarrow: they load when something runs."""
    import subprocess
    import sys

    code = (
        "import sys, bowlrec, bowlrec.batch, bowlrec.scene_input\n"
        "bowlrec.simulate_many\n"
        "heavy = [m for m in ('numba', 'h5py', 'dask', 'distributed', 'pyarrow') "
        "if m in sys.modules]\n"
        "assert not heavy, heavy\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


# -- one way in: every front end says the same about the same bad scene ------------------------

#: a bad scene of each kind and the one line every way in gives for it
BAD: dict[str, tuple[dict[str, Any], str]] = {
    "physical": (
        {"delivery": {"speed_mps": -1}},
        "delivery.speed_mps: Input should be greater than 0 (got -1)",
    ),
    "bowler": (
        {"format": "bowler", "delivery": {"speed_mph": -1}},
        "delivery.speed_mph: Input should be greater than 0 (got -1)",
    ),
}


def _scene_file(tmp_path: Path, scene: dict[str, Any]) -> Path:
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(scene))
    return path


def _raised(kind: type[BaseException], call: Callable[[], Any]) -> BaseException:
    with pytest.raises(kind) as info:
        call()
    return info.value


def _simulate_path(tmp_path: Path, scene: dict[str, Any]) -> tuple[BaseException, str]:
    path = _scene_file(tmp_path, scene)
    return _raised(SceneInputError, lambda: bowlrec.simulate(str(path))), f"{path}: "


def _simulate_mapping(tmp_path: Path, scene: dict[str, Any]) -> tuple[BaseException, str]:
    return _raised(SceneInputError, lambda: bowlrec.simulate(scene)), ""


def _service(tmp_path: Path, scene: dict[str, Any]) -> tuple[BaseException, str]:
    balls = Archive(tmp_path / "a").balls  # the request handlers pass the archive's library
    return _raised(SceneInputError, lambda: parse_scene_spec(scene, balls)), ""


def _job_base_inline(tmp_path: Path, scene: dict[str, Any]) -> tuple[BaseException, str]:
    job = JobSpec.model_validate({"base": scene})
    return _raised(JobError, lambda: job_context(job)), "base: "


def _job_base_file(tmp_path: Path, scene: dict[str, Any]) -> tuple[BaseException, str]:
    path = _scene_file(tmp_path, scene)
    job = JobSpec.model_validate({"base": path.name})
    return _raised(JobError, lambda: job_context(job, base_dir=tmp_path)), f"base: {path}: "


def _session_inline(tmp_path: Path, scene: dict[str, Any]) -> tuple[BaseException, str]:
    data = {"bowlers": [{"name": "A", "scene": scene}]}
    return _raised(SceneInputError, lambda: parse_session(data)), "bowlers[0].scene: "


def _session_file(tmp_path: Path, scene: dict[str, Any]) -> tuple[BaseException, str]:
    path = _scene_file(tmp_path, scene)
    session = tmp_path / "session.yaml"
    session.write_text(yaml.safe_dump({"bowlers": [{"name": "A", "scene": path.name}]}))
    err = _raised(SceneInputError, lambda: load_session(session))
    return err, f"{session}: bowlers[0].scene: {path}: "


#: every way in that raises, as (name, call giving the error and the prefix it should carry)
WAYS: dict[str, Callable[[Path, dict[str, Any]], tuple[BaseException, str]]] = {
    "simulate(path)": _simulate_path,
    "simulate(mapping)": _simulate_mapping,
    "service parse_scene": _service,
    "job base inline": _job_base_inline,
    "job base file": _job_base_file,
    "session scene inline": _session_inline,
    "session scene file": _session_file,
}


@pytest.mark.parametrize(
    ("way", "kind"),
    [
        (way, kind)
        for way in WAYS
        for kind in sorted(BAD)
        if kind == "bowler" or not way.startswith("session")  # bowlers throw bowler scenes
    ],
)
def test_every_way_in_raises_the_same_bowlrec_error(tmp_path: Path, way: str, kind: str) -> None:
    scene, line = BAD[kind]
    err, prefix = WAYS[way](tmp_path, scene)
    assert isinstance(err, InputError) and isinstance(err, ValueError)
    assert not isinstance(err, ValidationError)
    assert str(err) == prefix + line


@pytest.mark.parametrize("kind", sorted(BAD))
def test_the_service_answers_422_with_the_same_line(tmp_path: Path, kind: str) -> None:
    pytest.importorskip("fastapi")
    from fastapi.testclient import TestClient

    from bowlrec.service.app import create_app

    scene, line = BAD[kind]
    service = create_app(tmp_path / "a", warm_up=False)
    with TestClient(service, base_url="http://127.0.0.1") as client:
        r = client.post("/runs", json=scene)
    assert r.status_code == 422 and r.json() == {"detail": line}


@pytest.mark.parametrize("command", ["simulate", "validate"])
@pytest.mark.parametrize("kind", sorted(BAD))
def test_the_cli_says_it_in_one_line(tmp_path: Path, command: str, kind: str) -> None:
    scene, line = BAD[kind]
    path = _scene_file(tmp_path, scene)
    extra = ["--no-archive"] if command == "simulate" else []
    result = CliRunner().invoke(app, [command, str(path), *extra])
    assert result.exit_code == 2, result.output
    assert result.output.strip() == f"error: {path}: {line}"


@pytest.mark.parametrize("kind", sorted(BAD))
@pytest.mark.parametrize("entry", ["inline", "file"])
def test_a_listed_scene_is_a_failed_run_with_the_same_line(
    tmp_path: Path, kind: str, entry: str
) -> None:
    """A job's listed scenes are validated run by run: a bad one is a failed row, not a job
    error, and its error carries the intake's line."""
    scene, line = BAD[kind]
    listed = scene if entry == "inline" else _scene_file(tmp_path, scene).name
    job = JobSpec.model_validate({"sweep": {"kind": "scenes", "scenes": [{}, listed]}})
    ok, bad = prepare_runs(job, base_dir=tmp_path)
    assert ok.error is None and ok.run_id is not None
    assert bad.error == f"invalid scene: {line}" and bad.run_id is None


def test_a_file_that_cannot_be_read_is_named_by_every_way_in(tmp_path: Path) -> None:
    missing = tmp_path / "nope.yaml"
    assert str(_raised(SceneInputError, lambda: bowlrec.simulate(missing))) == (
        f"{missing}: no such file"
    )
    result = CliRunner().invoke(app, ["validate", str(missing)])
    assert result.exit_code == 2 and result.output.strip() == f"error: {missing}: no such file"
    job = JobSpec.model_validate({"base": "nope.yaml"})
    err = _raised(JobError, lambda: job_context(job, base_dir=tmp_path))
    assert str(err) == f"base: {missing}: no such file"
    data = {"bowlers": [{"name": "A", "scene": "nope.yaml"}]}
    err = _raised(SceneInputError, lambda: parse_session(data, tmp_path))
    assert str(err) == f"bowlers[0].scene: {missing}: no such file"
    listed = tmp_path / "list.json"
    listed.write_text("[1, 2]")
    assert str(_raised(SceneInputError, lambda: bowlrec.simulate(listed))) == (
        f"{listed}: scene: expected a mapping (JSON object), got list"
    )


def test_simulate_takes_every_form_of_the_same_scene(tmp_path: Path) -> None:
    """A path, a mapping and a model of one scene are one scene; a bowler mapping is
    converted as its file is."""
    bowler = BowlerScene.model_validate(BOWLER)
    path = tmp_path / "bowler.json"
    path.write_text(json.dumps(BOWLER))
    expected = bowler.to_scene()
    for given in (BOWLER, bowler, path, str(path)):
        assert as_scene(given) == expected
    physical = Scene(delivery={"speed_mps": 7.5})
    assert as_scene(physical) is physical  # a Scene is taken as it is
    assert as_scene(physical.model_dump(mode="json")) == physical


def test_checked_scenes_keep_the_model_and_bowler_mode_reads_a_bowler_scene() -> None:
    bowler = {k: v for k, v in BOWLER.items() if k != "format"}
    checked = check_scene(bowler, bowler=True)
    assert checked.is_bowler and checked.model == BowlerScene.model_validate(BOWLER)
    with pytest.raises(SceneInputError, match="^format: missing; .*belong to a bowler-language"):
        check_scene(bowler)  # read as a physical scene, its bowler fields are pointed out
    with pytest.raises(SceneInputError, match="^scene: a bowler scene is needed"):
        check_scene(Scene(), bowler=True)
    with pytest.raises(SceneInputError, match=r"^format: Input should be 'bowler'"):
        check_scene({"format": "scene"})


def test_a_bowler_scene_without_a_physical_scene_is_a_scene_input_error() -> None:
    illegal = {**BOWLER, "ball": {**BOWLER["ball"], "weight_lb": 16.5}}
    with pytest.raises(SceneInputError, match=r"^scene: ball .* is illegal .*weight_max"):
        parse_scene(illegal)
    with pytest.raises(SceneInputError, match=r"^scene: ball .* is illegal .*weight_max"):
        bowlrec.simulate(illegal)

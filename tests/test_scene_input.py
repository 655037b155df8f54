"""One scene parser for every front end: physical and bowler-language scenes, library balls of
both kinds, one clear message per problem; batch jobs accept what the CLI and service accept."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bowlrec.archive import Archive
from bowlrec.batch import JobSpec, run_job
from bowlrec.bowling.ball import BowlerBall
from bowlrec.errors import SceneInputError, SpecError
from bowlrec.scene_input import is_bowler, parse_scene, parse_scene_file
from bowlrec.service.models import parse_scene_spec
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

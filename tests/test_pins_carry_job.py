"""The carry-map job file and ``bowlrec carry`` (in process, one worker)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

import bowlrec.pins  # noqa: F401  (MUJOCO_GL=disable before MuJoCo loads)
from bowlrec.cli import app
from bowlrec.errors import JobError
from bowlrec.pins.carry_job import CarryJob, load_carry_job

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def test_the_example_job_is_the_readme_map() -> None:
    job = load_carry_job(ROOT / "examples/carry/carry-map.yaml")
    grid = job.grid()
    assert len(grid.boards) == 15 and len(grid.angles_deg) == 10 and grid.repeats == 20
    assert grid.size == 3000
    assert grid.boards[0] == 14.0 and grid.boards[-1] == 21.0
    assert job.pin_plan().hand == "right"


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"boards": [40.0]}, "boards = 40 is outside [1, 39]"),
        ({"angles_deg": {"from": 5.0, "to": 1.0, "step": 1.0}}, "must not be below from"),
        ({"repeats": 0}, "repeats"),
        ({"pins": {"seed": 3}}, "pins.seed, pins.standing and pins.moved are set by the map"),
        ({"boards": {"from": 1.0, "to": 39.0, "step": 0.01}}, "more than 1000 values"),
        (
            {"boards": [float(b) for b in range(1, 40)], "repeats": 10_000},
            "at most 200,000 per job",
        ),
    ],
)
def test_a_bad_job_is_one_line_per_problem(
    tmp_path: Path, change: dict[str, object], words: str
) -> None:
    data = {"format": "bowlrec-carry", "boards": [17.5], "angles_deg": [6.0], **change}
    path = tmp_path / "job.json"
    path.write_text(json.dumps(data))
    with pytest.raises(JobError) as err:
        load_carry_job(path)
    assert words in str(err.value)
    assert all(line.startswith(str(path)) for line in str(err.value).splitlines())


def test_a_missing_job_file_is_one_line(tmp_path: Path) -> None:
    result = runner.invoke(app, ["carry", str(tmp_path / "none.yaml")])
    assert result.exit_code != 0
    assert "none.yaml" in result.output and "Traceback" not in result.output


def test_carry_runs_a_map_and_writes_its_table_and_figure(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    job = CarryJob.model_validate(
        {"format": "bowlrec-carry", "boards": [17.5], "angles_deg": [5.0, 6.0], "repeats": 2}
    )
    path = tmp_path / "job.json"
    path.write_text(job.model_dump_json(by_alias=True))
    out, fig = tmp_path / "cells.csv", tmp_path / "map.svg"
    result = runner.invoke(
        app, ["carry", str(path), "-j", "0", "--out", str(out), "--plot", str(fig)]
    )
    assert result.exit_code == 0, result.output
    assert "2 cells x 2 racks = 4 deliveries" in result.output
    rows = list(csv.DictReader(out.open()))
    assert [float(r["angle_deg"]) for r in rows] == [5.0, 6.0]
    for r in rows:
        leaves = json.loads(r["leaves"])
        assert sum(leaves.values()) == int(r["n"]) == 2
        assert float(r["strike_probability"]) == pytest.approx(int(r["strikes"]) / 2)
    assert fig.read_bytes().startswith(b"<?xml")

"""Edge cases of the batch engine: ship mode on a rerun, boolean sweeps in tables, table files
next to replay folders, and library balls with sample outputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from bowlrec.archive import Archive
from bowlrec.batch import JobSpec, run_job, to_arrow, to_numpy, write_table
from bowlrec.cli import app
from bowlrec.spec import Ball

runner = CliRunner()


def _grid(**extra: object) -> JobSpec:
    return JobSpec.model_validate(
        {
            "base": {"options": {"record": "summary"}},
            "sweep": {"kind": "grid", "axes": {"delivery.speed_mps": [6.0, 7.0, 8.0]}},
            **extra,
        }
    )


def test_shipped_runs_found_in_the_archive_are_archived_rows(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    first = run_job(_grid(), archive, workers=0, worker_writes="no")
    assert first.counts["ok"] == 3 and archive.info()["runs"] == 3
    again = run_job(_grid(), archive, workers=0, worker_writes="no")
    assert again.counts["ok"] == 0 and again.counts["archived"] == 3
    assert archive.info()["runs"] == 3 and archive.info()["duplicate_copies"] == 0


def test_a_boolean_sweep_makes_a_table(tmp_path: Path) -> None:
    job = JobSpec.model_validate(
        {
            "base": {"options": {"record": "rate", "record_dt_s": 0.01}},
            "sweep": {"kind": "grid", "axes": {"options.record_terms": [True, False]}},
            "record": "scene",
        }
    )
    result = run_job(job, None, workers=0)
    table = to_arrow(result, job)
    assert table.column("options.record_terms").to_pylist() == [True, False]
    assert to_numpy(result)["options.record_terms"].tolist() == [True, False]
    paths = write_table(result, tmp_path / "t.csv", job)
    assert paths == [tmp_path / "t.csv"] and ",true," in (tmp_path / "t.csv").read_text()


def test_replays_beside_a_table_file_go_to_its_stem(tmp_path: Path) -> None:
    job = tmp_path / "job.json"
    spec = _grid(record="trajectory", formats=["mcap"]).model_dump(mode="json", by_alias=True)
    job.write_text(json.dumps(spec))
    out = tmp_path / "table.csv"
    res = runner.invoke(
        app, ["batch", str(job), "-a", str(tmp_path / "a"), "--workers", "0", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert out.is_file() and len(list((tmp_path / "table").glob("*.mcap"))) == 3


def test_a_library_ball_keeps_the_samples_the_outputs_need(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    archive.balls.add("heavy", Ball.model_validate({"mass_kg": 7.2}))
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps({"options": {"record": "summary"}}))
    npz = tmp_path / "run.npz"
    res = runner.invoke(
        app,
        ["simulate", str(scene), "--ball", "heavy", "-a", str(tmp_path / "a"), "--out", str(npz)],
    )
    assert res.exit_code == 0, res.output
    with np.load(npz) as data:
        assert data["t_s"].shape[0] > 10


def test_a_batch_whose_job_record_cannot_be_written_still_runs(tmp_path: Path) -> None:
    """The job record in ``ARCHIVE/jobs/cli/`` only lists the batch on the web app: when it
    cannot be written (here ``jobs`` is a file), the batch archives every run, exits 0 and
    says in one warning line that the Jobs page will not list it."""
    root = tmp_path / "archive"
    Archive(root).close()
    (root / "jobs").write_text("not a directory")
    job = tmp_path / "job.json"
    job.write_text(
        json.dumps(
            {
                "format": "bowlrec-job",
                "name": "unlisted",
                "base": {"options": {"record": "summary"}},
                "sweep": {"kind": "grid", "axes": {"delivery.speed_mps": [7.0, 8.0]}},
            }
        )
    )
    out = tmp_path / "t.csv"
    done = runner.invoke(app, ["batch", str(job), "-a", str(root), "-j", "0", "-q", "-o", str(out)])
    assert done.exit_code == 0, done.output
    warnings = [line for line in done.output.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and "Jobs page will not list this batch" in warnings[0]
    assert str(root / "jobs") in warnings[0]
    assert len(Archive(root).list_runs()) == 2

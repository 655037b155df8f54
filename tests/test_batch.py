"""Batch jobs: sweep expansion, paths, failure rows, resume after kill/Ctrl-C, Dask equality."""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers.scene_builders import recorded_speed_job

from bowlrec.archive import Archive
from bowlrec.batch import (
    METRIC_COLUMNS,
    BatchResult,
    JobSpec,
    apply_override,
    job_schema_text,
    latin_hypercube,
    load_job,
    parse_path,
    prepare_runs,
    run_job,
    write_table,
)
from bowlrec.errors import JobError
from bowlrec.spec import Ball, Scene

ROOT = Path(__file__).resolve().parents[1]


def grid_job(n_speed: int = 5, n_spin: int = 4, name: str = "grid") -> JobSpec:
    return JobSpec.model_validate(
        {
            "name": name,
            "sweep": {
                "kind": "grid",
                "axes": {
                    "delivery.speed_mps": {"start": 6.0, "stop": 9.0, "num": n_speed},
                    "delivery.omega_radps[1]": list(np.linspace(10.0, 40.0, n_spin)),
                },
            },
        }
    )


def comparable(result: BatchResult) -> list[tuple[Any, ...]]:
    """Run IDs and summary numbers of every row (statuses differ between fresh and rerun)."""
    return [(r["index"], r["run_id"], *(r[k] for k in METRIC_COLUMNS)) for r in result.rows]


# -- sweeps -----------------------------------------------------------------------------------


def test_grid_is_the_cartesian_product_first_axis_slowest() -> None:
    points = grid_job(3, 4).points()
    assert len(points) == 12
    speeds = [p.overrides["delivery.speed_mps"] for p in points]
    spins = [p.overrides["delivery.omega_radps[1]"] for p in points]
    assert speeds == [6.0] * 4 + [7.5] * 4 + [9.0] * 4
    assert spins == pytest.approx([10.0, 20.0, 30.0, 40.0] * 3)
    assert [p.index for p in points] == list(range(12))


def test_zip_points_and_concatenated_blocks() -> None:
    job = JobSpec.model_validate(
        {
            "sweep": [
                {"kind": "zip", "axes": {"delivery.speed_mps": [7, 8], "name": ["a", "b"]}},
                {"kind": "points", "points": [{"delivery.takeoff_angle_deg": 1.0}, {}]},
            ]
        }
    )
    assert [p.overrides for p in job.points()] == [
        {"delivery.speed_mps": 7, "name": "a"},
        {"delivery.speed_mps": 8, "name": "b"},
        {"delivery.takeoff_angle_deg": 1.0},
        {},
    ]
    with pytest.raises(ValueError, match="equal lengths"):
        JobSpec.model_validate({"sweep": {"kind": "zip", "axes": {"a": [1], "b": [1, 2]}}})


def _random(kind: str, seed: int, n: int = 50) -> list[dict[str, Any]]:
    job = JobSpec.model_validate(
        {
            "sweep": {
                "kind": kind,
                "n": n,
                "seed": seed,
                "axes": {
                    "delivery.speed_mps": {"low": 6.0, "high": 9.0},
                    "delivery.takeoff_angle_deg": {"low": -2.0, "high": 2.0},
                },
            }
        }
    )
    return [p.overrides for p in job.points()]


@pytest.mark.parametrize("kind", ["random", "lhs"])
def test_random_and_lhs_are_seeded(kind: str) -> None:
    a, b, c = _random(kind, 1), _random(kind, 1), _random(kind, 2)
    assert a == b
    assert a != c
    assert len(a) == 50
    for p in a:
        assert 6.0 <= p["delivery.speed_mps"] <= 9.0
        assert -2.0 <= p["delivery.takeoff_angle_deg"] <= 2.0
        assert all(type(v) is float for v in p.values())


def test_lhs_puts_one_point_in_every_stratum() -> None:
    n = 37
    pts = _random("lhs", 5, n)
    for path, (lo, hi) in {
        "delivery.speed_mps": (6.0, 9.0),
        "delivery.takeoff_angle_deg": (-2.0, 2.0),
    }.items():
        strata = sorted(math.floor((p[path] - lo) / (hi - lo) * n) for p in pts)
        assert strata == list(range(n))
    u = latin_hypercube(n, 3, 0)
    assert u.shape == (n, 3)
    for j in range(3):
        assert sorted(np.floor(u[:, j] * n).astype(int)) == list(range(n))


# -- paths ------------------------------------------------------------------------------------


def test_parse_path() -> None:
    assert parse_path("delivery.omega_radps[1]") == ("delivery", "omega_radps", 1)
    assert parse_path("pattern") == ("pattern",)
    for bad in ["", ".x", "a..b", "a[x]", "a.1", "[0]", "a[0]b"]:
        with pytest.raises(JobError, match="not a field path"):
            parse_path(bad)


def test_apply_override_errors_name_the_path() -> None:
    data = Scene().model_dump(mode="json")
    apply_override(data, "ball.rg_m[2]", 0.07)
    assert data["ball"]["rg_m"] == [0.067, 0.067, 0.07]
    with pytest.raises(JobError, match=r"'delivery.sped_mps'.*no field 'sped_mps'.*speed_mps"):
        apply_override(data, "delivery.sped_mps", 1.0)
    with pytest.raises(JobError, match=r"'ball.rg_m\[3\]'.*3 elements"):
        apply_override(data, "ball.rg_m[3]", 1.0)
    with pytest.raises(JobError, match=r"delivery.position_m is null"):
        apply_override(data, "delivery.position_m[1]", 0.5)


def test_invalid_value_is_a_job_error_naming_the_path() -> None:
    job = JobSpec.model_validate(
        {"sweep": {"kind": "grid", "axes": {"delivery.speed_mps": [7.0, -1.0]}}}
    )
    with pytest.raises(JobError) as info:
        prepare_runs(job)
    msg = str(info.value)
    assert "delivery.speed_mps" in msg and "greater than 0" in msg and "-1.0" in msg
    job = JobSpec.model_validate(
        {
            "sweep": {
                "kind": "random",
                "n": 3,
                "seed": 0,
                "axes": {"ball.mass_kg": {"low": -1, "high": 7}},
            }
        }
    )
    with pytest.raises(JobError, match=r"ball.mass_kg"):
        prepare_runs(job)
    job = JobSpec.model_validate({"sweep": {"kind": "grid", "axes": {"ball.nope": [1]}}})
    with pytest.raises(JobError, match=r"ball has no field 'nope'"):
        prepare_runs(job)
    # a field inside a tagged union (Pydantic names the tag in the error's location)
    axes = {"lane.friction.mu_oil": [0.04, -1.0]}
    job = JobSpec.model_validate({"sweep": {"kind": "grid", "axes": axes}})
    with pytest.raises(JobError, match=r"'lane.friction.mu_oil'\]: value -1.0 is invalid"):
        prepare_runs(job)


def test_a_points_sweep_value_invalid_on_its_own_is_a_job_error_naming_its_point() -> None:
    points = [{"delivery.speed_mps": 7.0}, {"delivery.speed_mps": 1000.0}, {"ball.nope": 1}]
    job = JobSpec.model_validate({"sweep": {"kind": "points", "points": points[:2]}})
    with pytest.raises(JobError) as info:
        prepare_runs(job)
    assert str(info.value).startswith("sweep[0].points[1]['delivery.speed_mps']: value 1000.0")
    assert "less than or equal to 100" in str(info.value)
    job = JobSpec.model_validate({"sweep": {"kind": "points", "points": [points[0], points[2]]}})
    with pytest.raises(JobError, match=r"sweep\[0\].points\[1\]\['ball.nope'\].*no field 'nope'"):
        prepare_runs(job)
    good = [{"delivery.speed_mps": 7.0}, {"delivery.speed_mps": 9.0, "ball.mass_kg": 6.0}]
    assert (
        len(prepare_runs(JobSpec.model_validate({"sweep": {"kind": "points", "points": good}})))
        == 2
    )


def test_invalid_combination_is_a_failure_row_not_a_job_error() -> None:
    # y = 1.2 m is off the default 1.0668 m lane but fine on a 1.5 m lane
    job = JobSpec.model_validate(
        {
            "base": {"delivery": {"position_m": [0.0, 0.5]}},
            "sweep": {
                "kind": "grid",
                "axes": {"lane.width_m": [1.0668, 1.5], "delivery.position_m[1]": [0.5, 1.2]},
            },
        }
    )
    prepared = prepare_runs(job)
    errors = [p.error for p in prepared]
    assert errors[0] is None and errors[2] is None and errors[3] is None
    assert errors[1] is not None and "position_m[1]" in errors[1] and "lane.width_m" in errors[1]
    assert prepared[1].run_id is None


def test_library_ball_reference(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    heavy = Ball(mass_kg=7.2)
    archive.balls.add("heavy", heavy)
    job = JobSpec.model_validate(
        {"ball": "heavy@1", "sweep": {"kind": "grid", "axes": {"delivery.speed_mps": [7, 8]}}}
    )
    prepared = prepare_runs(job, balls=archive.balls)
    assert all(p.ball_ref == "heavy@1" and p.scene.ball == heavy for p in prepared)  # type: ignore[union-attr]
    job = JobSpec.model_validate({"sweep": {"kind": "grid", "axes": {"ball": ["heavy", "nope"]}}})
    with pytest.raises(JobError, match="no ball 'nope'"):
        prepare_runs(job, balls=archive.balls)


def test_bowler_base_and_pattern_names() -> None:
    job = load_job(ROOT / "examples" / "jobs" / "bowler-lhs.json")
    prepared = prepare_runs(job, base_dir=ROOT / "examples" / "jobs")
    assert len(prepared) == 35
    assert all(p.error is None for p in prepared)
    assert all(p.scene is not None and p.scene.options.record == "summary" for p in prepared)
    assert len({p.run_id for p in prepared}) == 35
    assert [p.params for p in prepared[-3:]] == [
        {"pattern": "house_shot_approx"},
        {"pattern": "kegel_chromium_6742"},
        {"pattern": "sport_short_36ft_approx"},
    ]


def test_committed_job_schema_and_examples() -> None:
    path = ROOT / "schemas" / "job.schema.json"
    assert path.read_text(encoding="utf-8") == job_schema_text(), (
        "schemas/job.schema.json is stale: write bowlrec.batch.job_schema_text() to it"
    )
    for example in sorted((ROOT / "examples" / "jobs").iterdir()):
        prepare_runs(load_job(example), base_dir=example.parent)


# -- running ----------------------------------------------------------------------------------


def test_failure_rows_and_table(tmp_path: Path) -> None:
    job = JobSpec.model_validate(
        {
            "sweep": {
                "kind": "points",
                "points": [
                    {"delivery.speed_mps": 7.5},
                    {"ball.com_offset_m": [0.02, 0.0, 0.0]},  # airborne
                    {"delivery.position_m": [0.0, 5.0]},  # off the lane
                    {"delivery.takeoff_angle_deg": 10.0},  # gutter
                ],
            }
        }
    )
    archive = Archive(tmp_path / "a")
    result = run_job(job, archive, workers=0)
    status = [r["status"] for r in result.rows]
    assert status == ["ok", "failed", "failed", "ok"]
    assert result.rows[1]["outcome"] == "airborne" and "normal force" in result.rows[1]["error"]
    assert result.rows[2]["run_id"] is None and "position_m[1]" in result.rows[2]["error"]
    assert result.rows[3]["outcome"] == "gutter"  # a normal result, not a failure
    assert len(archive) == 2  # failures are not archived

    paths = write_table(result, tmp_path / "out" / "t")
    assert [p.name for p in paths] == ["t.csv", "t.parquet"]
    with open(paths[0], newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == [
        "index",
        "delivery.speed_mps",
        "ball.com_offset_m",
        "delivery.position_m",
        "delivery.takeoff_angle_deg",
        "run_id",
        "status",
        "error",
        *METRIC_COLUMNS,
    ]
    assert [r["status"] for r in rows] == status
    assert rows[1]["ball.com_offset_m"] == "[0.02,0.0,0.0]"
    assert float(rows[0]["slide_m"]) == result.rows[0]["slide_m"]
    pq = pytest.importorskip("pyarrow.parquet")
    table = pq.read_table(paths[1]).to_pylist()
    assert [r["run_id"] for r in table] == [r["run_id"] for r in result.rows]
    assert table[0]["hook_m"] == result.rows[0]["hook_m"]
    assert table[2]["outcome"] is None and table[1]["n_steps"] == result.rows[1]["n_steps"]


@pytest.mark.process
def test_rerun_is_idempotent_and_pool_equals_in_process(tmp_path: Path) -> None:
    job = grid_job(4, 5)
    pooled = run_job(job, Archive(tmp_path / "pool"), workers=2, chunk_size=3)
    assert pooled.counts["ok"] == 20 and pooled.simulated == 20
    inline = run_job(job, Archive(tmp_path / "inline"), workers=0)
    assert comparable(inline) == comparable(pooled)
    again = run_job(job, Archive(tmp_path / "pool"), workers=2)
    assert again.simulated == 0 and again.counts["archived"] == 20
    assert comparable(again) == comparable(pooled)  # metrics of skipped runs from the index
    assert len(Archive(tmp_path / "pool")) == 20


@pytest.mark.process
def test_local_cluster_equals_local_run(tmp_path: Path) -> None:
    distributed = pytest.importorskip(
        "distributed", reason="dask.distributed not installed (pip install 'bowlrec[dask]')"
    )
    job = grid_job(4, 4)
    local = run_job(job, Archive(tmp_path / "local"), workers=0)
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        remote = run_job(job, Archive(tmp_path / "dask"), scheduler=cluster.scheduler_address)
    assert remote.counts["ok"] == 16
    assert comparable(remote) == comparable(local)
    assert {r["run_id"] for r in Archive(tmp_path / "dask").list_runs()} == {
        r["run_id"] for r in local.rows
    }


# -- interruption -----------------------------------------------------------------------------


def _write_job(tmp_path: Path, n: int) -> Path:
    job = {
        "format": "bowlrec-job",
        "name": "long",
        "sweep": {
            "kind": "random",
            "n": n,
            "seed": 3,
            "axes": {"delivery.speed_mps": {"low": 6.0, "high": 9.0}},
        },
    }
    path = tmp_path / "long.json"
    path.write_text(json.dumps(job))
    return path


def _start_batch(job: Path, archive: Path, out: Path) -> subprocess.Popen[bytes]:
    cmd = [sys.executable, "-m", "bowlrec.cli", "batch", str(job), "-a", str(archive)]
    cmd += ["--out", str(out), "--workers", "2", "--chunk-size", "2", "--quiet"]
    return subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )


def _stored_runs(archive: Path) -> set[str]:
    """Run IDs in the archive's sealed segment files (registered or not)."""
    from bowlrec.archive import SegmentFile

    ids: set[str] = set()
    for path in (archive / "segments").glob("*.h5"):
        with SegmentFile(path) as seg:
            ids.update(seg.run_ids())
    return ids


def _wait_for_runs(archive: Path, n: int, proc: subprocess.Popen[bytes]) -> None:
    deadline = time.monotonic() + 90
    while len(_stored_runs(archive)) < n:
        assert proc.poll() is None, proc.stderr.read().decode() if proc.stderr else ""
        assert time.monotonic() < deadline, "the batch made no progress"
        time.sleep(0.05)


def _assert_consistent(archive_dir: Path, killed: bool = False) -> set[str]:
    """Every indexed run is in a sealed segment; only killed writers may leave temporaries
    (one per worker that seals segments: hidden, removed by the next writer) or segments not
    yet registered."""
    parts = list((archive_dir / "segments").glob(".*.part"))
    files = _stored_runs(archive_dir)
    archive = Archive(archive_dir)
    assert len(parts) <= (2 if killed else 0)
    indexed = {r["run_id"] for r in archive.list_runs()}
    assert indexed <= files and (killed or indexed == files)
    return files


@pytest.mark.fault
def test_killed_batch_resumes_without_losing_runs(tmp_path: Path) -> None:
    # each chunk of 2 runs is sealed by a worker as one segment: the job lasts several seconds,
    # so the kill lands after some segments were sealed and before the last one
    job = _write_job(tmp_path, 3000)
    expected = {p.run_id for p in prepare_runs(load_job(job))}
    archive = tmp_path / "a"
    proc = _start_batch(job, archive, tmp_path / "t1")
    _wait_for_runs(archive, 5, proc)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    before = _assert_consistent(archive, killed=True)
    assert 5 <= len(before) < 3000 and before <= expected

    proc = _start_batch(job, archive, tmp_path / "t2")
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err.decode()
    with open(tmp_path / "t2.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    skipped = {r["run_id"] for r in rows if r["status"] == "archived"}
    assert before <= skipped  # nothing finished was redone (an unindexed file is reused too)
    assert {r["status"] for r in rows} <= {"ok", "archived"}
    final = Archive(archive)
    assert {r["run_id"] for r in final.list_runs()} == expected
    assert _assert_consistent(archive) == expected
    report = final.repair()
    assert report["damaged_runs"] == [] and report["index_rows_fixed"] == 0
    assert (report["temporaries_removed"], report["segments_registered"]) == (0, 0)


@pytest.mark.process
def test_ctrl_c_stops_cleanly_with_exit_130(tmp_path: Path) -> None:
    job = _write_job(tmp_path, 3000)  # seconds of work: Ctrl-C lands mid-batch
    archive = tmp_path / "a"
    proc = _start_batch(job, archive, tmp_path / "t")
    _wait_for_runs(archive, 3, proc)
    os.killpg(proc.pid, signal.SIGINT)  # what a terminal's Ctrl-C does: the whole group
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err.decode()
    assert "interrupted" in err.decode()
    files = _assert_consistent(archive)
    assert {r["run_id"] for r in Archive(archive).list_runs()} == files
    with open(tmp_path / "t.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["index"]) for r in rows] == list(range(len(rows)))  # job order, no gaps
    assert {r["run_id"] for r in rows if r["status"] == "ok"} == files
    assert sum(r["status"] == "cancelled" for r in rows) == len(rows) - len(files)
    assert rows[-1]["status"] == "ok"  # the table ends with the last run reached


def test_cli_reports_an_invalid_job(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from bowlrec.cli import app

    job = tmp_path / "bad.json"
    job.write_text(json.dumps({"sweep": {"kind": "grid", "axes": {"delivery.speed": [1]}}}))
    res = CliRunner().invoke(app, ["batch", str(job), "-a", str(tmp_path / "a")])
    assert res.exit_code == 2
    assert "delivery.speed" in res.output and "speed_mps" in res.output


@pytest.mark.parametrize("worker_writes", ["yes", "no"])
def test_recorded_chunks_grow_where_workers_seal_them(tmp_path: Path, worker_writes: str) -> None:
    """Recorded runs go in chunks sized by time like the others (one segment each) when the
    workers seal them; workers that ship their records back get chunks of at most 32 runs (a
    shipped chunk's samples are held whole). 300 short runs (~1 ms each) on one worker: chunks
    of 4, 16, 64 and more when sealed; 4, 16, then 32 when shipped."""
    import h5py

    job = JobSpec.model_validate(recorded_speed_job(300, 0.05))
    archive = Archive(tmp_path / "a")
    result = run_job(job, archive, workers=0, worker_writes=worker_writes)
    assert result.counts["ok"] == 300
    sizes = []
    for path in archive.segments_dir.glob("*.h5"):
        with h5py.File(path, "r") as f:
            sizes.append(int(f.attrs["n_runs"]))
    assert sum(sizes) == 300
    assert max(sizes) > 32 if worker_writes == "yes" else max(sizes) == 32

"""The batch pipeline end to end: fast preparation bit-equal to resolve(), lazy sweeps, engine
results equal to solve(), the archive through the engine (digests from the documented
definition), tables and the CLI without an archive, and Dask worker writes."""

from __future__ import annotations

import copy
import csv
import json
import math
import time
import zlib
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from bowlrec.archive import Archive, RunRecord, SegmentBuilder, SegmentFile
from bowlrec.archive.balls import ball_sha
from bowlrec.archive.run_id import canonical_plan, run_id
from bowlrec.archive.scene_store import scene_texts
from bowlrec.archive.store import pattern_label
from bowlrec.batch import (
    METRIC_COLUMNS,
    BatchResult,
    JobSpec,
    apply_override,
    fastprep,
    job_context,
    prepare_runs,
    run_job,
    simulate_many,
)
from bowlrec.batch.chunks import ChunkTask, run_chunk
from bowlrec.batch.context import WriteTarget
from bowlrec.batch.fastprep import FastSweep
from bowlrec.batch.table import table_columns
from bowlrec.core.arguments import use_closed_form
from bowlrec.core.batch import pack_plans
from bowlrec.core.solver import run_plan, solve
from bowlrec.core.summary import FLOAT_METRICS, INT_METRICS
from bowlrec.provenance import environment
from bowlrec.sinks import RunData
from bowlrec.spec import Scene

ROOT = Path(__file__).resolve().parents[1]
CASE16 = ROOT / "examples" / "paper" / "case16.json"
BOWLER = ROOT / "examples" / "bowler" / "house-shot-right.json"
PACKED_FIELDS = (
    "par",
    "y0",
    "x_edges",
    "x_off",
    "y_edges",
    "y_off",
    "mu",
    "mu_off",
    "lane",
    "opts",
    "flags",
)


def case16(rtol: float = 2e-4) -> dict[str, Any]:
    """Paper case 16 (a non-uniform ball: the integrator) at a loose tolerance, summary only."""
    doc = json.loads(CASE16.read_text())
    doc["options"]["rtol"] = rtol
    doc["options"]["record"] = "summary"
    return doc


RANGES = {
    "delivery.speed_mps": {"low": 5.0, "high": 9.5},
    "delivery.takeoff_angle_deg": {"low": -3.0, "high": 3.0},
    "delivery.omega_radps[0]": {"low": -30.0, "high": 5.0},
    "delivery.omega_radps[1]": {"low": 0.0, "high": 40.0},
    "delivery.omega_radps[2]": {"low": -10.0, "high": 10.0},
}


def fast_jobs() -> dict[str, dict[str, Any]]:
    zip_n = 200
    return {
        "random": {
            "base": case16(),
            "sweep": {"kind": "random", "n": 300, "seed": 11, "axes": RANGES},
        },
        "lhs-default-base": {
            "sweep": {
                "kind": "lhs",
                "n": 250,
                "seed": 3,
                "axes": {k: RANGES[k] for k in list(RANGES)[:3]},
            },
        },
        "grid-ints-linspace": {
            "base": case16(),
            "sweep": {
                "kind": "grid",
                "axes": {
                    "delivery.speed_mps": [6, 7, 8],
                    "delivery.takeoff_angle_deg": {"start": -2.0, "stop": 2.0, "num": 5},
                    "delivery.omega_radps[0]": [-20, -10.5, 0, 3],
                    "delivery.omega_radps[2]": {"start": -5.0, "stop": 5.0, "num": 5},
                },
            },
        },
        "zip": {
            "base": case16(),
            "sweep": {
                "kind": "zip",
                "axes": {
                    "delivery.omega_radps[1]": [float(v) for v in np.linspace(0.5, 45.0, zip_n)],
                    "delivery.speed_mps": [6 + (k % 4) for k in range(zip_n)],
                    "delivery.takeoff_angle_deg": [0.01 * k - 1.0 for k in range(zip_n)],
                },
            },
        },
        "two-blocks": {
            "base": case16(),
            "sweep": [
                {
                    "kind": "random",
                    "n": 150,
                    "seed": 5,
                    "axes": {"delivery.speed_mps": RANGES["delivery.speed_mps"]},
                },
                {
                    "kind": "grid",
                    "axes": {
                        "delivery.omega_radps[1]": {"start": 5.0, "stop": 40.0, "num": 15},
                        "delivery.omega_radps[2]": [-4.0, -1, 0, 2.5, 9.5, 1e-3, 7, 8, 9, 10],
                    },
                },
            ],
        },
    }


def mixed_job(rtol: float = 2e-4) -> JobSpec:
    """A fast-path job with a gutter ball (10 deg) and a failed run (airborne at release)."""
    return JobSpec.model_validate(
        {
            "name": "mixed",
            "base": case16(rtol),
            "sweep": [
                {"kind": "random", "n": 40, "seed": 7, "axes": RANGES},
                {
                    "kind": "zip",
                    "axes": {
                        "delivery.takeoff_angle_deg": [10.0, 0.0, -1.0],
                        "delivery.omega_radps[1]": [23.7, 200.0, 23.7],
                    },
                },
            ],
        }
    )


def points_job() -> JobSpec:
    """A general-path job: ok, gutter, airborne, invalid, an other ball, a duplicate run and a
    bowler scene."""
    return JobSpec.model_validate(
        {
            "name": "points",
            "base": case16(),
            "sweep": [
                {
                    "kind": "points",
                    "points": [
                        {"delivery.speed_mps": 7.5},
                        {"delivery.takeoff_angle_deg": 10.0},  # gutter
                        {"delivery.omega_radps": [0.0, 200.0, 0.0]},  # airborne: failed
                        {"delivery.position_m": [0.0, 5.0]},  # off the lane: invalid
                        {"ball.mass_kg": 7.0, "delivery.speed_mps": 8.2},
                        {"delivery.speed_mps": 7.5},  # the first run again
                    ],
                },
                {"kind": "scenes", "scenes": [str(BOWLER)]},
            ],
        }
    )


def fbits(v: Any) -> str | None:
    """A float exactly (its hex; None and NaN are None)."""
    if v is None:
        return None
    v = float(v)
    return None if math.isnan(v) else v.hex()


def summary_bits(summary: Any) -> dict[str, Any]:
    out: dict[str, Any] = {"outcome": summary.outcome}
    out.update({k: fbits(getattr(summary, k)) for k in FLOAT_METRICS})
    out.update({k: int(getattr(summary, k)) for k in INT_METRICS})
    return out


def row_bits(row: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {"outcome": row["outcome"]}
    out.update({k: fbits(row[k]) for k in FLOAT_METRICS})
    out.update({k: row[k] for k in INT_METRICS})
    return out


def comparable(result: BatchResult) -> list[tuple[Any, ...]]:
    """Index, run ID and exact metrics of every row (statuses differ on reruns)."""
    return [(r["index"], r["run_id"], *row_bits(r).values()) for r in result.rows]


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return (
        a.dtype == b.dtype
        and a.shape == b.shape
        and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        and a.tobytes() == b.tobytes()
    )


# -- 1. fast preparation ----------------------------------------------------------------------


@pytest.mark.parametrize("name", list(fast_jobs()))
def test_fast_preparation_is_bit_equal_to_resolve(name: str) -> None:
    doc = fast_jobs()[name]
    job = JobSpec.model_validate({**doc, "record": "summary"})
    ctx = job_context(job)
    assert ctx.fast_paths is not None
    assert set(ctx.fast_paths) == {p for b in job.blocks() for p in b.axes}  # type: ignore[union-attr]
    base_doc = copy.deepcopy(doc.get("base") or {})
    base_doc.setdefault("options", {})["record"] = "summary"
    base = Scene.model_validate(base_doc)
    assert ctx.base_data == base.model_dump(mode="json")

    n = job.count()
    assert 200 <= n <= 400
    points = job.points()
    fast = FastSweep(Scene.model_validate(ctx.base_data), ctx.fast_paths)
    chunk = fast.prepare(np.arange(n, dtype=np.int64), job.columns(0, n, ctx.fast_paths))

    scenes, plans = [], []
    for p in points:
        data = base.model_dump(mode="json")
        for path, value in p.overrides.items():
            apply_override(data, path, value)
        scene = Scene.model_validate(data)
        scenes.append(scene)
        plans.append(scene.resolve())
    ref = pack_plans(plans)
    for f in PACKED_FIELDS:
        assert same_bits(getattr(chunk.packed, f), getattr(ref, f)), f
    assert chunk.run_ids == [run_id(p) for p in plans]
    assert len(set(chunk.run_ids)) == n
    for i in range(n):
        assert Scene.model_validate_json(chunk.scene_json[i]) == scenes[i], i
        assert canonical_plan(chunk.plan(i, fast.plan)) == canonical_plan(plans[i]), i
    # the engine's chunk of the same job carries the same IDs
    res = run_chunk(ChunkTask(ctx, 0, 50, None))
    assert res.table.run_id == chunk.run_ids[:50]


def test_fast_scene_json_is_the_general_paths_text() -> None:
    """The fast path's scene JSON is the text the general path stores for the same run
    (``RunData.scene_json``: pydantic's compact JSON), also for numbers whose shortest
    representations differ between Python's repr and pydantic (1e-09 / 1e-9)."""
    job = JobSpec.model_validate(
        {
            "base": case16(rtol=1e-9),
            "sweep": {
                "kind": "zip",
                "axes": {"delivery.omega_radps[2]": [1e-05, 2.5e-7, 3.0, 999.0, 1e-20]},
            },
        }
    )
    ctx = job_context(job)
    assert ctx.fast_paths is not None
    fast = FastSweep(Scene.model_validate(ctx.base_data), ctx.fast_paths)
    chunk = fast.prepare(np.arange(5), job.columns(0, 5, ctx.fast_paths))
    for i, prep in enumerate(prepare_runs(job)):
        assert prep.scene is not None
        assert chunk.scene_json[i].decode() == prep.scene.model_dump_json()


@pytest.mark.parametrize(
    "doc",
    [
        {"base": str(BOWLER), "sweep": {"kind": "grid", "axes": {"delivery.speed_mph": [16, 17]}}},
        {
            "base": case16(),
            "sweep": {"kind": "points", "points": [{"delivery.speed_mps": 7.0}]},
        },
        {"base": case16(), "sweep": {"kind": "scenes", "scenes": [case16()]}},
        {
            "base": case16(),
            "sweep": [
                {"kind": "grid", "axes": {"delivery.speed_mps": [7.0]}},
                {"kind": "points", "points": [{"delivery.speed_mps": 7.5}]},
            ],
        },
        {"base": case16(), "sweep": {"kind": "grid", "axes": {"ball.mass_kg": [6.5, 7.0]}}},
        {
            "base": case16(),
            "sweep": {
                "kind": "grid",
                "axes": {"delivery.speed_mps": [7.0], "ball.mass_kg": [6.5, 7.0]},
            },
        },
        {
            "base": case16(),
            "record": "trajectory",
            "formats": ["mcap"],
            "sweep": {"kind": "grid", "axes": {"delivery.speed_mps": [7.0, 8.0]}},
        },
        {"base": case16()},
    ],
    ids=[
        "bowler",
        "points",
        "scenes",
        "grid+points",
        "mass",
        "speed+mass",
        "trajectory-with-replays",
        "no-sweep",
    ],
)
def test_fast_path_applies_only_to_physical_delivery_sweeps(doc: dict[str, Any]) -> None:
    job = JobSpec.model_validate(doc)
    assert job_context(job).fast_paths is None


# -- 2. lazy sweeps ----------------------------------------------------------------------------


def _mixed_blocks(scenes: bool = True) -> JobSpec:
    two = {k: RANGES[k] for k in ("delivery.speed_mps", "delivery.omega_radps[1]")}
    blocks: list[dict[str, Any]] = [
        {
            "kind": "grid",
            "axes": {
                "delivery.speed_mps": [6, 7, 8],
                "delivery.takeoff_angle_deg": {"start": -1.0, "stop": 1.0, "num": 4},
            },
        },
        {"kind": "zip", "axes": {"delivery.omega_radps[1]": [10.0, 20.0, 30.0]}},
        {"kind": "random", "n": 17, "seed": 4, "axes": two},
        {"kind": "lhs", "n": 11, "seed": 9, "axes": two},
        {"kind": "random", "n": 9, "seed": 4, "axes": RANGES},
    ]
    if scenes:
        blocks.insert(2, {"kind": "points", "points": [{"ball.mass_kg": 7.0}, {}, {"name": "x"}]})
        blocks.append({"kind": "scenes", "scenes": [{"name": "s1"}, {"name": "s2"}]})
    return JobSpec.model_validate({"sweep": blocks})


def test_points_of_any_range_equal_the_slice_of_all_points() -> None:
    job = _mixed_blocks()
    full = job.points()
    n = job.count()
    assert n == len(full) == 12 + 3 + 3 + 17 + 11 + 9 + 2
    assert [p.index for p in full] == list(range(n))
    assert [p.block for p in full][-3:] == [5, 6, 6]
    assert [p.scene for p in full][-2:] == [0, 1]
    for a in range(n + 2):
        for b in range(a, n + 3):
            assert job.points(a, b) == full[a:b], (a, b)
    assert job.points(5, 3) == []
    assert job.points(40) == full[40:]


def test_columns_equal_points() -> None:
    job = _mixed_blocks(scenes=False)
    paths = list(RANGES)
    full = job.points()
    n = job.count()
    for a, b in [(0, n), (3, 14), (14, 16), (15, 40), (30, 31), (40, n + 5), (n, n + 1)]:
        cols = job.columns(a, b, paths)
        pts = full[a:b]
        for p in paths:
            expected = [float(pt.overrides.get(p, math.nan)) for pt in pts]
            assert same_bits(cols[p], np.array(expected, dtype=np.float64)), (a, b, p)


def test_random_sweep_is_default_rng_scaled() -> None:
    seed, n = 123, 1000
    axes = {
        "delivery.speed_mps": (5.5, 9.25),
        "delivery.omega_radps[2]": (-7.0, 3.0),
        "delivery.takeoff_angle_deg": (-2.0, 2.0),
    }
    job = JobSpec.model_validate(
        {
            "sweep": {
                "kind": "random",
                "n": n,
                "seed": seed,
                "axes": {p: {"low": lo, "high": hi} for p, (lo, hi) in axes.items()},
            }
        }
    )
    u = np.random.default_rng(seed).random((n, len(axes)))
    for lo_hi in [(0, n), (0, 1), (999, 1000), (17, 433), (500, 2000)]:
        for k, point in enumerate(job.points(*lo_hi), lo_hi[0]):
            assert point.index == k
            for j, (path, (lo, hi)) in enumerate(axes.items()):
                value = point.overrides[path]
                assert type(value) is float
                assert value == lo + float(u[k, j]) * (hi - lo), (k, path)


def test_ten_million_runs_are_not_expanded() -> None:
    n, seed = 10_000_000, 42
    lows, highs = np.array([5.0, -3.0]), np.array([9.0, 3.0])
    start = time.perf_counter()
    job = JobSpec.model_validate(
        {
            "base": case16(),
            "sweep": {
                "kind": "random",
                "n": n,
                "seed": seed,
                "axes": {
                    "delivery.speed_mps": {"low": 5.0, "high": 9.0},
                    "delivery.takeoff_angle_deg": {"low": -3.0, "high": 3.0},
                },
            },
        }
    )
    assert job.count() == n
    ctx = job_context(job)
    assert ctx.fast_paths is not None
    tail = job.points(9_999_990, 10_000_000)
    cols = job.columns(9_999_990, 10_000_000, ctx.fast_paths)
    assert time.perf_counter() - start < 2.0
    assert [p.index for p in tail] == list(range(9_999_990, n))
    assert job.points(9_999_995, 20_000_000) == tail[5:]
    assert job.points(n, n + 10) == []
    # the same rows drawn from the whole stream, 1,000,000 rows at a time
    rng = np.random.default_rng(seed)
    for _ in range(9):
        rng.random((1_000_000, 2))
    rng.random((999_990, 2))
    u = rng.random((10, 2))
    x = lows + u * (highs - lows)
    assert [list(p.overrides.values()) for p in tail] == x.tolist()
    assert same_bits(cols["delivery.speed_mps"], x[:, 0])


# -- 3. engine results equal solve() -------------------------------------------------------------


def _check_against_solve(job: JobSpec, result: BatchResult, base_dir: Path | str = ".") -> None:
    prepared = prepare_runs(job, base_dir=base_dir)
    rows = result.rows
    assert len(rows) == len(prepared) == job.count()
    for row, prep in zip(rows, prepared, strict=True):
        assert row["index"] == prep.index
        assert row["run_id"] == prep.run_id
        if prep.plan is None:
            assert row["status"] == "failed" and row["error"] == prep.error
            assert all(row[k] is None for k in METRIC_COLUMNS)
            continue
        summary = solve(prep.plan).summary
        assert row_bits(row) == summary_bits(summary), row["index"]
        failed = summary.outcome in ("airborne", "max_steps", "stalled")
        assert row["status"] == ("failed" if failed else "ok"), row


def test_fast_path_engine_equals_solve() -> None:
    job = mixed_job()
    assert job_context(job).fast_paths is not None
    result = run_job(job, None, workers=0, chunk_size=16)
    _check_against_solve(job, result)
    outcomes = [r["outcome"] for r in result.rows]
    assert outcomes[-3:] == ["gutter", "airborne", "pins"]
    assert outcomes.count("pins") >= 10 and outcomes.count("gutter") >= 10


def test_general_path_engine_equals_solve() -> None:
    bowler = JobSpec.model_validate(
        {
            "base": str(BOWLER),
            "sweep": {
                "kind": "lhs",
                "n": 10,
                "seed": 1,
                "axes": {
                    "delivery.speed_mph": {"low": 14.0, "high": 20.0},
                    "delivery.rev_rate_rpm": {"low": 200.0, "high": 450.0},
                },
            },
        }
    )
    for job in (bowler, points_job()):
        assert job_context(job).fast_paths is None
        result = run_job(job, None, workers=0, chunk_size=4)
        _check_against_solve(job, result)
    statuses = [r["status"] for r in result.rows]
    assert statuses == ["ok", "ok", "failed", "failed", "ok", "ok", "ok"]


def _force_general(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(fastprep.FastSweep, "applies", staticmethod(lambda *a: False))


def test_fast_and_general_paths_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    jobs = [mixed_job(), JobSpec.model_validate({**fast_jobs()["grid-ints-linspace"]})]
    fast = [run_job(job, None, workers=0, chunk_size=64) for job in jobs]
    _force_general(monkeypatch)
    assert all(job_context(job).fast_paths is None for job in jobs)
    general = [run_job(job, None, workers=0, chunk_size=64) for job in jobs]
    for f, g in zip(fast, general, strict=True):
        assert comparable(f) == comparable(g)
        assert [(r["status"], r["error"]) for r in f.rows] == [
            (r["status"], r["error"]) for r in g.rows
        ]


def test_a_recorded_delivery_sweep_archives_what_the_general_path_archives(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A sweep of the delivery that records samples is prepared the fast way (no Scene per
    run) and archives the runs the general path archives: the same run IDs, scene JSON,
    samples (bit for bit), events and summaries."""
    job = JobSpec.model_validate(
        {
            "base": case16(),
            "record": "trajectory",
            "sweep": [
                {"kind": "grid", "axes": {"delivery.speed_mps": [6.5, 8.0, 8.0]}},
                {"kind": "random", "n": 3, "seed": 2, "axes": RANGES},
            ],
        }
    )
    assert job_context(job).fast_paths is not None

    def archived(root: Path) -> dict[str, Any]:
        archive = Archive(root)
        result = run_job(job, archive, workers=0, chunk_size=4)
        assert result.counts["ok"] + result.counts["failed"] == 6
        out = {}
        for row in archive.list_runs(limit=None):
            stored = archive.load(row["run_id"])
            arrays = {k: v.tobytes() for k, v in stored.trajectory.arrays().items()}
            out[row["run_id"]] = (
                stored.attrs["scene_json"],
                arrays,
                stored.trajectory.events,
                stored.trajectory.summary,
                row["solver"],
                row["speed_mps"],
            )
        return out

    fast = archived(tmp_path / "fast")
    _force_general(monkeypatch)
    assert job_context(job).fast_paths is None
    general = archived(tmp_path / "general")
    assert len(fast) >= 4 and fast == general


def test_fast_and_general_paths_give_the_same_parameter_columns(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A path a block does not sweep has no value in that block's rows (null), whichever
    path prepares the job (the general path and the rows of cancelled chunks leave it null)."""
    job = JobSpec.model_validate(fast_jobs()["two-blocks"])
    fast = run_job(job, None, workers=0)
    _force_general(monkeypatch)
    general = run_job(job, None, workers=0)
    cols = fast.param_columns
    assert (
        cols
        == general.param_columns
        == ["delivery.speed_mps", "delivery.omega_radps[1]", "delivery.omega_radps[2]"]
    )
    params_fast = [[r[c] for c in cols] for r in fast.rows]
    params_general = [[r[c] for c in cols] for r in general.rows]
    assert params_general[0][1:] == [None, None]  # block 0 sweeps only the speed
    assert params_fast == params_general


# -- 4. the archive through the engine -------------------------------------------------------------


def _segment_files(archive: Archive) -> set[str]:
    return {p.name for p in archive.segments_dir.glob("*.h5")}


def _check_archived(job: JobSpec, result: BatchResult, archive: Archive) -> None:
    rows = result.rows
    ok = {r["run_id"] for r in rows if r["status"] == "ok"}
    assert ok and all(r["status"] in ("ok", "failed") for r in rows)
    listed = {r["run_id"] for r in archive.list_runs()}
    assert ok <= listed
    by_id = {p.run_id: p for p in prepare_runs(job) if p.run_id is not None}
    for row in rows:
        if row["status"] != "ok":
            continue
        stored = archive.load(row["run_id"])
        assert summary_bits(stored.trajectory.summary) == row_bits(row)
        prep = by_id[row["run_id"]]
        assert prep.plan is not None
        expected = run_plan(prep.plan)  # the numbers of solve() and the outcome in words
        assert stored.trajectory.summary == expected.summary
        assert stored.trajectory.events == expected.events
        assert stored.scene == prep.scene


@pytest.mark.parametrize("workers", [0, pytest.param(2, marks=pytest.mark.process)])
def test_engine_archives_every_ok_run(tmp_path: Path, workers: int) -> None:
    archive = Archive(tmp_path / "a")
    jobs = [mixed_job(), points_job()]
    first = []
    for job in jobs:
        result = run_job(job, archive, workers=workers, chunk_size=8)
        assert result.error is None and not result.cancelled
        _check_archived(job, result, archive)
        first.append(result)
    n_ok = len({r["run_id"] for res in first for r in res.rows if r["status"] == "ok"})
    assert len(archive) == n_ok
    for path in archive.segments_dir.glob("*.h5"):
        with SegmentFile(path) as seg:
            healthy, damaged = seg.verify()
            assert damaged == {} and healthy == list(range(seg.n_runs))
    report = archive.repair(min_age_s=0.0)
    assert report["damaged_runs"] == [] and report["quarantined_segments"] == []
    assert report["index_rows_fixed"] == 0 and report["runs_checked"] == n_ok

    files = _segment_files(archive)
    again_archive = Archive(tmp_path / "a")
    for job, before in zip(jobs, first, strict=True):
        again = run_job(job, again_archive, workers=workers, chunk_size=8)
        retried = {r["run_id"] for r in before.rows if r["status"] == "failed" and r["run_id"]}
        assert again.simulated == len(retried)
        assert [r["status"] for r in again.rows] == [
            "archived" if r["status"] == "ok" else r["status"] for r in before.rows
        ]
        assert comparable(again) == comparable(before)  # metrics of archived runs: the index
    assert _segment_files(again_archive) == files
    assert len(again_archive) == n_ok


@pytest.mark.parametrize("rtol", [2e-4, 1e-9])
def test_summary_runs_segment_equals_segment_builder_segment(tmp_path: Path, rtol: float) -> None:
    """The fast path's columns and the records of the same runs make the same segment, but for
    how the scenes are stored (the fast path: the swept values as override columns; the
    builder: JSON overrides) and so the digests: the scenes read back as the same text (with
    case 16's own rtol = 1e-9 the scene JSON holds a number Python and pydantic write apart)."""
    job = mixed_job(rtol)
    ctx = job_context(job)
    assert ctx.fast_paths is not None
    n = job.count()
    res = run_chunk(ChunkTask(ctx, 0, n, WriteTarget(str(tmp_path / "nowhere"), mode="no")))
    runs = res.summary_runs
    assert runs is not None and not res.segments and not res.records
    ok = [i for i, s in enumerate(res.table.status) if s == "ok"]
    assert runs.run_ids() == [res.table.run_id[i] for i in ok]
    assert len(ok) == n - 1  # one run is airborne: not stored

    prepared = prepare_runs(job)
    builder = SegmentBuilder(environment())
    for i in ok:
        prep = prepared[i]
        assert prep.scene is not None and prep.plan is not None and prep.run_id is not None
        traj = run_plan(prep.plan)
        builder.append(
            RunRecord.from_run(
                RunData(prep.scene, prep.plan, traj, prep.run_id),
                wall_time_s=0.001 * i,
                ball_ref="",
                solver="closed_form" if use_closed_form(prep.plan) else "integrator",
                ball_sha=ball_sha(prep.scene.ball),
                pattern=pattern_label(prep.scene),
                created_at_ns=runs.created_at_ns,
            )
        )
    runs.floats["wall_time_s"] = np.array([0.001 * i for i in ok])
    a, b = runs.columns(), builder.columns()
    assert a.keys() == b.keys()
    assert a["_attrs"] == b["_attrs"]
    for group in a:
        if group in ("_attrs", "scene", "digest"):
            continue
        if group == "_terms":
            assert same_bits(a[group], b[group])
            continue
        assert a[group].keys() == b[group].keys(), group
        for name in a[group]:
            assert same_bits(a[group][name], b[group][name]), f"{group}/{name}"
    assert a["scene"]["override_paths"].size == len(ctx.fast_paths)
    assert b["scene"]["override_paths"].size == 0
    texts = [
        scene_texts(
            c["scene"]["base_json"].tobytes(),
            [json.loads(p) for p in c["scene"]["override_paths"].tolist()],
            c["scene"]["override_values"],
            c["scene"]["override_json"],
            c["scene"]["override_offsets"],
        )
        for c in (a, b)
    ]
    assert texts[0] == texts[1] == [prepared[i].scene.model_dump_json() for i in ok]


# -- 5. digests as docs/archive-format.md defines them ---------------------------------------------


def _entry_bytes(ds: Any, a: int, b: int) -> list[bytes]:
    """Each entry's raw bytes (rows a..b of one dataset, fixed-length strings padded)."""
    arr = np.ascontiguousarray(ds[a:b])
    return [arr[i : i + 1].tobytes() for i in range(b - a)]


def _rows(group: Any, names: list[str], a: int, b: int) -> bytes:
    """Rows a..b: per row, the named datasets' entries side by side."""
    cols = [_entry_bytes(group[k], a, b) for k in names]
    return b"".join(b"".join(c[i] for c in cols) for i in range(b - a))


def _span(f: h5py.File, group: str, a: int, b: int) -> tuple[int, int]:
    """Rows of runs ``a:b`` in ``group`` (its offsets)."""
    lo, hi = (int(f[group]["offsets"][j]) for j in (a, b))
    return lo, hi


def samples_2_3() -> list[str]:
    """The sample datasets of a 2.3 segment, in the digest's order."""
    names = "alpha_radps2 energy_J friction_force_N mu normal_force_N omega_radps phase "
    return (names + "position_m quaternion_wxyz slip_mps t_s velocity_mps").split()


def docs_digest(f: h5py.File, k: int) -> int:
    """Block ``k``'s digest, following the text of docs/archive-format.md ("Digests")."""
    n, size = int(f.attrs["n_runs"]), int(f["digest"].attrs["block_runs"])
    assert f["digest"].attrs["algorithm"] == "crc32"
    a, b = k * size, min(n, (k + 1) * size)
    crc = 0

    def part(data: bytes) -> None:
        nonlocal crc
        crc = zlib.crc32(len(data).to_bytes(8, "little"), crc)
        crc = zlib.crc32(data, crc)

    # 1, 2: the base scene and the override paths, as stored
    part(f["scene/base_json"][()].tobytes())
    part(np.ascontiguousarray(f["scene/override_paths"][()]).tobytes())
    # 3: per run of the block, runs/* then summary/* (not message, message_offsets), each
    # group's datasets in sorted name order: the entries' raw bytes
    fixed = [
        (group, name)
        for group in ("runs", "summary")
        for name in sorted(f[group])
        if name not in ("message", "message_offsets")
    ]
    part(b"".join(_entry_bytes(f[g][name], i, i + 1)[0] for i in range(a, b) for g, name in fixed))
    # 4: the block's rows of the override values
    part(np.ascontiguousarray(f["scene/override_values"][a:b]).tobytes())
    # 5, 6: the block's override JSON and message bytes
    for data, offsets in (
        ("scene/override_json", "scene/override_offsets"),
        ("summary/message", "summary/message_offsets"),
    ):
        lo, hi = (int(f[offsets][j]) for j in (a, b))
        part(f[data][lo:hi].tobytes())
    # 7: events; 8: samples (3.0: one part per dataset, each the block's rows as stored; 2.3:
    # the datasets side by side per sample); 9: torque rows
    state = str(f.attrs["format_version"]) == "3.0"
    samples = "friction_dir mu omega_radps phase position_m quaternion_wxyz t_s velocity_mps"
    samples = samples.split()
    part(
        _rows(f["events"], ["kind", "mu", "phase", "t_s", "x_m", "y_m"], *_span(f, "events", a, b))
    )
    if state:
        lo, hi = _span(f, "trajectory", a, b)
        for name in samples:
            part(np.ascontiguousarray(f["trajectory"][name][lo:hi]).tobytes())
    else:
        lo, hi = _span(f, "trajectory", a, b)
        present = [name for name in samples_2_3() if name in f["trajectory"]]
        part(_rows(f["trajectory"], present, lo, hi) if present else b"")
    groups = [
        (
            "torques",
            [t.decode() if isinstance(t, bytes) else str(t) for t in f["torques"].attrs["order"]],
        ),
    ]
    # 10 and on: further groups with an offsets dataset, sorted; their other datasets sorted
    known = {"runs", "summary", "events", "trajectory", "torques", "scene", "digest"}
    for g in sorted(f):
        if g not in known and "offsets" in f[g]:
            groups.append((g, sorted(name for name in f[g] if name != "offsets")))
    for g, names in groups:
        lo, hi = (int(f[g]["offsets"][j]) for j in (a, b))
        present = [name for name in names if name in f[g]]
        part(_rows(f[g], present, lo, hi) if present else b"")
    return crc


def test_digests_follow_the_documented_definition(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    recorded = copy.deepcopy(case16())
    recorded["options"].update(record="rate", record_dt_s=0.05, record_terms=True)
    jobs = [
        JobSpec.model_validate({**mixed_job().model_dump(mode="json", by_alias=True)}),
        points_job(),
        JobSpec.model_validate(
            {
                "base": recorded,
                "record": "scene",
                "sweep": {"kind": "grid", "axes": {"delivery.speed_mps": [7.0, 8.0]}},
            }
        ),
    ]
    for job in jobs:
        assert run_job(job, archive, workers=0, chunk_size=25).error is None
    checked = 0
    seen = {"events": 0, "trajectory": 0, "torques": 0}
    for path in sorted(archive.segments_dir.glob("*.h5")):
        with h5py.File(path, "r") as f:
            stored = f["digest/blocks"][()]
            assert stored.dtype == np.dtype("uint32")
            n, size = int(f.attrs["n_runs"]), int(f["digest"].attrs["block_runs"])
            assert size == (1 if f["trajectory/offsets"][-1] else 256)
            assert stored.shape == (-(-n // size),)
            for k in range(stored.shape[0]):
                assert docs_digest(f, k) == int(stored[k]), (path.name, k)
            checked += n
            for i in range(n):
                for g in seen:
                    a, b = f[g]["offsets"][i : i + 2]
                    seen[g] += int(b > a)
        with SegmentFile(path) as seg:
            computed = [seg.computed_digest(i) for i in range(0, seg.n_runs, seg.block_runs)]
            assert computed == [f"{int(v):08x}".encode() for v in stored]
    assert checked == len(archive)
    assert all(seen.values()), seen  # every part was exercised with rows


# -- 6. tables ---------------------------------------------------------------------------------


def _no_nan_or_inf(values: list[Any]) -> bool:
    return not any(isinstance(v, float) and not math.isfinite(v) for v in values)


def test_simulate_many_tables_null_nan_and_minus_one() -> None:
    pa = pytest.importorskip("pyarrow")
    scenes: list[Any] = [
        Scene.model_validate(case16()),
        Scene.model_validate(
            {**case16(), "delivery": {**case16()["delivery"], "takeoff_angle_deg": 10.0}}
        ),
        Scene.model_validate(
            {**case16(), "ball": {**case16()["ball"], "com_offset_m": [0.02, 0.0, 0.0]}}
        ),
        {**case16(), "delivery": {**case16()["delivery"], "position_m": [0.0, 5.0]}},
        str(BOWLER),
    ]
    expected_outcomes = ["pins", "gutter", "airborne", None, "pins"]
    expected_status = ["ok", "ok", "failed", "failed", "ok"]
    for source in (scenes, mixed_job()):
        table = simulate_many(source, workers=0, output="arrow")
        assert isinstance(table, pa.Table)
        assert table.schema.field("hook_m").type == pa.float64()
        assert table.schema.field("n_steps").type == pa.int64()
        rows = table.to_pylist()
        for name in table.column_names:
            assert _no_nan_or_inf(table.column(name).to_pylist()), name
        if source is scenes:
            assert [r["outcome"] for r in rows] == expected_outcomes
            assert [r["status"] for r in rows] == expected_status
            assert rows[0]["hook_m"] is not None
            assert rows[1]["hook_m"] is None and rows[1]["time_s"] is not None
            assert rows[2]["hook_m"] is None and rows[2]["n_steps"] is not None
            assert all(rows[3][k] is None for k in METRIC_COLUMNS)
            assert rows[3]["run_id"] is None and "position_m[1]" in rows[3]["error"]
        else:
            assert [r["outcome"] for r in rows][-3:] == ["gutter", "airborne", "pins"]
            assert rows[-3]["hook_m"] is None and rows[-2]["hook_m"] is None
            assert rows[-2]["status"] == "failed" and rows[-1]["hook_m"] is not None

        arr = simulate_many(source, workers=0, output="numpy")
        assert arr.dtype.names == tuple(table.column_names)
        assert len(arr) == len(rows)
        for name in arr.dtype.names:
            if arr.dtype[name].kind == "f":
                assert not np.isinf(arr[name]).any(), name
        hook = arr["hook_m"]
        for k, r in enumerate(rows):
            assert (r["hook_m"] is None) == bool(np.isnan(hook[k]))
            if r["hook_m"] is not None:
                assert hook[k] == r["hook_m"]
            for name in INT_METRICS:
                assert arr[name][k] == (-1 if r[name] is None else r[name])
            assert arr["outcome"][k] == (r["outcome"] or "")
        if source is scenes:
            assert arr["n_steps"][3] == -1 and arr["n_steps"][2] > 0
            assert arr["run_id"][3] == ""


def _write_job(path: Path) -> JobSpec:
    doc = points_job().model_dump(mode="json", by_alias=True)
    path.write_text(json.dumps(doc))
    return points_job()


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".json", ".jsonl"])
def test_cli_batch_no_archive_writes_exactly_the_table(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, suffix: str
) -> None:
    from typer.testing import CliRunner

    from bowlrec.cli import app

    if suffix == ".parquet":
        pytest.importorskip("pyarrow")
    jobs, out_dir, cwd, home = (tmp_path / d for d in ("jobs", "out", "cwd", "home"))
    for d in (jobs, out_dir, cwd, home):
        d.mkdir()
    job_path = jobs / "job.json"
    job = _write_job(job_path)
    env_archive = tmp_path / "env-archive"
    monkeypatch.chdir(cwd)
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("XDG_DATA_HOME", raising=False)
    monkeypatch.delenv("XDG_CONFIG_HOME", raising=False)
    monkeypatch.delenv("BOWLREC_CONFIG", raising=False)
    monkeypatch.delenv("BOWLREC_SCHEDULER", raising=False)
    if suffix == ".csv":
        monkeypatch.setenv("BOWLREC_ARCHIVE", str(env_archive))
    else:
        monkeypatch.delenv("BOWLREC_ARCHIVE", raising=False)
    out = out_dir / f"t{suffix}"
    args = ["batch", str(job_path), "--no-archive", "--out", str(out), "-j", "0", "--quiet"]
    result = CliRunner().invoke(app, [*args, "--allow-failures"])  # the job has failed runs
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out_dir.iterdir()) == [out.name]
    assert sorted(p.name for p in jobs.iterdir()) == ["job.json"]
    assert list(cwd.iterdir()) == [] and list(home.iterdir()) == []
    assert not env_archive.exists()

    expected = run_job(job, None, workers=0).rows
    columns = table_columns(
        [
            "delivery.speed_mps",
            "delivery.takeoff_angle_deg",
            "delivery.omega_radps",
            "delivery.position_m",
            "ball.mass_kg",
            "scene",
        ]
    )
    assert list(expected[0]) == columns
    assert expected[3]["outcome"] is None and expected[1]["hook_m"] is None
    if suffix == ".csv":
        with open(out, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            assert reader.fieldnames == columns
            got = list(reader)
        assert len(got) == len(expected)
        for g, e in zip(got, expected, strict=True):
            for k in columns:
                if e[k] is None:
                    assert g[k] == "", (k, g)
                elif isinstance(e[k], float):
                    assert float(g[k]) == e[k], (k, g[k], e[k])
                else:
                    assert g[k] == str(e[k]), (k, g[k], e[k])
    elif suffix == ".parquet":
        import pyarrow.parquet as pq

        got = pq.read_table(out).to_pylist()
        assert got == expected
    elif suffix == ".json":
        got = json.loads(out.read_text())
        assert got == expected
    else:
        lines = out.read_text().splitlines()
        assert [json.loads(line) for line in lines] == expected
        assert '"hook_m": null' in lines[1]


# -- 7. Dask worker writes ------------------------------------------------------------------


@pytest.mark.process  # a Dask cluster of processes
def test_dask_worker_writes_yes_no_auto(tmp_path: Path) -> None:
    distributed = pytest.importorskip(
        "distributed", reason="dask.distributed not installed (pip install 'bowlrec[dask]')"
    )
    fast_job = JobSpec.model_validate(
        {
            "base": case16(),
            "sweep": [
                {"kind": "random", "n": 240, "seed": 21, "axes": RANGES},
                {"kind": "zip", "axes": {"delivery.omega_radps[1]": [200.0, 20.0]}},
            ],
        }
    )
    jobs = {"fast": (fast_job, 60), "general": (points_job(), 3)}
    local = {k: run_job(job, None, workers=0, chunk_size=size) for k, (job, size) in jobs.items()}
    results: dict[str, dict[str, BatchResult]] = {}
    stored: dict[str, set[str]] = {}
    parent_seals: dict[str, list[int]] = {}
    probes_seen: dict[str, set[str]] = {}
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=":0",
    ) as cluster:
        for mode in ("yes", "no", "auto"):
            archive = Archive(tmp_path / mode)
            seals: list[int] = []
            probes: set[str] = set()
            parent_seal = archive.seal

            def counting_seal(
                builder: Any, _seal: Any = parent_seal, _n: list[int] = seals, **kw: Any
            ) -> Any:
                _n.append(len(builder))
                return _seal(builder, **kw)

            def watch(_: Any, _a: Archive = archive, _p: set[str] = probes) -> None:
                _p.update(p.name for p in _a.segments_dir.glob(".probe-*"))

            archive.seal = counting_seal  # type: ignore[method-assign]
            results[mode] = {
                k: run_job(
                    job,
                    archive,
                    scheduler=cluster.scheduler_address,
                    worker_writes=mode,
                    chunk_size=size,
                    progress=watch,
                )
                for k, (job, size) in jobs.items()
            }
            stored[mode] = {r["run_id"] for r in archive.list_runs()}
            parent_seals[mode] = seals
            probes_seen[mode] = probes
            assert list(archive.segments_dir.glob(".probe-*")) == []
            assert list(archive.segments_dir.glob(".*.part")) == []
            report = archive.repair(min_age_s=0.0)
            assert report["damaged_runs"] == [] and report["segments_registered"] == 0
            n_segments = len(list(archive.segments_dir.glob("*.h5")))
            if mode == "no":  # the parent sealed every segment
                assert n_segments == len(seals) > 0
            else:  # the workers did (they see the archive's files)
                assert seals == [] and n_segments > 0

    assert probes_seen["yes"] == probes_seen["no"] == set()
    assert len(probes_seen["auto"]) == len(jobs)  # one probe per batch
    ok = {r["run_id"] for res in local.values() for r in res.rows if r["status"] == "ok"}
    for mode in ("yes", "no", "auto"):
        assert stored[mode] == ok, mode
        for k, res in results[mode].items():
            assert res.error is None
            assert comparable(res) == comparable(local[k]), (mode, k)
            statuses = [r["status"] for r in res.rows]
            expected = [r["status"] for r in local[k].rows]
            if mode == "no":
                # a shipped run the parent finds archived is an "archived" row; that includes a
                # run repeated in the same job once one copy is registered (chunks finish in any
                # order, so any of its rows may be the one that stored it)
                ids = [r["run_id"] for r in local[k].rows]
                repeated = {rid for rid in ids if rid is not None and ids.count(rid) > 1}
                for i, rid in enumerate(ids):
                    if rid in repeated and statuses[i] == "archived":
                        expected[i] = "archived"
                for rid in repeated:  # one of its rows stored it
                    assert "ok" in {statuses[i] for i, r in enumerate(ids) if r == rid}, rid
            assert statuses == expected, (mode, k)

"""The pipeline against the kernel, side by side in one run: batch with and without the archive,
``simulate_many``, the service, recorded trajectories and a bowler-language job.

    python -m benchmarks.pipeline [--quick] [--out benchmarks/results]

The jobs are committed in ``benchmarks/jobs/`` so everyone measures the same runs:

- ``case16-summary.json``: 200,000 case-16-like deliveries (non-scalar inertia, 0.7 mm offset)
  at rtol 2e-4, summary only, a random sweep over speed, spin and take-off angle;
- ``bowler-lhs.json``: the house-shot bowler scene at its default rtol, a Latin hypercube of
  20,000 points over speed, rev rate and axis rotation, summary only;
- ``case16-recorded.json``: 2,000 case-16-like deliveries recorded at 1 ms, stored with their
  samples.

Measured (2 workers / 2 threads everywhere):

- kernel: the job's deliveries packed in memory and run by the compiled many-delivery kernel
  (``bowlrec.core.batch.run_batch``, 2 numba threads); nothing prepared, stored or tabled in
  the timing. Measured before and after the pipeline rows; the table quotes both and the ratios
  use their mean, since the machine is shared;
- batch: ``run_job`` with 2 local worker processes, into a fresh archive and with no archive;
  the steady-state rate is taken from the progress reports between 10 % and 90 % of the runs
  (worker start-up excluded), the whole-job rate includes it;
- ``simulate_many(job, workers=2)``, the Python API (an Arrow table back);
- the CLI end to end: ``bowlrec batch JOB --no-archive --out t.parquet`` (process start-up
  included);
- per-run costs in one process (prepare, kernel, segment, index registration) and the
  throughput ceiling they impose on 2 cores;
- the service (``bowlrec serve --job-workers 2``): ``POST /jobs`` of 100,000 runs of the
  case-16 job (``--quick``: 20,000), and
  16 concurrent clients posting new summary-only scenes against ``GET /health`` of the same app
  with the same load generator (httpx, one thread per client);
- recorded trajectories: runs/s on 2 workers, bytes per run, and the fsynced sequential write
  rate of the same disk measured in the same run.

Writes ``pipeline.json`` and ``pipeline.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
JOBS = ROOT / "benchmarks" / "jobs"


def _job(name: str, n: int | None = None) -> Any:
    from bowlrec.batch import JobSpec, load_job

    job = load_job(JOBS / name)
    if n is None:
        return job
    data = job.model_dump(mode="json", by_alias=True)
    data["sweep"]["n"] = n
    return JobSpec.model_validate(data)


def _packed(job: Any, n: int) -> Any:
    """The first ``n`` deliveries of a job, packed for the kernel (prepared untimed)."""
    from bowlrec.batch import job_context
    from bowlrec.batch.fastprep import FastSweep
    from bowlrec.batch.job import prepare_point
    from bowlrec.core.batch import pack_plans
    from bowlrec.spec import Scene

    ctx = job_context(job, base_dir=JOBS)
    if ctx.fast_paths is not None:
        import numpy as np

        fast = FastSweep(Scene.model_validate(ctx.base_data), ctx.fast_paths)
        return fast.prepare(np.arange(n), job.columns(0, n, ctx.fast_paths)).packed
    plans = [prepare_point(ctx, p).plan for p in job.points(0, n)]
    return pack_plans([p for p in plans if p is not None])


def kernel_rate(packed: Any, repeats: int = 3) -> float:
    """Deliveries/s of the many-delivery kernel on 2 numba threads (median of ``repeats``)."""
    import numba

    from bowlrec.core.batch import run_batch, take

    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    import numpy as np

    run_batch(take(packed, np.arange(min(100, packed.n))), parallel=True)  # warm
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run_batch(packed, parallel=True)
        times.append(time.perf_counter() - t0)
    return packed.n / statistics.median(times)


class _Steady:
    """Progress callback: the rate between 10 % and 90 % of the runs (where the progress jumps
    over 90 %: up to the last report short of all the runs)."""

    def __init__(self) -> None:
        self.points: list[tuple[float, int]] = []

    def __call__(self, p: Any) -> None:
        self.points.append((time.perf_counter(), p.done))

    def rate(self, total: int) -> float:
        lo = [pt for pt in self.points if pt[1] >= 0.1 * total]
        hi = [pt for pt in self.points if pt[1] >= 0.9 * total]
        if lo and hi and hi[0][0] > lo[0][0]:
            return (hi[0][1] - lo[0][1]) / (hi[0][0] - lo[0][0])
        short = [pt for pt in lo if pt[1] < total]
        if len(short) >= 2 and short[-1][0] > short[0][0]:
            return (short[-1][1] - short[0][1]) / (short[-1][0] - short[0][0])
        return float("nan")


def batch_row(label: str, job: Any, archive: Any, total: int) -> dict[str, Any]:
    from bowlrec.batch import run_job

    steady = _Steady()
    t0 = time.perf_counter()
    res = run_job(job, archive, base_dir=JOBS, workers=2, progress=steady)
    wall = time.perf_counter() - t0
    c = res.counts
    if c["ok"] + c["archived"] + c["failed"] != total or res.error:
        raise RuntimeError(f"{label}: {c} {res.error}")
    return {
        "path": label,
        "runs": total,
        "wall_s": wall,
        "whole_job_per_s": total / wall,
        "steady_per_s": steady.rate(total),
        "kernel_s_per_run": res.simulate_s / max(1, res.simulated),
        "write_s_per_run": res.write_s / max(1, res.simulated),
    }


def many_row(job: Any, total: int) -> dict[str, Any]:
    from bowlrec import simulate_many

    steady = _Steady()
    t0 = time.perf_counter()
    table = simulate_many(job, workers=2, progress=steady)
    wall = time.perf_counter() - t0
    assert table.num_rows == total
    return {
        "path": "simulate_many(job, workers=2) -> Arrow",
        "runs": total,
        "wall_s": wall,
        "whole_job_per_s": total / wall,
        "steady_per_s": steady.rate(total),
    }


def cli_row(job_path: Path, tmp: Path, total: int) -> dict[str, Any]:
    out = tmp / "cli.parquet"
    cmd = [sys.executable, "-m", "bowlrec.cli", "batch", str(job_path), "--no-archive"]
    cmd += ["--out", str(out), "--workers", "2", "--quiet"]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    return {
        "path": "bowlrec batch JOB --no-archive --out t.parquet (end to end)",
        "runs": total,
        "wall_s": wall,
        "whole_job_per_s": total / wall,
        "steady_per_s": float("nan"),
    }


def per_run_costs(job: Any, tmp: Path, n: int | None = None) -> dict[str, float]:
    """µs per run of each stage in one process (a chunk of ``n`` runs, after a warm chunk;
    default: the batch's largest summary-only chunk)."""
    from bowlrec.archive import Archive
    from bowlrec.batch import job_context
    from bowlrec.batch.chunks import ChunkTask, run_chunk
    from bowlrec.batch.context import WriteTarget
    from bowlrec.batch.fastprep import FastSweep
    from bowlrec.batch.runner import SUMMARY_CHUNK
    from bowlrec.spec import Scene

    n = n or SUMMARY_CHUNK
    archive = Archive(tmp / "costs")
    ctx = job_context(job, base_dir=JOBS)
    assert ctx.fast_paths is not None
    fast = FastSweep(Scene.model_validate(ctx.base_data), ctx.fast_paths)
    target = WriteTarget(str(archive.root), "yes", durable=True)
    run_chunk(ChunkTask(ctx, 0, 64, target))  # warm: kernels, caches
    import numpy as np

    t0 = time.perf_counter()
    fast.prepare(np.arange(n), job.columns(1000, 1000 + n, ctx.fast_paths))
    prepare = time.perf_counter() - t0
    t0 = time.perf_counter()
    table_only = run_chunk(ChunkTask(ctx, 1000, 1000 + n, None))
    no_archive = time.perf_counter() - t0
    t0 = time.perf_counter()
    stored = run_chunk(ChunkTask(ctx, 2000 + n, 2000 + 2 * n, target))
    with_archive = time.perf_counter() - t0
    assert len(stored.segments) == 1, stored.error
    t0 = time.perf_counter()
    archive.register(stored.segments)
    register = time.perf_counter() - t0
    us = 1e6 / n
    kernel = (table_only.simulate_s + stored.simulate_s) / 2 * us
    return {
        "chunk_runs": float(n),
        "prepare_us": prepare * us,
        "kernel_us": kernel,
        "chunk_no_archive_us": no_archive * us,
        "segment_us": stored.write_s * us,
        "chunk_with_archive_us": with_archive * us,
        "index_us": register * us,
    }


def disk_rate(tmp: Path, mb: int = 128) -> float:
    """Sequential write rate (MB/s) of ``tmp``'s disk, fsynced at the end."""
    block = os.urandom(1 << 20)
    path = tmp / "disk-probe"
    t0 = time.perf_counter()
    with open(path, "wb") as fh:
        for _ in range(mb):
            fh.write(block)
        fh.flush()
        os.fsync(fh.fileno())
    wall = time.perf_counter() - t0
    path.unlink()
    return mb / wall


def recorded_row(tmp: Path, n: int, samples: str) -> dict[str, Any]:
    """The recorded job with its samples stored by filter ``samples`` (gzip or none)."""
    from bowlrec.archive import Archive
    from bowlrec.batch import JobSpec

    archive = Archive(tmp / f"recorded-{samples}")
    rate_disk = disk_rate(tmp)
    data = _job("case16-recorded.json", n).model_dump(mode="json", by_alias=True)
    data["samples"] = samples
    job = JobSpec.model_validate(data)
    row = batch_row(f"batch, recorded at 1 ms, samples {samples}", job, archive, n)
    seg_bytes = sum(p.stat().st_size for p in archive.segments_dir.glob("*.h5"))
    bytes_per_run = seg_bytes / n
    row.update(
        samples=samples,
        bytes_per_run=bytes_per_run,
        disk_mb_per_s=rate_disk,
        disk_runs_per_s=rate_disk * 1e6 / bytes_per_run,
        samples_per_run=float(
            statistics.mean(r["n_samples"] for r in archive.list_runs(limit=200))
        ),
    )
    row["pct_of_disk"] = 100 * row["steady_per_s"] / row["disk_runs_per_s"]
    return row


#: the samples filters the recorded rows compare (the job's ``samples``)
RECORDED_FILTERS = ("gzip", "lz4", "none")


def recorded_rows(tmp: Path, quick: bool) -> list[dict[str, Any]]:
    return [recorded_row(tmp, 400 if quick else 2000, f) for f in RECORDED_FILTERS]


def recorded_costs(n: int = 200) -> dict[str, float]:
    """CPU ms per recorded run of each stage in one process (``time.process_time``, so a
    loaded machine inflates it less than wall time), for the first ``samples`` filter of
    :data:`RECORDED_FILTERS` and each other: what a worker spends on a run of the recorded
    job, and what the parent's index registration costs."""
    import numpy as np

    from bowlrec.archive import Archive, SegmentBuilder
    from bowlrec.archive.ball_files import ball_sha
    from bowlrec.archive.segment import RunRecord
    from bowlrec.archive.segment_file import lz4_filters, write_segment
    from bowlrec.archive.writing import pattern_label
    from bowlrec.batch import job_context
    from bowlrec.batch.fastprep import FastSweep
    from bowlrec.core.solver import kernel_call, solve, solve_state
    from bowlrec.provenance import environment
    from bowlrec.sinks.common import RunData
    from bowlrec.spec import Scene

    job = _job("case16-recorded.json", n)
    ctx = job_context(job, base_dir=JOBS)
    assert ctx.fast_paths is not None  # a delivery sweep: the fast preparation, as the job
    fast = FastSweep(Scene.model_validate(ctx.base_data), ctx.fast_paths)  # once per worker
    columns = job.columns(0, n, ctx.fast_paths)
    solve(fast.plan)  # warm
    out: dict[str, float] = {}

    def clock(key: str, t0: float) -> float:
        now = time.process_time()
        out[key] = out.get(key, 0.0) + (now - t0) * 1e3 / n
        return now

    t = time.process_time()
    chunk = fast.prepare(np.arange(n, dtype=np.int64), columns)
    plans = [chunk.plan(i, fast.plan) for i in range(n)]
    t = clock("prepare", t)
    for plan in plans:
        fn, args = kernel_call(plan)
        fn(*args)
    t = clock("kernel", t)
    solved = [solve_state(plan) for plan in plans]  # as the job's workers do
    t = clock("solve", t)
    out["derive"] = out.pop("solve") - out["kernel"]
    t = time.process_time()
    sha, pattern = ball_sha(fast.scene.ball), pattern_label(fast.scene)
    records = [
        RunRecord.from_run(
            RunData(fast.scene, plan, tr, chunk.run_ids[i]),
            wall_time_s=0.0,
            ball_ref="",
            solver="integrator",
            ball_sha=sha,
            pattern=pattern,
            scene_json=chunk.scene_json[i],
            samples=state,
        )
        for i, (plan, (tr, state)) in enumerate(zip(plans, solved, strict=True))
    ]
    t = clock("record", t)
    builder = SegmentBuilder(environment())
    for r in records:
        builder.append(r)
    t = time.process_time()
    columns = builder.columns()
    t = clock("columns", t)
    lz4_filters()  # a worker registers the Blosc filter (imports hdf5plugin) once, not per run
    with tempfile.TemporaryDirectory(dir=ROOT) as tmp_name:
        tmp = Path(tmp_name)
        for f in RECORDED_FILTERS:
            path = tmp / f"{f}.h5"
            t = time.process_time()
            write_segment(path, "x", columns, environment(), durable=False, samples=f)
            t = clock(f"write_{f}", t)
            out[f"bytes_{f}"] = path.stat().st_size / n
        archive = Archive(tmp / "index")
        info = archive.seal(builder)
        t = time.process_time()
        archive.register([info])
        clock("index", t)
        archive.close()
    return out


def service_rows(tmp: Path, n_job: int, clients: int, per_client: int) -> dict[str, Any]:
    import httpx

    from .service import server

    job = _job("case16-summary.json", n_job).model_dump(mode="json", by_alias=True)
    out: dict[str, Any] = {}
    with server(tmp / "service", "--job-workers", "2") as url:
        with httpx.Client(base_url=url, timeout=600) as c:
            t0 = time.perf_counter()
            r = c.post("/jobs", json=job)
            r.raise_for_status()
            job_id = r.json()["job_id"]
            steady = _Steady()
            while (status := c.get(f"/jobs/{job_id}").json())["status"] in ("queued", "running"):
                steady.points.append((time.perf_counter(), status["done"]))
                time.sleep(0.05)
            wall = time.perf_counter() - t0
        if status["status"] != "done" or status["done"] != n_job:
            raise RuntimeError(f"service job ended {status}")
        out["jobs"] = {
            "runs": n_job,
            "wall_s": wall,
            "runs_per_s": n_job / wall,
            "steady_per_s": steady.rate(n_job),
        }
        out["runs"] = _load(url, clients, per_client, new_scene=True)
        out["health"] = _load(url, clients, per_client, new_scene=False)
    return out


def _server_pid(url: str) -> int | None:
    """The process listening at ``url`` (a ``bowlrec serve --port P`` of :func:`server`), found
    by its command line in /proc; None where there is no /proc."""
    port = url.rsplit(":", 1)[1].strip("/")
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            args = cmdline.read_bytes().split(b"\0")
        except OSError:
            continue
        if b"serve" in args and b"--port" in args and port.encode() in args:
            return int(cmdline.parent.name)
    return None


def _cpu_s(pid: int | None) -> float:
    """User + system CPU time of process ``pid`` (s; 0 without /proc)."""
    if pid is None:
        return 0.0
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _machine_cpu_s() -> tuple[float, float]:
    """(busy, total) CPU time of the whole machine since boot, summed over its cores (s; from
    /proc/stat: busy is all but idle and iowait; zeros without /proc)."""
    try:
        ticks = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    except OSError:
        return 0.0, 0.0
    hz = os.sysconf("SC_CLK_TCK")
    return (sum(ticks) - ticks[3] - ticks[4]) / hz, sum(ticks) / hz


def _load(url: str, clients: int, per_client: int, new_scene: bool) -> dict[str, Any]:
    """``clients`` threads, each with its own httpx client, ``per_client`` requests each; with
    the CPU time the server process, this (the clients') process and the whole machine (the
    server's writer process included) spent on them."""
    import threading

    import httpx

    from .service import scene

    barrier = threading.Barrier(clients + 1)
    errors: list[str] = []
    # scenes new to this archive; speeds 6-16 m/s (service.scene adds 1e-6 m/s per step of i)
    base = int(time.time() * 1000) % 1_000_000 * 10

    def work(k: int) -> None:
        with httpx.Client(base_url=url, timeout=120) as c:
            barrier.wait()
            for i in range(per_client):
                if new_scene:
                    r = c.post("/runs", json=scene(base + k * per_client + i, "load"))
                    ok = r.status_code == 201
                else:
                    r = c.get("/health")
                    ok = r.status_code == 200
                if not ok:
                    errors.append(f"{r.status_code} {r.text[:200]}")

    threads = [threading.Thread(target=work, args=(k,)) for k in range(clients)]
    for t in threads:
        t.start()
    pid = _server_pid(url)
    barrier.wait()
    t0, server0, clients0 = time.perf_counter(), _cpu_s(pid), time.process_time()
    machine0 = _machine_cpu_s()
    for t in threads:
        t.join()
    wall = time.perf_counter() - t0
    server_s, clients_s = _cpu_s(pid) - server0, time.process_time() - clients0
    machine1 = _machine_cpu_s()
    busy_s, all_s = machine1[0] - machine0[0], machine1[1] - machine0[1]
    if errors:
        raise RuntimeError(f"{len(errors)} failed requests, e.g. {errors[0]}")
    total = clients * per_client
    return {
        "requests": total,
        "wall_s": wall,
        "per_s": total / wall,
        "server_cpu_ms_per_request": 1e3 * server_s / total,
        "server_cores": server_s / wall,
        "client_cores": clients_s / wall,
        "machine_busy_pct": 100 * busy_s / all_s if all_s else float("nan"),
        "machine_cpu_ms_per_request": 1e3 * busy_s / total,
    }


def _rss_mb(pid: int) -> float:
    """Resident memory of a process and its descendants (MB), from /proc."""
    total = 0.0
    stack = [pid]
    while stack:
        p = stack.pop()
        try:
            with open(f"/proc/{p}/statm") as fh:
                total += int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6
            with open(f"/proc/{p}/task/{p}/children") as fh:
                stack += [int(c) for c in fh.read().split()]
        except (OSError, ValueError):
            continue
    return total


def lazy_start(stop_at: int) -> dict[str, Any]:
    """A 10,000,000-run job with no archive: seconds until the first chunk is done, and the
    memory of this process and its workers at 100,000 runs and at ``stop_at`` runs (then it is
    cancelled)."""
    import threading

    from bowlrec.batch import JobSpec, run_job

    data = _job("case16-summary.json").model_dump(mode="json", by_alias=True)
    data["sweep"]["n"] = 10_000_000
    job = JobSpec.model_validate(data)
    cancel = threading.Event()
    marks: dict[str, float] = {}
    t0 = time.perf_counter()

    def progress(p: Any) -> None:
        marks.setdefault("started_s", time.perf_counter() - t0)
        if p.done > 0 and "first_chunk_s" not in marks:
            marks["first_chunk_s"] = time.perf_counter() - t0
        if p.done >= 100_000 and "rss_100k_mb" not in marks:
            marks["rss_100k_mb"] = _rss_mb(os.getpid())
        if p.done >= stop_at and "rss_stop_mb" not in marks:
            marks["rss_stop_mb"] = _rss_mb(os.getpid())
            marks["stop_runs"] = p.done
            cancel.set()

    res = run_job(job, None, workers=2, progress=progress, cancel=cancel, sink=lambda t: None)
    marks["rows"] = res.n_rows
    marks["rss_change_pct"] = 100 * (marks["rss_stop_mb"] / marks["rss_100k_mb"] - 1)
    return marks


#: times each pipeline path and the kernel are measured (the table quotes medians)
REPEATS = 3


def _median_row(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """One row of medians over repeated measurements of the same path."""
    out = dict(rows[0])
    for key, value in rows[0].items():
        if isinstance(value, float):
            out[key] = statistics.median(r[key] for r in rows)
    out["repeats"] = len(rows)
    return out


def measure(quick: bool) -> dict[str, Any]:
    from bowlrec.archive import Archive

    n = 20_000 if quick else 200_000
    n_bowler = 2_000 if quick else 20_000
    n_service = 20_000 if quick else 100_000
    load_before = os.getloadavg()
    job = _job("case16-summary.json", n)
    packed = _packed(job, min(n, 100_000))
    with tempfile.TemporaryDirectory(dir=ROOT) as tmp_name:
        tmp = Path(tmp_name)
        reps: list[list[dict[str, Any]]] = []
        kernels: list[float] = []
        for rep in range(REPEATS):  # the machine is shared: each path REPEATS times, medians
            before = kernel_rate(packed)
            rows = [
                batch_row("batch --archive", job, Archive(tmp / f"a{rep}"), n),
                batch_row("batch --no-archive", job, None, n),
                many_row(job, n),
            ]
            after = kernel_rate(packed)
            kernel_rep = (before + after) / 2
            for r in rows:
                r["pct_of_kernel"] = 100 * r["steady_per_s"] / kernel_rep
                r["pct_of_kernel_whole"] = 100 * r["whole_job_per_s"] / kernel_rep
            kernels += [before, after]
            reps.append(rows)
        rows = [_median_row([rep[k] for rep in reps]) for k in range(len(reps[0]))]
        job_file = tmp / "case16.json"
        job_file.write_text(json.dumps(job.model_dump(mode="json", by_alias=True)))
        cli = cli_row(job_file, tmp, n)
        kernel = statistics.median(kernels)
        cli["pct_of_kernel"] = float("nan")
        cli["pct_of_kernel_whole"] = 100 * cli["whole_job_per_s"] / kernel
        rows.append(cli)
        costs = per_run_costs(job, tmp)
        bowler_job = _job("bowler-lhs.json", n_bowler)
        bowler_kernel = kernel_rate(_packed(bowler_job, min(n_bowler, 4000)))
        bowler = batch_row("bowler LHS, batch --archive", bowler_job, Archive(tmp / "b"), n_bowler)
        bowler["kernel_per_s"] = bowler_kernel
        recorded = recorded_rows(tmp, quick)
        service = service_rows(tmp, n_service, clients=16, per_client=20 if quick else 40)
        lazy = lazy_start(300_000 if quick else 1_000_000)
    batch_rate = rows[0]["steady_per_s"]
    service["jobs"]["pct_of_batch"] = 100 * service["jobs"]["steady_per_s"] / batch_rate
    service["runs"]["pct_of_health"] = 100 * service["runs"]["per_s"] / service["health"]["per_s"]
    # the rate at which POST /runs would use every core at its measured CPU per request
    cpu_ms = service["runs"]["machine_cpu_ms_per_request"]
    service["runs"]["cpu_bound_per_s"] = (os.cpu_count() or 1) * 1e3 / cpu_ms
    service["runs"]["cpu_bound_pct_of_health"] = (
        100 * service["runs"]["cpu_bound_per_s"] / service["health"]["per_s"]
    )
    core_us = costs["kernel_us"]
    overhead = costs["chunk_with_archive_us"] - core_us + costs["index_us"]
    costs["ceiling_pct_archive"] = 100 * core_us / (core_us + overhead)
    costs["ceiling_pct_no_archive"] = 100 * core_us / costs["chunk_no_archive_us"]
    data = {
        "machine": {
            "platform": platform.platform(),
            "python": sys.version.split()[0],
            "cpu_count": os.cpu_count(),
            "loadavg_before": load_before,
            "loadavg_after": os.getloadavg(),
        },
        "quick": quick,
        "runs": n,
        "kernel_per_s": {"each": kernels, "median": kernel},
        "repeats": [[dict(r) for r in rep] for rep in reps],
        "rows": rows,
        "costs_us_per_run": costs,
        "bowler": bowler,
        "recorded": recorded,
        "service": service,
        "lazy_start": lazy,
    }
    data["targets"] = targets(data)
    data["headline"] = headline(data)
    return data


def _target(key: str, what: str, value: float, limit: float, unit: str) -> dict[str, Any]:
    return {
        "key": key,
        "what": what,
        "limit": limit,
        "unit": unit,
        "measured": round(value, 1),
        "met": bool(value >= limit),
    }


def targets(d: dict[str, Any]) -> list[dict[str, Any]]:
    """The issue's targets against this run's numbers (every one a lower limit)."""
    rows = {r["path"]: r for r in d["rows"]}
    archive = rows["batch --archive"]
    out = [
        _target(
            "archive_pct",
            "batch --archive, steady, % of the kernel",
            archive["pct_of_kernel"],
            80.0,
            "%",
        ),
    ]
    if d["kernel_per_s"]["median"] >= 25_000:
        out.append(
            _target(
                "archive_rate",
                "batch --archive, steady deliveries/s (kernel >= 25,000/s in this run)",
                archive["steady_per_s"],
                20_000.0,
                "/s",
            )
        )
    out.append(
        _target(
            "no_archive_pct",
            "batch --no-archive, steady, % of the kernel",
            rows["batch --no-archive"]["pct_of_kernel"],
            90.0,
            "%",
        )
    )
    out.append(
        _target(
            "many_pct",
            "simulate_many, steady, % of the kernel",
            rows["simulate_many(job, workers=2) -> Arrow"]["pct_of_kernel"],
            90.0,
            "%",
        )
    )
    for r in d["recorded"]:  # the target: 1,000 runs/s or 80 % of the disk-bound rate
        rate = _target(
            f"recorded_{r['samples']}",
            f"recorded at 1 ms, samples {r['samples']}: runs/s on 2 workers, or % of the "
            "disk-bound rate",
            r["steady_per_s"],
            1000.0,
            "/s",
        )
        disk = _target("", "", r["pct_of_disk"], 80.0, "%")
        rate["or"] = {k: disk[k] for k in ("limit", "unit", "measured", "met")}
        rate["met"] = rate["met"] or disk["met"]
        out.append(rate)
    s = d["service"]
    out.append(
        _target(
            "service_jobs_pct",
            "service POST /jobs, steady, % of batch --archive",
            s["jobs"]["pct_of_batch"],
            50.0,
            "%",
        )
    )
    out.append(
        _target(
            "service_runs_pct",
            "service POST /runs, 16 clients, % of GET /health",
            s["runs"]["pct_of_health"],
            50.0,
            "%",
        )
    )
    return out


def targets_table(d: dict[str, Any]) -> str:
    lines = ["| target | limit | measured | met |", "|---|---:|---:|---:|"]
    for t in d["targets"]:
        limit, measured = f">= {t['limit']:,.0f} {t['unit']}", f"{t['measured']:,.1f} {t['unit']}"
        if "or" in t:  # either limit meets the target
            o = t["or"]
            limit += f" or >= {o['limit']:,.0f} {o['unit']}"
            measured += f", {o['measured']:,.1f} {o['unit']}"
        lines.append(f"| {t['what']} | {limit} | {measured} | {'yes' if t['met'] else 'no'} |")
    return "\n".join(lines) + "\n"


def headline(d: dict[str, Any]) -> str:
    rows = {r["path"]: r for r in d["rows"]}
    a, n = rows["batch --archive"], rows["batch --no-archive"]
    return (
        f"kernel {_f(d['kernel_per_s']['median'])} deliveries/s; `bowlrec batch --archive` "
        f"{_f(a['steady_per_s'])}/s steady ({_f(a['pct_of_kernel'], 0)} % of the kernel), "
        f"`--no-archive` {_f(n['steady_per_s'])}/s ({_f(n['pct_of_kernel'], 0)} %); targets "
        f"met: {sum(t['met'] for t in d['targets'])} of {len(d['targets'])} "
        "([the table](docs/pipeline.md#targets)).\n"
    )


def _f(x: float, digits: int = 0) -> str:
    return "n/a" if x != x else f"{x:,.{digits}f}"


def markdown(d: dict[str, Any]) -> str:
    m = d["machine"]
    k = d["kernel_per_s"]
    lines = [
        "# Pipeline throughput against the kernel",
        "",
        f"`python -m benchmarks.pipeline{' --quick' if d['quick'] else ''}` on {m['cpu_count']} "
        f"cores, Python {m['python']}; load average {m['loadavg_before'][0]:.2f} before, "
        f"{m['loadavg_after'][0]:.2f} after (a shared machine). Job: "
        f"`benchmarks/jobs/case16-summary.json`, {d['runs']:,} case-16-like deliveries at rtol "
        "2e-4, summary only.",
        "",
        f"Kernel (`run_batch`, 2 numba threads, inputs packed in memory), measured before and "
        f"after each of the {REPEATS} rounds of pipeline rows: "
        f"{', '.join(_f(v) for v in k['each'])} deliveries/s (median {_f(k['median'])}). Each "
        f"round's ratios use the mean of the kernel measured around it; the table gives the "
        f"median over the rounds of each number (the CLI row: one run, against the median "
        f"kernel).",
        "",
        "| path | runs | steady deliveries/s | % of kernel | whole job /s | % of kernel (whole) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in d["rows"]:
        lines.append(
            f"| {r['path']} | {r['runs']:,} | {_f(r['steady_per_s'])} | "
            f"{_f(r['pct_of_kernel'], 1)} | {_f(r['whole_job_per_s'])} | "
            f"{_f(r['pct_of_kernel_whole'], 1)} |"
        )
    c = d["costs_us_per_run"]
    lines += [
        "",
        "Steady: between 10 % and 90 % of the runs (worker start-up excluded); whole job: "
        "wall time of the call (start-up of the workers and, for the CLI, of the process "
        "included).",
        "",
        f"## Per-run costs (one process, a chunk of {c.get('chunk_runs', 4096):,.0f} runs)",
        "",
        "| stage | µs per run |",
        "|---|---:|",
        f"| prepare (fast delivery-sweep path: kernel inputs, run ID, scene JSON) | "
        f"{c['prepare_us']:.1f} |",
        f"| kernel (one thread) | {c['kernel_us']:.1f} |",
        f"| whole chunk, no archive (prepare, kernel, summary, table) | "
        f"{c['chunk_no_archive_us']:.1f} |",
        f"| segment (columns, digests, HDF5 write with gzip, fsync) | {c['segment_us']:.1f} |",
        f"| whole chunk with archive | {c['chunk_with_archive_us']:.1f} |",
        f"| index registration (in the parent, SQLite) | {c['index_us']:.1f} |",
        "",
        f"On 2 cores every stage shares the same CPU: the measured costs cap the batch at "
        f"{c['ceiling_pct_archive']:.0f} % of the kernel with the archive and "
        f"{c['ceiling_pct_no_archive']:.0f} % without. At 80 % of the kernel, everything "
        f"but the kernel may take {c['kernel_us'] * 0.25:.1f} µs of CPU per run (a quarter of "
        f"the kernel's); the stages above take "
        f"{c['chunk_with_archive_us'] - c['kernel_us'] + c['index_us']:.1f} µs, "
        f"{c['index_us']:.1f} µs of it the index row.",
        "",
    ]
    b = d["bowler"]
    lines += [
        "## Bowler-language job",
        "",
        f"`benchmarks/jobs/bowler-lhs.json` ({b['runs']:,} runs, default rtol): batch with the "
        f"archive {_f(b['steady_per_s'])} deliveries/s steady ({_f(b['whole_job_per_s'])} whole "
        f"job), kernel {_f(b['kernel_per_s'])}/s on the same deliveries. Bowler scenes are "
        "validated and converted one by one in the workers (the general path).",
        "",
    ]
    rec = d["recorded"]
    lines += [
        "## Recorded trajectories",
        "",
        f"`benchmarks/jobs/case16-recorded.json` (samples every 1 ms, "
        f"~{rec[0]['samples_per_run']:.0f} samples per run; segment format 3.0: each "
        "sample's state stored, forces, slip, energy and alpha derived on read), 2 workers; "
        "the disk rate is a sequential write of 128 MB fsynced, measured on the same disk "
        "just before each row. Samples filters: gzip = HDF5's shuffle + gzip level 4, lz4 = "
        "Blosc's byte shuffle + LZ4 level 5 (`hdf5plugin`), none = stored as they are."
        + (
            f" Load average {_loadavg(d['recorded_machine'])} (a shared machine)."
            if "recorded_machine" in d
            else ""
        ),
        "",
        "| samples filter (job `samples`) | runs | steady runs/s | whole job /s | bytes/run "
        "| disk MB/s | disk-bound runs/s | % of disk-bound |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rec:
        lines.append(
            f"| {r['samples']} | {r['runs']:,} | {_f(r['steady_per_s'])} | "
            f"{_f(r['whole_job_per_s'])} | {_f(r['bytes_per_run'])} | {_f(r['disk_mb_per_s'])} "
            f"| {_f(r['disk_runs_per_s'])} | {_f(r['pct_of_disk'], 1)} |"
        )
    lines += [""]
    c = d.get("recorded_costs_ms")
    if c:
        stages = [
            ("prepare (the sweep's fast preparation: Plan, scene JSON, run ID)", c["prepare"]),
            ("kernel with dense output at 1 ms", c["kernel"]),
            ("after the kernel: events, summary, state arrays (`solve_state`)", c["derive"]),
            ("segment record of the run (scene JSON, state arrays)", c["record"]),
            ("segment columns (concatenation, digests)", c["columns"]),
            *((f"HDF5 write, samples {f} (no fsync)", c[f"write_{f}"]) for f in RECORDED_FILTERS),
            ("index registration (parent)", c["index"]),
        ]
        lines += [
            "CPU time per recorded run in one process (`time.process_time`, 200 runs), stage "
            "by stage; bytes per run of the segment by filter: "
            + ", ".join(f"{f} {_f(c[f'bytes_{f}'])}" for f in RECORDED_FILTERS)
            + ".",
            "",
            "| stage | CPU ms per run |",
            "|---|---:|",
            *(f"| {name} | {ms:.2f} |" for name, ms in stages),
            "",
        ]
    s = d["service"]
    lines += [
        "## Service",
        "",
        f"`POST /jobs` of {s['jobs']['runs']:,} runs of the case-16 job (`bowlrec serve "
        f"--job-workers 2`): {_f(s['jobs']['steady_per_s'])} runs/s steady (from the job's "
        f"`done` count, polled every 50 ms), {_f(s['jobs']['pct_of_batch'], 1)} % of the "
        f"batch's steady rate with the archive; {_f(s['jobs']['runs_per_s'])} runs/s from "
        "submission to done.",
        "",
        f"16 concurrent clients (httpx, one thread and one connection each, "
        f"{s['runs']['requests']} requests): `POST /runs` of new summary-only scenes "
        f"{_f(s['runs']['per_s'])} requests/s; `GET /health` of the same app "
        f"{_f(s['health']['per_s'])} requests/s; ratio {_f(s['runs']['pct_of_health'], 1)} %. "
        "CPU of the server process per request: "
        f"`POST /runs` {_f(s['runs']['server_cpu_ms_per_request'], 2)} ms, `GET /health` "
        f"{_f(s['health']['server_cpu_ms_per_request'], 2)} ms; the server process used "
        f"{_f(s['runs']['server_cores'], 2)} / {_f(s['health']['server_cores'], 2)} cores and "
        f"the clients' process {_f(s['runs']['client_cores'], 2)} / "
        f"{_f(s['health']['client_cores'], 2)} (one interpreter each).",
        "",
        f"The whole machine (server, its writer process, the clients; other load of the shared "
        f"machine included) was {_f(s['runs']['machine_busy_pct'])} % busy under `POST /runs` "
        f"and {_f(s['health']['machine_busy_pct'])} % under `GET /health`: "
        f"{_f(s['runs']['machine_cpu_ms_per_request'], 2)} ms of CPU per `POST /runs` against "
        f"{_f(s['health']['machine_cpu_ms_per_request'], 2)} ms per `GET /health`. At that CPU "
        f"per request, the machine's {d['machine']['cpu_count']} cores, all busy, would serve "
        "at most "
        f"{_f(s['runs']['cpu_bound_per_s'])} `POST /runs` per second, "
        f"{_f(s['runs']['cpu_bound_pct_of_health'], 1)} % of `GET /health`'s rate. More "
        "server processes cannot take `POST /runs` past that rate on this machine; less CPU "
        "per request can.",
        "",
        "## A 10,000,000-run job",
        "",
        f"The case-16 job with n = 10,000,000, `--no-archive`, table discarded: checked and "
        f"ready to submit {d['lazy_start']['started_s']:.3f} s after `run_job` was called, "
        f"first chunk done at {d['lazy_start']['first_chunk_s']:.2f} s (worker start-up "
        f"included); this process and its workers held "
        f"{d['lazy_start']['rss_100k_mb']:.0f} MB at 100,000 runs and "
        f"{d['lazy_start']['rss_stop_mb']:.0f} MB at {d['lazy_start']['stop_runs']:,} runs "
        f"({d['lazy_start']['rss_change_pct']:+.1f} %), when it was cancelled (its table has "
        f"{d['lazy_start']['rows']:,} rows, up to the last run reached).",
        "",
        "## Targets",
        "",
        targets_table(d),
    ]
    return "\n".join(lines)


def measure_recorded(quick: bool, previous: dict[str, Any]) -> dict[str, Any]:
    """``previous`` (the results of a whole run) with the recorded rows and their costs
    measured again, the targets and headline recomputed."""
    data = dict(previous)
    data["recorded_machine"] = {"loadavg_before": os.getloadavg()}
    with tempfile.TemporaryDirectory(dir=ROOT) as tmp_name:
        data["recorded"] = recorded_rows(Path(tmp_name), quick)
    data["recorded_costs_ms"] = recorded_costs()
    data["recorded_machine"]["loadavg_after"] = os.getloadavg()
    data["targets"] = targets(data)
    data["headline"] = headline(data)
    return data


def _loadavg(m: dict[str, Any]) -> str:
    return f"{m['loadavg_before'][0]:.2f} before, {m['loadavg_after'][0]:.2f} after"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="20,000 runs instead of 200,000")
    parser.add_argument(
        "--only",
        choices=["recorded"],
        help="measure only these rows; the others are kept from OUT/pipeline.json",
    )
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument(
        "--update-docs",
        action="store_true",
        help="also write the targets table into docs/pipeline.md and the headline into README.md",
    )
    args = parser.parse_args()
    if args.only == "recorded":
        previous = json.loads((args.out / "pipeline.json").read_text())
        data = measure_recorded(args.quick, previous)
    else:
        data = measure(args.quick)
        data["recorded_costs_ms"] = recorded_costs()
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "pipeline.json").write_text(json.dumps(data, indent=2) + "\n")
    (args.out / "pipeline.md").write_text(markdown(data))
    if args.update_docs:
        from tools.readme_blocks import block_path, replace_block

        replace_block(block_path("pipeline-targets"), "pipeline-targets", targets_table(data))
        replace_block(block_path("pipeline-headline"), "pipeline-headline", data["headline"])
    print(markdown(data))


if __name__ == "__main__":
    main()

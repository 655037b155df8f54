"""The archive (format 2.3) at a million summary-only runs, and the archive path against the
kernel, against their targets (TARGETS).

    python -m benchmarks.archive [--runs 1000000] [--quick] [--bases 2000]
                                 [--register-batch 1] [--path-runs 200000] [--path-repeats 5]
                                 [--out benchmarks/results]

First, the archive path against the kernel (:func:`archive_path`): ``bowlrec batch --archive``
of the ``case16-summary`` job (``--path-runs`` summary-only runs, 2 workers, a fresh archive)
and the kernel alone, interleaved in rounds (kernel, archive path, batch without an archive,
kernel), medians over ``--path-repeats`` rounds, and their ratio against the 80 % target.

What is built: ``--bases`` distinct summary-only deliveries are simulated with bowlrec (the
house-shot bowler scene with speed, rev rate, axis rotation, target board and oil pattern drawn
at random; real solver, real summaries, events and scene JSON), turned into
:class:`~bowlrec.archive.segment.RunRecord` s by :meth:`Archive.record`, then ``--runs``
records are made from them: run ID ``synthetic_run_id(i)`` (20 hex digits of SHA-256, spread
like real content IDs, so the index's run-ID B-tree sees random inserts), each 1,000-run
segment drawing distinct deliveries (so no scene repeats inside a segment), every summary
float, the speed, rev rate and wall time jittered by ~1 % (so the index holds no duplicate
values), ``created_at`` spread over 30 days. They are written as 1,000-run segments in a
fresh archive under /tmp: ``SegmentBuilder.append`` x 1,000, :meth:`Archive.seal` (durable:
fsync) and :meth:`Archive.register` in batches of ``--register-batch`` segments (every 50th
segment is registered alone, to time a one-segment registration at growing index sizes). Then
100 recorded runs (``record='rate'``, ``record_dt_s=0.002``) are added in a segment of their own.

What is measured (each target's measured value, next to it, met or missed):

- bytes per summary-only run on disk: (segment files + ``index.sqlite``) / runs, after the
  build (before the recorded runs), and after a full rebuild;
- writer CPU per run (``time.process_time``) of append + seal + register, per 1,000-run
  segment, over every segment of the build (median, best, p95); wall time too (fsync and
  the index commit wait on the disk, not the CPU);
- where the writer's time goes, on the records of one segment written to a scratch directory
  (repeated): :meth:`Archive.record` per run (RunData -> RunRecord), ``append``,
  ``SegmentBuilder.columns()`` (columns and digests), the HDF5 write, fsync of the file and
  directory; registration from the build; and a cProfile of one full segment write;
- ``Archive.list_runs(outcome='pins', where=['hook_m>=0.3'], limit=50)`` in-process (judged on
  a fresh index connection per call; a reused connection reported too) and the whole
  ``bowlrec runs list ... --json`` process (``bowlrec --help`` start-up reported beside it);
- one run's summary: :meth:`Archive.row` in-process and ``GET /runs/{id}`` against a
  ``bowlrec serve`` subprocess (httpx, one keep-alive client);
- one recorded trajectory: :meth:`Archive.load` of each recorded run;
- :meth:`Archive.repair` and :meth:`Archive.reindex` of the whole archive (once each).

Timings are medians (and best) of repeats; the machine's speed can drift with other load, so
its load average before and after is recorded. The OS page cache is warm (the archive was just
written). ``--quick`` is a 20,000-run smoke test (1,000 bases) written as
``archive-quick.json``/``.md``; the committed ``archive.json``/``archive.md`` come from the full
1,000,000-run benchmark. The temporary archive is deleted at the end (``--keep`` keeps it).
"""

from __future__ import annotations

import argparse
import contextlib
import cProfile
import dataclasses
import hashlib
import io
import json
import os
import platform
import pstats
import random
import shutil
import socket
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bowlrec.archive.segment import SUMMARY_FLOAT_COLUMNS

if TYPE_CHECKING:
    from bowlrec.archive import Archive
    from bowlrec.archive.segment import RunRecord
    from bowlrec.sinks.common import RunData

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
KIB = 1024
SEGMENT_RUNS = 1000
PATTERNS = ("house_shot_approx", "kegel_chromium_6742", "sport_short_36ft_approx")
LIST_QUERY: dict[str, Any] = {"outcome": "pins", "where": ["hook_m>=0.3"], "limit": 50}
#: a supplementary, selective query (not a target): few rows match, so more of the index is read
RARE_QUERY: dict[str, Any] = {"outcome": "pins", "where": ["hook_m>=1.45"], "limit": 50}
SINGLE_EVERY = 50
#: the summary floats jittered per synthetic run (every float metric of the segment format)
SUMMARY_JITTER = SUMMARY_FLOAT_COLUMNS

#: the archive path against the kernel (issue 32): ``bowlrec batch --archive`` of a summary job
PATH_JOB = "case16-summary.json"
PATH_RUNS = 200_000
PATH_REPEATS = 5
PATH_TARGET_PCT = 80.0
PATH_TARGET_RATE = 20_000.0
PATH_KERNEL_FLOOR = 25_000.0

TARGETS: dict[str, tuple[str, float, str]] = {
    # key: (what, limit, unit)
    "bytes_per_run": ("summary-only run on disk (segments + index), bytes/run", 1024.0, "B"),
    "writer_cpu_per_run": ("writer CPU per run (append + seal + register)", 20.0, "us"),
    "list_in_process": ("list outcome=pins, hook_m>=0.3, limit 50, in-process", 0.2, "s"),
    "list_cli": ("same listing from the CLI (whole process)", 0.5, "s"),
    "row_in_process": ("one run's summary, in-process (Archive.row)", 50.0, "ms"),
    "row_http": ("one run's summary over HTTP (GET /runs/{id})", 50.0, "ms"),
    "load_trajectory": ("one recorded trajectory loaded (Archive.load)", 20.0, "ms"),
    "repair": ("Archive.repair() of the whole archive", 60.0, "s"),
    "reindex": ("Archive.reindex() (full index rebuild)", 300.0, "s"),
    "archive_path": (
        "batch --archive steady rate, % of the kernel in the same run (median of rounds)",
        PATH_TARGET_PCT,
        "%",
    ),
}
#: targets met at or above their limit (the others: at or below)
AT_LEAST = frozenset({"archive_path"})


# -- helpers -------------------------------------------------------------------------------------


def synthetic_run_id(i: int) -> str:
    """The i-th synthetic run ID: 20 hex digits of SHA-256, like a content ID."""
    return hashlib.sha256(f"bench-{i}".encode()).hexdigest()[:20]


def _stats(values: Sequence[float], scale: float = 1.0, digits: int = 3) -> dict[str, Any]:
    """median / best / p95 / mean / max of ``values`` times ``scale``."""
    v = sorted(x * scale for x in values)
    p95 = v[min(len(v) - 1, int(round(0.95 * (len(v) - 1))))]
    return {
        "n": len(v),
        "median": round(statistics.median(v), digits),
        "best": round(v[0], digits),
        "p95": round(p95, digits),
        "mean": round(statistics.fmean(v), digits),
        "max": round(v[-1], digits),
    }


def _timed(fn: Callable[[], Any]) -> tuple[float, float, Any]:
    """(wall s, CPU s, result) of one call."""
    c0, w0 = time.process_time(), time.perf_counter()
    out = fn()
    return time.perf_counter() - w0, time.process_time() - c0, out


def _du(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def _version(dist: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return "not installed"


def _git() -> dict[str, Any]:
    def run(*args: str) -> str:
        res = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)
        return res.stdout.strip()

    import hashlib

    h = hashlib.sha256()
    for path in sorted((ROOT / "bowlrec" / "archive").glob("*.py")):
        h.update(path.read_bytes())
    return {
        "commit": run("rev-parse", "HEAD"),
        "dirty": bool(run("status", "--porcelain")),
        "bowlrec_archive_sources_sha256": h.hexdigest()[:16],
    }


def machine() -> dict[str, Any]:
    import h5py

    import bowlrec

    cpu = ""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    return {
        "platform": platform.platform(),
        "cpu": cpu,
        "nproc": os.cpu_count(),
        "python": sys.version.split()[0],
        "bowlrec": bowlrec.__version__,
        "physics": bowlrec.PHYSICS_VERSION,
        "numpy": np.__version__,
        "h5py": h5py.version.version,
        "hdf5": h5py.version.hdf5_version,
        "sqlite": sqlite3.sqlite_version,
        **{d: _version(d) for d in ("numba", "pydantic", "fastapi", "uvicorn", "httpx")},
        "git": _git(),
    }


def _profile(fn: Callable[[], Any], top: int = 12) -> list[dict[str, Any]]:
    """The ``top`` functions of one call by own time (cProfile)."""
    prof = cProfile.Profile()
    prof.enable()
    fn()
    prof.disable()
    st = pstats.Stats(prof, stream=io.StringIO())
    rows = []
    for (file, line, func), (_cc, nc, tt, ct, _callers) in st.stats.items():  # type: ignore[attr-defined]
        short = file.replace(str(ROOT) + "/", "").split("site-packages/")[-1]
        rows.append({"function": f"{short}:{line}({func})", "calls": nc, "own_s": tt, "cum_s": ct})
    rows.sort(key=lambda r: -r["own_s"])
    total = sum(r["own_s"] for r in rows)
    for r in rows:
        r["own_s"], r["cum_s"] = round(r["own_s"], 4), round(r["cum_s"], 4)
    return [{"total_s": round(total, 4)}, *rows[:top]]


# -- simulated deliveries ------------------------------------------------------------------------


def _scene(rng: random.Random, record: str, dt: float | None = None) -> Any:
    from bowlrec.bowling.scene import BowlerScene

    doc = json.loads((ROOT / "examples" / "bowler" / "house-shot-right.json").read_text())
    d = doc["delivery"]
    d["speed_mph"] = rng.uniform(14.0, 20.0)
    d["rev_rate_rpm"] = rng.uniform(200.0, 450.0)
    d["axis_rotation_deg"] = rng.uniform(20.0, 70.0)
    d["target_board_at_arrows"] = rng.uniform(7.0, 13.0)
    doc["pattern"] = rng.choice(PATTERNS)
    doc["options"] = {"record": record} | ({} if dt is None else {"record_dt_s": dt})
    return BowlerScene.model_validate(doc).to_scene()


def simulate(
    n: int, seed: int, record: str, dt: float | None = None
) -> list[tuple[RunData, float]]:
    """``n`` distinct deliveries simulated now: (RunData with content ID, solver wall s)."""
    from bowlrec.archive.run_id import run_id
    from bowlrec.core.solver import solve
    from bowlrec.sinks.common import RunData

    rng = random.Random(seed)
    out: list[tuple[RunData, float]] = []
    seen: set[str] = set()
    while len(out) < n:
        scene = _scene(rng, record, dt)
        plan = scene.resolve()
        rid = run_id(plan)
        if rid in seen:
            continue
        seen.add(rid)
        t0 = time.perf_counter()
        traj = solve(plan)
        out.append((RunData(scene, plan, traj, rid), time.perf_counter() - t0))
    return out


def record_cost(archive_dir: Path, runs: list[tuple[RunData, float]], repeats: int = 3) -> Any:
    """CPU per run of :meth:`Archive.record` (a fresh Archive object per pass: no cached ball
    hashes), and the records of the last pass."""
    from bowlrec.archive import Archive

    per_run: list[float] = []
    records: list[RunRecord] = []
    for _ in range(repeats):
        archive = Archive(archive_dir)
        c0 = time.process_time()
        records = [archive.record(r, wall_time_s=w, solver=_solver(r)) for r, w in runs]
        per_run.append((time.process_time() - c0) / len(runs))
    return per_run, records


def _solver(run: RunData) -> str:
    from bowlrec.core.arguments import use_closed_form

    return "closed_form" if use_closed_form(run.plan) else "integrator"


class RecordFactory:
    """Synthetic runs ``i`` made from the simulated base records (see the module doc)."""

    def __init__(self, bases: list[RunRecord], n_runs: int, seed: int = 7) -> None:
        self.bases = bases
        self.rng = np.random.default_rng(seed)
        self.order = self.rng.permutation(len(bases))
        self.t0 = time.time_ns() - 30 * 86400 * 10**9
        self.step = 30 * 86400 * 10**9 // max(n_runs, 1)

    def segment(self, first: int, count: int) -> list[RunRecord]:
        nb = len(self.bases)
        jit = 1.0 + 0.01 * self.rng.standard_normal((count, len(SUMMARY_JITTER) + 3))
        out = []
        for k in range(count):
            i = first + k
            base = self.bases[self.order[i % nb]]
            j = jit[k]
            s = base.summary
            summary = dataclasses.replace(
                s,
                **{
                    name: (None if (v := getattr(s, name)) is None else v * float(j[m]))
                    for m, name in enumerate(SUMMARY_JITTER)
                },
            )
            out.append(
                dataclasses.replace(
                    base,
                    run_id=synthetic_run_id(i),
                    summary=summary,
                    speed_mps=base.speed_mps * float(j[-3]),
                    rev_rate_rpm=base.rev_rate_rpm * float(j[-2]),
                    wall_time_s=base.wall_time_s * float(j[-1]),
                    created_at_ns=self.t0 + i * self.step + int(self.rng.integers(self.step)),
                )
            )
        return out


# -- the build -----------------------------------------------------------------------------------


def build(
    archive: Archive, factory: RecordFactory, n_runs: int, batch: int, log: Callable[[str], None]
) -> dict[str, Any]:
    """Write ``n_runs`` runs as 1,000-run segments; per-segment timings."""
    segs: list[dict[str, Any]] = []
    singles: list[dict[str, Any]] = []
    pending: list[tuple[Any, dict[str, Any]]] = []
    gen_s = 0.0

    def flush() -> None:
        if not pending:
            return
        wall, cpu, _ = _timed(lambda: archive.register([info for info, _ in pending]))
        for _, row in pending:
            row["register_cpu_s"] = cpu / len(pending)
            row["register_wall_s"] = wall / len(pending)
        pending.clear()

    start = time.perf_counter()
    n_segments = (n_runs + SEGMENT_RUNS - 1) // SEGMENT_RUNS
    for s in range(n_segments):
        first = s * SEGMENT_RUNS
        g0 = time.perf_counter()
        records = factory.segment(first, min(SEGMENT_RUNS, n_runs - first))
        gen_s += time.perf_counter() - g0
        builder = archive.builder()

        def append(b: Any = builder, recs: list[RunRecord] = records) -> None:
            for r in recs:
                b.append(r)

        a_wall, a_cpu, _ = _timed(append)
        s_wall, s_cpu, info = _timed(partial(archive.seal, builder))
        row = {
            "runs": len(records),
            "append_cpu_s": a_cpu,
            "append_wall_s": a_wall,
            "seal_cpu_s": s_cpu,
            "seal_wall_s": s_wall,
            "bytes": info.path.stat().st_size,
        }
        segs.append(row)
        if s % SINGLE_EVERY == 0:
            flush()
            r_wall, r_cpu, _ = _timed(partial(archive.register, [info]))
            row["register_cpu_s"], row["register_wall_s"] = r_cpu, r_wall
            singles.append({"index_runs_before": first, "cpu_s": r_cpu, "wall_s": r_wall})
        else:
            pending.append((info, row))
            if len(pending) >= batch:
                flush()
        if (s + 1) % 100 == 0 or s + 1 == n_segments:
            el, done = time.perf_counter() - start, first + len(records)
            log(f"  {done:>9,} runs, {el:6.1f} s ({done / el:,.0f} runs/s)")
    flush()
    wall = time.perf_counter() - start
    for row in segs:
        row["writer_cpu_s"] = row["append_cpu_s"] + row["seal_cpu_s"] + row["register_cpu_s"]
        row["writer_wall_s"] = row["append_wall_s"] + row["seal_wall_s"] + row["register_wall_s"]
    return {"segments": segs, "singles": singles, "wall_s": wall, "generate_records_s": gen_s}


def _per_run_us(segs: list[dict[str, Any]], key: str) -> dict[str, Any]:
    full = [r for r in segs if r["runs"] == SEGMENT_RUNS] or segs
    return _stats([r[key] / r["runs"] for r in full], 1e6, 2)


def breakdown(
    archive: Archive, records: list[RunRecord], scratch: Path, repeats: int
) -> dict[str, Any]:
    """The writer's pieces on one segment's records, written to ``scratch`` (not the archive)."""
    from bowlrec.archive.segment import new_segment_id
    from bowlrec.archive.segment_file import write_segment
    from bowlrec.atomic_files import fsync_dir

    scratch.mkdir(parents=True, exist_ok=True)
    rows: dict[str, list[float]] = {
        k: []
        for k in (
            "append_cpu",
            "columns_cpu",
            "hdf5_write_cpu",
            "hdf5_write_wall",
            "fsync_wall",
            "seal_durable_cpu",
            "seal_durable_wall",
        )
    }
    for _ in range(repeats):
        builder = archive.builder()

        def append(b: Any = builder) -> None:
            for r in records:
                b.append(r)

        _, cpu, _ = _timed(append)
        rows["append_cpu"].append(cpu)
        _, cpu, cols = _timed(builder.columns)
        rows["columns_cpu"].append(cpu)
        sid = new_segment_id()
        path = scratch / f"{sid}.h5"
        wall, cpu, _ = _timed(
            partial(write_segment, path, sid, cols, builder.provenance, durable=False)
        )
        rows["hdf5_write_cpu"].append(cpu)
        rows["hdf5_write_wall"].append(wall)

        def sync(p: Path = path) -> None:
            fd = os.open(p, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
            fsync_dir(scratch)

        wall, _, _ = _timed(sync)
        rows["fsync_wall"].append(wall)
        wall, cpu, _ = _timed(partial(builder.seal, scratch, durable=True))
        rows["seal_durable_cpu"].append(cpu)
        rows["seal_durable_wall"].append(wall)
    out: dict[str, Any] = {k: _stats(v, 1e6 / len(records), 2) for k, v in rows.items()}
    builder = archive.builder()
    for r in records:
        builder.append(r)
    out["profile_seal"] = _profile(lambda: builder.seal(scratch, durable=True))
    shutil.rmtree(scratch)
    return out


def add_recorded(archive: Archive, n: int, seed: int) -> tuple[list[str], dict[str, Any]]:
    """``n`` recorded runs (record='rate', dt 2 ms) in a segment of their own."""
    runs = simulate(n, seed, "rate", 0.002)
    builder = archive.builder()
    for run, wall in runs:
        builder.append(archive.record(run, wall_time_s=wall, solver=_solver(run)))
    info = archive.seal(builder)
    archive.register([info])
    samples = [r.trajectory.n_samples for r, _ in runs]
    return [r.run_id or "" for r, _ in runs], {
        "runs": n,
        "segment_bytes": info.path.stat().st_size,
        "samples_per_run": _stats(samples, 1.0, 1),
    }


# -- reads ---------------------------------------------------------------------------------------


def list_in_process(archive: Archive, query: dict[str, Any], repeats: int) -> dict[str, Any]:
    from bowlrec.archive.index import forget_connections

    fresh, warm = [], []
    n_rows = 0
    for _ in range(repeats):
        forget_connections(archive.index_path)
        wall, _, rows = _timed(lambda: archive.list_runs(**query))
        fresh.append(wall)
        n_rows = len(rows)
    for _ in range(repeats):
        wall, _, _ = _timed(lambda: archive.list_runs(**query))
        warm.append(wall)
    from bowlrec.archive.index import Filter, select_sql

    filters = [Filter.parse(w) for w in query["where"]] + [Filter("outcome", "=", query["outcome"])]
    sql, params = select_sql(filters, "created_at", query["limit"])
    con = archive.index_reader()
    plan = [str(tuple(r)) for r in con.execute("EXPLAIN QUERY PLAN " + sql, params)]
    return {
        "query": query,
        "rows": n_rows,
        "fresh_connection_s": _stats(fresh, 1.0, 4),
        "reused_connection_s": _stats(warm, 1.0, 4),
        "query_plan": plan,
    }


def list_cli(archive_dir: Path, repeats: int) -> dict[str, Any]:
    cmd = [str(BIN / "bowlrec"), "runs", "list", "-a", str(archive_dir), "--outcome", "pins"]
    cmd += ["-w", "hook_m>=0.3", "--limit", "50", "--json"]
    walls, n_rows = [], 0
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = subprocess.run(cmd, capture_output=True, text=True, check=True)
        walls.append(time.perf_counter() - t0)
        n_rows = len(json.loads(res.stdout))
    help_walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([str(BIN / "bowlrec"), "--help"], capture_output=True, check=True)
        help_walls.append(time.perf_counter() - t0)
    imp = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "import bowlrec.cli"],
        capture_output=True,
        text=True,
    )
    top = []
    for line in imp.stderr.splitlines()[1:]:
        parts = line.split("|")
        if len(parts) == 3 and parts[1].strip().isdigit():
            top.append((int(parts[1]), parts[2].rstrip()))
    top.sort(reverse=True)
    return {
        "command": "bowlrec runs list -a DIR --outcome pins -w 'hook_m>=0.3' --limit 50 --json",
        "rows": n_rows,
        "wall_s": _stats(walls, 1.0, 3),
        "bowlrec_help_wall_s": _stats(help_walls, 1.0, 3),
        "import_bowlrec_cli_cumulative_us": [{"us": us, "module": m} for us, m in top[:8]],
    }


def row_in_process(archive: Archive, ids: list[str]) -> dict[str, Any]:
    from bowlrec.archive.index import forget_connections

    fresh, warm = [], []
    for rid in ids:
        forget_connections(archive.index_path)
        fresh.append(_timed(partial(archive.row, rid))[0])
    for rid in ids:
        warm.append(_timed(partial(archive.row, rid))[0])
    return {
        "fresh_connection_ms": _stats(fresh, 1e3, 3),
        "reused_connection_ms": _stats(warm, 1e3, 3),
    }


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def server(archive_dir: Path) -> Iterator[tuple[str, float]]:
    """A ``bowlrec serve`` subprocess on 127.0.0.1; yields (base URL, start-up s)."""
    from benchmarks.service import server as serve

    t0 = time.perf_counter()
    with serve(archive_dir) as url:
        yield url, time.perf_counter() - t0


def http_reads(archive_dir: Path, ids: list[str]) -> dict[str, Any]:
    import httpx

    with server(archive_dir) as (url, startup), httpx.Client(base_url=url, timeout=60) as c:
        first = _timed(lambda: c.get(f"/runs/{ids[0]}"))
        for rid in ids[:5]:  # warm the connection and the code path
            c.get(f"/runs/{rid}").raise_for_status()
        times = []
        for rid in ids:
            wall, _, r = _timed(partial(c.get, f"/runs/{rid}"))
            r.raise_for_status()
            times.append(wall)
        params: dict[str, str | int] = {"outcome": "pins", "where": "hook_m>=0.3", "limit": 50}
        lists = []
        for _ in range(20):
            wall, _, r = _timed(lambda: c.get("/runs", params=params))
            r.raise_for_status()
            lists.append(wall)
    return {
        "server_startup_s": round(startup, 3),
        "first_get_ms": round(first[0] * 1e3, 3),
        "get_run_ms": _stats(times, 1e3, 3),
        "list_pins_hook_limit50_ms": _stats(lists, 1e3, 3),
    }


def load_recorded(archive: Archive, ids: list[str]) -> dict[str, Any]:
    first = _timed(lambda: archive.load(ids[0]))[0]
    times = [_timed(partial(archive.load, rid))[0] for rid in ids]
    prof = _profile(lambda: [archive.load(r) for r in ids[:20]])
    return {
        "first_in_process_ms": round(first * 1e3, 3),
        "load_ms": _stats(times, 1e3, 3),
        "profile_20_loads": prof,
    }


# -- the whole benchmark -------------------------------------------------------------------------


def measure(
    n_runs: int,
    n_bases: int,
    batch: int,
    log: Callable[[str], None],
    keep: bool = False,
    path_runs: int = PATH_RUNS,
    path_repeats: int = PATH_REPEATS,
) -> dict[str, Any]:
    from bowlrec.archive import Archive

    t_start = time.perf_counter()
    data: dict[str, Any] = {"machine": machine(), "loadavg_before": os.getloadavg()}
    log(f"the archive path against the kernel: {path_runs:,} runs, {path_repeats} rounds ...")
    data["archive_path"] = archive_path(path_runs, path_repeats, log)
    data["setup"] = {
        "runs": n_runs,
        "segment_runs": SEGMENT_RUNS,
        "bases_simulated": n_bases,
        "register_batch": batch,
        "single_register_every": SINGLE_EVERY,
    }
    tmp = Path(tempfile.mkdtemp(prefix="bowlrec-archive-bench-", dir="/tmp"))
    try:
        root = tmp / "archive"
        archive = Archive(root)
        log(f"simulating {n_bases} summary-only deliveries ...")
        wall, _, bases = _timed(lambda: simulate(n_bases, 1, "summary"))
        outcomes: dict[str, int] = {}
        for r, _ in bases:
            outcomes[r.trajectory.summary.outcome] = (
                outcomes.get(r.trajectory.summary.outcome, 0) + 1
            )
        data["setup"]["simulate_s"] = round(wall, 2)
        data["setup"]["base_outcomes"] = outcomes
        data["setup"]["base_events_per_run"] = round(
            statistics.fmean(len(r.trajectory.events) for r, _ in bases), 2
        )
        per_run, records = record_cost(root, bases)
        data["record"] = {"cpu_us_per_run": _stats(per_run, 1e6, 2), "passes": len(per_run)}
        fresh = Archive(root)
        data["record"]["profile_1000"] = _profile(
            lambda: [fresh.record(r, wall_time_s=w) for r, w in bases[:1000]]
        )
        data["setup"]["scene_json_bytes_per_run"] = round(
            statistics.fmean(len(r.scene_json) for r in records), 1
        )

        factory = RecordFactory(records, n_runs)
        log(f"writing {n_runs:,} runs ...")
        b = build(archive, factory, n_runs, batch, log)
        segs = b["segments"]
        seg_bytes = sum(p.stat().st_size for p in archive.segments_dir.glob("*.h5"))
        idx_bytes = archive.index_path.stat().st_size
        n_indexed = len(archive)
        data["build"] = {
            "wall_s": round(b["wall_s"], 2),
            "runs_per_s": round(n_runs / b["wall_s"], 1),
            "generate_records_s": round(b["generate_records_s"], 2),
            "runs_indexed": n_indexed,
            "segments": len(segs),
            "writer_cpu_us_per_run": _per_run_us(segs, "writer_cpu_s"),
            "writer_wall_us_per_run": _per_run_us(segs, "writer_wall_s"),
            "append_cpu_us_per_run": _per_run_us(segs, "append_cpu_s"),
            "seal_cpu_us_per_run": _per_run_us(segs, "seal_cpu_s"),
            "seal_wall_us_per_run": _per_run_us(segs, "seal_wall_s"),
            "register_cpu_us_per_run": _per_run_us(segs, "register_cpu_s"),
            "register_wall_us_per_run": _per_run_us(segs, "register_wall_s"),
            "single_register": [
                {
                    "index_runs_before": s["index_runs_before"],
                    "cpu_ms": round(s["cpu_s"] * 1e3, 2),
                    "wall_ms": round(s["wall_s"] * 1e3, 2),
                }
                for s in b["singles"]
            ],
            "first_10_segments_writer_cpu_us_per_run": [
                round(r["writer_cpu_s"] / r["runs"] * 1e6, 1) for r in segs[:10]
            ],
            "last_10_segments_writer_cpu_us_per_run": [
                round(r["writer_cpu_s"] / r["runs"] * 1e6, 1) for r in segs[-10:]
            ],
        }
        data["disk"] = {
            "segment_bytes_per_run": round(seg_bytes / n_indexed, 1),
            "index_bytes_per_run": round(idx_bytes / n_indexed, 1),
            "bytes_per_run": round((seg_bytes + idx_bytes) / n_indexed, 1),
            "archive_dir_bytes": _du(root),
            "segment_bytes_total": seg_bytes,
            "index_bytes_total": idx_bytes,
        }
        data["datasets_one_segment"] = _datasets(next(archive.segments_dir.glob("*.h5")))
        log("breakdown of one segment's write ...")
        data["breakdown"] = breakdown(
            archive, factory.segment(n_runs, SEGMENT_RUNS), tmp / "scratch", 10
        )

        log("adding 100 recorded runs ...")
        rec_ids, data["recorded"] = add_recorded(archive, 100, 2)
        rng = random.Random(3)
        ids = [synthetic_run_id(rng.randrange(n_runs)) for _ in range(200)]

        log("reads ...")
        data["list_in_process"] = list_in_process(archive, LIST_QUERY, 20)
        data["list_rare_in_process"] = list_in_process(archive, RARE_QUERY, 5)
        data["list_cli"] = list_cli(root, 10)
        data["row_in_process"] = row_in_process(archive, ids)
        data["http"] = http_reads(root, ids)
        data["load"] = load_recorded(archive, rec_ids)

        log("repair ...")
        wall, cpu, report = _timed(archive.repair)
        data["repair"] = {
            "wall_s": round(wall, 2),
            "cpu_s": round(cpu, 2),
            "report": {k: v for k, v in report.items() if not isinstance(v, list)}
            | {k: len(v) for k, v in report.items() if isinstance(v, list)},
        }
        log(f"  {wall:.1f} s; reindex ...")
        wall, cpu, n = _timed(archive.reindex)
        data["reindex"] = {
            "wall_s": round(wall, 2),
            "cpu_s": round(cpu, 2),
            "runs": n,
            "index_bytes_after": archive.index_path.stat().st_size,
            "index_bytes_per_run_after": round(archive.index_path.stat().st_size / n, 1),
        }
        log(f"  {wall:.1f} s")
    finally:
        if keep:
            log(f"kept the archive: {root}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    data["loadavg_after"] = os.getloadavg()
    data["benchmark_wall_s"] = round(time.perf_counter() - t_start, 1)
    data["targets"] = _targets(data)
    return data


def _datasets(path: Path) -> list[dict[str, Any]]:
    """Stored bytes per dataset of one segment, largest first."""
    import h5py

    rows: list[dict[str, Any]] = []
    with h5py.File(path, "r") as f:
        n = int(f.attrs["n_runs"])

        def visit(name: str, obj: Any) -> None:
            if isinstance(obj, h5py.Dataset):
                size = obj.id.get_storage_size()
                rows.append({"dataset": name, "bytes_per_run": round(size / n, 1)})

        f.visititems(visit)
    rows.sort(key=lambda r: -r["bytes_per_run"])
    total = sum(r["bytes_per_run"] for r in rows)
    file_per_run = path.stat().st_size / n
    return [
        {"dataset": "(file total)", "bytes_per_run": round(file_per_run, 1)},
        {
            "dataset": "(HDF5 metadata, headers, free space)",
            "bytes_per_run": round(file_per_run - total, 1),
        },
        *rows,
    ]


# -- the archive path against the kernel -----------------------------------------------------


def archive_path(
    n_runs: int, repeats: int, log: Callable[[str], None], tmp: Path | None = None
) -> dict[str, Any]:
    """``bowlrec batch --archive`` of a summary-only job against the kernel, interleaved.

    Each round measures, in this order: the kernel alone (``run_batch`` on 2 numba threads,
    100,000 of the job's deliveries packed in memory, median of 3), the batch with a fresh
    archive (``run_job``, 2 worker processes: segments written, fsynced, registered), the batch
    without an archive, the kernel again. A round's ratio is the archive path's steady rate
    (between 10 % and 90 % of the runs, worker start-up excluded) over the mean of the kernel
    measured around it; the result is the median over the rounds of each number."""
    from benchmarks.pipeline import _job, _packed, batch_row, kernel_rate
    from bowlrec.archive import Archive

    job = _job(PATH_JOB, n_runs)
    packed = _packed(job, min(n_runs, 100_000))
    own = tmp is None
    root = Path(tempfile.mkdtemp(prefix="bowlrec-archive-path-", dir="/tmp")) if own else tmp
    assert root is not None
    rounds: list[dict[str, Any]] = []
    try:
        for rep in range(repeats):
            before = kernel_rate(packed)
            archive = Archive(root / f"a{rep}")
            arch = batch_row("batch --archive", job, archive, n_runs)
            seg_bytes = sum(p.stat().st_size for p in archive.segments_dir.glob("*.h5"))
            idx_bytes = archive.index_path.stat().st_size
            archive.close()
            shutil.rmtree(root / f"a{rep}", ignore_errors=True)
            plain = batch_row("batch --no-archive", job, None, n_runs)
            after = kernel_rate(packed)
            kernel = (before + after) / 2
            rounds.append(
                {
                    "kernel_before_per_s": before,
                    "kernel_after_per_s": after,
                    "kernel_per_s": kernel,
                    "archive_steady_per_s": arch["steady_per_s"],
                    "archive_whole_per_s": arch["whole_job_per_s"],
                    "no_archive_steady_per_s": plain["steady_per_s"],
                    "ratio_pct": 100 * arch["steady_per_s"] / kernel,
                    "ratio_whole_pct": 100 * arch["whole_job_per_s"] / kernel,
                    "no_archive_pct": 100 * plain["steady_per_s"] / kernel,
                    "segment_bytes_per_run": seg_bytes / n_runs,
                    "index_bytes_per_run": idx_bytes / n_runs,
                    "write_us_per_run": arch["write_s_per_run"] * 1e6,
                }
            )
            r = rounds[-1]
            log(
                f"  round {rep + 1}: kernel {before:,.0f} / {after:,.0f} per s, archive path "
                f"{r['archive_steady_per_s']:,.0f} per s ({r['ratio_pct']:.1f} %), no archive "
                f"{r['no_archive_steady_per_s']:,.0f} per s"
            )
    finally:
        if own:
            shutil.rmtree(root, ignore_errors=True)
    med = {k: round(statistics.median(r[k] for r in rounds), 1) for k in rounds[0]}
    return {
        "job": PATH_JOB,
        "runs": n_runs,
        "repeats": repeats,
        "rounds": [{k: round(v, 1) for k, v in r.items()} for r in rounds],
        "median": med,
        "met_pct": med["ratio_pct"] >= PATH_TARGET_PCT,
        # the rate target applies when the kernel does >= PATH_KERNEL_FLOOR (None: it did not)
        "met_rate": med["archive_steady_per_s"] >= PATH_TARGET_RATE
        if med["kernel_per_s"] >= PATH_KERNEL_FLOOR
        else None,
    }


def path_markdown(p: dict[str, Any]) -> list[str]:
    """The archive path section of the report."""
    m = p["median"]
    lines = [
        "## The archive path against the kernel",
        "",
        f"`bowlrec batch --archive` of `benchmarks/jobs/{p['job']}` ({p['runs']:,} summary-only "
        "runs, 2 worker processes, a fresh archive each round: segments written, fsynced and "
        "registered) against the kernel alone (`run_batch`, 2 numba threads, 100,000 of the "
        "job's deliveries packed in memory), interleaved in one process tree: kernel, archive "
        f"path, batch without an archive, kernel; {p['repeats']} rounds. Steady rate: between "
        "10 % and 90 % of the runs. A round's ratio uses the mean of the kernel measured around "
        "it; every number below is the median over the rounds.",
        "",
        "| measured | median |",
        "|---|---:|",
        f"| kernel alone, deliveries/s | {m['kernel_per_s']:,.0f} |",
        f"| batch --archive, steady, runs/s | {m['archive_steady_per_s']:,.0f} |",
        f"| batch --archive, whole job, runs/s | {m['archive_whole_per_s']:,.0f} |",
        f"| batch --no-archive, steady, runs/s | {m['no_archive_steady_per_s']:,.0f} |",
        f"| **archive path / kernel** | **{m['ratio_pct']:.1f} %** |",
        f"| archive path / kernel, whole job | {m['ratio_whole_pct']:.1f} % |",
        f"| no archive / kernel | {m['no_archive_pct']:.1f} % |",
        f"| segment bytes per run | {m['segment_bytes_per_run']:.0f} |",
        f"| index bytes per run | {m['index_bytes_per_run']:.0f} |",
        f"| storing a run, wall (worker: columns, digests, HDF5, fsync; parent: index), µs | "
        f"{m['write_us_per_run']:.1f} |",
        "",
        f"Target: archive path >= {PATH_TARGET_PCT:.0f} % of the kernel, and >= "
        f"{PATH_TARGET_RATE:,.0f} runs/s when the kernel does >= {PATH_KERNEL_FLOOR:,.0f}/s: "
        f"ratio {'met' if p['met_pct'] else '**missed**'}; rate "
        + (
            f"not judged (the kernel did {m['kernel_per_s']:,.0f}/s on this shared machine)"
            if p["met_rate"] is None
            else ("met" if p["met_rate"] else "**missed**")
        )
        + ".",
        "",
        "| round | kernel before | kernel after | archive path | ratio | no archive |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for i, r in enumerate(p["rounds"], 1):
        lines.append(
            f"| {i} | {r['kernel_before_per_s']:,.0f} | {r['kernel_after_per_s']:,.0f} | "
            f"{r['archive_steady_per_s']:,.0f} | {r['ratio_pct']:.1f} % | "
            f"{r['no_archive_steady_per_s']:,.0f} |"
        )
    lines.append("")
    return lines


def _targets(d: dict[str, Any]) -> list[dict[str, Any]]:
    measured = {
        "bytes_per_run": d["disk"]["bytes_per_run"],
        "writer_cpu_per_run": d["build"]["writer_cpu_us_per_run"]["median"],
        "list_in_process": d["list_in_process"]["fresh_connection_s"]["median"],
        "list_cli": d["list_cli"]["wall_s"]["median"],
        "row_in_process": d["row_in_process"]["fresh_connection_ms"]["median"],
        "row_http": d["http"]["get_run_ms"]["median"],
        "load_trajectory": d["load"]["load_ms"]["median"],
        "repair": d["repair"]["wall_s"],
        "reindex": d["reindex"]["wall_s"],
        "archive_path": d["archive_path"]["median"]["ratio_pct"],
    }
    return [
        {
            "key": key,
            "what": what,
            "target": f"{'>=' if key in AT_LEAST else '<='} {limit:g} {unit}",
            "measured": measured[key],
            "unit": unit,
            "met": measured[key] >= limit if key in AT_LEAST else measured[key] <= limit,
        }
        for key, (what, limit, unit) in TARGETS.items()
    ]


# -- report --------------------------------------------------------------------------------------


def markdown(d: dict[str, Any]) -> str:
    m, s, b, k = d["machine"], d["setup"], d["build"], d["breakdown"]
    lines = [
        "# Archive (format 2.3) at scale",
        "",
        f"{s['runs']:,} summary-only runs in {b['segments']:,} segments of "
        f"{s['segment_runs']:,} (made from {s['bases_simulated']:,} simulated deliveries, "
        f"outcomes {s['base_outcomes']}), plus {d['recorded']['runs']} recorded runs "
        f"(rate, 2 ms). {m['nproc']} cores ({m['cpu']}), load average "
        f"{d['loadavg_before'][0]:.2f} before / {d['loadavg_after'][0]:.2f} after; "
        f"Python {m['python']}, numpy {m['numpy']}, h5py {m['h5py']} (HDF5 "
        f"{m['hdf5']}), SQLite {m['sqlite']}. Whole benchmark: {d['benchmark_wall_s']:.0f} s. "
        "Times: median of repeats (best in the tables below).",
        "",
        "| target | limit | measured | met |",
        "|---|---:|---:|:---:|",
    ]
    for t in d["targets"]:
        lines.append(
            f"| {t['what']} | {t['target']} | {t['measured']:g} {t['unit']} | "
            f"{'yes' if t['met'] else '**no**'} |"
        )
    disk = d["disk"]
    lines += ["", *path_markdown(d["archive_path"])]
    lines += [
        "## Writing",
        "",
        f"Build: {b['wall_s']:.0f} s wall for {b['runs_indexed']:,} runs ({b['runs_per_s']:,.0f} "
        f"runs/s; making the synthetic records took {b['generate_records_s']:.0f} s of it). "
        f"On disk: {disk['segment_bytes_per_run']:.0f} B/run of segments + "
        f"{disk['index_bytes_per_run']:.0f} B/run of index = {disk['bytes_per_run']:.0f} B/run "
        f"(index {d['reindex']['index_bytes_per_run_after']:.0f} B/run after a full rebuild).",
        "",
        "Per run, microseconds, over every 1,000-run segment of the build "
        f"(registration in batches of {s['register_batch']}, its cost shared out):",
        "",
        "| piece | median | best | p95 |",
        "|---|---:|---:|---:|",
    ]
    for label, key in (
        ("writer CPU: append + seal + register", "writer_cpu_us_per_run"),
        ("writer wall: append + seal + register", "writer_wall_us_per_run"),
        ("append CPU", "append_cpu_us_per_run"),
        ("seal CPU (columns, digests, HDF5, fsync)", "seal_cpu_us_per_run"),
        ("seal wall", "seal_wall_us_per_run"),
        ("register CPU", "register_cpu_us_per_run"),
        ("register wall", "register_wall_us_per_run"),
    ):
        st = b[key]
        lines.append(f"| {label} | {st['median']:.1f} | {st['best']:.1f} | {st['p95']:.1f} |")
    rec = d["record"]["cpu_us_per_run"]
    lines += [
        "",
        "Pieces, one segment's records written to a scratch directory "
        f"({k['append_cpu']['n']} repeats), microseconds per run:",
        "",
        "| piece | median | best |",
        "|---|---:|---:|",
        f"| Archive.record() (RunData -> RunRecord; CPU, not in the writer target) | "
        f"{rec['median']:.1f} | {rec['best']:.1f} |",
    ]
    for label, key in (
        ("SegmentBuilder.append (CPU)", "append_cpu"),
        ("SegmentBuilder.columns(): columns + digests (CPU)", "columns_cpu"),
        ("HDF5 write, write_segment(durable=False) (CPU)", "hdf5_write_cpu"),
        ("HDF5 write (wall)", "hdf5_write_wall"),
        ("fsync file + directory (wall)", "fsync_wall"),
        ("SegmentBuilder.seal(durable=True) (CPU)", "seal_durable_cpu"),
        ("SegmentBuilder.seal(durable=True) (wall)", "seal_durable_wall"),
    ):
        lines.append(f"| {label} | {k[key]['median']:.1f} | {k[key]['best']:.1f} |")
    reg = b["register_cpu_us_per_run"]
    singles = b["single_register"]
    lines += [
        f"| Archive.register (CPU, from the build, batches of {s['register_batch']}) | "
        f"{reg['median']:.1f} | {reg['best']:.1f} |",
        "",
        "Registering one segment alone (CPU ms / wall ms) as the index grows: "
        + ", ".join(
            f"{x['index_runs_before']:,}: {x['cpu_ms']:.0f}/{x['wall_ms']:.0f}"
            for x in singles[:: max(1, len(singles) // 6)]
        )
        + ".",
        "",
        "Largest datasets of one segment (stored bytes per run): "
        + ", ".join(
            f"{x['dataset']} {x['bytes_per_run']:.0f}" for x in d["datasets_one_segment"][:10]
        )
        + ".",
        "",
        "## Reading",
        "",
    ]
    li, lr, cli = d["list_in_process"], d["list_rare_in_process"], d["list_cli"]
    row, http, load = d["row_in_process"], d["http"], d["load"]
    lines += [
        "| measurement | median | best | p95 |",
        "|---|---:|---:|---:|",
        _trow("list pins, hook_m>=0.3, limit 50; fresh connection (s)", li["fresh_connection_s"]),
        _trow("same, reused connection (s)", li["reused_connection_s"]),
        _trow(
            f"list pins, hook_m>=1.45 ({lr['rows']} rows), fresh connection (s)",
            lr["fresh_connection_s"],
        ),
        _trow("`bowlrec runs list ... --json`, whole process (s)", cli["wall_s"]),
        _trow("`bowlrec --help`, whole process (s)", cli["bowlrec_help_wall_s"]),
        _trow("Archive.row, fresh connection (ms)", row["fresh_connection_ms"]),
        _trow("Archive.row, reused connection (ms)", row["reused_connection_ms"]),
        _trow("GET /runs/{id} (ms)", http["get_run_ms"]),
        _trow(
            "GET /runs?outcome=pins&where=hook_m>=0.3&limit=50 (ms)",
            http["list_pins_hook_limit50_ms"],
        ),
        _trow("Archive.load of a recorded run (ms)", load["load_ms"]),
        "",
        f"Query plan of the listing: {'; '.join(li['query_plan'])}. Recorded runs: "
        f"{d['recorded']['samples_per_run']['median']:.0f} samples each (median). "
        f"`Archive.repair()`: {d['repair']['wall_s']:.1f} s wall, {d['repair']['cpu_s']:.1f} s "
        f"CPU ({d['repair']['report'].get('runs_checked', 0):,} runs checked). "
        f"`Archive.reindex()`: {d['reindex']['wall_s']:.1f} s wall, {d['reindex']['cpu_s']:.1f} s "
        "CPU (each once).",
        "",
        "Caveats: the run IDs are SHA-256 prefixes like real content IDs; the page cache is "
        "warm (the archive was just written); `process_time` does not count waiting for fsync "
        "or the index commit.",
        "",
    ]
    return "\n".join(lines)


def _trow(label: str, st: dict[str, Any]) -> str:
    return f"| {label} | {st['median']:g} | {st['best']:g} | {st['p95']:g} |"


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", type=int, default=None, help="summary-only runs (1,000,000)")
    parser.add_argument("--quick", action="store_true", help="a 20,000-run smoke test")
    parser.add_argument("--bases", type=int, default=None, help="deliveries to simulate (2,000)")
    parser.add_argument("--register-batch", type=int, default=1)
    parser.add_argument(
        "--path-runs", type=int, default=None, help="runs of the archive path job (200,000)"
    )
    parser.add_argument("--path-repeats", type=int, default=PATH_REPEATS)
    parser.add_argument(
        "--keep", action="store_true", help="keep the archive under /tmp (to investigate)"
    )
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    n_runs = args.runs or (20_000 if args.quick else 1_000_000)
    n_bases = args.bases or (1_000 if args.quick else 2_000)
    name = "archive-quick" if args.quick else "archive"
    os.chdir(ROOT)

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    path_runs = args.path_runs or (20_000 if args.quick else PATH_RUNS)
    data = measure(
        n_runs,
        n_bases,
        args.register_batch,
        log,
        keep=args.keep,
        path_runs=path_runs,
        path_repeats=args.path_repeats,
    )
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"{name}.json").write_text(json.dumps(data, indent=2) + "\n")
    (args.out / f"{name}.md").write_text(markdown(data))
    print(markdown(data))


if __name__ == "__main__":
    main()

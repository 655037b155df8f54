"""Run prepared jobs: workers simulate, this process writes the archive.

Workers (a local process pool, a dask.distributed cluster, or this process) receive chunks of
resolved Plans and return summaries and trajectories; they never touch the archive. The calling
process skips runs whose content ID is archived already, collects finished runs into a segment
(:class:`~bowlrec.archive.SegmentBuilder`) that it seals and registers every
:data:`SEGMENT_RUNS` runs or :data:`FLUSH_S` seconds (a kill loses at most the runs not yet
sealed; rerunning the job simulates them again) and reports progress. Cancellation (an Event,
set e.g. by SIGINT) stops submitting, keeps every run that finished, and marks the rest
``cancelled``. A write that fails (a full disk) stops the batch the same way: the runs already
sealed stay, the unsealed ones become failed rows naming the error, and ``BatchResult.error``
says what happened.
"""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.core.trajectory import Summary

from .job import JobSpec, PreparedRun, prepare_runs

if TYPE_CHECKING:
    from bowlrec.archive import Archive
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Trajectory

__all__ = [
    "FAILED_OUTCOMES",
    "METRIC_COLUMNS",
    "BatchProgress",
    "BatchResult",
    "InlineExecutor",
    "SimResult",
    "SimTask",
    "run_job",
    "run_prepared",
    "simulate_chunk",
]

#: runs per sealed segment, at most
SEGMENT_RUNS = 1000
#: seconds after which collected runs are sealed even when fewer than SEGMENT_RUNS
FLUSH_S = 1.0

#: outcomes that mean the model or the solver gave up: recorded as failures, not archived
FAILED_OUTCOMES = frozenset({"airborne", "max_steps", "stalled"})

#: summary metrics of every table row: the Summary fields but the message (units in the names)
METRIC_COLUMNS = tuple(f.name for f in dataclasses.fields(Summary) if f.name != "message")

#: row statuses: simulated and added now / found in the archive / not run (see error) /
#: not reached before cancellation
STATUSES = ("ok", "archived", "failed", "cancelled")


# -- worker side ------------------------------------------------------------------------------


@dataclass(frozen=True)
class SimTask:
    """One simulation for a worker: the run's content ID and its resolved Plan."""

    run_id: str
    plan: Plan


@dataclass(frozen=True)
class SimResult:
    """A worker's answer: the trajectory (None on error), solver wall time (s), solver name."""

    run_id: str
    trajectory: Trajectory | None
    wall_time_s: float
    solver: str
    error: str | None = None


def simulate_chunk(tasks: Sequence[SimTask]) -> list[SimResult]:
    """Simulate each task (exceptions become ``error`` results). Runs in a worker process."""
    from bowlrec.core.solver import solve, use_closed_form

    out = []
    for task in tasks:
        start = time.perf_counter()
        try:
            traj = solve(task.plan)
        except Exception as err:  # a failing scene is a row, never a crashed batch
            out.append(SimResult(task.run_id, None, 0.0, "", f"{type(err).__name__}: {err}"))
            continue
        wall = time.perf_counter() - start
        solver = "closed_form" if use_closed_form(task.plan) else "integrator"
        out.append(SimResult(task.run_id, traj, wall, solver))
    return out


def _worker_init() -> None:
    """Pool workers leave Ctrl-C to the parent (which stops the batch cleanly)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


# -- progress and results ---------------------------------------------------------------------


@dataclass(frozen=True)
class BatchProgress:
    """Counts so far: ``done`` of ``total`` rows settled (simulated, archived or failed)."""

    total: int
    done: int
    simulated: int
    archived: int
    failed: int
    elapsed_s: float

    @property
    def rate_per_s(self) -> float:
        """Simulated runs per second of wall time so far."""
        return self.simulated / self.elapsed_s if self.elapsed_s > 0 else 0.0

    @property
    def eta_s(self) -> float | None:
        """Estimated seconds to finish (None before the first simulated run)."""
        rate = self.rate_per_s
        return (self.total - self.done) / rate if rate > 0 else None


@dataclass
class BatchResult:
    """What a batch did: one row per run (job order) and totals.

    rows: dicts with ``index``, the parameter columns, ``run_id``, ``status`` (ok | archived |
    failed | cancelled), ``error`` and :data:`METRIC_COLUMNS`; param_columns: the parameter
    column names in order; simulate_s: summed solver time in the workers (s); write_s: time
    spent adding runs to the archive (s); elapsed_s: wall time of the whole batch (s).
    """

    rows: list[dict[str, Any]]
    param_columns: list[str]
    cancelled: bool = False
    elapsed_s: float = 0.0
    simulate_s: float = 0.0
    write_s: float = 0.0
    replays: list[Path] = field(default_factory=list)
    #: why the batch stopped early when writing failed (e.g. a full disk); None otherwise
    error: str | None = None

    def count(self, status: str) -> int:
        return sum(1 for r in self.rows if r["status"] == status)

    @property
    def counts(self) -> dict[str, int]:
        return {s: self.count(s) for s in STATUSES}

    @property
    def simulated(self) -> int:
        """Runs simulated by this batch (added now, plus simulated failures)."""
        return sum(1 for r in self.rows if r.get("_simulated"))


ProgressCallback = Callable[[BatchProgress], None]


# -- executors --------------------------------------------------------------------------------


class InlineExecutor(Executor):
    """Runs each submitted call at once in this process (``workers=0``; for tests and tiny
    jobs)."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        fut: Future[Any] = Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except BaseException as err:
            fut.set_exception(err)
        return fut


@contextmanager
def _executor(workers: int | None, scheduler: str | None) -> Iterator[tuple[Executor, int]]:
    """(executor, parallelism): a dask client's executor, this process, or a process pool."""
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError as err:
            raise RuntimeError(
                "--scheduler needs dask.distributed: pip install 'bowlrec[dask]'"
            ) from err
        with Client(scheduler, set_as_default=False) as client:
            nthreads = sum(client.nthreads().values()) or 1
            yield client.get_executor(pure=False), nthreads
        return
    if workers == 0:
        yield InlineExecutor(), 1
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    n = workers or os.cpu_count() or 1
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(["bowlrec.batch.runner", "bowlrec.core.solver"])
    pool = ProcessPoolExecutor(max_workers=n, mp_context=ctx, initializer=_worker_init)
    try:
        yield pool, n
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


# -- the writer -------------------------------------------------------------------------------


def _metrics(source: dict[str, Any]) -> dict[str, Any]:
    return {k: source.get(k) for k in METRIC_COLUMNS}


def _empty_row(prep: PreparedRun) -> dict[str, Any]:
    row: dict[str, Any] = {"index": prep.index, **prep.params, "run_id": prep.run_id}
    row.update({"status": "cancelled", "error": None})
    row.update({k: None for k in METRIC_COLUMNS})
    return row


def _archived_metrics(archive: Archive, run_ids: set[str]) -> dict[str, dict[str, Any]]:
    """Summary metrics of the runs among ``run_ids`` that are archived already (from the
    index)."""
    if not run_ids:
        return {}
    return {rid: _metrics(r) for rid, r in archive.rows(run_ids).items()}


class _Writer:
    """Turns worker results into table rows and segments of archive runs."""

    def __init__(
        self,
        archive: Archive,
        prepared: Sequence[PreparedRun],
        rows: list[dict[str, Any]],
        formats: Sequence[str],
        replay_dir: Path | None,
        durable: bool,
    ) -> None:
        self.archive = archive
        self.prepared = {p.run_id: p for p in prepared if p.run_id is not None}
        self.rows_by_id: dict[str, list[dict[str, Any]]] = {}
        for p, row in zip(prepared, rows, strict=True):
            if p.run_id is not None:
                self.rows_by_id.setdefault(p.run_id, []).append(row)
        self.formats = formats
        self.replay_dir = replay_dir
        self.durable = durable
        self.write_s = 0.0
        self.simulate_s = 0.0
        self.replays: list[Path] = []
        self._ball_refs: dict[str, str] = {}
        self.builder = archive.builder()
        self._pending: list[str] = []
        self._last_flush = time.perf_counter()
        #: rows a failed flush settled as failed
        self.failed_rows = 0

    def _ball_ref(self, prep: PreparedRun) -> str:
        if prep.ball_ref is not None:
            return prep.ball_ref
        from bowlrec.archive import ball_sha

        assert prep.scene is not None
        sha = ball_sha(prep.scene.ball)
        if sha not in self._ball_refs:
            entry = self.archive.balls.find(prep.scene.ball)
            self._ball_refs[sha] = entry.ref if entry is not None else ""
        return self._ball_refs[sha]

    def handle(self, res: SimResult) -> int:
        """Record one result; returns the number of rows it settled (a run to archive settles
        when its segment is sealed: :meth:`flush`)."""
        from bowlrec.sinks.common import RunData

        rows = self.rows_by_id[res.run_id]
        status, error, metrics = "failed", res.error, {}
        if res.trajectory is not None:
            self.simulate_s += res.wall_time_s
            summary = res.trajectory.summary
            metrics = _metrics(summary.to_dict())
            if summary.outcome in FAILED_OUTCOMES:
                error = f"{summary.outcome}: {summary.message}"
            else:
                prep = self.prepared[res.run_id]
                assert prep.scene is not None and prep.plan is not None
                run = RunData(prep.scene, prep.plan, res.trajectory, res.run_id)
                start = time.perf_counter()
                record = self.archive.record(
                    run,
                    wall_time_s=res.wall_time_s,
                    ball_ref=self._ball_ref(prep),
                    solver=res.solver,
                )
                if self.builder.append(record):
                    self._pending.append(res.run_id)
                self.write_s += time.perf_counter() - start
                status = "ok"
                self._replays(run)
        for row in rows:
            row.update(metrics)
            row.update({"status": status, "error": error, "_simulated": True})
        return 0 if status == "ok" else len(rows)

    def due(self) -> bool:
        """True when the collected runs should be sealed now."""
        return len(self.builder) >= SEGMENT_RUNS or (
            len(self.builder) > 0 and time.perf_counter() - self._last_flush >= FLUSH_S
        )

    def flush(self) -> int:
        """Seal the collected runs as one segment and register it; the rows it settled. On a
        write error the collected runs become failed rows and ArchiveWriteError propagates."""
        from bowlrec.archive import ArchiveWriteError

        self._last_flush = time.perf_counter()
        if not len(self.builder):
            return 0
        start = time.perf_counter()
        pending, builder = self._pending, self.builder
        self._pending, self.builder = [], self.archive.builder()
        try:
            info = self.archive.seal(builder, durable=self.durable)
        except ArchiveWriteError as err:
            self.failed_rows = self._fail(pending, str(err))
            self.write_s += time.perf_counter() - start
            raise
        try:
            self.archive.register([info])
        except ArchiveWriteError:
            # the runs are sealed on disk: the next writer registers them, so they stay "ok"
            self.failed_rows = 0
            raise
        finally:
            self.write_s += time.perf_counter() - start
        return sum(len(self.rows_by_id[rid]) for rid in pending)

    def _fail(self, run_ids: Sequence[str], error: str) -> int:
        n = 0
        for rid in run_ids:
            for row in self.rows_by_id[rid]:
                row.update({"status": "failed", "error": f"not archived: {error}"})
                n += 1
        return n

    def abandon(self, error: str) -> int:
        """Drop the collected runs (after a failed write), marking their rows failed; the rows
        it settled."""
        n = self._fail(self._pending, error)
        self._pending, self.builder = [], self.archive.builder()
        return n

    def fail_chunk(self, chunk: Sequence[SimTask], err: BaseException) -> int:
        n = 0
        for task in chunk:
            for row in self.rows_by_id[task.run_id]:
                row.update({"status": "failed", "error": f"worker: {type(err).__name__}: {err}"})
                n += 1
        return n

    def _replays(self, run: Any) -> None:
        if not self.formats or self.replay_dir is None:
            return
        self.replay_dir.mkdir(parents=True, exist_ok=True)
        if "mcap" in self.formats:
            from bowlrec.sinks.mcap_file import write_mcap

            self.replays.append(write_mcap(run, self.replay_dir / f"{run.run_id}.mcap"))
        if "rrd" in self.formats:
            from bowlrec.sinks.rerun_recording import write_rrd

            self.replays.append(write_rrd(run, self.replay_dir / f"{run.run_id}.rrd"))


def _param_columns(prepared: Sequence[PreparedRun]) -> list[str]:
    cols: dict[str, None] = {}
    for p in prepared:
        cols.update(dict.fromkeys(p.params))
    return list(cols)


def run_prepared(
    prepared: Sequence[PreparedRun],
    archive: Archive,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    executor: Executor | None = None,
    chunk_size: int | None = None,
    progress: ProgressCallback | None = None,
    cancel: threading.Event | None = None,
    formats: Sequence[str] = (),
    replay_dir: str | Path | None = None,
    durable: bool = True,
    recover: bool = True,
) -> BatchResult:
    """Simulate the prepared runs not yet archived and add them to ``archive``.

    ``workers``: local processes (None: all cores; 0: simulate in this process);
    ``scheduler``: a dask.distributed address (``tcp://host:port``) instead of local
    processes; ``executor``: any concurrent.futures Executor to use instead of both (kept
    open). ``chunk_size``: runs per task (default: about 8 tasks per worker, at most 64 runs).
    ``progress`` is called from this thread after every settled chunk; setting ``cancel``
    stops the batch after the chunks in flight (their finished runs are kept). ``recover``
    first runs :meth:`~bowlrec.archive.Archive.recover` (finishes what a killed writer left);
    ``durable`` fsyncs every sealed segment.
    """
    from bowlrec.archive import ArchiveWriteError

    start = time.perf_counter()
    if recover:  # finish what a killed writer left (temporaries, unregistered segments)
        archive.recover()
    rows = [_empty_row(p) for p in prepared]
    result = BatchResult(rows, _param_columns(prepared))
    todo: dict[str, SimTask] = {}
    for p, row in zip(prepared, rows, strict=True):
        if p.error is not None:
            row.update({"status": "failed", "error": p.error})
        elif p.run_id is not None and p.plan is not None:
            todo.setdefault(p.run_id, SimTask(p.run_id, p.plan))
    archived = _archived_metrics(archive, set(todo))
    for p, row in zip(prepared, rows, strict=True):
        if p.run_id in archived:
            row.update({"status": "archived", **archived[p.run_id]})
    tasks = [t for rid, t in todo.items() if rid not in archived]
    writer = _Writer(
        archive,
        prepared,
        rows,
        formats,
        None if replay_dir is None else Path(replay_dir),
        durable,
    )
    done = len(rows) - len([r for r in rows if r["status"] == "cancelled"])
    counts = {"simulated": 0}

    def report() -> None:
        if progress is not None:
            progress(
                BatchProgress(
                    total=len(rows),
                    done=done,
                    simulated=counts["simulated"],
                    archived=result.count("archived"),
                    failed=result.count("failed"),
                    elapsed_s=time.perf_counter() - start,
                )
            )

    report()
    cancel = cancel or threading.Event()
    if tasks:
        with _maybe_executor(executor, workers, scheduler) as (pool, parallel):
            size = chunk_size or max(1, min(64, math.ceil(len(tasks) / (8 * parallel))))
            queue = deque(tasks[i : i + size] for i in range(0, len(tasks), size))
            inflight: dict[Future[list[SimResult]], list[SimTask]] = {}
            while (queue or inflight) and not cancel.is_set():
                while queue and len(inflight) < 2 * parallel:
                    chunk = queue.popleft()
                    inflight[pool.submit(simulate_chunk, chunk)] = chunk
                finished, _ = wait(list(inflight), timeout=0.2, return_when=FIRST_COMPLETED)
                for fut in finished:
                    chunk = inflight.pop(fut)
                    try:
                        results = fut.result()
                    except Exception as err:  # a dead worker fails its chunk, not the batch
                        done += writer.fail_chunk(chunk, err)
                        continue
                    for res in results:
                        done += writer.handle(res)
                        counts["simulated"] += 1
                if writer.due():
                    try:
                        done += writer.flush()
                    except ArchiveWriteError as err:
                        done += writer.failed_rows
                        result.error = str(err)
                        cancel.set()
                if finished:
                    report()
            if cancel.is_set():
                result.cancelled = True
                # chunks not started are dropped; running ones finish and are kept
                running = [f for f in inflight if not f.cancel()]
                for fut in running:
                    try:
                        results = fut.result()
                    except Exception as err:
                        done += writer.fail_chunk(inflight[fut], err)
                        continue
                    for res in results:
                        done += writer.handle(res)
                        counts["simulated"] += 1
            if result.error is None:
                try:
                    done += writer.flush()
                except ArchiveWriteError as err:
                    done += writer.failed_rows
                    result.error = str(err)
            if result.error is not None:
                done += writer.abandon(result.error)
            report()
    result.elapsed_s = time.perf_counter() - start
    result.simulate_s = writer.simulate_s
    result.write_s = writer.write_s
    result.replays = writer.replays
    return result


@contextmanager
def _maybe_executor(
    executor: Executor | None, workers: int | None, scheduler: str | None
) -> Iterator[tuple[Executor, int]]:
    if executor is not None:
        yield executor, max(1, workers or os.cpu_count() or 1)
        return
    with _executor(workers, scheduler) as pair:
        yield pair


def run_job(
    job: JobSpec,
    archive: Archive,
    *,
    base_dir: str | Path = ".",
    **options: Any,
) -> BatchResult:
    """Prepare (:func:`~bowlrec.batch.job.prepare_runs`) and run a job; ``options`` as in
    :func:`run_prepared` (``formats`` defaults to the job's). Raises JobError for an invalid
    job before anything is simulated."""
    prepared = prepare_runs(job, base_dir=base_dir, balls=archive.balls)
    options.setdefault("formats", job.formats)
    return run_prepared(prepared, archive, **options)

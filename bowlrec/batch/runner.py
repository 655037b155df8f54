"""Run jobs: workers prepare, simulate and store chunks of runs; this process orchestrates.

The job is cut into chunks of consecutive runs (thousands for summary-only jobs, tens for
recorded ones). Each chunk goes to a worker (a local process pool, a dask.distributed cluster, or
this process) that expands only its points, prepares them, skips the runs archived already,
simulates the rest (:mod:`bowlrec.batch.chunks`) and seals them as one segment of the archive;
this process registers each segment in the index (one transaction per chunk), collects the
table rows in job order and reports progress. Nothing is expanded up front: a job of millions of
runs starts at once and, with a streaming table sink, runs in flat memory.

Where a worker cannot reach the archive's files (a Dask cluster without the shared filesystem;
``worker_writes`` "auto" probes for it), it ships its records back and this process seals them.
A kill loses at most the chunks in flight: sealed segments that were not yet registered are
registered by the next writer (:meth:`~bowlrec.archive.Archive.recover`), and rerunning the job
skips every archived run. Cancellation (an Event, set e.g. by SIGINT) stops submitting, keeps
every run that finished, marks the runs before the last one reached ``cancelled`` and counts the
rest as ``not_reached`` (the table ends with the last run reached, so stopping a job of millions
of runs is immediate). A write that fails (a full disk) stops the batch the same way, and
``BatchResult.error`` says what happened.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bowlrec.batch.job import PointsSweep, ScenesSweep
from bowlrec.batch.table import BatchResult
from bowlrec.errors import ArchiveWriteError, MissingExtraError

from .chunks import (
    FAILED_OUTCOMES,
    METRIC_COLUMNS,
    ChunkResult,
    ChunkTable,
    ChunkTask,
    WriteTarget,
    new_probe,
    remove_probe,
    run_chunk,
)
from .job import JobSpec, job_context
from .lifeline import Lifeline, bind_worker, lifeline
from .spans import SUMMARY_TARGET_S, TARGET_CHUNK_S, Spans

if TYPE_CHECKING:
    from bowlrec.archive import Archive

    from .context import JobContext

__all__ = [
    "FAILED_OUTCOMES",
    "METRIC_COLUMNS",
    "BatchProgress",
    "InlineExecutor",
    "run_job",
]

#: runs per chunk at most: summary-only and recorded jobs. A chunk is sized by time below its
#: cap (``spans``); a recorded chunk seals its samples as one segment (a worker holding
#: ``chunks.SEAL_SAMPLES`` samples seals before the chunk ends, which bounds its memory), so a
#: segment's fixed costs (its HDF5 datasets, digests, fsyncs and index transaction) are shared by
#: the few hundred 1 ms runs a 0.5 s chunk holds (benchmarks/results/pipeline.md)
SUMMARY_CHUNK = 16384
RECORDED_CHUNK = 1024
#: the recorded cap when workers may ship their records back (``worker_writes`` "no" or "auto"
#: on a cluster): a shipped chunk's samples travel and are held whole
SHIPPED_RECORDED_CHUNK = 32


def _worker_init(line: Lifeline | None = None) -> None:
    """Pool workers leave Ctrl-C to the parent (which stops the batch cleanly), and die with the
    fork server and with the batch's process (``line``): once that is gone (killed), nothing
    would read their results, and the next run of the job registers what they sealed."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    bind_worker(line)


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


class _Workers:
    """The executor a batch submits to; a local process pool is restarted when one of its
    processes dies (killed, out of memory): a dead pool worker can leave the pool's result queue
    locked, so the pool is replaced, not reused."""

    def __init__(
        self,
        pool: Executor,
        parallel: int,
        make: Callable[[], Executor] | None = None,
    ) -> None:
        self.pool = pool
        self.parallel = parallel
        self._make = make

    def lost(self, fut: Future[Any]) -> bool:
        """True when the future failed because its restartable pool broke (a worker died)."""

        if self._make is None or not fut.done() or fut.cancelled():
            return False
        return isinstance(fut.exception(), BrokenProcessPool)

    def broken(self) -> bool:
        """True when a process of the local pool has died."""
        return self._make is not None and pool_died(self.pool)

    def restart(self) -> None:
        """Kill what is left of the pool and start a new one (:func:`discard_pool`)."""
        assert self._make is not None
        discard_pool(self.pool)
        self.pool = self._make()

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


def pool_died(pool: Executor) -> bool:
    """Whether a process of a process pool has exited (False for other executors)."""
    processes = getattr(pool, "_processes", None) or {}  # ProcessPoolExecutor's workers
    return any(p.exitcode is not None for p in list(processes.values()))


def discard_pool(old: Executor) -> None:
    """Kill what is left of a process pool one of whose processes died, and shut it down.

    A worker killed while sending its result leaves a partial message in the pool's result
    pipe, and the pool's manager thread then waits for the rest of it forever (and Python
    waits for that thread at exit). Once every worker is dead, closing this process's copy of
    the pipe's write end lets that read end with EOF, so the old pool shuts down."""
    processes = list((getattr(old, "_processes", None) or {}).values())
    for p in processes:
        if p.exitcode is None:
            p.kill()
    for p in processes:
        p.join(timeout=10)
    writer = getattr(getattr(old, "_result_queue", None), "_writer", None)
    if writer is not None:
        with contextlib.suppress(OSError):
            writer.close()
    old.shutdown(wait=False, cancel_futures=True)


@contextmanager
def worker_pool(workers: int | None, scheduler: str | None) -> Iterator[_Workers]:
    """A dask client's executor (``scheduler``: its address), this process (``workers`` 0), or
    a local process pool of ``workers`` processes (None: one per core) whose workers fork from
    a server that has the kernels loaded; what jobs and sessions (``bowlrec session``) run on."""
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError as err:
            raise MissingExtraError(
                "--scheduler needs dask.distributed, which is not installed; install it with: "
                "pip install 'bowlrec[dask]'",
                name=err.name,
            ) from None
        with Client(scheduler, set_as_default=False) as client:
            nthreads = sum(client.nthreads().values()) or 1
            yield _Workers(client.get_executor(pure=False), nthreads)
        return
    if workers == 0:
        yield _Workers(InlineExecutor(), 1)
        return

    n = workers or os.cpu_count() or 1
    ctx = multiprocessing.get_context("forkserver")
    # the fork server imports and warms the kernels once; every worker forks from it ready.
    # It, its workers and the resource tracker die with this process (see .lifeline)
    ctx.set_forkserver_preload(["bowlrec.batch.warm"])
    line = lifeline()

    def make() -> Executor:
        return ProcessPoolExecutor(
            max_workers=n, mp_context=ctx, initializer=_worker_init, initargs=(line,)
        )

    pool = _Workers(make(), n, make)
    try:
        yield pool
    finally:
        pool.close()


# -- the orchestrator -------------------------------------------------------------------------


TableSink = Callable[[ChunkTable], None]


def param_columns(job: JobSpec) -> list[str]:
    """The table's parameter columns: the swept paths in order (``scene`` for a scenes
    block)."""

    cols: dict[str, None] = {}
    for block in job.blocks():
        if isinstance(block, ScenesSweep):
            cols["scene"] = None
        elif isinstance(block, PointsSweep):
            for point in block.points_:
                cols.update(dict.fromkeys(point))
        else:
            cols.update(dict.fromkeys(block.axes))
    return list(cols)


def _default_chunk(job: JobSpec, total: int, parallel: int, shipped: bool = False) -> int:
    """The largest chunk of a job of ``total`` runs on ``parallel`` workers (at least 4 chunks
    a worker); ``shipped``: workers may ship recorded runs back instead of sealing them."""
    if job.record == "summary":
        cap = SUMMARY_CHUNK
    else:
        cap = SHIPPED_RECORDED_CHUNK if shipped else RECORDED_CHUNK
    return max(1, min(cap, math.ceil(total / (4 * parallel))))


def _unrun(ctx: JobContext, start: int, stop: int, status: str, error: str | None) -> ChunkTable:
    """Rows for runs ``start`` to ``stop`` that were not run (cancelled or failed)."""

    if ctx.fast_paths is not None:  # numeric sweeps: columns, no object per run
        index = np.arange(start, min(stop, ctx.job.count()), dtype=np.int64)
        columns = ctx.job.columns(start, stop, ctx.fast_paths)
        table = ChunkTable.empty(index, dict(columns))
        table.status = [status] * len(index)
        table.error = [error] * len(index)
        return table
    points = ctx.job.points(start, stop)
    params: dict[str, list[Any]] = {}
    for k, p in enumerate(points):
        overrides = {"scene": _scene_label(ctx, p)} if p.scene is not None else p.overrides
        for name, value in overrides.items():
            params.setdefault(name, [None] * len(points))[k] = value
    index = np.fromiter((p.index for p in points), dtype=np.int64, count=len(points))
    table = ChunkTable.empty(index, dict(params))
    table.status = [status] * len(points)
    table.error = [error] * len(points)
    return table


def _scene_label(ctx: JobContext, point: Any) -> str:
    block = ctx.job.blocks()[point.block]
    entry = block.scenes[point.scene]
    return entry if isinstance(entry, str) else str(entry.get("name", point.scene))


class _Orchestrator:
    """Submits chunks, registers what workers sealed, and emits table chunks in job order."""

    def __init__(
        self,
        ctx: JobContext,
        archive: Archive | None,
        target: WriteTarget | None,
        result: BatchResult,
        sink: TableSink | None,
        progress: ProgressCallback | None,
        start: float,
        before_register: TableSink | None = None,
    ) -> None:
        self.ctx = ctx
        self.before_register = before_register
        self.archive = archive
        self.target = target
        self.result = result
        self.sink = sink
        self.progress = progress
        self.start = start
        self.total = ctx.job.count()
        self.ready: dict[int, ChunkTable] = {}
        #: run IDs a shipped chunk held that were archived already (set by _seal_shipped)
        self._present: set[str] = set()
        self.next_row = 0
        self.done = 0

    def emit(self, start: int, table: ChunkTable) -> None:
        """Take a chunk's rows; pass on every chunk now complete in job order."""
        for s in table.status:
            self.result.counts[s] += 1
        self.done += len(table)
        self.ready[start] = table
        while self.next_row in self.ready:
            t = self.ready.pop(self.next_row)
            self.next_row += len(t)
            if self.sink is not None:
                self.sink(t)
            else:
                self.result.tables.append(t)

    def report(self) -> None:
        if self.progress is None:
            return
        c = self.result.counts
        self.progress(
            BatchProgress(
                total=self.total,
                done=c["ok"] + c["archived"] + c["failed"],
                simulated=self.result.simulated,
                archived=c["archived"],
                failed=c["failed"],
                elapsed_s=time.perf_counter() - self.start,
            )
        )

    def take(self, res: ChunkResult) -> None:
        """A finished chunk: store what the worker could not, register what it sealed."""

        r = self.result
        r.simulated += res.simulated
        r.simulate_s += res.simulate_s
        r.write_s += res.write_s
        r.replays.extend(res.replays)
        if res.error is not None and r.error is None:
            r.error = res.error
        if self.before_register is not None:
            self.before_register(res.table)
        if self.archive is not None:
            t0 = time.perf_counter()
            try:
                if res.records or res.summary_runs is not None:
                    shipped = self._seal_shipped(res)
                    res.segments += [] if shipped is None else [shipped]
                    _mark_present(res.table, self._present)
                if res.segments:
                    # the worker may see the archive under another path (a Dask worker)
                    self.archive.register(
                        [
                            replace(s, path=self.archive.segments_dir / s.path.name)
                            for s in res.segments
                        ]
                    )
            except ArchiveWriteError as err:
                if r.error is None:
                    r.error = str(err)
                if not res.segments:  # nothing sealed: the new runs are not archived
                    _fail_new(res.table, str(err))
            r.write_s += time.perf_counter() - t0
        self.emit(res.start, res.table)

    def _seal_shipped(self, res: ChunkResult) -> Any:
        """Seal runs a worker shipped back (runs archived meanwhile are left out)."""
        assert self.archive is not None
        durable = self.target.durable if self.target is not None else True
        if res.summary_runs is not None:
            runs = res.summary_runs
            present = self.archive.rows(runs.run_ids())
            self._present = set(present)
            keep = [i for i, rid in enumerate(runs.run_ids()) if rid not in present]
            return self.archive.seal(runs.select(keep), durable=durable) if keep else None
        present = self.archive.rows(r.run_id for r in res.records)
        self._present = set(present)
        builder = self.archive.builder(samples=self.ctx.job.samples)
        for rec in res.records:
            if rec.run_id not in present:
                builder.append(rec)
        return self.archive.seal(builder, durable=durable) if len(builder) else None


def _mark_present(table: ChunkTable, present: set[str]) -> None:
    """Rows of shipped runs the archive already held are "archived", not new."""
    for i, (status, rid) in enumerate(zip(table.status, table.run_id, strict=True)):
        if status == "ok" and rid in present:
            table.status[i] = "archived"


def _fail_new(table: ChunkTable, error: str) -> None:
    for i, status in enumerate(table.status):
        if status == "ok":
            table.status[i], table.error[i] = "failed", f"not archived: {error}"


def run_job(
    job: JobSpec,
    archive: Archive | None,
    *,
    base_dir: str | Path = ".",
    workers: int | None = None,
    scheduler: str | None = None,
    executor: Executor | None = None,
    chunk_size: int | None = None,
    progress: ProgressCallback | None = None,
    cancel: threading.Event | None = None,
    replay_dir: str | Path | None = None,
    durable: bool = True,
    recover: bool = True,
    worker_writes: str = "auto",
    sink: TableSink | None = None,
    before_register: TableSink | None = None,
    run_log: str | Path | None = None,
) -> BatchResult:
    """Run a job: simulate every run not yet archived, add it to ``archive`` (None: store
    nothing, the table only) and return the table.

    ``workers``: local processes (None: all cores; 0: this process); ``scheduler``: a
    dask.distributed address (``tcp://host:port``) instead; ``executor``: any
    concurrent.futures Executor instead of both (kept open). ``chunk_size``: runs per task
    (default: up to 16,384 summary-only or 1,024 recorded runs, 32 when workers may ship them
    back; at least 4 tasks per worker).
    ``progress`` is called from this thread after every chunk; setting ``cancel`` stops the
    batch after the chunks in flight (their runs are kept). ``worker_writes``: "yes" workers
    seal segments, "no" they ship records back, "auto" (default) workers write when they see
    the archive's files (always for local processes). ``sink``: receives the table chunk by
    chunk in job order instead of keeping it in the result; ``before_register`` sees each
    finished chunk's rows before its runs are registered in the index (to log their run IDs
    durably first, as the service does); ``run_log``: a file to which workers append ``index
    run_id`` lines (fsynced) before sealing each chunk, so runs of a segment sealed just before
    a kill are accounted for too. ``recover`` first finishes what a killed writer left;
    ``durable`` fsyncs every sealed segment. Raises JobError for an invalid job before anything
    runs.
    """

    start = time.perf_counter()
    ctx = job_context(
        job,
        base_dir=base_dir,
        balls=None if archive is None else archive.balls,
        ball_refs=None if archive is None else archive._library_refs(),
        replay_dir=replay_dir,
    )
    if archive is not None and recover:
        archive.recover()  # ArchiveWriteError when the archive cannot be written
    result = BatchResult(param_columns(job))
    cancel = cancel or threading.Event()
    with _maybe_executor(executor, workers, scheduler) as pool:
        local = executor is None and scheduler is None
        mode = "yes" if local and worker_writes == "auto" else worker_writes
        probe = token = None
        if archive is not None and mode == "auto":
            probe, token = new_probe(archive.root)
        target = (
            None
            if archive is None
            else WriteTarget(
                str(archive.root),
                mode,
                probe,
                token,
                durable,
                None if run_log is None else str(run_log),
            )
        )
        orch = _Orchestrator(ctx, archive, target, result, sink, progress, start, before_register)
        try:
            _drive(orch, pool, chunk_size, cancel)
        finally:
            remove_probe(probe)
    result.elapsed_s = time.perf_counter() - start
    return result


def _drive(
    orch: _Orchestrator,
    workers: _Workers,
    chunk_size: int | None,
    cancel: threading.Event,
) -> None:
    total = orch.total
    shipped = orch.target is not None and orch.target.mode != "yes"
    cap = chunk_size or _default_chunk(orch.ctx.job, total, workers.parallel, shipped)
    summary = orch.ctx.job.record == "summary"
    ranges = Spans(
        total,
        cap,
        fixed=chunk_size is not None,
        target_s=SUMMARY_TARGET_S if summary else TARGET_CHUNK_S,
    )
    inflight: dict[Future[ChunkResult], tuple[int, int]] = {}
    retried: set[tuple[int, int]] = set()
    result = orch.result
    orch.report()

    def settle(fut: Future[ChunkResult], span: tuple[int, int]) -> None:
        try:
            res = fut.result()
        except Exception as err:  # a failing chunk fails its rows, not the batch
            error = f"worker: {type(err).__name__}: {err}"
            orch.emit(span[0], _unrun(orch.ctx, *span, "failed", error))
            return
        ranges.timed(res.stop - res.start, res.worker_s)
        orch.take(res)
        if orch.result.error is not None:
            cancel.set()

    def replace_pool(lost: list[tuple[int, int]]) -> None:
        """A worker died: a new pool runs its chunks again (once; twice fails their rows)."""
        lost += list(inflight.values())
        inflight.clear()
        workers.restart()
        if orch.archive is not None:  # segments the dead worker sealed are registered first
            orch.archive.recover()
        for span in sorted(lost, reverse=True):
            if span in retried:
                error = "worker: a worker process died twice running these runs"
                orch.emit(span[0], _unrun(orch.ctx, *span, "failed", error))
            else:
                retried.add(span)
                ranges.give_back(span)

    while (ranges or inflight) and not cancel.is_set():
        while ranges and len(inflight) < 2 * workers.parallel:
            span = ranges.pop()
            task = ChunkTask(orch.ctx, span[0], span[1], orch.target)
            inflight[workers.pool.submit(run_chunk, task)] = span
        finished, _ = wait(list(inflight), timeout=0.2, return_when=FIRST_COMPLETED)
        lost = []
        for fut in finished:
            span = inflight.pop(fut)
            if workers.lost(fut):
                lost.append(span)
            else:
                settle(fut, span)
        if lost or workers.broken():
            replace_pool(lost)
        if finished:
            orch.report()
    if cancel.is_set():
        result.cancelled = True
        for fut, span in list(inflight.items()):
            if fut.cancel():
                ranges.give_back(span)
            elif workers.broken():
                ranges.give_back(span)  # its worker died: not run
            else:
                settle(fut, span)
        # the table ends with the last run reached: runs before it that did not run are rows
        # (failures that say why after a failed write, else "cancelled"); the runs after it
        # are only counted (a cancelled 10,000,000-run job writes no 10,000,000 rows)
        error = None if result.error is None else f"not archived: {result.error}"
        end = max([orch.next_row, *(s + len(t) for s, t in orch.ready.items())])
        for start, stop in ranges.left():
            if start < end:
                status = "cancelled" if error is None else "failed"
                orch.emit(start, _unrun(orch.ctx, start, min(stop, end), status, error))
            result.not_reached += max(0, stop - max(start, end))
    orch.report()


@contextmanager
def _maybe_executor(
    executor: Executor | None, workers: int | None, scheduler: str | None
) -> Iterator[_Workers]:
    if executor is not None:
        yield _Workers(executor, max(1, workers or os.cpu_count() or 1))
        return
    with worker_pool(workers, scheduler) as pool:
        yield pool

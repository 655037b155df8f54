"""The worker's side of a batch: prepare, simulate and store one chunk of a job's runs.

A :class:`ChunkTask` names a range of the job's runs; :func:`run_chunk` expands only those
points (:meth:`~bowlrec.batch.job.JobSpec.points`), prepares them (the fast delivery-sweep path
of :mod:`bowlrec.batch.fastprep`, or validate + resolve per run), looks up which are archived
already, simulates the rest (summary-only runs in one call of the compiled many-delivery kernel,
:func:`bowlrec.core.batch.run_batch`; recorded runs through :func:`bowlrec.core.solver.solve`),
and stores them: as a sealed segment it writes itself (the parent only registers it) or, when
the worker cannot reach the archive's files, as records shipped back for the parent to seal. It
returns the chunk's table columns (:class:`ChunkTable`).
"""

from __future__ import annotations

import contextlib
import os
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from bowlrec.archive import Archive, RunRecord, SummaryRuns
from bowlrec.archive.balls import ball_sha
from bowlrec.archive.store import pattern_label
from bowlrec.batch.fastprep import FastSweep
from bowlrec.batch.job import PreparedRun, prepare_point
from bowlrec.core.codes import (
    EV_KIND,
    EV_MU,
    EV_PHASE,
    EV_T,
    EV_X,
    EV_Y,
    EVENT_KINDS,
    PHASE_NAMES,
    RECORD_SUMMARY,
    ROLLING,
)
from bowlrec.core.outcome import outcome_message
from bowlrec.core.trajectory import FLOAT_METRICS, INT_METRICS, Event, summary_trajectory
from bowlrec.errors import ArchiveWriteError
from bowlrec.sinks.common import RunData
from bowlrec.sinks.registry import sink_named
from bowlrec.spec import Scene

from .context import JobContext, WriteTarget

if TYPE_CHECKING:
    from bowlrec.archive import Archive, RunRecord, SegmentInfo, SummaryRuns
    from bowlrec.core.batch import PackedPlans
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Summary, Trajectory

    from .fastprep import FastSweep
    from .job import Point, PreparedRun

__all__ = [
    "FAILED_OUTCOMES",
    "KERNEL_COLUMNS",
    "METRIC_COLUMNS",
    "PIN_COLUMNS",
    "ChunkResult",
    "ChunkTable",
    "ChunkTask",
    "run_chunk",
]

_T = TypeVar("_T")
#: outcomes that mean the model or the solver gave up: recorded as failures, not archived
FAILED_OUTCOMES = frozenset({"airborne", "max_steps", "stalled"})
#: recorded samples a worker holds before it seals them as a segment (about 130 bytes each)
SEAL_SAMPLES = 1_000_000
#: summary metrics of every table row (units in the names)
#: the kernel's metrics (every run has them)
KERNEL_COLUMNS = ("outcome", *FLOAT_METRICS, *INT_METRICS)
#: the pins' metrics, for runs with pin action (``options.pins``): pins down (-1: no pin
#: action) and the leave in bowlers' names (None: no pin action)
PIN_COLUMNS = ("pinfall", "leave")
METRIC_COLUMNS = (*KERNEL_COLUMNS, *PIN_COLUMNS)
#: event kind name -> the kernels' code
_EVENT_CODES = {name: float(code) for code, name in EVENT_KINDS.items()}


@dataclass(frozen=True)
class ChunkTask:
    """Runs ``start`` to ``stop`` of the job; ``target`` None: nothing is stored."""

    context: JobContext
    start: int
    stop: int
    target: WriteTarget | None


@dataclass
class ChunkTable:
    """A chunk's rows of the batch table, column by column (job order).

    params: swept path -> values; run_id/status/error: per row (None where absent); metrics:
    ``outcome`` (object), float metrics (float64, NaN: no value), int metrics (int64, valid
    where ``has_metrics``)."""

    index: np.ndarray
    params: dict[str, list[Any] | np.ndarray]
    run_id: list[str | None]
    status: list[str]
    error: list[str | None]
    metrics: dict[str, np.ndarray]
    has_metrics: np.ndarray

    def __len__(self) -> int:
        return int(self.index.shape[0])

    @classmethod
    def empty(cls, index: np.ndarray, params: dict[str, list[Any] | np.ndarray]) -> ChunkTable:
        n = int(index.shape[0])
        metrics: dict[str, np.ndarray] = {"outcome": np.full(n, None, dtype=object)}
        metrics.update({k: np.full(n, np.nan) for k in FLOAT_METRICS})
        metrics.update({k: np.zeros(n, dtype=np.int64) for k in INT_METRICS})
        metrics["pinfall"] = np.full(n, -1, dtype=np.int64)
        metrics["leave"] = np.full(n, None, dtype=object)
        return cls(
            index=index,
            params=params,
            run_id=[None] * n,
            status=["cancelled"] * n,
            error=[None] * n,
            metrics=metrics,
            has_metrics=np.zeros(n, dtype=bool),
        )

    def set_metrics(self, i: int, values: dict[str, Any]) -> None:
        """Row ``i``'s metrics from a mapping (None: no value)."""
        for k in METRIC_COLUMNS:
            v = values.get(k)
            if k in ("outcome", "leave"):
                self.metrics[k][i] = v
            elif k == "pinfall":
                self.metrics[k][i] = -1 if v is None else int(v)
            elif k in INT_METRICS:
                self.metrics[k][i] = 0 if v is None else int(v)
            else:
                self.metrics[k][i] = np.nan if v is None else float(v)
        self.has_metrics[i] = values.get("outcome") is not None


@dataclass
class ChunkResult:
    """What a worker returns: the table rows, the segment it sealed (or the records to seal),
    and its counts and times (s)."""

    start: int
    stop: int
    table: ChunkTable
    #: the segments it sealed, in order (more than one when its samples exceeded SEAL_SAMPLES)
    segments: list[SegmentInfo] = field(default_factory=list)
    records: list[RunRecord] = field(default_factory=list)
    #: summary-only runs as columns, for the parent to seal (worker cannot write)
    summary_runs: SummaryRuns | None = None
    simulated: int = 0
    simulate_s: float = 0.0
    write_s: float = 0.0
    #: the worker's time for the whole chunk (preparation, simulation, writes), s
    worker_s: float = 0.0
    replays: list[Path] = field(default_factory=list)
    #: a write that failed in the worker (full disk): its runs are failed rows
    error: str | None = None


# -- per-process caches -------------------------------------------------------------------------

_FAST: dict[str, FastSweep] = {}
_ARCHIVES: dict[str, Archive] = {}


def _fast(ctx: JobContext) -> FastSweep:
    fast = _FAST.get(ctx.key)
    if fast is None:
        assert ctx.fast_paths is not None
        if len(_FAST) > 8:
            _FAST.clear()
        fast = _FAST[ctx.key] = FastSweep(Scene.model_validate(ctx.base_data), ctx.fast_paths)
    return fast


def _archive(root: str) -> Archive:
    archive = _ARCHIVES.get(root)
    if archive is None:
        archive = _ARCHIVES[root] = Archive(root, create=False)
    return archive


# -- the chunk ------------------------------------------------------------------------------------


def run_chunk(task: ChunkTask) -> ChunkResult:
    """Prepare, simulate and store runs ``task.start`` to ``task.stop`` (in a worker)."""
    began = time.perf_counter()
    result = _run_chunk(task)
    result.worker_s = time.perf_counter() - began
    return result


def _run_chunk(task: ChunkTask) -> ChunkResult:
    ctx = task.context
    writes = task.target is not None and task.target.worker_writes()
    archive = _archive(task.target.root) if writes and task.target is not None else None
    if ctx.fast_paths is not None:
        index = np.arange(task.start, min(task.stop, ctx.job.count()), dtype=np.int64)
        if ctx.job.record != "summary":
            return _run_fast_recorded(ctx, task, index, archive)
        return _run_fast(ctx, task, index, archive)
    points = ctx.job.points(task.start, task.stop)
    index = np.fromiter((p.index for p in points), dtype=np.int64, count=len(points))
    return _run_general(ctx, task, points, index, archive)


def _archived_rows(archive: Archive | None, run_ids: Sequence[str]) -> dict[str, dict[str, Any]]:
    if archive is None or not run_ids:
        return {}
    return archive.rows(set(run_ids))


def _messages(
    summaries: dict[str, np.ndarray], rows: Sequence[int], packed: PackedPlans
) -> list[str]:
    return [
        outcome_message(
            str(summaries["outcome"][i]),
            float(summaries["time_s"][i]),
            float(summaries["x_end_m"][i]),
            float(packed.lane[i, 2]),
            int(packed.opts[i, 3]),
        )
        for i in rows
    ]


def _kernel(packed: PackedPlans) -> tuple[dict[str, np.ndarray], Any, float]:
    """Run the many-delivery kernel (this thread): metric columns, the raw output, seconds."""
    from bowlrec.core.batch import B_STATUS, batch_metrics, run_batch

    start = time.perf_counter()
    result = run_batch(packed, parallel=False)
    wall = time.perf_counter() - start
    cols = batch_metrics(packed, result)
    cols["_status"] = result.out[:, B_STATUS].astype(np.int64)
    return cols, result, wall


def _events(result: Any, i: int) -> list[tuple[str, float, str, float, float, float]] | None:
    """Run ``i``'s events from the batch output (None when it had more than the batch keeps)."""
    from bowlrec.core.batch import B_EVENTS, EVENT_CAP

    n = int(result.out[i, B_EVENTS])
    if n > EVENT_CAP:
        return None
    return [
        (
            EVENT_KINDS[int(row[EV_KIND])],
            float(row[EV_MU]),
            PHASE_NAMES[int(row[EV_PHASE])],
            float(row[EV_T]),
            float(row[EV_X]),
            float(row[EV_Y]),
        )
        for row in result.events[i, :n]
    ]


class _Store:
    """Collects a chunk's records; seals them as segments (worker writes) or ships them.

    A worker that writes seals what it holds as soon as it holds SEAL_SAMPLES samples, so a
    chunk of recorded runs never holds more than that plus one run (at most
    MAX_SAMPLES_PER_RUN samples) in memory, whatever its runs record."""

    def __init__(
        self,
        archive: Archive | None,
        target: WriteTarget | None,
        result: ChunkResult,
        samples: str = "gzip",
    ) -> None:
        self.archive = archive
        self.target = target
        self.result = result
        self.samples = samples
        self.records: list[RunRecord] = []
        self.held = 0  # samples in self.records
        self.logged = False
        #: run IDs sealed so far (a later failed write fails only the others)
        self.sealed: set[str] = set()

    def add(self, record: RunRecord) -> None:
        self.records.append(record)
        column = next(iter(record.trajectory.values()), None)
        self.held += 0 if column is None else len(column)
        if self.held >= SEAL_SAMPLES and self.archive is not None:
            self._seal()

    def _seal(self) -> None:
        """Seal the records held as one segment and let them go. After a failed write they
        are only let go: the chunk's runs not sealed become failed rows
        (:func:`_fail_unwritten`)."""

        assert self.archive is not None and self.target is not None
        records, self.records, self.held = self.records, [], 0
        if not records or self.result.error is not None:
            return
        start = time.perf_counter()
        builder = self.archive.builder(samples=self.samples)
        for rec in records:
            builder.append(rec)
        if not self.logged:  # the run log names the chunk's runs before its first segment
            self.target.log_runs(self.result.table.index.tolist(), self.result.table.run_id)
            self.logged = True
        try:
            self.result.segments.append(self.archive.seal(builder, durable=self.target.durable))
            self.sealed.update(rec.run_id for rec in records)
        except ArchiveWriteError as err:
            self.result.error = str(err)
        self.result.write_s += time.perf_counter() - start

    def finish(self) -> None:
        if not self.records or self.target is None:
            return
        if self.archive is None:
            self.result.records = self.records
            return
        self._seal()


def _run_fast(
    ctx: JobContext,
    task: ChunkTask,
    index: np.ndarray,
    archive: Archive | None,
) -> ChunkResult:
    """A chunk of a delivery sweep: prepared, simulated and stored column by column."""
    from bowlrec.core.batch import take

    fast = _fast(ctx)
    assert ctx.fast_paths is not None
    columns = ctx.job.columns(task.start, task.stop, ctx.fast_paths)
    chunk = fast.prepare(index, columns, scenes=False)  # a segment stores base and values
    table, result, first = _fast_table(task, chunk, archive)
    todo = np.fromiter(first.values(), dtype=np.int64, count=len(first))
    if todo.size:
        packed = take(chunk.packed, todo)
        cols, raw, wall = _kernel(packed)
        result.simulated = int(todo.size)
        result.simulate_s = wall
        ok = _set_kernel_metrics(table, todo, cols, packed)
        if task.target is not None and ok.any():
            _store_fast(ctx, task, fast, chunk, todo[ok], cols, raw, packed, archive, result, ok)
    _copy_duplicates(table, chunk.run_ids, first)
    _fail_unwritten(result)
    return result


def _fast_table(
    task: ChunkTask, chunk: Any, archive: Archive | None
) -> tuple[ChunkTable, ChunkResult, dict[str, int]]:
    """A fast chunk's table and result, the runs found archived settled; the first row of
    each run ID still to simulate."""
    table = ChunkTable.empty(chunk.index, dict(chunk.params))
    table.run_id = list(chunk.run_ids)
    result = ChunkResult(task.start, task.stop, table)
    archived = _archived_rows(archive, chunk.run_ids)
    first: dict[str, int] = {}
    for i, rid in enumerate(chunk.run_ids):
        if rid in archived:
            table.status[i] = "archived"
            table.set_metrics(i, archived[rid])
        else:
            first.setdefault(rid, i)
    return table, result, first


def _run_fast_recorded(
    ctx: JobContext,
    task: ChunkTask,
    index: np.ndarray,
    archive: Archive | None,
) -> ChunkResult:
    """A chunk of a delivery sweep that records samples: prepared column by column (no Scene
    per run: the base scene's Plan with each run's velocity and spin, its scene JSON from the
    sweep's template), each run simulated on its own. The runs and their records are the ones
    the general path makes (tests/test_pipeline.py compares them). The archive stores a run's
    state only, so the forces, slip, energy and alpha are not derived here
    (:func:`~bowlrec.core.solver.solve_state`) unless the run records per-term torques."""
    from bowlrec.core.arguments import use_closed_form

    fast = _fast(ctx)
    assert ctx.fast_paths is not None
    columns = ctx.job.columns(task.start, task.stop, ctx.fast_paths)
    chunk = fast.prepare(index, columns)
    table, result, first = _fast_table(task, chunk, archive)
    store = _Store(archive, task.target, result, ctx.job.samples)
    scene = fast.scene
    sha = ball_sha(scene.ball)
    ball_ref = ctx.base_ref or ctx.ball_refs.get(sha, "")
    pattern = pattern_label(scene)
    for i in first.values():
        plan = chunk.plan(i, fast.plan)
        ran = _simulate_row(table, i, result, _archived_samples, plan)
        if ran is None:
            continue
        (traj, samples), wall = ran
        if not _settle_row(table, i, traj.summary) or task.target is None:
            continue
        store.add(
            RunRecord.from_run(
                RunData(scene, plan, traj, chunk.run_ids[i]),
                wall_time_s=wall,
                ball_ref=ball_ref,
                solver="closed_form" if use_closed_form(plan) else "integrator",
                ball_sha=sha,
                pattern=pattern,
                scene_json=chunk.scene_json[i],
                samples=samples,
            )
        )
    _copy_duplicates(table, chunk.run_ids, first)
    store.finish()
    _fail_unwritten(result, store.sealed)
    return result


def _set_kernel_metrics(
    table: ChunkTable, rows: np.ndarray, cols: dict[str, np.ndarray], packed: PackedPlans
) -> np.ndarray:
    """Rows ``rows`` take the kernel's metrics and status; returns the mask of rows that
    succeeded (not a failed outcome)."""
    for k in KERNEL_COLUMNS:
        table.metrics[k][rows] = cols[k]
    table.has_metrics[rows] = True
    failed = np.isin(cols["outcome"], list(FAILED_OUTCOMES))
    status, error = table.status, table.error
    for j in np.flatnonzero(~failed).tolist():
        status[rows[j]] = "ok"
    for j in np.flatnonzero(failed).tolist():
        message = _messages(cols, [j], packed)[0]
        status[rows[j]], error[rows[j]] = "failed", f"{cols['outcome'][j]}: {message}"
    return ~failed


def _store_fast(
    ctx: JobContext,
    task: ChunkTask,
    fast: FastSweep,
    chunk: Any,
    rows: np.ndarray,
    cols: dict[str, np.ndarray],
    raw: Any,
    packed: PackedPlans,
    archive: Archive | None,
    result: ChunkResult,
    ok: np.ndarray,
) -> None:
    """Store the chunk's successful runs ``rows`` (kernel rows where ``ok``) as one segment."""
    from bowlrec.core.batch import B_EVENTS, EVENT_CAP

    assert task.target is not None
    start = time.perf_counter()
    scene = fast.scene
    sha = ball_sha(scene.ball)
    k = np.flatnonzero(ok)
    n_events = raw.out[k, B_EVENTS].astype(np.int64)
    events = raw.events[k]
    over = np.flatnonzero(n_events > EVENT_CAP)
    if over.size:  # more events than the batch keeps: the one-run solver has them all
        from bowlrec.core.solver import solve

        full = {j: solve(chunk.plan(int(rows[j]), fast.plan)).events for j in over.tolist()}
        wider = np.zeros((events.shape[0], max(len(e) for e in full.values()), events.shape[2]))
        wider[:, : events.shape[1]] = events
        for j, evs in full.items():
            wider[j, : len(evs)] = [
                (
                    e.t_s,
                    _EVENT_CODES[e.kind],
                    e.x_m,
                    e.y_m,
                    e.mu,
                    float(e.phase == PHASE_NAMES[ROLLING]),
                )
                for e in evs
            ]
        events = wider
    v, w = chunk.velocity0[rows], chunk.omega0[rows]
    runs = SummaryRuns(
        strings={
            "run_id": [chunk.run_ids[i] for i in rows.tolist()],
            "name": scene.name,
            "ball_ref": ctx.base_ref or ctx.ball_refs.get(sha, ""),
            "ball_sha": sha,
            "pattern": pattern_label(scene),
            "record": "summary",
            "solver": "closed_form" if bool(fast._packed.flags[0, 0]) else "integrator",
        },
        floats={
            "speed_mps": np.hypot(v[:, 0], v[:, 1]),
            "rev_rate_rpm": np.sqrt(w[:, 0] * w[:, 0] + w[:, 1] * w[:, 1] + w[:, 2] * w[:, 2])
            * 60.0
            / (2.0 * np.pi),
            "mass_kg": np.full(rows.size, float(fast.plan.mass_kg)),
            "rtol": np.full(rows.size, float(fast.plan.rtol)),
            "wall_time_s": np.full(rows.size, result.simulate_s / max(1, ok.size)),
        },
        created_at_ns=time.time_ns(),
        scene_base=fast.scene_base,
        scene_paths=fast.scene_paths,
        # NaN where a sweep block leaves the path alone: the base scene's value
        scene_values=np.column_stack([chunk.params[p] for p in fast.paths])[rows],
        summary={name: cols[name][k] for name in KERNEL_COLUMNS},
        messages=_messages(cols, k.tolist(), packed),
        events=events,
        n_events=n_events,
    )
    if archive is None:
        result.summary_runs = runs
    else:
        task.target.log_runs(result.table.index.tolist(), result.table.run_id)
        try:
            result.segments.append(archive.seal(runs, durable=task.target.durable))
        except ArchiveWriteError as err:
            result.error = str(err)
    result.write_s += time.perf_counter() - start


def _copy_duplicates(
    table: ChunkTable, run_ids: Sequence[str | None], first: dict[str, int]
) -> None:
    """Rows repeating a run of the same chunk take its status and metrics."""
    for i, rid in enumerate(run_ids):
        if rid is None or table.status[i] != "cancelled":
            continue
        j = first.get(rid)
        if j is not None and j != i:
            table.status[i], table.error[i] = table.status[j], table.error[j]
            for _k, col in table.metrics.items():
                col[i] = col[j]
            table.has_metrics[i] = table.has_metrics[j]


def _fail_unwritten(result: ChunkResult, sealed: set[str] | None = None) -> None:
    """After a failed write, the chunk's new runs (but those in ``sealed``, archived by an
    earlier segment of the chunk) are failed rows naming the error."""
    if result.error is None:
        return
    table = result.table
    for i, status in enumerate(table.status):
        if status == "ok" and (sealed is None or table.run_id[i] not in sealed):
            table.status[i], table.error[i] = "failed", f"not archived: {result.error}"


def _run_general(
    ctx: JobContext,
    task: ChunkTask,
    points: Sequence[Point],
    index: np.ndarray,
    archive: Archive | None,
) -> ChunkResult:
    prepared = [prepare_point(ctx, p) for p in points]
    params: dict[str, list[Any]] = {}
    for k, p in enumerate(prepared):
        for name, value in p.params.items():
            params.setdefault(name, [None] * len(prepared))[k] = value
    table = ChunkTable.empty(index, dict(params))
    table.run_id = [p.run_id for p in prepared]
    result = ChunkResult(task.start, task.stop, table)
    ids = [p.run_id for p in prepared if p.run_id is not None]
    archived = _archived_rows(archive, ids)
    first: dict[str, int] = {}
    for i, p in enumerate(prepared):
        if p.error is not None:
            table.status[i], table.error[i] = "failed", p.error
        elif p.run_id in archived:
            table.status[i] = "archived"
            table.set_metrics(i, archived[p.run_id])
        elif p.run_id is not None:
            first.setdefault(p.run_id, i)
    todo = list(first.values())
    store = _Store(archive, task.target, result, ctx.job.samples)
    summary_only = [i for i in todo if _summary_only(prepared[i].plan) and not _pins(prepared[i])]
    recorded = [i for i in todo if i not in set(summary_only)]
    if summary_only:
        _general_summary(ctx, task, prepared, summary_only, table, store, result)
    for i in recorded:
        _general_recorded(ctx, task, prepared[i], i, table, store, result)
    _copy_duplicates(table, table.run_id, first)
    store.finish()
    _fail_unwritten(result, store.sealed)
    return result


def _settle_row(table: ChunkTable, i: int, summary: Summary, pins: Any = None) -> bool:
    """Row ``i`` takes a simulated run's metrics (and its pins' for a run with pin action) and
    status; True when the run is to be stored (not a failed outcome)."""
    values = dict(summary.__dict__)
    if pins is not None:
        values.update(pinfall=pins.pinfall, leave=pins.leave)
    table.set_metrics(i, values)
    if summary.outcome in FAILED_OUTCOMES:
        table.status[i], table.error[i] = "failed", f"{summary.outcome}: {summary.message}"
        return False
    table.status[i] = "ok"
    return True


def _pins(prep: PreparedRun) -> bool:
    """True when the run asks for pin action (it runs on its own, through the pin engine)."""
    return prep.plan is not None and prep.plan.pins is not None


def _summary_only(plan: Plan | None) -> bool:

    return plan is not None and plan.record_mode == RECORD_SUMMARY


def _record(
    ctx: JobContext,
    prep: PreparedRun,
    summary: Summary,
    events: list[tuple[str, float, str, float, float, float]],
    wall: float,
    solver: str,
    trajectory: Any = None,
) -> RunRecord:
    """A general-path run as a segment record."""

    assert prep.scene is not None and prep.plan is not None and prep.run_id is not None
    sha = ball_sha(prep.scene.ball)
    if trajectory is None:
        trajectory = summary_trajectory(
            [Event(t, k, x, y, mu, ph) for k, mu, ph, t, x, y in events], summary
        )
    run = RunData(prep.scene, prep.plan, trajectory, prep.run_id)
    return RunRecord.from_run(
        run,
        wall_time_s=wall,
        ball_ref=prep.ball_ref or ctx.ball_refs.get(sha, ""),
        solver=solver,
        ball_sha=sha,
        pattern=pattern_label(prep.scene),
    )


def _general_summary(
    ctx: JobContext,
    task: ChunkTask,
    prepared: Sequence[PreparedRun],
    rows: Sequence[int],
    table: ChunkTable,
    store: _Store,
    result: ChunkResult,
) -> None:
    from bowlrec.core.batch import pack_plans
    from bowlrec.core.solver import summary_from_columns

    plans = [prepared[i].plan for i in rows]
    packed = pack_plans(plans)  # type: ignore[arg-type]
    cols, raw, wall = _kernel(packed)
    result.simulated += len(rows)
    result.simulate_s += wall
    messages = _messages(cols, range(len(rows)), packed)
    for j, i in enumerate(rows):
        summary = summary_from_columns(cols, j, messages[j])
        if not _settle_row(table, i, summary) or task.target is None:
            continue
        prep = prepared[i]
        events = _events(raw, j)
        traj = None
        if events is None:
            from bowlrec.core.solver import run_plan

            assert prep.plan is not None
            traj = run_plan(prep.plan)
            events = []
        solver = "closed_form" if bool(packed.flags[j, 0]) else "integrator"
        store.add(_record(ctx, prep, summary, events, wall / len(rows), solver, traj))


def _general_recorded(
    ctx: JobContext,
    task: ChunkTask,
    prep: PreparedRun,
    i: int,
    table: ChunkTable,
    store: _Store,
    result: ChunkResult,
) -> None:
    from bowlrec.api import with_pins
    from bowlrec.core.arguments import use_closed_form
    from bowlrec.core.solver import run_plan

    plan = prep.plan
    assert plan is not None
    ran = _simulate_row(table, i, result, lambda p: with_pins(p, run_plan(p)), plan)
    if ran is None:
        return
    traj, wall = ran
    summary = traj.summary
    if not _settle_row(table, i, summary, traj.pins) or task.target is None:
        return
    solver = "closed_form" if use_closed_form(plan) else "integrator"
    store.add(_record(ctx, prep, summary, [], wall, solver, traj))
    _replays(ctx, prep, traj, result)


def _simulate_row(
    table: ChunkTable, i: int, result: ChunkResult, simulate: Callable[[Plan], _T], plan: Plan
) -> tuple[_T, float] | None:
    """``simulate(plan)`` for row ``i``, timed and counted in ``result``: its value and wall
    time (s), or None when it raised (the row is then failed with the error: a failing scene
    is a row, never a crashed batch)."""
    start = time.perf_counter()
    try:
        value = simulate(plan)
    except Exception as err:
        table.status[i], table.error[i] = "failed", f"{type(err).__name__}: {err}"
        return None
    wall = time.perf_counter() - start
    result.simulated += 1
    result.simulate_s += wall
    return value, wall


def _archived_samples(plan: Plan) -> tuple[Trajectory, dict[str, np.ndarray] | None]:
    """A recorded run as the archive takes it: its summary and events, and its state
    (:func:`~bowlrec.core.solver.solve_state`); a run recording per-term torques whole, with
    no separate state (they are derived)."""
    from bowlrec.core.solver import run_plan, solve_state

    return (run_plan(plan), None) if plan.record_terms else solve_state(plan)


def _replays(ctx: JobContext, prep: PreparedRun, traj: Any, result: ChunkResult) -> None:
    if not ctx.formats or ctx.replay_dir is None:
        return

    assert prep.scene is not None and prep.plan is not None
    run = RunData(prep.scene, prep.plan, traj, prep.run_id)
    folder = Path(ctx.replay_dir)
    folder.mkdir(parents=True, exist_ok=True)
    for name in ctx.formats:
        sink = sink_named(name)
        result.replays.append(sink.write(run, folder / f"{prep.run_id}{sink.suffix}"))


def new_probe(root: Path) -> tuple[str, str]:
    """Write a probe file in the archive (path, token): a worker that reads the token there
    shares the archive's filesystem."""
    token = uuid.uuid4().hex
    path = root / "segments" / f".probe-{token[:12]}"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(token)
    return str(path), token


def remove_probe(path: str | None) -> None:
    if path is not None:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)

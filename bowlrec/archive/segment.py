"""Segment files: many runs in one sealed HDF5 file (format ``bowlrec-segment`` 2.0).

A segment holds the runs of one writer as columns: one dataset per quantity with the values of
all its runs concatenated (``offsets`` datasets give each run's slice), the summary metrics and
the index columns one dataset each, the scenes as gzip-compressed JSON bytes. What is the same
for every run of the segment (the provenance: package versions, platform) is stored once, as
root attributes. Layout and digests: ``docs/archive-format.md``.

:class:`SegmentBuilder` collects runs in memory and :meth:`SegmentBuilder.seal` writes the file
whole (temporary name, fsync, rename): a segment on disk is complete or absent. Sealed segments
are never modified; removal and compaction are the index's and the maintenance module's work.
"""

from __future__ import annotations

import gc
import hashlib
import os
import time
import uuid
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.core.codes import EV_KIND, EV_MU, EV_PHASE, EV_T, EV_X, EV_Y, EVENT_KINDS, PHASE_NAMES
from bowlrec.core.trajectory import FLOAT_METRICS, INT_METRICS, Summary

if TYPE_CHECKING:
    from bowlrec.sinks.common import RunData

__all__ = [
    "EVENT_FIELDS",
    "FIXED_GROUPS",
    "RECORDS_FORMAT_VERSION",
    "RUN_FLOAT_COLUMNS",
    "RUN_STRING_COLUMNS",
    "SEGMENT_FORMAT",
    "SEGMENT_FORMAT_VERSION",
    "SUMMARY_FLOAT_COLUMNS",
    "SUMMARY_INT_COLUMNS",
    "TRAJECTORY_FIELDS",
    "RunRecord",
    "SegmentBuilder",
    "SegmentInfo",
    "SummaryRuns",
    "new_segment_id",
    "run_digest",
    "seal_columns",
]

SEGMENT_FORMAT = "bowlrec-segment"
#: major.minor: readers accept every minor of their major (docs/archive-format.md)
SEGMENT_FORMAT_VERSION = "2.0"
#: the minor version a segment declares when it holds per-run record groups (``RunRecord.records``)
RECORDS_FORMAT_VERSION = "2.1"
#: groups with a fixed place in the digest (parts 1-6); any other group with an ``offsets``
#: dataset is a per-run record group (parts 7 and on, groups in sorted name order)
FIXED_GROUPS = frozenset({"runs", "summary", "events", "trajectory", "torques"})

#: summary metrics stored as float64 columns (NaN stands for None) and as int64 columns
SUMMARY_FLOAT_COLUMNS = FLOAT_METRICS
SUMMARY_INT_COLUMNS = INT_METRICS
#: per-run index columns that are not summary metrics
RUN_FLOAT_COLUMNS = ("speed_mps", "rev_rate_rpm", "mass_kg", "rtol", "wall_time_s")
RUN_STRING_COLUMNS = ("run_id", "name", "ball_ref", "ball_sha", "pattern", "record", "solver")
#: per-sample trajectory quantities (first axis = sample), in the digest's order
TRAJECTORY_FIELDS = (
    "alpha_radps2",
    "energy_J",
    "friction_force_N",
    "mu",
    "normal_force_N",
    "omega_radps",
    "phase",
    "position_m",
    "quaternion_wxyz",
    "slip_mps",
    "t_s",
    "velocity_mps",
)
#: per-event columns; kind and phase are fixed-length UTF-8 strings
EVENT_FIELDS = ("kind", "mu", "phase", "t_s", "x_m", "y_m")

_GZIP: dict[str, Any] = {"compression": "gzip", "compression_opts": 4, "shuffle": True}


def new_segment_id() -> str:
    """A new segment ID that sorts by creation time: 16 hex digits of ns since the epoch, a
    dash and 8 random hex digits (unique across processes and machines)."""
    return f"{time.time_ns():016x}-{uuid.uuid4().hex[:8]}"


@dataclass
class RunRecord:
    """One run as a segment stores it (everything plain: strings, floats, arrays).

    ``scene_json`` is the scene as given (compact JSON); ``created_at_ns`` nanoseconds since
    1970-01-01 UTC; the index columns (``speed_mps`` ... ``pattern``) are what the archive's
    index lists without opening the segment.
    """

    run_id: str
    scene_json: bytes
    summary: Summary
    name: str
    ball_ref: str
    ball_sha: str
    pattern: str
    record: str
    solver: str
    speed_mps: float
    rev_rate_rpm: float
    mass_kg: float
    rtol: float
    wall_time_s: float
    created_at_ns: int
    #: per-sample arrays by TRAJECTORY_FIELDS name (empty arrays for a summary-only run)
    trajectory: dict[str, NDArray[Any]] = field(default_factory=dict)
    #: per-term torques (n, 3) in N m, only when recorded
    torques: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    #: events as (kind, mu, phase, t_s, x_m, y_m) tuples
    events: list[tuple[str, float, str, float, float, float]] = field(default_factory=list)
    #: per-run record groups (format 2.1): group name -> {dataset name: array}, the arrays of a
    #: group with equal first dimensions (the run's rows of that group), e.g. the oil grid after
    #: a session's shot (``bowlrec.session.records``)
    records: dict[str, dict[str, NDArray[Any]]] = field(default_factory=dict)

    @classmethod
    def from_run(
        cls,
        run: RunData,
        *,
        wall_time_s: float,
        ball_ref: str,
        solver: str,
        ball_sha: str,
        pattern: str,
        created_at_ns: int | None = None,
        records: dict[str, dict[str, NDArray[Any]]] | None = None,
    ) -> RunRecord:
        """A finished run (scene, plan, trajectory) as a record; ``run.run_id`` must be set;
        ``records``: its per-run record groups (see :attr:`RunRecord.records`)."""
        assert run.run_id is not None, "a run needs its content ID before it is archived"
        plan, traj = run.plan, run.trajectory
        v, w = plan.velocity0_mps, plan.omega0_radps
        return cls(
            run_id=run.run_id,
            scene_json=run.scene_json().encode(),
            summary=traj.summary,
            name=run.scene.name,
            ball_ref=ball_ref,
            ball_sha=ball_sha,
            pattern=pattern,
            record=run.scene.options.record,
            solver=solver,
            speed_mps=float(np.hypot(v[0], v[1])),
            rev_rate_rpm=float(np.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]))
            * 60.0
            / (2.0 * np.pi),
            mass_kg=float(plan.mass_kg),
            rtol=float(plan.rtol),
            wall_time_s=float(wall_time_s),
            # whole microseconds: the precision listings show, so a time copied from a listing
            # finds the run again in a created_at filter
            created_at_ns=(time.time_ns() if created_at_ns is None else created_at_ns)
            // 1000
            * 1000,
            trajectory={name: getattr(traj, name) for name in TRAJECTORY_FIELDS}
            if traj.n_samples
            else {},
            torques=dict(traj.torques_Nm),
            events=[(e.kind, e.mu, e.phase, e.t_s, e.x_m, e.y_m) for e in traj.events],
            records=check_records(run.run_id, records or {}),
        )


def check_records(
    run_id: str, records: dict[str, dict[str, NDArray[Any]]]
) -> dict[str, dict[str, NDArray[Any]]]:
    """``records`` as contiguous arrays, checked: group names outside the fixed groups, at least
    one dataset per group, no dataset named ``offsets``, equal first dimensions within a group
    (ValueError naming the run otherwise)."""
    out: dict[str, dict[str, NDArray[Any]]] = {}
    for group, datasets in records.items():
        if group in FIXED_GROUPS or group.startswith("_") or "/" in group or not group:
            raise ValueError(f"run {run_id}: {group!r} cannot name a per-run record group")
        arrays = {k: np.ascontiguousarray(v) for k, v in datasets.items()}
        if not arrays or "offsets" in arrays:
            raise ValueError(
                f"run {run_id}: record group {group!r} needs datasets other than 'offsets'"
            )
        rows = {a.shape[0] if a.ndim else -1 for a in arrays.values()}
        if len(rows) != 1 or -1 in rows:
            raise ValueError(
                f"run {run_id}: the datasets of record group {group!r} need equal first "
                f"dimensions (got {sorted(rows)})"
            )
        out[group] = arrays
    return out


def record_groups(records: Sequence[RunRecord]) -> dict[str, tuple[dict[str, Any], Any]]:
    """The per-run record groups of ``records``: group -> (its datasets concatenated over the
    runs with ``offsets``, its row matrix for the digests), groups in sorted name order. Every
    run that has a group gives it the same dataset names, dtypes and trailing shapes (a
    ValueError names the first run that does not)."""
    names = sorted({g for r in records for g in r.records})
    out: dict[str, tuple[dict[str, Any], Any]] = {}
    for group in names:
        having = [r for r in records if group in r.records]
        first = having[0].records[group]
        layout = {k: (v.dtype, v.shape[1:]) for k, v in first.items()}
        for r in having[1:]:
            got = {k: (v.dtype, v.shape[1:]) for k, v in r.records[group].items()}
            if got != layout:
                raise ValueError(
                    f"run {r.run_id}: record group {group!r} has datasets {got}, the segment's "
                    f"first run has {layout}; seal the segment first"
                )
        lengths = [
            int(next(iter(r.records[group].values())).shape[0]) if group in r.records else 0
            for r in records
        ]
        offsets = np.zeros(len(records) + 1, dtype=np.int64)
        np.cumsum(lengths, out=offsets[1:])
        datasets: dict[str, Any] = {
            k: np.concatenate([r.records[group][k] for r in having]) for k in sorted(first)
        }
        matrix = row_matrix([datasets[k] for k in sorted(first)], int(offsets[-1]))
        datasets["offsets"] = offsets
        out[group] = (datasets, matrix)
    return out


@dataclass(frozen=True)
class SegmentInfo:
    """A sealed segment: its ID, path and the IDs of its runs (in row order).

    A segment sealed in this process also carries what registering it needs (its per-run
    index columns and provenance), so registration does not read the file back.
    """

    segment_id: str
    path: Path
    run_ids: tuple[str, ...]
    index_columns: dict[str, NDArray[Any]] | None = field(default=None, compare=False, repr=False)
    provenance: dict[str, Any] | None = field(default=None, compare=False, repr=False)


# -- digests -------------------------------------------------------------------------------------


def run_digest(
    fixed_row: bytes | memoryview,
    scene: bytes | memoryview,
    message: bytes | memoryview,
    events: bytes | memoryview,
    samples: bytes | memoryview,
    torques: bytes | memoryview,
    *extra: bytes | memoryview,
) -> bytes:
    """BLAKE2b-128 of one run's stored bytes (docs/archive-format.md, "Digests").

    Each part is preceded by its length (8 bytes, little-endian): the run's row of the per-run
    matrix, its scene JSON, its summary message, its rows of the event, sample and torque
    matrices, then the rows of any further per-run record group (later 2.x versions). Returns 32
    hex digits as ASCII bytes.
    """
    h = hashlib.blake2b(digest_size=16)
    for part in (fixed_row, scene, message, events, samples, torques, *extra):
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest().encode()


def row_matrix(columns: Sequence[NDArray[Any]], n: int) -> NDArray[np.uint8]:
    """The columns' raw bytes side by side: row i holds every column's i-th entry (n, width)."""
    if not columns:
        return np.zeros((n, 0), dtype=np.uint8)
    parts = []
    for c in columns:
        arr = np.ascontiguousarray(c)
        width = int(np.prod(arr.shape[1:], dtype=np.int64)) * arr.dtype.itemsize
        parts.append(arr.reshape(-1).view(np.uint8).reshape(n, width))
    return np.ascontiguousarray(np.hstack(parts))


def fixed_columns(runs: dict[str, NDArray[Any]], summary: dict[str, NDArray[Any]]) -> list[Any]:
    """The fixed-width per-run columns in digest order: runs/* then summary/* (names sorted),
    without runs/digest."""
    cols = [runs[k] for k in sorted(runs) if k != "digest"]
    cols += [summary[k] for k in sorted(summary)]
    return cols


def event_columns(events: dict[str, NDArray[Any]]) -> list[NDArray[Any]]:
    return [events[k] for k in EVENT_FIELDS]


def sample_columns(trajectory: dict[str, NDArray[Any]]) -> list[NDArray[Any]]:
    return [trajectory[k] for k in TRAJECTORY_FIELDS if k in trajectory]


def _strings(values: Iterable[str]) -> NDArray[np.bytes_]:
    """UTF-8 fixed-length strings (numpy 'S' of the longest entry, at least 1 byte)."""
    encoded = [v.encode() for v in values]
    if not encoded:
        return np.zeros(0, dtype="S1")
    return np.array(encoded, dtype=np.bytes_)  # numpy picks the longest entry's width


def _concat(chunks: Sequence[bytes]) -> tuple[NDArray[np.uint8], NDArray[np.int64]]:
    offsets = np.zeros(len(chunks) + 1, dtype=np.int64)
    np.cumsum([len(c) for c in chunks], out=offsets[1:])
    return np.frombuffer(b"".join(chunks), dtype=np.uint8).copy(), offsets


# -- the builder ---------------------------------------------------------------------------------


class SegmentBuilder:
    """Collects runs, then writes them as one sealed segment (:meth:`seal`).

    ``provenance``: the attributes shared by every run (see
    :func:`bowlrec.provenance.environment`). A run ID appended twice is stored once.
    Any process may build and seal segments; registering them in the index is
    :meth:`bowlrec.archive.Archive.register`'s work.
    """

    def __init__(self, provenance: dict[str, Any], *, samples: str = "gzip") -> None:
        self.provenance = dict(provenance)
        #: storage filter of per-sample datasets: "gzip" or "none" (see write_segment)
        self.samples = samples
        self.records: list[RunRecord] = []
        self._ids: set[str] = set()

    def __len__(self) -> int:
        return len(self.records)

    def append(self, record: RunRecord) -> bool:
        """Add a run; False (nothing added) when its run ID is already in this segment."""
        if record.run_id in self._ids:
            return False
        if record.torques and self.records:
            terms = next((list(r.torques) for r in self.records if r.torques), None)
            if terms is not None and terms != list(record.torques):
                raise ValueError(
                    f"run {record.run_id}: torque terms {list(record.torques)} differ from the "
                    f"segment's {terms}; seal the segment first"
                )
        for group, datasets in record.records.items():
            other = next((r for r in self.records if group in r.records), None)
            if other is None:
                continue
            layout = {k: (v.dtype, v.shape[1:]) for k, v in other.records[group].items()}
            got = {k: (v.dtype, v.shape[1:]) for k, v in datasets.items()}
            if got != layout:
                raise ValueError(
                    f"run {record.run_id}: record group {group!r} has datasets {got}, the "
                    f"segment's runs have {layout}; seal the segment first"
                )
        self._ids.add(record.run_id)
        self.records.append(record)
        return True

    def columns(self) -> dict[str, Any]:
        """Every dataset of the segment by group and name (digests included)."""
        recs = self.records
        runs: dict[str, NDArray[Any]] = {}
        for name in RUN_STRING_COLUMNS:
            runs[name] = _strings(getattr(r, name) for r in recs)
        for name in RUN_FLOAT_COLUMNS:
            runs[name] = np.array([getattr(r, name) for r in recs], dtype=np.float64)
        runs["created_at_ns"] = np.array([r.created_at_ns for r in recs], dtype=np.int64)
        summary: dict[str, NDArray[Any]] = {"outcome": _strings(r.summary.outcome for r in recs)}
        for name in SUMMARY_FLOAT_COLUMNS:
            values = [getattr(r.summary, name) for r in recs]
            summary[name] = np.array([np.nan if v is None else v for v in values], dtype=np.float64)
        for name in SUMMARY_INT_COLUMNS:
            summary[name] = np.array([getattr(r.summary, name) for r in recs], dtype=np.int64)
        scene_bytes, scene_offsets = _concat([r.scene_json for r in recs])
        message_bytes, message_offsets = _concat([r.summary.message.encode() for r in recs])
        events = self._events()
        trajectory, traj_offsets = self._samples()
        torques, torque_offsets, terms = self._torques()
        smp_m = row_matrix(sample_columns(trajectory), int(traj_offsets[-1]))
        tq_m = row_matrix([torques[t] for t in terms], int(torque_offsets[-1]))
        trajectory["offsets"] = traj_offsets
        torques["offsets"] = torque_offsets
        return _with_digests(
            runs,
            summary,
            (scene_bytes, scene_offsets),
            (message_bytes, message_offsets),
            events,
            (trajectory, smp_m),
            (torques, tq_m),
            terms,
            record_groups(recs),
        )

    def _events(self) -> dict[str, NDArray[Any]]:
        rows = [e for r in self.records for e in r.events]
        offsets = np.zeros(len(self.records) + 1, dtype=np.int64)
        np.cumsum([len(r.events) for r in self.records], out=offsets[1:])
        cols = list(zip(*rows, strict=True)) if rows else [()] * len(EVENT_FIELDS)
        out: dict[str, NDArray[Any]] = {}
        for name, values in zip(EVENT_FIELDS, cols, strict=True):
            if name in ("kind", "phase"):
                out[name] = _strings(values) if values else np.zeros(0, dtype="S1")
            else:
                out[name] = np.array(values, dtype=np.float64)
        out["offsets"] = offsets
        return out

    def _samples(self) -> tuple[dict[str, NDArray[Any]], NDArray[np.int64]]:
        lengths = [int(r.trajectory["t_s"].shape[0]) if r.trajectory else 0 for r in self.records]
        offsets = np.zeros(len(self.records) + 1, dtype=np.int64)
        np.cumsum(lengths, out=offsets[1:])
        recorded = [r.trajectory for r in self.records if r.trajectory]
        out: dict[str, NDArray[Any]] = {}
        if recorded:
            for name in TRAJECTORY_FIELDS:
                out[name] = np.concatenate([t[name] for t in recorded])
        return out, offsets

    def _torques(self) -> tuple[dict[str, NDArray[Any]], NDArray[np.int64], list[str]]:
        with_torques = [r for r in self.records if r.torques]
        terms = list(with_torques[0].torques) if with_torques else []
        lengths = [
            int(next(iter(r.torques.values())).shape[0]) if r.torques else 0 for r in self.records
        ]
        offsets = np.zeros(len(self.records) + 1, dtype=np.int64)
        np.cumsum(lengths, out=offsets[1:])
        out = {t: np.concatenate([r.torques[t] for r in with_torques]) for t in terms}
        return out, offsets, terms

    def seal(self, directory: str | os.PathLike[str], *, durable: bool = True) -> SegmentInfo:
        """Write the segment under ``directory`` whole or not at all; its info."""
        if not self.records:
            raise ValueError("a segment needs at least one run")
        collecting = gc.isenabled()
        gc.disable()  # thousands of small objects: a collection pass here costs, frees nothing
        try:
            columns = self.columns()
        finally:
            if collecting:
                gc.enable()
        return seal_columns(
            directory, columns, self.provenance, durable=durable, samples=self.samples
        )


def seal_columns(
    directory: str | os.PathLike[str],
    columns: dict[str, Any],
    provenance: dict[str, Any],
    *,
    durable: bool = True,
    samples: str = "gzip",
) -> SegmentInfo:
    """Write a segment's datasets (as :meth:`SegmentBuilder.columns` makes them) as a new
    sealed segment under ``directory``; its info. ``samples``: see
    :func:`~bowlrec.archive.segment_file.write_segment`."""
    from .segment_file import write_segment

    segment_id = new_segment_id()
    path = Path(directory) / f"{segment_id}.h5"
    write_segment(path, segment_id, columns, provenance, durable=durable, samples=samples)
    index = {k: v for group in ("runs", "summary") for k, v in columns[group].items()}
    index["n_samples"] = np.diff(columns["trajectory"]["offsets"])
    run_ids = tuple(v.decode() for v in columns["runs"]["run_id"].tolist())
    info = {
        **provenance,
        "format": SEGMENT_FORMAT,
        "format_version": format_version_of(columns),
        "segment_id": segment_id,
        "n_runs": len(run_ids),
    }
    return SegmentInfo(segment_id, path, run_ids, index, info)


@dataclass
class SummaryRuns:
    """Summary-only runs as columns (n runs): what :class:`RunRecord` holds for each, without
    a Python object per run. ``strings``: the :data:`RUN_STRING_COLUMNS` (a list of n, or one
    str shared by all); ``floats``: :data:`RUN_FLOAT_COLUMNS` (arrays of n); ``summary``:
    ``outcome`` (str array), :data:`SUMMARY_FLOAT_COLUMNS` (NaN: None) and
    :data:`SUMMARY_INT_COLUMNS`; ``messages``: one per run; ``events``: (n, cap, 6) rows as the
    kernels write them (t, kind code, x, y, mu, rolling) with ``n_events`` per run."""

    strings: dict[str, list[str] | str]
    floats: dict[str, NDArray[np.float64]]
    created_at_ns: int
    scene_json: list[bytes]
    summary: dict[str, NDArray[Any]]
    messages: list[str]
    events: NDArray[np.float64]
    n_events: NDArray[np.int64]

    def __len__(self) -> int:
        return len(self.scene_json)

    def run_ids(self) -> list[str]:
        ids = self.strings["run_id"]
        return [ids] if isinstance(ids, str) else list(ids)

    def select(self, keep: Sequence[int]) -> SummaryRuns:
        """The runs at positions ``keep`` (in that order)."""
        rows = np.asarray(keep, dtype=np.int64)
        pick = rows.tolist()
        return SummaryRuns(
            strings={
                k: v if isinstance(v, str) else [v[i] for i in pick]
                for k, v in self.strings.items()
            },
            floats={k: np.asarray(v)[rows] for k, v in self.floats.items()},
            created_at_ns=self.created_at_ns,
            scene_json=[self.scene_json[i] for i in pick],
            summary={k: np.asarray(v)[rows] for k, v in self.summary.items()},
            messages=[self.messages[i] for i in pick],
            events=self.events[rows],
            n_events=self.n_events[rows],
        )

    def columns(self) -> dict[str, Any]:
        """Every dataset of a segment holding these runs (as :meth:`SegmentBuilder.columns`
        makes them for the same runs appended as records)."""

        n = len(self)
        runs: dict[str, NDArray[Any]] = {}
        for name in RUN_STRING_COLUMNS:
            v = self.strings[name]
            runs[name] = _strings([v] * n if isinstance(v, str) else v)
        for name in RUN_FLOAT_COLUMNS:
            runs[name] = np.asarray(self.floats[name], dtype=np.float64)
        runs["created_at_ns"] = np.full(n, self.created_at_ns // 1000 * 1000, dtype=np.int64)
        summary: dict[str, NDArray[Any]] = {"outcome": _strings(self.summary["outcome"].tolist())}
        for name in SUMMARY_FLOAT_COLUMNS:
            summary[name] = np.asarray(self.summary[name], dtype=np.float64)
        for name in SUMMARY_INT_COLUMNS:
            summary[name] = np.asarray(self.summary[name], dtype=np.int64)
        scene_bytes, scene_offsets = _concat(self.scene_json)
        message_bytes, message_offsets = _concat([m.encode() for m in self.messages])
        keep = np.arange(self.events.shape[1])[None, :] < self.n_events[:, None]
        rows = self.events[keep]  # run by run, in event order
        offsets = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(self.n_events, out=offsets[1:])
        kinds = {code: name.encode() for code, name in EVENT_KINDS.items()}
        phases = {code: name.encode() for code, name in PHASE_NAMES.items()}
        events: dict[str, NDArray[Any]] = {
            "kind": _fixed([kinds[int(c)] for c in rows[:, EV_KIND]]),
            "mu": rows[:, EV_MU].copy(),
            "phase": _fixed([phases[int(r)] for r in rows[:, EV_PHASE]]),
            "t_s": rows[:, EV_T].copy(),
            "x_m": rows[:, EV_X].copy(),
            "y_m": rows[:, EV_Y].copy(),
            "offsets": offsets,
        }
        no_samples = np.zeros((0, 0), dtype=np.uint8)
        return _with_digests(
            runs,
            summary,
            (scene_bytes, scene_offsets),
            (message_bytes, message_offsets),
            events,
            ({"offsets": np.zeros(n + 1, dtype=np.int64)}, no_samples),
            ({"offsets": np.zeros(n + 1, dtype=np.int64)}, no_samples),
            [],
        )


def _with_digests(
    runs: dict[str, NDArray[Any]],
    summary: dict[str, NDArray[Any]],
    scenes: tuple[NDArray[np.uint8], NDArray[np.int64]],
    messages: tuple[NDArray[np.uint8], NDArray[np.int64]],
    events: dict[str, NDArray[Any]],
    samples: tuple[dict[str, NDArray[Any]], NDArray[np.uint8]],
    torques: tuple[dict[str, NDArray[Any]], NDArray[np.uint8]],
    terms: Sequence[str],
    records: dict[str, tuple[dict[str, Any], Any]] | None = None,
) -> dict[str, Any]:
    """A segment's datasets by group, each run's digest computed (see :func:`run_digest`).

    ``samples`` and ``torques``: each group's datasets (with ``offsets``) and its row matrix
    (:func:`row_matrix`; any empty matrix when no run has rows); ``records``: the per-run record
    groups (:func:`record_groups`), which join each digest after the torques."""
    records = records or {}
    n = int(runs["run_id"].shape[0])
    scene_bytes, scene_offsets = scenes
    message_bytes, message_offsets = messages
    fixed = row_matrix(fixed_columns(runs, summary), n)
    ev_off = events["offsets"]
    ev_m = row_matrix(event_columns(events), int(ev_off[-1]))
    smp_off, tq_off = samples[0]["offsets"], torques[0]["offsets"]
    smp_m, tq_m = samples[1], torques[1]
    digests = [
        run_digest(
            fixed[i].data,
            scene_bytes[scene_offsets[i] : scene_offsets[i + 1]].data,
            message_bytes[message_offsets[i] : message_offsets[i + 1]].data,
            ev_m[ev_off[i] : ev_off[i + 1]].data,
            smp_m[smp_off[i] : smp_off[i + 1]].data,
            tq_m[tq_off[i] : tq_off[i + 1]].data,
            *(m[d["offsets"][i] : d["offsets"][i + 1]].data for d, m in records.values()),
        )
        for i in range(n)
    ]
    runs["digest"] = np.array(digests, dtype="S32")
    runs["scene_json"] = scene_bytes
    runs["scene_json_offsets"] = scene_offsets
    summary["message"] = message_bytes
    summary["message_offsets"] = message_offsets
    return {
        "runs": runs,
        "summary": summary,
        "events": events,
        "trajectory": samples[0],
        "torques": torques[0],
        **{group: datasets for group, (datasets, _) in records.items()},
        "_terms": np.array([t.encode() for t in terms], dtype="S64"),
    }


def format_version_of(columns: dict[str, Any]) -> str:
    """The segment format version of a segment's datasets: 2.1 when they hold per-run record
    groups, else 2.0 (a segment without them is exactly a 2.0 segment)."""
    extra = any(g not in FIXED_GROUPS and not g.startswith("_") for g in columns)
    return RECORDS_FORMAT_VERSION if extra else SEGMENT_FORMAT_VERSION


def _fixed(values: list[bytes]) -> NDArray[np.bytes_]:
    if not values:
        return np.zeros(0, dtype="S1")
    return np.array(values, dtype=np.bytes_)

"""Segments built and sealed: many runs in one sealed HDF5 file (format ``bowlrec-segment``
2.0).

A segment holds the runs of one writer as columns: one dataset per quantity with the values of
all its runs concatenated (``offsets`` datasets give each run's slice), the summary metrics and
the index columns one dataset each, the scenes as gzip-compressed JSON bytes. What is the same
for every run of the segment (the provenance: package versions, platform) is stored once, as
root attributes. Layout and digests: ``docs/archive-format.md``.

:class:`SegmentBuilder` collects runs in memory and :meth:`SegmentBuilder.seal` writes the file
whole (temporary name, fsync, rename): a segment on disk is complete or absent. Sealed segments
are never modified; removal writes tombstones and compaction writes new segments.
"""

from __future__ import annotations

import gc
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.core.codes import EV_KIND, EV_MU, EV_PHASE, EV_T, EV_X, EV_Y, EVENT_KINDS, PHASE_NAMES

from .pin_records import pin_index_columns
from .segment_format import (
    EVENT_FIELDS,
    FIXED_GROUPS,
    RECORDS_FORMAT_VERSION,
    RUN_FLOAT_COLUMNS,
    RUN_STRING_COLUMNS,
    SEGMENT_FORMAT,
    SEGMENT_FORMAT_VERSION,
    SUMMARY_FLOAT_COLUMNS,
    SUMMARY_INT_COLUMNS,
    TRAJECTORY_FIELDS,
    RunRecord,
    SegmentInfo,
    check_records,
    event_columns,
    fixed_columns,
    format_version_of,
    new_segment_id,
    row_matrix,
    run_digest,
    sample_columns,
)

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
    "check_records",
    "event_columns",
    "fixed_columns",
    "format_version_of",
    "new_segment_id",
    "record_groups",
    "row_matrix",
    "run_digest",
    "sample_columns",
    "seal_columns",
]


def _layout(datasets: dict[str, NDArray[Any]]) -> dict[str, tuple[str, tuple[int, ...]]]:
    """A record group's datasets as a segment needs them alike across runs: each one's dtype
    and trailing shape (byte strings of any width: the segment stores the widest)."""
    return {
        k: ("S" if v.dtype.kind == "S" else v.dtype.str, tuple(v.shape[1:]))
        for k, v in datasets.items()
    }


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
        layout = _layout(first)
        for r in having[1:]:
            got = _layout(r.records[group])
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
            layout = _layout(other.records[group])
            got = _layout(datasets)
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
    from .segment_file import write_segment  # h5py: loaded by the first write, not on import

    segment_id = new_segment_id()
    path = Path(directory) / f"{segment_id}.h5"
    write_segment(path, segment_id, columns, provenance, durable=durable, samples=samples)
    index = {k: v for group in ("runs", "summary") for k, v in columns[group].items()}
    index["n_samples"] = np.diff(columns["trajectory"]["offsets"])
    index.update(pin_index_columns(len(columns["runs"]["run_id"]), columns.get("pin_outcome")))
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


def _fixed(values: list[bytes]) -> NDArray[np.bytes_]:
    if not values:
        return np.zeros(0, dtype="S1")
    return np.array(values, dtype=np.bytes_)

"""Segments built and sealed: many runs in one sealed HDF5 file (format ``bowlrec-segment``
3.0 with samples, 2.3 without).

A segment holds the runs of one writer as columns: one dataset per quantity with the values of
all its runs concatenated (``offsets`` datasets give each run's slice), the summary metrics and
the index columns one dataset each, event kinds and phases as small integer codes. A scene is
stored as the segment's base scene (once) and the run's overrides: the fields where it differs
(:mod:`.scene_store`). What is the same for every run of the segment (the provenance: package
versions, platform) is stored once, as root attributes. One CRC-32 covers each block of runs.
Layout and digests: ``docs/archive-format.md``.

:class:`SegmentBuilder` collects runs in memory and :meth:`SegmentBuilder.seal` writes the file
whole (temporary name, fsync, rename): a segment on disk is complete or absent. Sealed segments
are never modified; removal writes tombstones and compaction writes new segments.
"""

from __future__ import annotations

import gc
import json
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.core.codes import EV_KIND, EV_MU, EV_PHASE, EV_T, EV_X, EV_Y, EVENT_KINDS, PHASE_NAMES

from .derived import DERIVED_FIELDS, derived_samples
from .pin_records import pin_index_columns
from .scene_store import Path as FieldPath
from .scene_store import path_text
from .segment_format import (
    DIGEST_ALGORITHM,
    EVENT_FIELDS,
    FIXED_GROUPS,
    RECORDS_FORMAT_VERSION,
    RUN_FLOAT_COLUMNS,
    RUN_STRING_COLUMNS,
    SEGMENT_FORMAT,
    SEGMENT_FORMAT_VERSION,
    STATE_FIELDS,
    SUMMARY_FLOAT_COLUMNS,
    SUMMARY_INT_COLUMNS,
    TRAJECTORY_FIELDS,
    RunRecord,
    SegmentInfo,
    block_digest,
    block_runs_for,
    check_records,
    digest_parts,
    event_columns,
    fixed_columns,
    format_version_of,
    new_segment_id,
    row_matrix,
    run_digest,
    sample_columns,
    sample_parts,
)

#: event kind and phase codes (2.3): code i is names[i] (stored as each dataset's ``names_json``)
KIND_NAMES = tuple(EVENT_KINDS.get(i, "") for i in range(max(EVENT_KINDS) + 1))
PHASE_CODE_NAMES = tuple(PHASE_NAMES[i] for i in range(len(PHASE_NAMES)))

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
    "KIND_NAMES",
    "PHASE_CODE_NAMES",
    "RunRecord",
    "SegmentBuilder",
    "SegmentInfo",
    "SummaryRuns",
    "check_records",
    "digest_parts",
    "event_columns",
    "fixed_columns",
    "format_version_of",
    "new_segment_id",
    "record_groups",
    "row_matrix",
    "run_digest",
    "sample_columns",
    "scene_columns",
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


def _repeated(value: str, n: int) -> NDArray[np.bytes_]:
    """``_strings([value] * n)``, encoding ``value`` once (a column a batch's runs share)."""
    if n == 0:
        return _strings(())
    encoded = value.encode()
    return np.full(n, encoded, dtype=f"S{max(1, len(encoded))}")


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
        message_bytes, message_offsets = _concat([r.summary.message.encode() for r in recs])
        events = self._events()
        trajectory, traj_offsets = self._samples()
        torques, torque_offsets, terms = self._torques()
        smp_parts = sample_parts(trajectory, traj_offsets, bool(traj_offsets[-1]))
        tq_m = row_matrix([torques[t] for t in terms], int(torque_offsets[-1]))
        trajectory["offsets"] = traj_offsets
        torques["offsets"] = torque_offsets
        return _with_digests(
            runs,
            summary,
            scene_columns([r.scene_json for r in recs]),
            (message_bytes, message_offsets),
            events,
            (trajectory, smp_parts),
            (torques, tq_m),
            terms,
            record_groups(recs),
        )

    def _events(self) -> dict[str, Any]:
        rows = [e for r in self.records for e in r.events]
        offsets = np.zeros(len(self.records) + 1, dtype=np.int64)
        np.cumsum([len(r.events) for r in self.records], out=offsets[1:])
        cols = list(zip(*rows, strict=True)) if rows else [()] * len(EVENT_FIELDS)
        out: dict[str, Any] = {}
        names: dict[str, list[str]] = {}
        for name, values in zip(EVENT_FIELDS, cols, strict=True):
            if name in ("kind", "phase"):
                out[name], names[name] = _codes(
                    values, KIND_NAMES if name == "kind" else PHASE_CODE_NAMES
                )
            else:
                out[name] = np.array(values, dtype=np.float64)
        out["offsets"] = offsets
        out["_names"] = names
        return out

    def _samples(self) -> tuple[dict[str, NDArray[Any]], NDArray[np.int64]]:
        lengths = [int(r.trajectory["t_s"].shape[0]) if r.trajectory else 0 for r in self.records]
        offsets = np.zeros(len(self.records) + 1, dtype=np.int64)
        np.cumsum(lengths, out=offsets[1:])
        recorded = [r for r in self.records if r.trajectory]
        out: dict[str, NDArray[Any]] = {}
        if not recorded:
            return out, offsets
        for name in STATE_FIELDS:
            out[name] = np.concatenate([r.trajectory[name] for r in recorded])
        if any(DERIVED_FIELDS[0] in r.trajectory for r in recorded):
            # one run's derived quantities stored as given: every run's are stored
            full = [
                r.trajectory
                if DERIVED_FIELDS[0] in r.trajectory
                else derived_samples(r.trajectory, r.scene_json.decode())
                for r in recorded
            ]
            for name in DERIVED_FIELDS:
                out[name] = np.concatenate([t[name] for t in full])
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
    kernels write them (t, kind code, x, y, mu, rolling) with ``n_events`` per run. The scenes:
    ``scene_base`` (compact JSON) with, for run i, ``scene_values[i, j]`` at path
    ``scene_paths[j]`` (see :mod:`.scene_store`)."""

    strings: dict[str, list[str] | str]
    floats: dict[str, NDArray[np.float64]]
    created_at_ns: int
    scene_base: bytes
    scene_paths: list[FieldPath]
    scene_values: NDArray[np.float64]
    summary: dict[str, NDArray[Any]]
    messages: list[str]
    events: NDArray[np.float64]
    n_events: NDArray[np.int64]

    def __len__(self) -> int:
        return int(self.scene_values.shape[0])

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
            scene_base=self.scene_base,
            scene_paths=self.scene_paths,
            scene_values=self.scene_values[rows],
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
            runs[name] = _repeated(v, n) if isinstance(v, str) else _strings(v)
        for name in RUN_FLOAT_COLUMNS:
            runs[name] = np.asarray(self.floats[name], dtype=np.float64)
        runs["created_at_ns"] = np.full(n, self.created_at_ns // 1000 * 1000, dtype=np.int64)
        summary: dict[str, NDArray[Any]] = {"outcome": _strings(self.summary["outcome"].tolist())}
        for name in SUMMARY_FLOAT_COLUMNS:
            summary[name] = np.asarray(self.summary[name], dtype=np.float64)
        for name in SUMMARY_INT_COLUMNS:
            summary[name] = np.asarray(self.summary[name], dtype=np.int64)
        message_bytes, message_offsets = _concat([m.encode() for m in self.messages])
        keep = np.arange(self.events.shape[1])[None, :] < self.n_events[:, None]
        rows = self.events[keep]  # run by run, in event order
        offsets = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(self.n_events, out=offsets[1:])
        events: dict[str, Any] = {
            "kind": rows[:, EV_KIND].astype(np.uint8),
            "mu": rows[:, EV_MU].copy(),
            "phase": rows[:, EV_PHASE].astype(np.uint8),
            "t_s": rows[:, EV_T].copy(),
            "x_m": rows[:, EV_X].copy(),
            "y_m": rows[:, EV_Y].copy(),
            "offsets": offsets,
            "_names": {"kind": list(KIND_NAMES), "phase": list(PHASE_CODE_NAMES)},
        }
        no_samples = np.zeros((0, 0), dtype=np.uint8)
        scene = {
            "base_json": np.frombuffer(self.scene_base, dtype=np.uint8).copy(),
            "override_paths": _strings(path_text(p) for p in self.scene_paths),
            "override_values": np.ascontiguousarray(self.scene_values, dtype=np.float64).reshape(
                n, len(self.scene_paths)
            ),
            "override_json": np.zeros(0, dtype=np.uint8),
            "override_offsets": np.zeros(n + 1, dtype=np.int64),
        }
        return _with_digests(
            runs,
            summary,
            scene,
            (message_bytes, message_offsets),
            events,
            ({"offsets": np.zeros(n + 1, dtype=np.int64)}, [no_samples]),
            ({"offsets": np.zeros(n + 1, dtype=np.int64)}, no_samples),
            [],
        )


def _codes(values: Sequence[str], table: Sequence[str]) -> tuple[NDArray[np.uint8], list[str]]:
    """Text values as codes into ``table`` (names not in it are appended): (codes, names)."""
    names = list(table)
    index = {name: i for i, name in enumerate(names) if name}
    codes = []
    for v in values:
        code = index.get(v)
        if code is None:
            code = index[v] = len(names)
            names.append(v)
        codes.append(code)
    if len(names) > 256:
        raise ValueError(f"more than 256 distinct event codes in one segment ({len(names)})")
    return np.array(codes, dtype=np.uint8), names


def scene_columns(scenes: Sequence[bytes]) -> dict[str, NDArray[Any]]:
    """The ``scene`` group of the runs whose scenes (compact JSON) are ``scenes``: the first one
    is the base, and a run whose scene differs from it stores its scene whole (see
    :mod:`.scene_store`)."""
    n = len(scenes)
    base_raw = scenes[0]
    override_bytes, override_offsets = _concat([b"" if s == base_raw else s for s in scenes])
    return {
        "base_json": np.frombuffer(base_raw, dtype=np.uint8).copy(),
        "override_paths": np.zeros(0, dtype="S1"),
        "override_values": np.zeros((n, 0), dtype=np.float64),
        "override_json": override_bytes,
        "override_offsets": override_offsets,
    }


def _with_digests(
    runs: dict[str, NDArray[Any]],
    summary: dict[str, NDArray[Any]],
    scene: dict[str, NDArray[Any]],
    messages: tuple[NDArray[np.uint8], NDArray[np.int64]],
    events: dict[str, Any],
    samples: tuple[dict[str, NDArray[Any]], Sequence[Any]],
    torques: tuple[dict[str, NDArray[Any]], NDArray[np.uint8]],
    terms: Sequence[str],
    records: dict[str, tuple[dict[str, Any], Any]] | None = None,
) -> dict[str, Any]:
    """A segment's datasets by group, with one digest per block of runs (see
    :func:`digest_parts`).

    ``samples``: the group's datasets (with ``offsets``) and its digest parts
    (:func:`sample_parts`, or their matrices alone; an empty matrix when no run has samples);
    ``torques``: the group's datasets and its row matrix (:func:`row_matrix`; any empty matrix
    when no run has rows); ``records``: the per-run record
    groups (:func:`record_groups`), which join each digest after the torques."""
    records = records or {}
    n = int(runs["run_id"].shape[0])
    message_bytes, message_offsets = messages
    fixed = row_matrix(fixed_columns(runs, summary), n)
    names = events.pop("_names")
    ev_off = events["offsets"]
    ev_m = row_matrix(event_columns(events), int(ev_off[-1]))
    smp_off, tq_off = samples[0]["offsets"], torques[0]["offsets"]
    parts = [
        (scene["override_json"], scene["override_offsets"]),
        (message_bytes, message_offsets),
        (ev_m, ev_off),
        *((p[0] if isinstance(p, tuple) else p, smp_off) for p in samples[1]),
        (torques[1], tq_off),
        *((m, d["offsets"]) for d, m in records.values()),
    ]
    has_rows = bool(smp_off[-1] or tq_off[-1]) or any(
        int(d["offsets"][-1]) for d, _ in records.values()
    )
    block = block_runs_for(has_rows)
    digests = np.array(
        [
            block_digest(digest_parts(scene, fixed, parts, a, min(n, a + block)))
            for a in range(0, n, block)
        ],
        dtype=np.uint32,
    )
    summary["message"] = message_bytes
    summary["message_offsets"] = message_offsets
    return {
        "runs": runs,
        "summary": summary,
        "scene": scene,
        "events": events,
        "trajectory": samples[0],
        "torques": torques[0],
        **{group: datasets for group, (datasets, _) in records.items()},
        "digest": {"blocks": digests},
        "_terms": np.array([t.encode() for t in terms], dtype="S64"),
        "_attrs": {
            "digest": {"block_runs": block, "algorithm": DIGEST_ALGORITHM},
            **{
                f"events/{k}": {"names_json": json.dumps(v, separators=(",", ":"))}
                for k, v in names.items()
            },
        },
    }

"""Writing and reading segment files (HDF5, default ``libver``, gzip + shuffle).

:func:`write_segment` writes the datasets :meth:`~bowlrec.archive.segment.SegmentBuilder.columns`
made, whole or not at all. :class:`SegmentFile` reads them back: the index columns of every run
at once (registration, index rebuilds), one run with its digest checked (:meth:`read_run`), or
every run's digest (:meth:`verify`). A run whose bytes do not match its digest raises
:class:`RunDamagedError`, which names the run and the segment; other runs read as usual.
"""

from __future__ import annotations

import functools
import json
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from bowlrec.atomic_files import atomic_path
from bowlrec.core.plan import Plan
from bowlrec.core.trajectory import Event, Summary, Trajectory
from bowlrec.errors import RunDamagedError, SegmentError
from bowlrec.pins.records import PIN_MEANINGS, pin_engine, pin_outcome_of
from bowlrec.sinks.hdf5_run import GZIP_FILTERS
from bowlrec.units import DIMENSIONLESS, units_for

from . import faults
from .derived import DERIVED_FIELDS, derived_samples
from .hdf5_objects import new_dataset, read_whole, set_attr
from .pin_records import pin_index_columns
from .scene_store import scene_text
from .segment_format import (
    EVENT_FIELDS,
    FIXED_GROUPS,
    RUN_FLOAT_COLUMNS,
    RUN_STRING_COLUMNS,
    SEGMENT_FORMAT,
    SEGMENT_FORMAT_VERSION,
    STATE_FIELDS,
    STATE_FORMAT_VERSION,
    SUMMARY_FLOAT_COLUMNS,
    SUMMARY_INT_COLUMNS,
    TRAJECTORY_FIELDS,
    RunRecord,
    block_digest,
    digest_parts,
    event_columns,
    fixed_columns,
    format_version_of,
    row_matrix,
    run_digest,
    sample_columns,
    sample_parts,
    stored_samples,
    version_tuple,
)

__all__ = ["SegmentFile", "StoredRecord", "write_segment"]

#: datasets whose values are text or bookkeeping: units "1" and what the values mean
_MEANINGS = {
    "run_id": "content ID (hex)",
    "name": "scene name (UTF-8)",
    "ball_ref": "library ball name@version, or empty (UTF-8)",
    "ball_sha": "SHA-256 of the ball spec's canonical JSON (hex)",
    "pattern": "oil pattern preset or friction kind (UTF-8)",
    "record": "options.record: summary, steps or rate",
    "solver": "integrator or closed_form",
    "digest": "BLAKE2b-128 of the run's stored bytes (hex; docs/archive-format.md)",
    "blocks": "CRC-32 of each block of block_runs runs (docs/archive-format.md, Digests)",
    "base_json": "the segment's base scene, compact JSON (UTF-8 bytes)",
    "override_paths": "field paths (JSON arrays of keys and indices) of override_values' columns",
    "override_values": "run i's value of the field override_paths[j] (the units of that scene "
    "field; NaN: not overridden)",
    "override_json": "the scenes of the runs that differ from the base otherwise than in "
    "override_values, whole, compact JSON (UTF-8 bytes of all runs, concatenated; empty: the "
    "base with the run's override_values)",
    "override_offsets": "run i's scene is override_json[offsets[i]:offsets[i + 1]] when that is "
    "not empty",
    "outcome": "how the run ended",
    "scene_json": "scenes as given, compact JSON (UTF-8 bytes of all runs, concatenated)",
    "message": "summary messages (UTF-8 bytes of all runs, concatenated)",
    "offsets": "run i spans [offsets[i], offsets[i + 1]) of this group's datasets",
    "scene_json_offsets": "run i's scene is scene_json[offsets[i]:offsets[i + 1]]",
    "message_offsets": "run i's message is message[offsets[i]:offsets[i + 1]]",
    "kind": "event kind (a code: names_json[code] names it)",
    "phase": "rolling or sliding after the event (a code: names_json[code] names it)",
    "n_steps": "accepted integrator steps (count)",
    "n_rhs": "right-hand-side evaluations (count)",
    "n_events": "events (count)",
    "state_json": "a session's state after the shot, compact JSON (UTF-8 bytes)",
    "friction_dir": "unit direction (x, y) of the sliding friction force as the kernel applied "
    "it; with the state it gives the forces, slip, energy and alpha (docs/archive-format.md)",
}


#: groups whose place in the digest is fixed (parts 1-6)
_KNOWN_GROUPS = FIXED_GROUPS
#: per-run datasets of variable length (bytes concatenated over the runs, with offsets)
_VARIABLE = ("scene_json", "scene_json_offsets", "message", "message_offsets")


def _units(group: str, name: str) -> tuple[str, str | None]:
    if f"{group}/{name}" in PIN_MEANINGS:
        return PIN_MEANINGS[f"{group}/{name}"]
    if name in _MEANINGS and not (group == "trajectory" and name == "phase"):
        return "1", _MEANINGS[name]
    if name == "created_at_ns":
        return "ns", "time since 1970-01-01T00:00:00 UTC"
    if group == "torques":
        return units_for("torque_Nm"), None
    key = "phase" if (group == "trajectory" and name == "phase") else name
    return units_for(key), DIMENSIONLESS.get(key)


def write_segment(
    path: Path,
    segment_id: str,
    columns: dict[str, Any],
    provenance: dict[str, Any],
    *,
    durable: bool = True,
    samples: str = "gzip",
) -> None:
    """Write a segment file at ``path`` whole or not at all (see :mod:`bowlrec.archive.segment`).

    ``samples``: how per-sample datasets (trajectory, torques) are stored, "gzip" (shuffle +
    gzip, fewer bytes), "lz4" (Blosc: byte shuffle + LZ4, through the ``hdf5plugin`` package)
    or "none" (benchmarks/results/pipeline.md compares them); readers see no difference, and
    compaction rewrites segments with gzip."""
    if samples not in SAMPLE_FILTERS:
        raise ValueError(f"samples = {samples!r} must be one of {', '.join(SAMPLE_FILTERS)}")
    terms = columns["_terms"]
    n = int(columns["runs"]["run_id"].shape[0])
    meanings: dict[str, str] = {}
    with (
        atomic_path(path, durable=durable, hold_lock=True) as tmp,
        h5py.File(tmp, "w", locking=False, **_file_driver(columns)) as f,
    ):
        set_attr(f, "format", SEGMENT_FORMAT)
        set_attr(f, "format_version", format_version_of(columns))
        set_attr(f, "segment_id", segment_id)
        set_attr(f, "n_runs", n)
        for key, value in provenance.items():
            set_attr(f, key, value)
        record_groups = sorted(g for g in columns if g not in FIXED_GROUPS and g[0] != "_")
        fixed = ("runs", "summary", "scene", "events", "trajectory", "torques", "digest")
        for group_name in (*(g for g in fixed if g in columns), *record_groups):
            group = f.create_group(group_name)
            for name, arr in columns[group_name].items():
                data = np.asarray(arr)
                ds = new_dataset(group, name, data, _storage(group_name, name, data, samples))
                units, meaning = _units(group_name, name)
                set_attr(ds, "units", units)
                if meaning:
                    meanings[f"{group_name}/{name}"] = meaning
        f["torques"].attrs["order"] = terms
        for where, attrs in columns.get("_attrs", {}).items():
            for key, value in attrs.items():
                set_attr(f[where], key, value)
        set_attr(f, "meanings_json", json.dumps(meanings, sort_keys=True))
        f.flush()  # an image built in memory goes to the file here: a failed write raises now
        faults.point("segment-written", path=tmp)


#: segments whose datasets hold at most this many bytes are built in memory (HDF5's "core"
#: driver) and written to the file in one piece; larger ones are written as HDF5 goes (the
#: default driver). The file is the same byte for byte either way (tests/test_hdf5_objects.py).
#: The one write saves HDF5's hundreds of small ones, which is most of the time to write a
#: segment of a few runs on a busy machine; for segments of megabytes both take the same time,
#: and for larger ones growing the image in memory costs more than it saves
IN_MEMORY_BYTES = 4 << 20


def _file_driver(columns: dict[str, Any]) -> dict[str, Any]:
    """h5py's file driver options for a segment of these columns (:data:`IN_MEMORY_BYTES`)."""
    size = sum(
        np.asarray(arr).nbytes
        for group, datasets in columns.items()
        if group[0] != "_"
        for arr in datasets.values()
    )
    if size > IN_MEMORY_BYTES:
        return {}
    return {"driver": "core", "backing_store": True}


#: datasets of at most this many bytes are stored contiguous and uncompressed (a chunk index
#: and filter pipeline would cost more than they save)
_SMALL_BYTES = 4096
#: target chunk sizes (bytes): per-run and per-event columns are read whole (listing, index
#: rebuilds, repair), so they get large chunks that compress best; samples and scenes are read
#: one run at a time, so their chunks stay small enough that one run's read decompresses little
#: beyond that run (load times: benchmarks/results/archive.md)
_CHUNK_BYTES = {"runs": 1 << 20, "summary": 1 << 20, "events": 1 << 20}
_SLICED_CHUNK_BYTES = 1 << 15
_SLICED = {"scene_json", "message", "override_json", "override_values"}
#: float columns of measured values, which gzip shrinks by ~10-20 % at a cost that is most of a
#: segment's write time (benchmarks/results/archive.md): stored chunked, not compressed
_INCOMPRESSIBLE = frozenset(
    {
        ("events", "t_s"),
        ("events", "x_m"),
        ("events", "y_m"),
        ("scene", "override_values"),
        ("runs", "speed_mps"),
        ("runs", "rev_rate_rpm"),
        *(("summary", name) for name in SUMMARY_FLOAT_COLUMNS),
    }
)
#: per-sample storage filters (write_segment's ``samples``)
SAMPLE_FILTERS = ("gzip", "lz4", "none")


@functools.cache
def lz4_filters() -> dict[str, Any]:
    """The dataset options of samples = "lz4": Blosc (HDF5 filter 32001) with its byte shuffle
    and LZ4 at level 5, ~10x gzip's speed for ~12 % more bytes on recorded samples
    (benchmarks/results/pipeline.md). Importing ``hdf5plugin`` registers the filter with h5py
    (~60 ms, so it is done only where samples are written or read: :class:`SegmentFile` does
    it for a segment holding samples); h5dump reads it with HDF5_PLUGIN_PATH set to
    ``hdf5plugin.PLUGIN_PATH``."""
    import hdf5plugin

    return {
        "compression": hdf5plugin.Blosc(cname="lz4", clevel=5, shuffle=hdf5plugin.Blosc.SHUFFLE)
    }


_SAMPLE_GROUPS = {"trajectory", "torques"}
#: HDF5's registered ID of the Blosc filter (what samples = "lz4" stores with)
_BLOSC_ID = 32001


def _uses_blosc(f: h5py.File) -> bool:
    """Whether a per-sample dataset of the file is stored with Blosc, read from the datasets'
    filter pipelines (without importing ``hdf5plugin``, which only decoding needs)."""
    for group_name in _SAMPLE_GROUPS:
        group = f.get(group_name)
        if not isinstance(group, h5py.Group):
            continue
        for ds in group.values():
            if not isinstance(ds, h5py.Dataset):
                continue
            dcpl = ds.id.get_create_plist()
            if any(dcpl.get_filter(i)[0] == _BLOSC_ID for i in range(dcpl.get_nfilters())):
                return True
    return False


def _storage(group: str, name: str, data: NDArray[Any], samples: str = "gzip") -> dict[str, Any]:
    """How a dataset is stored: contiguous when small, else chunked + shuffle + gzip (per-sample
    datasets with ``samples`` "lz4": chunked + Blosc LZ4; with "none", and the measured float
    columns of :data:`_INCOMPRESSIBLE`: chunked, not compressed)."""
    if data.ndim == 0 or data.nbytes <= _SMALL_BYTES:
        return {}
    target = (
        _SLICED_CHUNK_BYTES if name in _SLICED else _CHUNK_BYTES.get(group, _SLICED_CHUNK_BYTES)
    )
    row_bytes = max(1, data.nbytes // max(1, data.shape[0]))
    rows = max(1, min(data.shape[0], target // row_bytes))
    if (samples == "none" and group in _SAMPLE_GROUPS) or (group, name) in _INCOMPRESSIBLE:
        return {"chunks": (rows, *data.shape[1:])}
    if samples == "lz4" and group in _SAMPLE_GROUPS:
        return {"chunks": (rows, *data.shape[1:]), **lz4_filters()}
    return {"chunks": (rows, *data.shape[1:]), **GZIP_FILTERS}


@dataclass(frozen=True)
class _RowBytes:
    """One run's stored values, as read (the digest's input)."""

    run_id: str
    fixed: dict[str, dict[str, NDArray[Any]]]
    #: the scene as stored: the whole scene (2.0-2.2), or for 2.3 on the run's whole scene when it
    #: differs from the base (empty: the base with its column values)
    scene: bytes
    message: bytes
    events: dict[str, NDArray[Any]]
    samples: dict[str, NDArray[Any]]
    torques: dict[str, NDArray[Any]]
    #: per-run record groups: group -> {dataset: the run's rows}
    records: dict[str, dict[str, NDArray[Any]]]
    #: 2.3: the rows of ``scene/override_values`` (else an empty array)
    values: NDArray[np.float64]


@dataclass(frozen=True)
class StoredRecord:
    """One run read back from a segment (digest checked)."""

    run_id: str
    segment_id: str
    row: int
    scene_json: str
    trajectory: Trajectory
    #: per-run provenance (created_at, wall_time_s, solver, ball_ref) and the segment's
    attrs: dict[str, Any]
    #: the run's per-run columns (RUN_STRING_COLUMNS, RUN_FLOAT_COLUMNS, created_at_ns)
    columns: dict[str, Any]
    #: the run's per-run record groups (format 2.1): group -> {dataset: the run's rows}; only
    #: the groups that have rows for this run
    records: dict[str, dict[str, NDArray[Any]]]

    def plan(self) -> Plan:
        """The run's scene resolved (what a reader derives the samples under)."""
        from bowlrec.spec import Scene

        return Scene.model_validate_json(self.scene_json).resolve()

    def to_record(self) -> RunRecord:
        """The run as a segment record again (to rewrite it into another segment)."""
        c = self.columns
        traj = self.trajectory
        return RunRecord(
            run_id=self.run_id,
            scene_json=self.scene_json.encode(),
            summary=traj.summary,
            name=c["name"],
            ball_ref=c["ball_ref"],
            ball_sha=c["ball_sha"],
            pattern=c["pattern"],
            record=c["record"],
            solver=c["solver"],
            speed_mps=c["speed_mps"],
            rev_rate_rpm=c["rev_rate_rpm"],
            mass_kg=c["mass_kg"],
            rtol=c["rtol"],
            wall_time_s=c["wall_time_s"],
            created_at_ns=c["created_at_ns"],
            # a run derived on read needs no plan to be checked against (it is marked)
            trajectory=stored_samples(
                traj, None if traj.derived_from_state() or not traj.n_samples else self.plan()
            ),
            torques=dict(traj.torques_Nm),
            events=[(e.kind, e.mu, e.phase, e.t_s, e.x_m, e.y_m) for e in traj.events],
            records={g: dict(d) for g, d in self.records.items()},
        )


def _has_rows(datasets: dict[str, NDArray[Any]]) -> bool:
    """Whether a run's slice of a record group holds any row (a run without the group reads
    as zero rows)."""
    return bool(datasets) and int(next(iter(datasets.values())).shape[0]) > 0


def _text(value: Any) -> str:
    return bytes(value).decode() if isinstance(value, bytes | np.bytes_) else str(value)


class SegmentFile:
    """A sealed segment opened for reading (a context manager; closes the HDF5 file)."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        try:
            self._f = h5py.File(self.path, "r", locking=False)
        except OSError as err:
            raise SegmentError(f"{self.path}: not a readable HDF5 file ({err})") from None
        try:
            fmt = self._f.attrs.get("format")
            version = str(self._f.attrs.get("format_version", ""))
        except (OSError, RuntimeError, KeyError) as err:
            self._f.close()
            raise SegmentError(f"{self.path}: unreadable header ({err})") from None
        if fmt != SEGMENT_FORMAT:
            self._f.close()
            raise SegmentError(f"{self.path}: not a bowlrec segment (format = {fmt!r})")
        major = version_tuple(version)[0]
        if not 2 <= major <= version_tuple(SEGMENT_FORMAT_VERSION)[0]:
            self._f.close()
            raise SegmentError(
                f"{self.path}: segment format {version} is not supported by this bowlrec "
                f"(it reads 2.x and {SEGMENT_FORMAT_VERSION.split('.')[0]}.x)"
            )
        self.segment_id = str(self._f.attrs["segment_id"])
        self.format_version = version
        #: 2.3 and on: base scene and overrides, event codes, a digest per block of runs
        self.blocks = version_tuple(version) >= (2, 3)
        #: 3.0 and on: samples store the state only, the rest is derived on read
        self.state = version_tuple(version) >= version_tuple(STATE_FORMAT_VERSION)
        # samples stored with Blosc LZ4 need hdf5plugin's filter (imported once per process)
        if self.state and "hdf5plugin" not in sys.modules and _uses_blosc(self._f):
            lz4_filters()
        self._dsets: dict[str, Any] = {}
        self._scene_shared: dict[str, Any] | None = None
        self._names: dict[str, list[str] | None] = {}
        self._columns: dict[str, dict[str, NDArray[Any]]] | None = None
        self._provenance: dict[str, Any] | None = None
        self._terms_cache: list[str] | None = None

    def __enter__(self) -> SegmentFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._f.close()

    @property
    def provenance(self) -> dict[str, Any]:
        """The root attributes (format, segment ID, package versions, platform)."""
        if self._provenance is None:
            self._provenance = {
                k: (v.item() if isinstance(v, np.generic) else v)
                for k, v in self._f.attrs.items()
                if k != "meanings_json"
            }
        return dict(self._provenance)

    @property
    def _terms(self) -> list[str]:
        if self._terms_cache is None:
            self._terms_cache = [_text(t) for t in self._f["torques"].attrs["order"]]
        return self._terms_cache

    @property
    def n_runs(self) -> int:
        return int(self._f.attrs["n_runs"])

    @property
    def has_samples(self) -> bool:
        """Whether any run of the segment has samples."""
        offsets = self._f["trajectory/offsets"]
        return bool(offsets.shape[0] and int(offsets[-1]))

    def run_ids(self) -> list[str]:
        return [_text(v) for v in self._f["runs/run_id"][()]]

    def index_columns(self) -> dict[str, NDArray[Any]]:
        """Every fixed-width per-run column (runs/* and summary/* but the variable-length
        bytes), whole: what the index needs, read without touching scenes or samples."""
        out: dict[str, NDArray[Any]] = {}
        for group in ("runs", "summary"):
            g = self._f[group]
            for name in g:
                if name in _VARIABLE:
                    continue
                out[name] = g[name][()]
        out["n_samples"] = np.diff(self._f["trajectory/offsets"][()])
        out.update(self.pin_index_columns() or pin_index_columns(self.n_runs, None))
        return out

    def pin_index_columns(self) -> dict[str, NDArray[Any]] | None:
        """The index's ``pinfall`` and ``leave`` of every run (format 2.2), or None when no
        run of the segment has pins."""
        pins = self._f.get("pin_outcome")
        if not isinstance(pins, h5py.Group) or "offsets" not in pins:
            return None
        group = {k: pins[k][()] for k in ("offsets", "pinfall", "leave")}
        return pin_index_columns(self.n_runs, group)

    # -- one run -------------------------------------------------------------------------------

    def _ds(self, path: str) -> Any:
        """A dataset handle, opened once per file (opening costs more than a small read)."""
        ds = self._dsets.get(path)
        if ds is None:
            ds = self._dsets[path] = self._f[path]
        return ds

    def _per_run(self) -> dict[str, dict[str, NDArray[Any]]]:
        """Every per-run column and offsets dataset, read whole once and kept: the fixed-width
        columns of runs/* and summary/*, and each group's offsets."""
        if self._columns is None:
            cols: dict[str, dict[str, NDArray[Any]]] = {}
            for group in ("runs", "summary"):
                g = self._f[group]
                cols[group] = {name: read_whole(g, name) for name in g if name not in _VARIABLE}
            scene_offsets = "scene/override_offsets" if self.blocks else "runs/scene_json_offsets"
            cols["offsets"] = {
                "scene_json": read_whole(self._f, scene_offsets),
                "message": read_whole(self._f, "summary/message_offsets"),
                **{
                    g: read_whole(self._f, f"{g}/offsets")
                    for g in self._f
                    if isinstance(self._f[g], h5py.Group) and "offsets" in self._f[g]
                },
            }
            self._columns = cols
        return self._columns

    def _span(self, offsets: str, row: int, end: int | None = None) -> tuple[int, int]:
        """Rows ``row:end`` (default one run) of a group with offsets, as data row bounds."""
        off = self._per_run()["offsets"][offsets]
        return int(off[row]), int(off[row + 1 if end is None else end])

    def _read_row(self, row: int, end: int | None = None) -> _RowBytes:
        """Everything stored for run ``row`` (or runs ``row:end``, concatenated: a digest block)
        (RunDamagedError when it cannot be read)."""
        f = self._f
        stop = row + 1 if end is None else end
        try:
            cols = self._per_run()
            fixed = {
                group: {name: arr[row:stop] for name, arr in cols[group].items()}
                for group in ("runs", "summary")
            }
            run_id = _text(fixed["runs"]["run_id"][0])
        except (OSError, RuntimeError, KeyError, ValueError, IndexError, TypeError) as err:
            raise RunDamagedError(f"row {row}", self.segment_id, f"unreadable: {err}") from None
        try:
            s0, s1 = self._span("scene_json", row, end)
            m0, m1 = self._span("message", row, end)
            e0, e1 = self._span("events", row, end)
            t0, t1 = self._span("trajectory", row, end)
            q0, q1 = self._span("torques", row, end)
            tg = f["trajectory"]
            ds = self._ds
            scene_ds = "scene/override_json" if self.blocks else "runs/scene_json"
            data = _RowBytes(
                run_id=run_id,
                fixed=fixed,
                scene=ds(scene_ds)[s0:s1].tobytes(),
                message=ds("summary/message")[m0:m1].tobytes(),
                events={k: ds(f"events/{k}")[e0:e1] for k in EVENT_FIELDS},
                samples={k: ds(f"trajectory/{k}")[t0:t1] for k in self._sample_fields if k in tg},
                torques={t: ds(f"torques/{t}")[q0:q1] for t in self._terms} if q1 > q0 else {},
                records=self._record_rows(row, end),
                values=ds("scene/override_values")[row:stop]
                if self.blocks
                else np.zeros((0, 0), dtype=np.float64),
            )
        except (OSError, RuntimeError, KeyError, ValueError, IndexError) as err:
            raise RunDamagedError(run_id, self.segment_id, f"unreadable: {err}") from None
        return data

    @staticmethod
    def _digest(d: _RowBytes) -> bytes:
        n_events = int(d.events["t_s"].shape[0])
        n_samples = int(d.samples["t_s"].shape[0]) if d.samples else 0
        n_torques = int(next(iter(d.torques.values())).shape[0]) if d.torques else 0
        return run_digest(
            row_matrix(fixed_columns(d.fixed["runs"], d.fixed["summary"]), 1)[0].data,
            d.scene,
            d.message,
            row_matrix(event_columns(d.events), n_events).data,
            row_matrix(sample_columns(d.samples), n_samples).data,
            row_matrix(list(d.torques.values()), n_torques).data,
            *(
                row_matrix(
                    [rows[k] for k in sorted(rows)],
                    int(next(iter(rows.values())).shape[0]) if rows else 0,
                ).data
                for _, rows in sorted(d.records.items())
            ),
        )

    # -- 2.3: digest blocks and scenes -----------------------------------------------------------

    @property
    def block_runs(self) -> int:
        """Runs per digest block (2.3; 1 for an earlier segment: a digest per run)."""
        return int(self._f["digest"].attrs["block_runs"]) if self.blocks else 1

    def _shared(self) -> dict[str, Any]:
        """The segment's base scene and override paths (2.3), read once."""
        if self._scene_shared is None:
            g = self._f["scene"]
            paths_raw = g["override_paths"][()]
            self._scene_shared = {
                "base_json": g["base_json"][()],
                "override_paths": paths_raw,
                "paths": [json.loads(_text(p)) for p in paths_raw.tolist()],
                "blocks": self._f["digest/blocks"][()],
            }
        return self._scene_shared

    def _block_digest(self, d: _RowBytes, n: int) -> int:
        """The CRC-32 of a block of ``n`` runs read by :meth:`_read_row` (see
        :func:`~bowlrec.archive.segment_format.digest_parts`)."""
        shared = self._shared()
        scene = {
            "base_json": shared["base_json"],
            "override_paths": shared["override_paths"],
            "override_values": d.values,
        }
        fixed = row_matrix(fixed_columns(d.fixed["runs"], d.fixed["summary"]), n)
        sizes = [
            len(d.scene),
            len(d.message),
            int(d.events["t_s"].shape[0]),
            int(d.samples["t_s"].shape[0]) if d.samples else 0,
            int(next(iter(d.torques.values())).shape[0]) if d.torques else 0,
        ]
        mats: list[Any] = [
            np.frombuffer(d.scene, dtype=np.uint8),
            np.frombuffer(d.message, dtype=np.uint8),
            row_matrix(event_columns(d.events), sizes[2]),
            None,  # the samples: their parts below
            row_matrix(list(d.torques.values()), sizes[4]),
        ]
        for _, rows in sorted(d.records.items()):
            size = int(next(iter(rows.values())).shape[0]) if rows else 0
            sizes.append(size)
            mats.append(row_matrix([rows[k] for k in sorted(rows)], size))
        parts = [(m, _block_offsets(n, size)) for m, size in zip(mats, sizes, strict=True)]
        parts[3:4] = sample_parts(d.samples, parts[3][1], self.state)
        return block_digest(digest_parts(scene, fixed, parts, 0, n))

    def _check_block(self, row: int) -> None:
        """RunDamagedError unless the digest block holding run ``row`` matches its digest."""
        size = self.block_runs
        a = row // size * size
        b = min(self.n_runs, a + size)
        d = self._read_row(a, b)
        try:
            stored = int(self._shared()["blocks"][row // size])
        except (OSError, RuntimeError, KeyError, ValueError, IndexError) as err:
            raise RunDamagedError(d.run_id, self.segment_id, f"unreadable: {err}") from None
        if self._block_digest(d, b - a) != stored:
            run_id = _text(self._per_run()["runs"]["run_id"][row])
            raise RunDamagedError(run_id, self.segment_id, "digest mismatch")

    def scene_text(self, row: int, d: _RowBytes | None = None) -> str:
        """Run ``row``'s scene (compact JSON): stored whole (2.0-2.2) or rebuilt from the base
        and the run's overrides (2.3)."""
        d = self._read_row(row) if d is None else d
        if not self.blocks:
            return d.scene.decode()
        try:
            shared = self._shared()
            return scene_text(
                shared["base_json"].tobytes(), shared["paths"], d.values[0].tolist(), d.scene
            )
        except (OSError, RuntimeError, ValueError, KeyError, IndexError, TypeError) as err:
            raise RunDamagedError(d.run_id, self.segment_id, f"unreadable scene: {err}") from None

    def computed_digest(self, row: int) -> bytes:
        """The digest of run ``row`` computed from its stored bytes (what ``runs/digest`` must
        hold, 2.0-2.2; for 2.3 the CRC-32 of its block as 8 hex digits; see
        docs/archive-format.md, "Digests")."""
        if self.blocks:
            size = self.block_runs
            a = row // size * size
            b = min(self.n_runs, a + size)
            return f"{self._block_digest(self._read_row(a, b), b - a):08x}".encode()
        return self._digest(self._read_row(row))

    def read_run(self, row: int) -> StoredRecord:
        """Run ``row`` with its digest checked (:class:`RunDamagedError` when it fails)."""
        if self.blocks:
            self._check_block(row)
            d = self._read_row(row)
        else:
            d = self._read_row(row)
            if self._digest(d) != bytes(d.fixed["runs"]["digest"][0]):
                raise RunDamagedError(d.run_id, self.segment_id, "digest mismatch")
        return self._record(
            row,
            d.run_id,
            d.fixed,
            self.scene_text(row, d).encode(),
            d.message,
            d.events,
            d.samples,
            d.torques,
            d.records,
        )

    def _event_text(self, name: str, values: NDArray[Any]) -> list[str]:
        """An event column as text: stored as text (2.0-2.2) or as codes (2.3)."""
        if name not in self._names:
            attr = self._f[f"events/{name}"].attrs.get("names_json")
            self._names[name] = None if attr is None else json.loads(_text(attr))
        names = self._names[name]
        if names is None:
            return [_text(v) for v in values]
        return [names[int(c)] for c in values]

    def _record(
        self,
        row: int,
        run_id: str,
        fixed: dict[str, dict[str, NDArray[Any]]],
        scene: bytes,
        message: bytes,
        events: dict[str, NDArray[Any]],
        samples: dict[str, NDArray[Any]],
        torques: dict[str, NDArray[Any]],
        records: dict[str, dict[str, NDArray[Any]]],
    ) -> StoredRecord:
        r, s = fixed["runs"], fixed["summary"]
        values: dict[str, Any] = {"outcome": _text(s["outcome"][0]), "message": message.decode()}
        for name in SUMMARY_FLOAT_COLUMNS:
            v = float(s[name][0])
            values[name] = None if np.isnan(v) else v
        for name in SUMMARY_INT_COLUMNS:
            values[name] = int(s[name][0])
        summary = Summary(**values)
        kinds = self._event_text("kind", events["kind"])
        phases = self._event_text("phase", events["phase"])
        evs = [
            Event(
                t_s=float(events["t_s"][i]),
                kind=kinds[i],
                x_m=float(events["x_m"][i]),
                y_m=float(events["y_m"][i]),
                mu=float(events["mu"][i]),
                phase=phases[i],
            )
            for i in range(int(events["t_s"].shape[0]))
        ]
        derived = False
        if not samples:
            samples = _empty_samples()
        elif self.state and not all(k in samples for k in DERIVED_FIELDS):
            derived = True
            try:
                samples = derived_samples(samples, scene.decode())
            except (ValueError, KeyError, TypeError) as err:
                reason = f"unreadable samples: {err}"
                raise RunDamagedError(run_id, self.segment_id, reason) from None
        arrays: dict[str, Any] = dict(samples)
        own = {g: d for g, d in records.items() if _has_rows(d)}
        traj = Trajectory(
            **arrays,
            events=evs,
            summary=summary,
            torques_Nm=dict(torques),
            pins=pin_outcome_of(own),
        )
        if derived:
            traj.mark_derived_from_state()
        attrs = {k: v for k, v in self.provenance.items() if k not in ("n_runs",)}
        engine = pin_engine(own)
        if engine is not None:
            attrs["pin_engine_version"] = engine
        attrs.update(
            {
                "ball_ref": _text(r["ball_ref"][0]),
                "solver": _text(r["solver"][0]),
                "wall_time_s": float(r["wall_time_s"][0]),
                "created_at_ns": int(r["created_at_ns"][0]),
            }
        )
        columns: dict[str, Any] = {k: _text(r[k][0]) for k in RUN_STRING_COLUMNS}
        columns.update({k: float(r[k][0]) for k in RUN_FLOAT_COLUMNS})
        columns["created_at_ns"] = int(r["created_at_ns"][0])
        return StoredRecord(run_id, self.segment_id, row, scene.decode(), traj, attrs, columns, own)

    # -- every run -----------------------------------------------------------------------------

    def verify(self) -> tuple[list[int], dict[int, str]]:
        """Check every run's digest: (healthy rows, {damaged row: reason})."""
        if self.blocks:
            return self._verify_blocks()
        f = self._f
        n = self.n_runs
        try:
            cols = self.index_columns()
            runs = {k: v for k, v in cols.items() if k in f["runs"] and k != "n_samples"}
            summary = {k: v for k, v in cols.items() if k in f["summary"]}
            fixed = row_matrix(fixed_columns(runs, summary), n)
        except (OSError, RuntimeError, KeyError, ValueError) as err:
            return [], {i: f"unreadable per-run columns: {err}" for i in range(n)}
        parts: dict[str, tuple[Any, NDArray[np.int64]]] = {}
        broken: str | None = None
        readers: dict[str, Callable[[], tuple[Any, NDArray[np.int64]]]] = {
            "scene": lambda: (f["runs/scene_json"][()], f["runs/scene_json_offsets"][()]),
            "message": lambda: (f["summary/message"][()], f["summary/message_offsets"][()]),
            "events": lambda: self._matrix("events", EVENT_FIELDS),
            "samples": lambda: self._matrix("trajectory", TRAJECTORY_FIELDS),
            "torques": lambda: self._matrix(
                "torques", [_text(t) for t in f["torques"].attrs["order"]]
            ),
        }
        for g in self._extra_groups():
            names = sorted(k for k in self._f[g] if k != "offsets")
            readers[g] = functools.partial(self._matrix, g, names)
        for key, read in readers.items():
            try:
                parts[key] = read()
            except (OSError, RuntimeError, KeyError, ValueError) as err:
                broken = broken or f"unreadable {key}: {err}"
        if broken is not None:
            # one damaged chunk makes a whole dataset unreadable: check run by run, reading
            # only each run's own slices (as load() does), so that healthy runs are kept
            healthy_rows: list[int] = []
            damaged_rows: dict[int, str] = {}
            for i in range(n):
                try:
                    self.read_run(i)
                    healthy_rows.append(i)
                except RunDamagedError as err:
                    damaged_rows[i] = err.reason
            return healthy_rows, damaged_rows
        healthy: list[int] = []
        damaged: dict[int, str] = {}
        for i in range(n):
            slices = []
            for key in parts:
                data, offsets = parts[key]
                slices.append(data[offsets[i] : offsets[i + 1]].data)
            if run_digest(fixed[i].data, *slices) == bytes(runs["digest"][i]):
                healthy.append(i)
            else:
                damaged[i] = "digest mismatch"
        return healthy, damaged

    def _verify_blocks(self) -> tuple[list[int], dict[int, str]]:
        """:meth:`verify` of a 2.3 segment: every block's digest, from the datasets read whole
        (block by block, each reading only its own slices, when a dataset cannot be read)."""
        f = self._f
        n, size = self.n_runs, self.block_runs
        try:
            cols = self._per_run()
            fixed = row_matrix(fixed_columns(cols["runs"], cols["summary"]), n)
            shared = self._shared()
            scene = {
                "base_json": shared["base_json"],
                "override_paths": shared["override_paths"],
                "override_values": f["scene/override_values"][()],
            }
            parts = [
                (f["scene/override_json"][()], f["scene/override_offsets"][()]),
                (f["summary/message"][()], f["summary/message_offsets"][()]),
                self._matrix("events", EVENT_FIELDS),
                *self._sample_parts(),
                self._matrix("torques", self._terms),
                *(
                    self._matrix(g, sorted(k for k in f[g] if k != "offsets"))
                    for g in self._extra_groups()
                ),
            ]
        except (OSError, RuntimeError, KeyError, ValueError):
            healthy_rows: list[int] = []
            damaged_rows: dict[int, str] = {}
            for a in range(0, n, size):
                rows = range(a, min(n, a + size))
                try:
                    self._check_block(a)
                    healthy_rows.extend(rows)
                except RunDamagedError as err:
                    damaged_rows.update({i: err.reason for i in rows})
            return healthy_rows, damaged_rows
        healthy: list[int] = []
        damaged: dict[int, str] = {}
        for k, a in enumerate(range(0, n, size)):
            b = min(n, a + size)
            if block_digest(digest_parts(scene, fixed, parts, a, b)) == int(shared["blocks"][k]):
                healthy.extend(range(a, b))
            else:
                damaged.update({i: "digest mismatch" for i in range(a, b)})
        return healthy, damaged

    def unknown_groups(self) -> list[str]:
        """Groups this reader does not know: neither a fixed group nor a per-run record group
        (a group with ``offsets``). It cannot rewrite them into another segment."""
        return sorted(
            g for g in self._f if g not in _KNOWN_GROUPS and g not in self._extra_groups()
        )

    def _extra_groups(self) -> list[str]:
        """The per-run record groups (format 2.1 and on): groups beyond the fixed ones that
        have an ``offsets`` dataset, in sorted name order."""
        return sorted(
            g
            for g in self._f
            if g not in _KNOWN_GROUPS
            and isinstance(self._f[g], h5py.Group)
            and "offsets" in self._f[g]
        )

    def _record_rows(self, row: int, end: int | None = None) -> dict[str, dict[str, NDArray[Any]]]:
        """Run ``row``'s (or runs ``row:end``'s) rows of every per-run record group (zero rows
        where it has none)."""
        out = {}
        for g in self._extra_groups():
            a, b = self._span(g, row, end)
            out[g] = {k: self._ds(f"{g}/{k}")[a:b] for k in sorted(self._f[g]) if k != "offsets"}
        return out

    @property
    def _sample_fields(self) -> tuple[str, ...]:
        """The per-sample datasets this segment's format stores."""
        return STATE_FIELDS + DERIVED_FIELDS if self.state else TRAJECTORY_FIELDS

    def _sample_parts(self) -> list[tuple[NDArray[Any], NDArray[np.int64]]]:
        """Every run's samples as the block digests take them (read whole)."""
        g = self._f["trajectory"]
        offsets = g["offsets"][()]
        return sample_parts(
            {k: g[k][()] for k in self._sample_fields if k in g}, offsets, self.state
        )

    def _matrix(self, group: str, names: Any) -> tuple[NDArray[np.uint8], NDArray[np.int64]]:
        g = self._f[group]
        offsets = g["offsets"][()]
        cols = [g[k][()] for k in names if k in g]
        return row_matrix(cols, int(offsets[-1])), offsets

    def read_all(self, rows: list[int] | None = None) -> list[StoredRecord]:
        """Several runs (every run when ``rows`` is None), digests checked."""
        return [self.read_run(i) for i in (range(self.n_runs) if rows is None else rows)]


def _block_offsets(n: int, size: int) -> NDArray[np.int64]:
    """Offsets (n+1,) of a block of ``n`` runs holding ``size`` rows together: the block
    starts at 0 and ends at ``size`` (all a block digest reads of them)."""
    out = np.full(n + 1, size, dtype=np.int64)
    out[0] = 0
    return out


def _empty_samples() -> dict[str, NDArray[Any]]:
    shapes = {
        "alpha_radps2": (0, 3),
        "energy_J": (0,),
        "friction_force_N": (0, 3),
        "mu": (0,),
        "normal_force_N": (0,),
        "omega_radps": (0, 3),
        "position_m": (0, 3),
        "quaternion_wxyz": (0, 4),
        "slip_mps": (0, 3),
        "t_s": (0,),
        "velocity_mps": (0, 3),
    }
    out: dict[str, NDArray[Any]] = {k: np.zeros(s) for k, s in shapes.items()}
    out["phase"] = np.zeros(0, dtype=np.int8)
    return out

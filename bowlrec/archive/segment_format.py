"""The segment format's shared parts: format strings, column names, the run record, the
sealed segment's info and the per-run digest (docs/archive-format.md, "Segments" and
"Digests").

Both sides of a segment use them: :mod:`.segment` builds and seals segments,
:mod:`.segment_file` writes and reads the HDF5 files.
"""

from __future__ import annotations

import hashlib
import time
import uuid
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.core.trajectory import FLOAT_METRICS, INT_METRICS, STATE_SAMPLE_FIELDS, Summary
from bowlrec.pins.records import PIN_GROUPS

from .derived import DERIVED_FIELDS, given_samples
from .pin_records import PINS_FORMAT_VERSION

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Trajectory
    from bowlrec.sinks.common import RunData

__all__ = [
    "EVENT_FIELDS",
    "FIXED_GROUPS",
    "PIN_GROUPS",
    "PINS_FORMAT_VERSION",
    "RECORDS_FORMAT_VERSION",
    "RUN_FLOAT_COLUMNS",
    "RUN_STRING_COLUMNS",
    "DIGEST_ALGORITHM",
    "SCENE_FORMAT_VERSION",
    "STATE_FIELDS",
    "STATE_FORMAT_VERSION",
    "SEGMENT_FORMAT",
    "SEGMENT_FORMAT_VERSION",
    "SUMMARY_FLOAT_COLUMNS",
    "SUMMARY_INT_COLUMNS",
    "TRAJECTORY_FIELDS",
    "RunRecord",
    "SegmentInfo",
    "check_records",
    "event_columns",
    "fixed_columns",
    "format_version_of",
    "new_segment_id",
    "block_digest",
    "block_runs_for",
    "digest_parts",
    "row_matrix",
    "run_digest",
    "sample_columns",
    "sample_parts",
    "stored_samples",
    "version_tuple",
]

SEGMENT_FORMAT = "bowlrec-segment"
#: major.minor this code writes for a segment holding samples: the recorded state only, every
#: other per-sample quantity derived on read (docs/archive-format.md). A segment without
#: samples has the 2.3 layout and declares 2.3. Readers accept 2.0 and on.
SEGMENT_FORMAT_VERSION = "3.0"
#: the first version that stores the state of each sample only (STATE_FIELDS); a 2.x reader
#: cannot read its samples, so it refuses the segment by its major version
STATE_FORMAT_VERSION = "3.0"
#: the first minor version with that layout (segments before it store every run's scene whole,
#: event kinds and phases as text, and one BLAKE2b digest per run in ``runs/digest``)
SCENE_FORMAT_VERSION = "2.3"
#: the minor version a 2.1 writer declared for a segment with per-run record groups
RECORDS_FORMAT_VERSION = "2.1"
#: groups with a fixed place in the digest; any other group with an ``offsets`` dataset is a
#: per-run record group (after the fixed parts, groups in sorted name order)
FIXED_GROUPS = frozenset({"runs", "summary", "events", "trajectory", "torques", "scene", "digest"})
#: the 2.3 digest: CRC-32 (zlib's, the polynomial of gzip and PNG) of each block of runs. It
#: detects accidental damage (a flipped bit, a torn or misplaced write: every burst of up to 32
#: bits, other damage but with probability 2**-32), which is all a digest stored beside its data
#: can do: whoever can rewrite the data can rewrite its digest, so a cryptographic hash would
#: buy nothing here, at ~4x the time (docs/archive-format.md, "Digests")
DIGEST_ALGORITHM = "crc32"
#: runs per digest block in a segment of summary-only runs (a block is read whole to check one
#: run of it); a segment holding samples, torques or record-group rows digests each run alone
SUMMARY_BLOCK_RUNS = 256

#: summary metrics stored as float64 columns (NaN stands for None) and as int64 columns
SUMMARY_FLOAT_COLUMNS = FLOAT_METRICS
SUMMARY_INT_COLUMNS = INT_METRICS
#: per-sample quantities stored from format 3.0 on (the recorded state, the friction's
#: direction), in the digest's order; the others of TRAJECTORY_FIELDS are derived on read
STATE_FIELDS = STATE_SAMPLE_FIELDS
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
    #: per-sample arrays by STATE_FIELDS name, and by DERIVED_FIELDS name when they are stored
    #: as given (:func:`stored_samples`; empty for a summary-only run)
    trajectory: dict[str, NDArray[Any]] = field(default_factory=dict)
    #: per-term torques (n, 3) in N m, only when recorded
    torques: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    #: events as (kind, mu, phase, t_s, x_m, y_m) tuples
    events: list[tuple[str, float, str, float, float, float]] = field(default_factory=list)
    #: per-run record groups (format 2.1): group name -> {dataset name: array}, the arrays of a
    #: group with equal first dimensions (the run's rows of that group), e.g. the oil grid after
    #: a session's shot (``bowlrec.session.records``) or the run's pins (format 2.2,
    #: :mod:`bowlrec.pins.records`; :meth:`from_run` adds them)
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
        scene_json: bytes | None = None,
        samples: dict[str, NDArray[Any]] | None = None,
    ) -> RunRecord:
        """A finished run (scene, plan, trajectory) as a record; ``run.run_id`` must be set;
        ``records``: its per-run record groups (see :attr:`RunRecord.records`); ``scene_json``:
        the run's scene as ``run.scene_json()`` writes it, when the caller has it already (a
        delivery sweep prepares it without a Scene per run: ``run.scene`` is then its base
        scene, which gives the fields a sweep does not vary: name, record, pins); ``samples``:
        the run's recorded state when the trajectory carries none
        (:func:`bowlrec.core.solver.solve_state`: the kernel's, stored as it is)."""
        assert run.run_id is not None, "a run needs its content ID before it is archived"
        plan, traj = run.plan, run.trajectory
        v, w = plan.velocity0_mps, plan.omega0_radps
        return cls(
            run_id=run.run_id,
            scene_json=run.scene_json().encode() if scene_json is None else scene_json,
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
            trajectory=stored_samples(traj, plan) if samples is None else samples,
            torques=dict(traj.torques_Nm),
            events=[(e.kind, e.mu, e.phase, e.t_s, e.x_m, e.y_m) for e in traj.events],
            records=check_records(run.run_id, {**_pin_records(run), **(records or {})}),
        )


def stored_samples(traj: Trajectory, plan: Plan | None) -> dict[str, NDArray[Any]]:
    """A trajectory's samples as a segment stores them (empty without samples): STATE_FIELDS,
    and DERIVED_FIELDS too when the state does not give them back bit for bit under ``plan``
    (:func:`~bowlrec.archive.derived.given_samples`). The friction's direction is the kernel's
    where the trajectory carries it, else the direction of the stored friction force (a run
    read from an older format: 0 where there is none; a rolling sample's direction is never
    used), and then the derived quantities are stored as given. ``plan`` may be None only for
    a trajectory without samples or one marked as derived from its state."""
    if not traj.n_samples:
        return {}
    out = {k: getattr(traj, k) for k in STATE_FIELDS if k != "friction_dir"}
    direction = traj.friction_dir
    if direction is None:
        force = np.asarray(traj.friction_force_N, dtype=np.float64)[:, :2]
        size = np.hypot(force[:, 0], force[:, 1])[:, None]
        out["friction_dir"] = np.divide(force, size, out=np.zeros_like(force), where=size > 0)
        # a direction rebuilt from the force does not give the force back bit for bit: the
        # derived quantities are stored as given, without deriving them to find out
        out.update({k: np.ascontiguousarray(getattr(traj, k)) for k in DERIVED_FIELDS})
        return out
    out["friction_dir"] = np.ascontiguousarray(direction, dtype=np.float64)
    out.update(given_samples(out, traj, plan))
    return out


def _pin_records(run: RunData) -> dict[str, dict[str, NDArray[Any]]]:
    """The record groups of the run's pins (format 2.2; none without pin action): every
    sample of their motion when the run records samples, else where they came to rest."""
    pins = run.trajectory.pins
    if pins is None:
        return {}
    from bowlrec.pins.records import pin_groups

    return pin_groups(pins, samples=run.scene.options.record != "summary")


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
    """BLAKE2b-128 of one run's stored bytes in a segment of format 2.0-2.2 (docs/
    archive-format.md, "Digests"; 2.3 digests blocks of runs: :func:`block_digest`).

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


def block_digest(parts: Sequence[bytes | memoryview]) -> int:
    """CRC-32 of one block of runs (2.3, docs/archive-format.md "Digests"): each part preceded
    by its length (8 bytes, little-endian), as an unsigned 32-bit integer."""
    crc = 0
    for part in parts:
        crc = zlib.crc32(memoryview(part).nbytes.to_bytes(8, "little"), crc)
        crc = zlib.crc32(part, crc)
    return crc


def digest_parts(
    scene: dict[str, NDArray[Any]],
    fixed: NDArray[np.uint8],
    parts: Sequence[tuple[NDArray[Any], NDArray[np.int64]]],
    a: int,
    b: int,
) -> list[bytes | memoryview]:
    """The digested bytes of the block of runs ``a:b`` (2.3, docs/archive-format.md
    "Digests"): the base scene, the override paths, the block's rows of the fixed columns and of
    the override values, then its slice of each of ``parts`` (a dataset's row matrix and its
    offsets: override JSON, messages, events, samples, torques, record groups in order)."""
    values = scene["override_values"]
    out: list[bytes | memoryview] = [
        np.ascontiguousarray(scene["base_json"]).data,
        np.ascontiguousarray(scene["override_paths"]).tobytes(),
        fixed[a:b].data,
        np.ascontiguousarray(values[a:b]).tobytes(),
    ]
    for matrix, offsets in parts:
        out.append(np.ascontiguousarray(matrix[int(offsets[a]) : int(offsets[b])]).data)
    return out


def block_runs_for(has_rows: bool) -> int:
    """Runs per digest block: one when the segment holds samples, torques or record-group rows
    (a run is read alone), else :data:`SUMMARY_BLOCK_RUNS`."""
    return 1 if has_rows else SUMMARY_BLOCK_RUNS


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


def sample_parts(
    samples: dict[str, NDArray[Any]], offsets: NDArray[np.int64], state: bool
) -> list[tuple[NDArray[Any], NDArray[np.int64]]]:
    """The digest parts of a segment's samples (rows ``offsets``): from 3.0 on (``state``) one
    part per STATE_FIELDS dataset, then one per DERIVED_FIELDS dataset the segment stores, its
    bytes as stored (no copy); before, one part of the TRAJECTORY_FIELDS side by side per
    sample (:func:`row_matrix`)."""
    rows = int(offsets[-1])
    if not state:
        return [(row_matrix(sample_columns(samples), rows), offsets)]
    out = []
    for k in STATE_FIELDS + tuple(k for k in DERIVED_FIELDS if k in samples):
        arr = np.ascontiguousarray(samples[k]) if k in samples else np.zeros((rows, 0), np.uint8)
        width = int(np.prod(arr.shape[1:], dtype=np.int64)) * arr.dtype.itemsize
        out.append((arr.reshape(-1).view(np.uint8).reshape(rows, width), offsets))
    return out


def version_tuple(version: str) -> tuple[int, int]:
    """``major.minor`` as integers ((0, 0) for what is not a version)."""
    parts = version.split(".")
    try:
        return int(parts[0]), int(parts[1]) if len(parts) > 1 else 0
    except ValueError:
        return 0, 0


def format_version_of(columns: dict[str, Any]) -> str:
    """The segment format version of a segment's datasets: 3.0 when they hold samples (the
    state only), else 2.3 for the layout this code writes (a ``scene`` group); for the earlier
    layout 2.2 when they hold a run's pins (:data:`PIN_GROUPS`), 2.1 when they hold other
    per-run record groups, else 2.0."""
    if "scene" in columns:
        offsets = columns.get("trajectory", {}).get("offsets")
        if offsets is not None and len(offsets) and int(offsets[-1]):
            return STATE_FORMAT_VERSION
        return SCENE_FORMAT_VERSION
    extra = {g for g in columns if g not in FIXED_GROUPS and not g.startswith("_")}
    if extra & set(PIN_GROUPS):
        return PINS_FORMAT_VERSION
    return RECORDS_FORMAT_VERSION if extra else "2.0"

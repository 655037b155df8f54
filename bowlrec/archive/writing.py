"""Writing runs: a finished run made a segment record, segments sealed (any process) and
registered in the index (one process at a time, under the writer lock), one run added.

A writer killed at any moment loses at most its unsealed runs: a sealed segment the index
lacks is registered by the next writer's recovery (:mod:`.maintenance`). Group commit (many
threads, one segment) is :mod:`.group_commit`.
"""

from __future__ import annotations

import os
import sqlite3
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.errors import ArchiveWriteError

from . import faults
from .ball_files import ball_sha
from .directory import ArchiveDir
from .index import transaction
from .maintenance import writer_index
from .queries import locate
from .run_id import run_id as content_id

if TYPE_CHECKING:
    from bowlrec.core.trajectory import Trajectory
    from bowlrec.sinks.common import RunData
    from bowlrec.spec import Scene

    from .segment import SegmentBuilder, SummaryRuns
    from .segment_format import RunRecord, SegmentInfo

__all__ = ["AddResult", "add", "make_record", "new_builder", "pattern_label", "register", "seal"]


@dataclass(frozen=True)
class AddResult:
    """What :func:`add` (``Archive.add``) or :func:`bowlrec.api.simulate_into` did."""

    run_id: str
    #: the segment file that holds the run
    path: Path
    #: False when the run was already archived (nothing was written)
    added: bool
    #: the trajectory (simulated now, or read back from the archive when it already existed)
    trajectory: Trajectory | None = None


def pattern_label(scene: Scene) -> str:
    """The lane's oil pattern for filtering: the preset or pattern-sheet name a bowler scene
    was built from, else the friction map's kind (typical, zones, constant, grid)."""
    friction = scene.lane.friction
    return str(getattr(friction, "pattern", None) or friction.kind)


#: id(ball) -> (ball, its SHA-256): a batch appends the same ball object many times
_BALL_SHAS: dict[int, tuple[Any, str]] = {}


def _ball_sha(ball: Any) -> str:
    cached = _BALL_SHAS.get(id(ball))
    if cached is not None and cached[0] is ball:
        return cached[1]
    sha = ball_sha(ball)
    if len(_BALL_SHAS) > 4096:
        _BALL_SHAS.clear()
    _BALL_SHAS[id(ball)] = (ball, sha)
    return sha


def make_record(
    run: RunData,
    library_refs: Callable[[], Mapping[str, str]],
    *,
    wall_time_s: float,
    ball_ref: str | None = None,
    solver: str = "",
    created_at_ns: int | None = None,
    records: dict[str, dict[str, Any]] | None = None,
) -> RunRecord:
    """A finished run (its ``run_id`` set) as a segment record. ``ball_ref`` None: the
    library entry with the ball's spec, looked up in ``library_refs()`` (ball-spec SHA-256 ->
    ``name@version``); ``wall_time_s`` in s; ``created_at_ns`` ns since the epoch (None: now);
    ``records``: its per-run record groups (:attr:`~.segment_format.RunRecord.records`)."""
    from .segment_format import RunRecord

    sha = _ball_sha(run.scene.ball)
    if ball_ref is None:
        ball_ref = library_refs().get(sha, "")
    return RunRecord.from_run(
        run,
        wall_time_s=wall_time_s,
        ball_ref=ball_ref,
        solver=solver,
        ball_sha=sha,
        pattern=pattern_label(run.scene),
        created_at_ns=created_at_ns,
        records=records,
    )


def new_builder(*, samples: str = "gzip") -> SegmentBuilder:
    """A segment builder carrying this process's provenance; ``samples``: the storage filter
    of per-sample datasets, "gzip" or "none" (faster; compaction recompresses)."""
    from bowlrec.provenance import environment

    from .segment import SegmentBuilder

    return SegmentBuilder(environment(), samples=samples)


def _os_reason(err: OSError) -> str:
    """A one-line reason for an OSError (h5py's strerror is HDF5's whole multi-line report)."""
    if err.errno:
        return os.strerror(err.errno)
    return " ".join(str(err).split())


def seal(
    d: ArchiveDir, builder: SegmentBuilder | SummaryRuns, *, durable: bool = True
) -> SegmentInfo:
    """Write the builder's runs (or columns of summary-only runs) as a sealed segment in
    ``segments/`` (not yet registered). Needs no lock. ArchiveWriteError when it cannot."""
    from bowlrec.provenance import environment

    from .segment import SummaryRuns, seal_columns

    try:
        if isinstance(builder, SummaryRuns):
            return seal_columns(d.segments_dir, builder.columns(), environment(), durable=durable)
        return builder.seal(d.segments_dir, durable=durable)
    except OSError as err:
        raise ArchiveWriteError(
            f"{d.segments_dir}: could not write a segment of {len(builder)} run(s) "
            f"({_os_reason(err)}); nothing already archived was lost"
        ) from None


def _dead_runs(con: sqlite3.Connection, paths: Sequence[Path]) -> dict[str, set[str]]:
    """Run IDs a tombstone names, by segment ID, for the segments at ``paths``."""
    dead: dict[str, set[str]] = {}
    for path in paths:
        rows = con.execute(
            "SELECT run_id FROM tombstones WHERE segment_id = ?", (path.stem,)
        ).fetchall()
        if rows:
            dead[path.stem] = {r[0] for r in rows}
    return dead


def register(d: ArchiveDir, segments: Iterable[SegmentInfo | Path]) -> tuple[int, int]:
    """Index sealed segments in one transaction, under the writer lock: (runs indexed,
    duplicate copies). Registering a segment twice changes nothing."""
    from .registry import register_segment

    items = [(s, None) if isinstance(s, Path) else (s.path, s) for s in segments]
    paths = [path for path, _ in items]
    added = shadowed = 0
    try:
        with d.writer_lock():
            con = writer_index(d, sealed_here=paths)
            with transaction(con, write=True):
                dead = _dead_runs(con, paths)
                for path, info in items:
                    a, s = register_segment(
                        con, path, d.relative(path), dead=dead.get(path.stem, ()), info=info
                    )
                    added += a
                    shadowed += s
                faults.point("registering")
    except sqlite3.OperationalError as err:
        raise ArchiveWriteError(
            f"{d.index_path}: could not register {len(paths)} segment(s) ({err}); they "
            "are sealed on disk and the next writer or `bowlrec runs repair` indexes them"
        ) from None
    return added, shadowed


def add(
    d: ArchiveDir,
    run: RunData,
    library_refs: Callable[[], Mapping[str, str]],
    *,
    wall_time_s: float,
    ball_ref: str | None = None,
    solver: str = "",
    durable: bool = True,
    records: dict[str, dict[str, Any]] | None = None,
) -> AddResult:
    """Store a finished run as a segment of one run (idempotent: an already archived run ID
    writes nothing); see :func:`make_record` for the arguments."""
    from bowlrec.sinks.common import RunData as _RunData

    rid = run.run_id or content_id(run.plan)
    run = _RunData(run.scene, run.plan, run.trajectory, rid)
    found = locate(d, rid)
    if found is not None:
        return AddResult(rid, found[2], False, run.trajectory)
    builder = new_builder()
    builder.append(
        make_record(
            run,
            library_refs,
            wall_time_s=wall_time_s,
            ball_ref=ball_ref,
            solver=solver,
            records=records,
        )
    )
    info = seal(d, builder, durable=durable)
    faults.point("sealed", path=info.path)
    register(d, [info])
    found = locate(d, rid)
    if found is not None and found[0] != info.segment_id:
        # another writer archived the same run first; this copy is a shadowed duplicate
        return AddResult(rid, found[2], False, run.trajectory)
    return AddResult(rid, info.path, True, run.trajectory)

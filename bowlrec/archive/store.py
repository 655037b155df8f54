"""The archive as one object: :class:`Archive`, a thin facade. Each method hands its work to
the module that does it, which takes the :class:`~.directory.ArchiveDir` (paths, marker, writer
lock, index connections, open segments): :mod:`.writing` and :mod:`.group_commit`,
:mod:`.queries`, :mod:`.reading`, :mod:`.maintenance`, :mod:`.repair`, :mod:`.compaction`,
:mod:`.balls`. Reads never write; the first write of a process recovers what killed writers
left, and says what it did. Layout and guarantees: docs/archive-format.md.
"""

from __future__ import annotations

import os
import sqlite3
from collections.abc import Iterable, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.errors import ArchiveError, ArchiveWriteError, RunNotFoundError

from . import compaction, maintenance, queries, reading, repair, writing
from .balls import BallLibrary
from .directory import ARCHIVE_FORMAT, ARCHIVE_FORMAT_VERSION, ArchiveDir
from .index import Filter
from .rebuild import read_index
from .writing import AddResult, pattern_label

if TYPE_CHECKING:
    from bowlrec.sinks.common import RunData
    from bowlrec.sinks.hdf5_run import StoredRun

    from .segment import SegmentBuilder, SummaryRuns
    from .segment_format import RunRecord, SegmentInfo

__all__ = [
    "ARCHIVE_FORMAT",
    "ARCHIVE_FORMAT_VERSION",
    "AddResult",
    "Archive",
    "ArchiveError",
    "ArchiveWriteError",
    "RunNotFoundError",
    "pattern_label",
]


class Archive:
    """A directory of runs with an index and a ball library (created on first use)."""

    def __init__(self, root: str | os.PathLike[str], *, create: bool = True) -> None:
        self.directory = d = ArchiveDir(root, create=create)
        self.root, self.index_path = d.root, d.index_path
        self.segments_dir, self.balls_dir = d.segments_dir, d.balls_dir
        self.tombstones_dir, self.quarantine_dir = d.tombstones_dir, d.quarantine_dir
        self.balls = BallLibrary(d)

    def __repr__(self) -> str:
        return f"Archive({str(self.root)!r})"

    @property
    def writable(self) -> bool:
        """True when this process may write the archive directory."""
        return self.directory.writable

    # -- the lock and the index ------------------------------------------------------------

    def writer_lock(self) -> AbstractContextManager[None]:
        """Exclusive across processes (flock) and threads; re-entrant within a thread."""
        return self.directory.writer_lock()

    def index_reader(self) -> sqlite3.Connection:
        """The index for reading (never writes; built in memory while the file is damaged)."""
        return read_index(self.directory)

    def index_writer(self) -> sqlite3.Connection:
        """The index for writing (hold :meth:`writer_lock`; :func:`~.maintenance.writer_index`)."""
        return maintenance.writer_index(self.directory)

    def recover(self) -> dict[str, int]:
        """Finish what killed writers left (cheap; no checksums read): counts of what was done
        (:func:`~.maintenance.recover`), this process's first write's recovery included."""
        return maintenance.recover(self.directory)

    # -- writing -----------------------------------------------------------------------------

    def builder(self, *, samples: str = "gzip") -> SegmentBuilder:
        """A new segment builder carrying this process's provenance (``samples``: "gzip" or
        "none", the storage filter of per-sample datasets)."""
        return writing.new_builder(samples=samples)

    def record(
        self,
        run: RunData,
        *,
        wall_time_s: float,
        ball_ref: str | None = None,
        solver: str = "",
        created_at_ns: int | None = None,
        records: dict[str, dict[str, Any]] | None = None,
    ) -> RunRecord:
        """A finished run as a segment record (:func:`~.writing.make_record`)."""
        return writing.make_record(
            run,
            self._library_refs,
            wall_time_s=wall_time_s,
            ball_ref=ball_ref,
            solver=solver,
            created_at_ns=created_at_ns,
            records=records,
        )

    def _library_refs(self) -> dict[str, str]:  # ball-spec SHA-256 -> newest name@version
        return self.balls.refs_by_sha()

    def seal(self, builder: SegmentBuilder | SummaryRuns, *, durable: bool = True) -> SegmentInfo:
        """Seal the builder's runs (or summary-only runs) as a segment, not yet registered."""
        return writing.seal(self.directory, builder, durable=durable)

    def register(self, segments: Iterable[SegmentInfo | Path]) -> tuple[int, int]:
        """Index sealed segments in one transaction: (runs indexed, duplicate copies)."""
        return writing.register(self.directory, segments)

    def add(
        self,
        run: RunData,
        *,
        wall_time_s: float,
        ball_ref: str | None = None,
        solver: str = "",
        durable: bool = True,
        records: dict[str, dict[str, Any]] | None = None,
    ) -> AddResult:
        """Store a finished run as a segment of one run; idempotent (:func:`~.writing.add`)."""
        return writing.add(
            self.directory,
            run,
            self._library_refs,
            wall_time_s=wall_time_s,
            ball_ref=ball_ref,
            solver=solver,
            durable=durable,
            records=records,
        )

    # -- removal and maintenance -------------------------------------------------------------

    def set_aside(self, run_id: str, segment_id: str, reason: str) -> None:
        """Tombstone one copy of a run (``reason`` "removed" or "damaged: ...")."""
        maintenance.set_aside(self.directory, run_id, segment_id, reason)

    def remove(self, run_id: str) -> str:
        """Tombstone every copy of a run (it never comes back); its full run ID."""
        return maintenance.remove(self.directory, run_id)

    def repair(self, *, min_age_s: float = 2.0) -> dict[str, Any]:
        """Check every digest, the index against the segments and ball files; quarantine
        damaged and unreadable segments, healthy runs kept. A report (:func:`~.repair.repair`)."""
        return repair.repair(self.directory, min_age_s=min_age_s)

    def reindex(self) -> int:
        """Rebuild the index from the data files (atomically replaced); the run count."""
        return int(self.rebuild_index()["runs"])

    def rebuild_index(self) -> dict[str, Any]:
        """:meth:`reindex` with its report (:func:`~.maintenance.reindex`)."""
        return maintenance.reindex(self.directory)

    def compact(self, *, target_runs: int = 10_000, upgrade: bool = False) -> dict[str, int]:
        """Rewrite segments with dead copies, merge small ones; with ``upgrade`` rewrite the
        segments of an older format instead (:func:`~.compaction.compact`)."""
        return compaction.compact(self.directory, target_runs=target_runs, upgrade=upgrade)

    # -- queries (the index only) ------------------------------------------------------------

    def list_runs(
        self,
        *,
        ball: str | None = None,
        pattern: str | None = None,
        outcome: str | None = None,
        name: str | None = None,
        where: Sequence[Filter | str] = (),
        order_by: str = "created_at",
        limit: int | None = None,
        offset: int = 0,
        leave: str | None = None,
        pinfall: int | None = None,
        strikes: bool = False,
    ) -> list[dict[str, Any]]:
        """Index rows (dicts keyed by :data:`~.index.INDEX_COLUMNS`), filtered: ``ball`` a
        library name or ``name@version``, ``where`` conditions such as ``"hook_m>=0.1"`` (any
        index column, ops <= >= != = < >); ``offset`` rows of the ordered result skipped;
        ``leave``, ``pinfall``, ``strikes``: runs with pin action whose leave (as named),
        pins down or strike match."""
        found = queries.run_filters(
            self.directory,
            ball,
            pattern,
            outcome,
            name,
            where,
            leave=leave,
            pinfall=pinfall,
            strikes=strikes,
        )
        return queries.list_runs(
            self.directory, *found, order_by=order_by, limit=limit, offset=offset
        )

    def count_runs(
        self,
        *,
        ball: str | None = None,
        pattern: str | None = None,
        outcome: str | None = None,
        name: str | None = None,
        where: Sequence[Filter | str] = (),
        cap: int | None = None,
        leave: str | None = None,
        pinfall: int | None = None,
        strikes: bool = False,
    ) -> int:
        """How many runs :meth:`list_runs` lists with these filters, counting at most ``cap``."""
        found = queries.run_filters(
            self.directory,
            ball,
            pattern,
            outcome,
            name,
            where,
            leave=leave,
            pinfall=pinfall,
            strikes=strikes,
        )
        return queries.count_runs(self.directory, *found, cap=cap)

    def damaged(self) -> list[dict[str, Any]]:
        """Copies of runs found damaged (set aside; quarantined by ``runs repair``)."""
        return queries.damaged(self.directory)

    def resolve_id(self, run_id: str) -> str:
        """The full run ID for an ID or a unique prefix of at least 4 characters."""
        return queries.resolve_id(self.directory, run_id)

    def locate(self, run_id: str) -> tuple[str, int, Path] | None:
        """(segment ID, row, segment path) of an archived run ID; None when not archived."""
        return queries.locate(self.directory, run_id)

    def has_run(self, run_id: str) -> bool:
        """True when ``run_id`` (a full ID) is archived."""
        return self.locate(run_id) is not None

    def row(self, run_id: str) -> dict[str, Any]:
        """The index row of one run (an ID or a unique prefix)."""
        rid = self.resolve_id(run_id)
        return self.rows([rid])[rid]

    def rows(self, run_ids: Iterable[str]) -> dict[str, dict[str, Any]]:
        """Index rows of the archived runs among ``run_ids`` (full IDs), by run ID."""
        return queries.rows(self.directory, run_ids)

    def info(self) -> dict[str, Any]:
        """Format, counts and sizes on disk (bytes) of the archive's parts."""
        return queries.info(self.directory)

    def __len__(self) -> int:
        return queries.count(self.directory)

    # -- reading (digests checked) -----------------------------------------------------------

    def load(self, run_id: str) -> StoredRun:
        """A run read back, its digest checked (:func:`~.reading.load`)."""
        return reading.load(self.directory, run_id)

    def run_data(self, run_id: str) -> RunData:
        """A stored run as the sinks take it (plan re-resolved, provenance as stored)."""
        return reading.run_data(self.directory, run_id)

    def export(self, run_id: str, dest: str | os.PathLike[str]) -> Path:
        """Write one run as a ``bowlrec-run`` file (1.0; 1.1 with pins) at ``dest`` (a file or a
        directory)."""
        return reading.export(self.directory, run_id, dest)

    def close(self) -> None:
        """Close the segment files kept open for reading (reopened when needed)."""
        self.directory.close()

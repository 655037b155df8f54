"""The archive as one object: :class:`Archive`, a thin facade over the archive's modules.

::

    ARCHIVE/
      archive.json                 {"format": "bowlrec-archive", "format_version": "2.0"}
      segments/<segment>.h5        sealed segments: many runs each, never modified
      balls/<name>/<version>.json  the ball library, one file per version
      tombstones/<time>-<id>.json  removed or damaged copies of runs
      quarantine/<segment>.h5      damaged segments set aside by `runs repair` (+ a report)
      index.sqlite                 derived: runs, segments, balls; rebuilt from the files above
      .writer.lock                 flock()ed while a process registers, removes or repairs

Each method hands its work to one module, which takes the :class:`~.directory.ArchiveDir`:
writing (:mod:`.writing`, :mod:`.group_commit`), queries (:mod:`.queries`), reading
(:mod:`.reading`), maintenance (:mod:`.maintenance`), repair, compaction and the ball library.
Reads never write; the first write of a process recovers what killed writers left. See
docs/archive-format.md.
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
        """The index for reading: the file read-only, or built in memory while it is missing
        or damaged. Never writes."""
        return read_index(self.directory)

    def index_writer(self) -> sqlite3.Connection:
        """The index for writing (hold :meth:`writer_lock`); rebuilt first when missing or
        damaged; the first call of a process recovers what killed writers left."""
        return maintenance.writer_index(self.directory)

    def recover(self) -> dict[str, int]:
        """Finish what killed writers left (cheap; no checksums read): delete stale
        temporaries, register sealed segments and ball and tombstone files the index lacks;
        counts of each, including what this process's first write recovered."""
        return maintenance.recover(self.directory)

    # -- writing -----------------------------------------------------------------------------

    def builder(self, *, samples: str = "gzip") -> SegmentBuilder:
        """A new segment builder carrying this process's provenance; ``samples``: the storage
        filter of per-sample datasets, "gzip" or "none" (faster; compaction recompresses)."""
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
        """A finished run as a segment record (``ball_ref`` None: looked up by spec;
        ``records``: its per-run record groups, see :attr:`~.segment.RunRecord.records`)."""
        return writing.make_record(
            run,
            self._library_refs,
            wall_time_s=wall_time_s,
            ball_ref=ball_ref,
            solver=solver,
            created_at_ns=created_at_ns,
            records=records,
        )

    def _library_refs(self) -> dict[str, str]:
        """SHA-256 of each library spec -> ``name@version`` of its newest entry."""
        return self.balls.refs_by_sha()

    def seal(self, builder: SegmentBuilder | SummaryRuns, *, durable: bool = True) -> SegmentInfo:
        """Write the builder's runs (or columns of summary-only runs) as a sealed segment of
        this archive (not yet registered)."""
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
        """Store a finished run as a segment of one run (idempotent: an already archived run
        ID writes nothing); the arguments as :meth:`record` takes them."""
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
        """Tombstone one copy of a run (``reason`` "removed" or "damaged: ...") and drop it
        from the index; a damaged copy is listed by :meth:`damaged`."""
        maintenance.set_aside(self.directory, run_id, segment_id, reason)

    def remove(self, run_id: str) -> str:
        """Remove a run (every stored copy of it; a tombstone first, so it never comes back;
        :meth:`compact` reclaims the space); returns the full run ID."""
        return maintenance.remove(self.directory, run_id)

    def repair(self, *, min_age_s: float = 2.0) -> dict[str, Any]:
        """Check every stored run's digest and the index against the segments and ball files;
        quarantine damaged and unreadable segments (their healthy runs are rewritten to a new
        segment). A report (:func:`~.repair.repair`)."""
        return repair.repair(self.directory, min_age_s=min_age_s)

    def reindex(self) -> int:
        """Rebuild the index from the data files (atomically replaced); the run count."""
        return int(self.rebuild_index()["runs"])

    def rebuild_index(self) -> dict[str, Any]:
        """:meth:`reindex` with its report (:func:`~.maintenance.reindex`): counts, the
        unreadable segments, what recovery did."""
        return maintenance.reindex(self.directory)

    def compact(self, *, target_runs: int = 10_000) -> dict[str, int]:
        """Rewrite segments that hold removed, damaged or duplicate copies, and merge small
        segments, into segments of up to ``target_runs`` runs. A report."""
        return compaction.compact(self.directory, target_runs=target_runs)

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
    ) -> list[dict[str, Any]]:
        """Index rows (dicts keyed by :data:`~bowlrec.archive.index.INDEX_COLUMNS`), filtered.

        ``ball`` is a library name or ``name@version``; ``where`` holds conditions such as
        ``"hook_m>=0.1"`` (any index column, ops <= >= != = < >); ``offset`` rows of the
        ordered result are skipped (pages of a table). Reads only the index.
        """
        found = queries.run_filters(self.directory, ball, pattern, outcome, name, where)
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
    ) -> int:
        """How many runs :meth:`list_runs` lists with these filters, counting at most ``cap``
        (a count of ``cap`` means "at least ``cap``")."""
        found = queries.run_filters(self.directory, ball, pattern, outcome, name, where)
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
        """Read a run back (scene, trajectory, provenance), its digest checked; raises
        RunNotFoundError, or RunDamagedError naming the run and its segment."""
        return reading.load(self.directory, run_id)

    def run_data(self, run_id: str) -> RunData:
        """A stored run as the sinks take it (plan re-resolved, provenance as stored)."""
        return reading.run_data(self.directory, run_id)

    def export(self, run_id: str, dest: str | os.PathLike[str]) -> Path:
        """Write one run as a self-contained run file (format ``bowlrec-run`` 1.0) at
        ``dest`` (a file or an existing directory)."""
        return reading.export(self.directory, run_id, dest)

    def close(self) -> None:
        """Close the segment files kept open for reading (reopened when needed)."""
        self.directory.close()

"""An archive directory (format 2.0): sealed segment files, ball files, tombstones, an index.

::

    ARCHIVE/
      archive.json                 {"format": "bowlrec-archive", "format_version": "2.0"}
      segments/<segment>.h5        sealed segments: many runs each, never modified
      balls/<name>/<version>.json  the ball library, one file per version
      tombstones/<time>-<id>.json  removed or damaged copies of runs
      quarantine/<segment>.h5      damaged segments set aside by `runs repair` (+ a report)
      index.sqlite                 derived: runs, segments, balls; rebuilt from the files above
      .writer.lock                 flock()ed while a process registers, removes or repairs

Any process may seal segments (:meth:`Archive.builder`, :class:`~.segment.SegmentBuilder`);
one process at a time registers them (:meth:`Archive.register`, under the writer lock). A
writer killed at any moment loses at most its unsealed segment: a sealed but unregistered
segment is registered by the next writer (:meth:`Archive.recover`). Reading needs no write
access. See docs/archive-format.md.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import sqlite3
import threading
from collections import OrderedDict
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.archive.balls import parse_ball_ref
from bowlrec.archive.run_id import run_id as content_id
from bowlrec.archive.tombstones import Tombstone
from bowlrec.atomic_files import atomic_path
from bowlrec.core.codes import OUTCOMES
from bowlrec.errors import (
    ArchiveError,
    ArchiveWriteError,
    IndexUnreadableError,
    InputError,
    RunDamagedError,
    RunNotFoundError,
    SegmentError,
)
from bowlrec.provenance import environment
from bowlrec.sinks.registry import sink_named

from .balls import BallLibrary, ball_sha
from .index import (
    FROM_RUNS,
    SELECT_COLUMNS,
    Filter,
    count_sql,
    iso_time,
    listed_row,
    open_index,
    select_sql,
    transaction,
)

if TYPE_CHECKING:
    from bowlrec.core.trajectory import Trajectory
    from bowlrec.sinks.common import RunData
    from bowlrec.sinks.hdf5_run import StoredRun
    from bowlrec.spec import Scene

    from .segment import RunRecord, SegmentBuilder, SegmentInfo, SummaryRuns

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

ARCHIVE_FORMAT = "bowlrec-archive"
ARCHIVE_FORMAT_VERSION = "2.0"
#: what a directory may hold before its marker is written (a creation in progress, or one
#: killed before it wrote the marker): such a directory is completed, not refused
_ARCHIVE_ENTRIES = {
    ".writer.lock",
    "segments",
    "balls",
    "tombstones",
    "index.sqlite",
    "index.sqlite-journal",
}


@dataclass(frozen=True)
class AddResult:
    """What :meth:`Archive.add` or :func:`bowlrec.api.simulate_into` did."""

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


def _os_reason(err: OSError) -> str:
    """A one-line reason for an OSError (h5py's strerror is HDF5's whole multi-line report)."""
    if err.errno:
        return os.strerror(err.errno)
    return " ".join(str(err).split())


def _read_marker(marker: Path) -> dict[str, Any]:
    try:
        meta = json.loads(marker.read_text())
    except (OSError, ValueError) as err:
        raise ArchiveError(f"{marker}: unreadable archive marker ({err})") from None
    if not isinstance(meta, dict) or meta.get("format") != ARCHIVE_FORMAT:
        raise ArchiveError(f"{marker}: not a bowlrec archive marker")
    return meta


class Archive:
    """A directory of runs with an index and a ball library (created on first use)."""

    def __init__(self, root: str | os.PathLike[str], *, create: bool = True) -> None:
        self.root = Path(root).expanduser()
        self.segments_dir = self.root / "segments"
        self.balls_dir = self.root / "balls"
        self.tombstones_dir = self.root / "tombstones"
        self.quarantine_dir = self.root / "quarantine"
        self.index_path = self.root / "index.sqlite"
        self._lock = threading.RLock()
        self._lock_depth = 0
        self._lock_file: Any = None
        self._memory: sqlite3.Connection | None = None
        self._recovered = False
        self._ball_shas: dict[int, tuple[Any, str]] = {}
        #: recently read segments, kept open (least recently used first)
        self._open_segments: OrderedDict[Path, Any] = OrderedDict()
        self._segments_lock = threading.Lock()
        #: ball-spec SHA-256 -> the newest library reference with that spec (loaded once)
        self._ball_refs: dict[str, str] | None = None
        marker = self.root / "archive.json"
        if not marker.exists():
            if not create:
                raise ArchiveError(f"{self.root} is not a bowlrec archive (no archive.json)")
            self._create(marker)
        meta = _read_marker(marker)
        version = str(meta.get("format_version", ""))
        major = version.split(".")[0]
        if major == "1":
            raise ArchiveError(
                f"{self.root} is a format {version} archive; this bowlrec reads format "
                f"{ARCHIVE_FORMAT_VERSION.split('.')[0]}.x. Convert it once with: "
                f"bowlrec archive migrate {self.root}"
            )
        if major != ARCHIVE_FORMAT_VERSION.split(".")[0]:
            raise ArchiveError(
                f"{self.root}: archive format {version} is not supported "
                f"(this bowlrec reads {ARCHIVE_FORMAT_VERSION.split('.')[0]}.x)"
            )
        self.balls = BallLibrary(self)

    def _create(self, marker: Path) -> None:
        """Make a new archive; safe when several processes create the same one at once."""

        self.root.mkdir(parents=True, exist_ok=True)
        with self.writer_lock():
            if marker.exists():
                return  # another process created it while this one waited for the lock
            strangers = [
                p.name
                for p in self.root.iterdir()
                if p.name not in _ARCHIVE_ENTRIES and not p.name.startswith("index.sqlite.")
            ]
            if strangers:
                raise ArchiveError(
                    f"{self.root} exists, is not empty and is not a bowlrec archive; "
                    "choose an empty or new directory"
                )
            for d in (self.segments_dir, self.balls_dir, self.tombstones_dir):
                d.mkdir(exist_ok=True)
            from .maintenance import rebuild_index

            rebuild_index(self)
            with atomic_path(marker) as tmp:
                doc = {"format": ARCHIVE_FORMAT, "format_version": ARCHIVE_FORMAT_VERSION}
                tmp.write_text(json.dumps(doc) + "\n")

    def __repr__(self) -> str:
        return f"Archive({str(self.root)!r})"

    @property
    def writable(self) -> bool:
        """True when this process may write the archive directory."""
        return os.access(self.root, os.W_OK)

    # -- locking and the index -------------------------------------------------------------------

    @contextlib.contextmanager
    def writer_lock(self) -> Iterator[None]:
        """Exclusive across processes (flock; released by the OS if the holder dies) and
        threads; re-entrant within a thread."""
        with self._lock:
            if self._lock_depth == 0:
                try:
                    fh = open(self.root / ".writer.lock", "a")  # noqa: SIM115 - held below
                except OSError as err:
                    raise ArchiveWriteError(
                        f"{self.root}: cannot write to the archive ({err.strerror})"
                    ) from None
                fcntl.flock(fh, fcntl.LOCK_EX)
                self._lock_file = fh
            self._lock_depth += 1
            try:
                yield
            finally:
                self._lock_depth -= 1
                if self._lock_depth == 0:
                    fcntl.flock(self._lock_file, fcntl.LOCK_UN)
                    self._lock_file.close()
                    self._lock_file = None

    def index_reader(self) -> sqlite3.Connection:
        """A read-only connection to the index. A missing or damaged index is rebuilt first
        (when this process may write), else built in memory from the data files."""
        if self._memory is not None:
            return self._memory
        try:
            return open_index(self.index_path, write=False)
        except IndexUnreadableError:
            if self.writable:
                with self.writer_lock():
                    self.index_writer()
                return open_index(self.index_path, write=False)
            from .maintenance import memory_index

            self._memory = memory_index(self)
            return self._memory

    def index_writer(self) -> sqlite3.Connection:
        """A writing connection to the index (hold :meth:`writer_lock`); a missing or damaged
        index is rebuilt from the data files first."""
        assert self._lock_depth > 0, "index_writer() needs the writer lock"
        try:
            con = open_index(self.index_path, write=True)
        except IndexUnreadableError:
            from .maintenance import rebuild_index

            rebuild_index(self)
            con = open_index(self.index_path, write=True)
        if not self._recovered:
            self._recovered = True
            from .maintenance import recover

            recover(self, con)
        return con

    def recover(self) -> dict[str, int]:
        """Finish what killed writers left (cheap; no checksums read): delete stale
        temporaries, register sealed segments and ball and tombstone files the index lacks."""
        from .maintenance import recover

        with self.writer_lock():
            return recover(self, self.index_writer())

    # -- writing ---------------------------------------------------------------------------------

    def builder(self, *, samples: str = "gzip") -> SegmentBuilder:
        """A new segment builder carrying this process's provenance; ``samples``: the storage
        filter of per-sample datasets, "gzip" or "none" (faster; compaction recompresses)."""
        from .segment import SegmentBuilder

        return SegmentBuilder(environment(), samples=samples)

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
        from .segment import RunRecord

        sha = self._ball_sha(run.scene.ball)
        if ball_ref is None:
            ball_ref = self._library_refs().get(sha, "")
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

    def _library_refs(self) -> dict[str, str]:
        """SHA-256 of each library spec -> ``name@version`` of its newest entry (read once;
        the library of this Archive forgets it when it changes)."""
        if self._ball_refs is None:
            rows = self.index_reader().execute(
                "SELECT sha, name, version FROM balls ORDER BY added_at, version"
            )
            self._ball_refs = {sha: f"{name}@{version}" for sha, name, version in rows}
        return self._ball_refs

    def _ball_sha(self, ball: Any) -> str:
        cached = self._ball_shas.get(id(ball))
        if cached is not None and cached[0] is ball:
            return cached[1]
        sha = ball_sha(ball)
        if len(self._ball_shas) > 4096:
            self._ball_shas.clear()
        self._ball_shas[id(ball)] = (ball, sha)
        return sha

    def seal(self, builder: SegmentBuilder | SummaryRuns, *, durable: bool = True) -> SegmentInfo:
        """Write the builder's runs (or columns of summary-only runs) as a sealed segment of
        this archive (not yet registered)."""
        from .segment import SummaryRuns, seal_columns

        try:
            if isinstance(builder, SummaryRuns):
                return seal_columns(
                    self.segments_dir, builder.columns(), environment(), durable=durable
                )
            return builder.seal(self.segments_dir, durable=durable)
        except OSError as err:
            raise ArchiveWriteError(
                f"{self.segments_dir}: could not write a segment of {len(builder)} run(s) "
                f"({_os_reason(err)}); nothing already archived was lost"
            ) from None

    def register(self, segments: Iterable[SegmentInfo | Path]) -> tuple[int, int]:
        """Index sealed segments in one transaction: (runs indexed, duplicate copies)."""
        from .registry import register_segment

        items = [(s, None) if isinstance(s, Path) else (s.path, s) for s in segments]
        paths = [path for path, _ in items]
        added = shadowed = 0
        try:
            with self.writer_lock():
                con = self.index_writer()
                with transaction(con, write=True):
                    dead = self._dead_runs(con, paths)
                    for path, info in items:
                        a, s = register_segment(
                            con,
                            path,
                            self._relative(path),
                            dead=dead.get(path.stem, ()),
                            info=info,
                        )
                        added += a
                        shadowed += s
        except sqlite3.OperationalError as err:
            raise ArchiveWriteError(
                f"{self.index_path}: could not register {len(paths)} segment(s) ({err}); they "
                "are sealed on disk and the next writer or `bowlrec runs repair` indexes them"
            ) from None
        return added, shadowed

    @staticmethod
    def _dead_runs(con: sqlite3.Connection, paths: Sequence[Path]) -> dict[str, set[str]]:
        dead: dict[str, set[str]] = {}
        for path in paths:
            rows = con.execute(
                "SELECT run_id FROM tombstones WHERE segment_id = ?", (path.stem,)
            ).fetchall()
            if rows:
                dead[path.stem] = {r[0] for r in rows}
        return dead

    def _relative(self, path: Path) -> str:
        return str(path.relative_to(self.root))

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
        ID writes nothing).

        ``ball_ref`` ("name@version") names the library ball the scene used; when None the
        library is searched for a spec equal to the scene's ball. ``records``: the run's
        per-run record groups (archive format 2.1; e.g. a session shot's oil grid).
        """
        from bowlrec.sinks.common import RunData as _RunData

        rid = run.run_id or content_id(run.plan)
        run = _RunData(run.scene, run.plan, run.trajectory, rid)
        found = self.locate(rid)
        if found is not None:
            return AddResult(rid, found[2], False, run.trajectory)
        builder = self.builder()
        builder.append(
            self.record(
                run, wall_time_s=wall_time_s, ball_ref=ball_ref, solver=solver, records=records
            )
        )
        info = self.seal(builder, durable=durable)
        self.register([info])
        found = self.locate(rid)
        if found is not None and found[0] != info.segment_id:
            # another writer archived the same run first; this copy is a shadowed duplicate
            return AddResult(rid, found[2], False, run.trajectory)
        return AddResult(rid, info.path, True, run.trajectory)

    def set_aside(self, run_id: str, segment_id: str, reason: str) -> None:
        """Tombstone one copy of a run (``reason`` "removed" or "damaged: ...") and drop it
        from the index; a damaged copy is listed by :meth:`damaged`."""
        from .maintenance import kill_copies

        with self.writer_lock():
            kill_copies(self, self.index_writer(), [Tombstone(segment_id, run_id, reason)])

    def remove(self, run_id: str) -> str:
        """Remove a run (every stored copy of it); returns the full run ID.

        Segments are not rewritten: a tombstone file records the removal first, so a removed
        run never comes back; :meth:`compact` reclaims the space.
        """
        from .maintenance import kill_copies

        rid = self.resolve_id(run_id)
        with self.writer_lock():
            con = self.index_writer()
            copies = [
                r[0]
                for r in con.execute(
                    "SELECT s.segment_id FROM runs r JOIN segments s ON s.seg = r.seg "
                    "WHERE r.run_id = ? UNION SELECT segment_id FROM shadowed WHERE run_id = ?",
                    (rid, rid),
                )
            ]
            kill_copies(self, con, [Tombstone(seg, rid, "removed") for seg in copies])
        return rid

    def repair(self, *, min_age_s: float = 2.0) -> dict[str, Any]:
        """Check every stored run's digest and the index against the segments; quarantine
        damaged segments (their healthy runs are rewritten to a new segment). A report."""
        from .repair import repair

        return repair(self, min_age_s=min_age_s)

    def reindex(self) -> int:
        """Rebuild the index from the data files (atomically replaced); the run count."""
        from .maintenance import rebuild_index

        with self.writer_lock():
            rebuild_index(self)
        return len(self)

    def compact(self, *, target_runs: int = 10_000) -> dict[str, int]:
        """Rewrite segments that hold removed, damaged or duplicate copies, and merge small
        segments, into segments of up to ``target_runs`` runs. A report."""
        from .compaction import compact

        return compact(self, target_runs=target_runs)

    # -- reading ---------------------------------------------------------------------------------

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
        filters, clauses = self._run_filters(ball, pattern, outcome, name, where)
        sql, params = select_sql(filters, order_by, limit, clauses, offset=offset)
        # one SELECT reads one consistent snapshot (and the in-memory index of a process that
        # may not write is shared by its threads: no transaction is opened on it)
        return [listed_row(r) for r in self.index_reader().execute(sql, params)]

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
        filters, clauses = self._run_filters(ball, pattern, outcome, name, where)
        sql, params = count_sql(filters, clauses, cap)
        return int(self.index_reader().execute(sql, params).fetchone()[0])

    def _run_filters(
        self,
        ball: str | None,
        pattern: str | None,
        outcome: str | None,
        name: str | None,
        where: Sequence[Filter | str],
    ) -> tuple[list[Filter], list[tuple[str, list[Any]]]]:
        """The filters and extra SQL clauses of :meth:`list_runs`' arguments."""
        if outcome is not None and outcome not in OUTCOMES.values():
            raise InputError(
                f"outcome {outcome!r} is not an outcome; the outcomes are "
                + ", ".join(OUTCOMES.values())
                + " ('pins': the ball reached the pins)"
            )
        filters = [w if isinstance(w, Filter) else Filter.parse(w) for w in where]
        clauses = [] if ball is None else [self._ball_clause(ball)]
        for column, value in (("pattern", pattern), ("outcome", outcome), ("name", name)):
            if value is not None:
                filters.append(Filter(column, "=", value))
        return filters, clauses

    def _ball_clause(self, ball: str) -> tuple[str, list[Any]]:
        """Runs that used library ball ``name`` (any version) or ``name@version``: by the
        reference stored with the run, or by an identical spec (runs made before the ball was
        added to the library)."""

        bname, bversion = parse_ball_ref(ball)
        shas = [
            e.sha
            for e in self.balls.list(bname, all_versions=True)
            if bversion is None or e.version == bversion
        ]
        by_ref = "r.ball_name = ?" + ("" if bversion is None else " AND r.ball_version = ?")
        params: list[Any] = [bname] + ([] if bversion is None else [bversion])
        if shas:
            by_ref += f" OR b.sha IN ({', '.join('?' for _ in shas)})"
            params += shas
        return by_ref, params

    def damaged(self) -> list[dict[str, Any]]:
        """Copies of runs found damaged (set aside; quarantined by ``runs repair``)."""
        con = self.index_reader()
        rows = con.execute(
            "SELECT run_id, segment_id, reason, detected_at FROM damaged ORDER BY detected_at"
        )
        return [dict(r) for r in rows]

    def resolve_id(self, run_id: str) -> str:
        """The full run ID for an ID or a unique prefix of at least 4 characters."""
        if len(run_id) < 4 or not all(c in "0123456789abcdef" for c in run_id):
            raise RunNotFoundError(f"{run_id!r} is not a run ID (hex, at least 4 characters)")
        rows = (
            self.index_reader()
            .execute(
                "SELECT run_id FROM runs WHERE run_id >= ? AND run_id < ? LIMIT 2",
                (run_id, run_id + "g"),
            )
            .fetchall()
        )
        if not rows:
            raise RunNotFoundError(f"no run {run_id!r} in archive {self.root}")
        if len(rows) > 1:
            raise RunNotFoundError(f"run ID prefix {run_id!r} is ambiguous; give more characters")
        return str(rows[0][0])

    def locate(self, run_id: str) -> tuple[str, int, Path] | None:
        """(segment ID, row, segment path) of an archived run ID; None when not archived."""
        row = (
            self.index_reader()
            .execute(
                "SELECT s.segment_id, r.row, s.path FROM runs r "
                "JOIN segments s ON s.seg = r.seg WHERE r.run_id = ?",
                (run_id,),
            )
            .fetchall()
        )
        return None if not row else (row[0][0], int(row[0][1]), self.root / row[0][2])

    def has_run(self, run_id: str) -> bool:
        """True when ``run_id`` (a full ID) is archived."""
        return self.locate(run_id) is not None

    def row(self, run_id: str) -> dict[str, Any]:
        """The index row of one run (an ID or a unique prefix)."""
        rid = self.resolve_id(run_id)
        return self.rows([rid])[rid]

    def rows(self, run_ids: Iterable[str]) -> dict[str, dict[str, Any]]:
        """Index rows of the archived runs among ``run_ids`` (full IDs), by run ID."""
        ids = list(run_ids)
        out: dict[str, dict[str, Any]] = {}
        con = self.index_reader()
        for i in range(0, len(ids), 900):
            part = ids[i : i + 900]
            marks = ", ".join("?" for _ in part)
            sql = f"SELECT {SELECT_COLUMNS} FROM {FROM_RUNS} WHERE r.run_id IN ({marks})"
            out.update({r["run_id"]: listed_row(r) for r in con.execute(sql, part)})
        return out

    def load(self, run_id: str) -> StoredRun:
        """Read a run back (scene, trajectory, provenance), its digest checked.

        Raises RunNotFoundError, or RunDamagedError (naming the run and its segment) when the
        stored bytes are damaged.
        """
        from bowlrec.sinks.hdf5_run import StoredRun
        from bowlrec.spec import Scene

        found = self.locate(run_id)
        if found is None:
            run_id = self.resolve_id(run_id)
            found = self.locate(run_id)
            assert found is not None
        for attempt in (1, 2):
            segment_id, row, path = found
            try:
                rec = self._segment(path).read_run(row)
                break
            except SegmentError as err:
                moved = self.locate(run_id)
                if attempt == 1 and moved is not None and moved != found:
                    found = moved  # rewritten by a compaction in another process: read it there
                    continue
                reason = "segment file missing" if not path.exists() else f"unreadable: {err}"
                raise RunDamagedError(run_id, segment_id, reason) from None
        if rec.run_id != run_id:
            raise RunDamagedError(run_id, segment_id, f"row {row} holds run {rec.run_id}")
        scene = Scene.model_validate_json(rec.scene_json)
        opts = scene.options
        attrs = dict(rec.attrs)
        attrs.update(
            {
                "run_id": run_id,
                "name": scene.name,
                "created_at": iso_time(attrs.pop("created_at_ns")),
                "rtol": opts.rtol,
                "record": opts.record,
                "record_dt_s": opts.record_dt_s,
                "record_terms": opts.record_terms,
                "slide_to_roll": opts.slide_to_roll,
                "scene_json": rec.scene_json,
            }
        )
        return StoredRun(
            run_id=run_id, scene=scene, trajectory=rec.trajectory, attrs=attrs, records=rec.records
        )

    def _segment(self, path: Path) -> Any:
        """The segment at ``path``, opened once and kept among the 8 most recently read
        (segments are immutable: a kept handle never goes stale). Safe across threads."""
        from .segment_file import SegmentFile

        with self._segments_lock:
            seg = self._open_segments.pop(path, None)
            if seg is None:
                seg = SegmentFile(path)
            self._open_segments[path] = seg
            while len(self._open_segments) > 8:
                # dropped, not closed: another thread may be reading it; HDF5 closes the file
                # when the last reference goes
                self._open_segments.popitem(last=False)
        return seg

    def close(self) -> None:
        """Close the segment files kept open for reading (reopened when needed)."""
        with self._segments_lock:
            while self._open_segments:
                self._open_segments.popitem()[1].close()

    def run_data(self, run_id: str) -> RunData:
        """A stored run as the sinks take it: the plan re-resolved from the stored scene, the
        provenance as its run file stores it (the stored attributes that are single values,
        and the segment holding the run)."""
        from bowlrec.sinks.common import RunData

        stored = self.load(run_id)
        own = ("format", "format_version", "run_id", "name", "scene_json", "segment_id")
        provenance = {
            k: v
            for k, v in stored.attrs.items()
            if k not in own and isinstance(v, str | int | float | bool)
        }
        found = self.locate(stored.run_id)
        if found is not None:
            provenance["segment_id"] = found[0]
        return RunData(
            stored.scene, stored.scene.resolve(), stored.trajectory, stored.run_id, provenance
        )

    def export(self, run_id: str, dest: str | os.PathLike[str]) -> Path:
        """Write one run as a self-contained run file (format ``bowlrec-run`` 1.0, with the
        resolved parameters and the run's provenance) at ``dest`` (a file or an existing
        directory)."""

        run = self.run_data(run_id)
        dest = Path(dest)
        if dest.is_dir():
            dest = dest / f"{run.run_id}.h5"
        return sink_named("hdf5").write(run, dest)

    def info(self) -> dict[str, Any]:
        """Format, counts and sizes on disk (bytes) of the archive's parts."""
        con = self.index_reader()

        def count(table: str) -> int:
            return int(con.execute(f"SELECT COUNT(*) FROM {table}").fetchall()[0][0])

        seg_bytes = con.execute("SELECT COALESCE(SUM(size_bytes), 0) FROM segments").fetchall()
        index_bytes = self.index_path.stat().st_size if self.index_path.exists() else 0
        return {
            "archive": str(self.root),
            "format_version": _read_marker(self.root / "archive.json").get("format_version"),
            "runs": count("runs"),
            "segments": count("segments"),
            "segment_bytes": int(seg_bytes[0][0]),
            "index_bytes": index_bytes,
            "balls": count("balls"),
            "removed_or_damaged_copies": count("tombstones"),
            "duplicate_copies": count("shadowed"),
            "damaged_runs": count("damaged"),
        }

    def __len__(self) -> int:
        return int(self.index_reader().execute("SELECT COUNT(*) FROM runs").fetchall()[0][0])

"""Keeping the index in step with the data files: the writer's index connection, recovery after
a kill, full rebuilds, and setting copies of runs aside (removal, damage).

- :func:`writer_index`: the index a writer uses. A missing or damaged index file is rebuilt
  from the data files first, and the first write of a process recovers (below); what it did is
  logged (logger ``bowlrec.archive``) and kept until an explicit command reports it.
- :func:`recover` (cheap, no checksums read): delete temporaries of killed writers, apply
  tombstone files, index ball files and sealed segments the index lacks, and finish the index
  switch of a repair killed after it moved a damaged segment to ``quarantine/``.
- :func:`reindex`: a new index from the data files alone (:func:`~.rebuild.rebuild_index`).
- :func:`kill_copies`: tombstone (segment, run) pairs and drop them from the index; a run whose
  live copy dies but has a duplicate copy elsewhere is served from that copy.

Checksum verification, quarantine and compaction are in :mod:`.repair` and :mod:`.compaction`.
"""

from __future__ import annotations

import logging
import sqlite3
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from bowlrec.atomic_files import remove_stale_parts
from bowlrec.errors import IndexUnreadableError

from . import faults
from .directory import ArchiveDir
from .index import transaction
from .quarantine import quarantine_reports
from .queries import resolve_id
from .rebuild import (
    apply_tombstone_files,
    index_ball_files,
    promote_copies,
    rebuild_index,
    record_damage,
    record_tombstones,
    register_segment_files,
    upgrade_index,
)
from .tombstones import Tombstone, write_tombstone

__all__ = [
    "LOCKED_PART_AGE_S",
    "RECOVERY_COUNTS",
    "kill_copies",
    "recover",
    "reindex",
    "remove",
    "set_aside",
    "switch_segment",
    "writer_index",
]

log = logging.getLogger(__package__)  # "bowlrec.archive"

#: seconds a locked-kind temporary must have existed before an unlocked one is deemed dead
#: (its writer creates it, then locks it: microseconds apart)
LOCKED_PART_AGE_S = 0.2
#: what a recovery reports, each a count
RECOVERY_COUNTS = (
    "temporaries_removed",
    "tombstone_files_applied",
    "ball_files_indexed",
    "segments_registered",
    "segments_unreadable",
    "repairs_finished",
)
_SAID = {
    "temporaries_removed": "removed {} temporaries of interrupted writers",
    "tombstone_files_applied": "applied {} tombstone file(s) the index lacked",
    "ball_files_indexed": "indexed {} ball file(s) the index lacked",
    "segments_registered": "registered {} sealed segment(s) the index lacked",
    "segments_unreadable": "found {} unreadable segment(s) (run `bowlrec runs repair`)",
    "repairs_finished": "finished {} interrupted repair(s)",
}


def _open_writer(d: ArchiveDir) -> sqlite3.Connection:
    """The index file for writing; a missing or damaged one is rebuilt first (logged)."""
    try:
        return d.index_writer()
    except IndexUnreadableError as err:
        if upgrade_index(d):
            log.info("%s; upgraded in place (the pins' columns added)", err)
            return d.index_writer()
        counts = rebuild_index(d)
        bad = counts["segments_unreadable"]
        log.warning(
            "%s; rebuilt from the data files (%d run(s) indexed%s)",
            err,
            counts["runs"],
            f"; {bad} unreadable segment(s): run `bowlrec runs repair`" if bad else "",
        )
        return d.index_writer()


def writer_index(d: ArchiveDir, *, sealed_here: Iterable[Path] = ()) -> sqlite3.Connection:
    """The writing connection to the index (hold ``d.writer_lock()``). The first call of a
    process recovers what killed writers left (:func:`recover`; ``sealed_here``: segments the
    caller sealed and registers next, left to it): what it did is logged (a warning when it
    found what only a kill or damage leaves, else at info level: a sealed segment may be
    another live writer's) and kept for the next explicit recover(), repair() or reindex()."""
    con = _open_writer(d)
    if not d.recovered:
        d.recovered = True
        counts = _recover(d, con, min_age_s=2.0, skip={p.stem for p in sealed_here})
        if any(counts.values()):
            said = "; ".join(_SAID[k].format(v) for k, v in counts.items() if v)
            killed = any(v for k, v in counts.items() if k != "segments_registered")
            log.log(logging.WARNING if killed else logging.INFO, "%s: %s", d.root, said)
            for k, v in counts.items():
                d.unreported_recovery[k] = d.unreported_recovery.get(k, 0) + v
    return con


def _take_unreported(d: ArchiveDir, counts: dict[str, int]) -> dict[str, int]:
    """``counts`` plus what the first write's recovery did and nobody reported yet."""
    out = {k: counts.get(k, 0) + d.unreported_recovery.get(k, 0) for k in RECOVERY_COUNTS}
    d.unreported_recovery = {}
    return out


def recover(d: ArchiveDir, *, min_age_s: float = 2.0) -> dict[str, int]:
    """Finish what killed writers left (see the module doc); counts of each
    (:data:`RECOVERY_COUNTS`), including what this process's first write recovered and no
    earlier call reported.

    Segment temporaries are written under a lock, so an unlocked one is a killed writer's
    once it is older than the instant between its creation and its lock
    (:data:`LOCKED_PART_AGE_S`, or ``min_age_s`` if smaller: 0 when the caller knows no writer
    runs); other temporaries are removed once ``min_age_s`` old."""
    with d.writer_lock():
        con = _open_writer(d)
        d.recovered = True
        return _take_unreported(d, _recover(d, con, min_age_s=min_age_s))


def _recover(
    d: ArchiveDir,
    con: sqlite3.Connection,
    *,
    min_age_s: float,
    skip: frozenset[str] | set[str] = frozenset(),
) -> dict[str, int]:
    removed = sum(
        remove_stale_parts(
            folder,
            min_age_s=min(min_age_s, LOCKED_PART_AGE_S) if folder == d.segments_dir else min_age_s,
        )
        for folder in (d.segments_dir, d.balls_dir, d.tombstones_dir)
        if folder.is_dir()
    )
    with transaction(con, write=True):
        tombstones = apply_tombstone_files(d, con)
        balls = index_ball_files(d, con, only_new=True)
        segments, unreadable = register_segment_files(d, con, only_new=True, skip=skip)
        finished = _finish_quarantines(d, con)
    return {
        "temporaries_removed": removed,
        "tombstone_files_applied": tombstones,
        "ball_files_indexed": balls,
        "segments_registered": segments,
        "segments_unreadable": len(unreadable),
        "repairs_finished": finished,
    }


def _finish_quarantines(d: ArchiveDir, con: sqlite3.Connection) -> int:
    """Switch the index away from segments a killed repair moved to ``quarantine/`` (inside
    the caller's transaction): the count."""
    indexed = {r[0] for r in con.execute("SELECT segment_id FROM segments")}
    n = 0
    for report in quarantine_reports(d.quarantine_dir):
        segment_id = str(report.get("segment_id"))
        if segment_id not in indexed or (d.segments_dir / f"{segment_id}.h5").exists():
            continue
        if not (d.quarantine_dir / f"{segment_id}.h5").exists():
            continue
        salvaged = report.get("salvaged_into")
        path = None if not salvaged else d.segments_dir / f"{salvaged}.h5"
        damaged = {item["run_id"]: item["reason"] for item in report.get("damaged", [])}
        switch_segment(d, con, segment_id, damaged, path if path and path.exists() else None)
        n += 1
    return n


def switch_segment(
    d: ArchiveDir,
    con: sqlite3.Connection,
    segment_id: str,
    damaged: dict[str, str],
    salvaged: Path | None,
) -> None:
    """Inside the caller's write transaction: drop segment ``segment_id`` from the index,
    index its salvaged runs (the sealed segment at ``salvaged``), list the damaged runs
    (``damaged``: run ID -> reason) and serve every run that lost its live copy from a
    duplicate copy where one exists."""
    from .registry import register_segment

    lost = {
        r[0]
        for r in con.execute(
            "SELECT run_id FROM runs WHERE seg = (SELECT seg FROM segments WHERE segment_id = ?)",
            (segment_id,),
        )
    }
    con.execute(
        "DELETE FROM runs WHERE seg = (SELECT seg FROM segments WHERE segment_id = ?)",
        (segment_id,),
    )
    con.execute("DELETE FROM shadowed WHERE segment_id = ?", (segment_id,))
    con.execute("DELETE FROM segments WHERE segment_id = ?", (segment_id,))
    if salvaged is not None:
        register_segment(con, salvaged, d.relative(salvaged))
    for rid, why in damaged.items():
        record_damage(con, segment_id, rid, why)
    promote_copies(d, con, sorted(lost | set(damaged)))
    con.execute("DELETE FROM damaged WHERE run_id IN (SELECT run_id FROM runs)")


def reindex(d: ArchiveDir) -> dict[str, Any]:
    """Rebuild the index from the data files (atomically replaced), after deleting the
    temporaries of killed writers: counts of what was indexed (``runs``, ``segments``,
    ``balls``, ``tombstone_files``), the unreadable segments (``unreadable_segments``, also
    listed as damaged: ``runs repair`` sets them aside) and ``recovered``, the counts of
    :func:`recover` this process has not reported yet."""
    with d.writer_lock():
        removed = sum(
            remove_stale_parts(folder, min_age_s=2.0)
            for folder in (d.segments_dir, d.balls_dir, d.tombstones_dir)
            if folder.is_dir()
        )
        report = rebuild_index(d)
        d.recovered = True  # a rebuilt index holds every data file: nothing left to recover
        report["recovered"] = _take_unreported(d, {"temporaries_removed": removed})
    return report


def kill_copies(d: ArchiveDir, con: sqlite3.Connection, entries: Sequence[Tombstone]) -> None:
    """Tombstone copies of runs (a durable file first, then the index), holding the writer
    lock; runs that lose their live copy fall back to a duplicate copy where one exists."""
    path = write_tombstone(d.tombstones_dir, entries)
    if path is None:
        return
    faults.point("tombstone-written", path=path)
    with transaction(con, write=True):
        orphaned = record_tombstones(con, entries)
        con.execute("INSERT OR IGNORE INTO tombstone_files (name) VALUES (?)", (path.name,))
        promote_copies(d, con, orphaned)


def set_aside(d: ArchiveDir, run_id: str, segment_id: str, reason: str) -> None:
    """Tombstone one copy of a run (``reason`` "removed" or "damaged: ...") and drop it from
    the index; a damaged copy is listed as damaged."""
    with d.writer_lock():
        kill_copies(d, writer_index(d), [Tombstone(segment_id, run_id, reason)])


def remove(d: ArchiveDir, run_id: str) -> str:
    """Tombstone every stored copy of a run (an ID or a unique prefix); its full ID."""
    rid = resolve_id(d, run_id)
    with d.writer_lock():
        con = writer_index(d)
        copies = [
            r[0]
            for r in con.execute(
                "SELECT s.segment_id FROM runs r JOIN segments s ON s.seg = r.seg "
                "WHERE r.run_id = ? UNION SELECT segment_id FROM shadowed WHERE run_id = ?",
                (rid, rid),
            )
        ]
        kill_copies(d, con, [Tombstone(seg, rid, "removed") for seg in copies])
    return rid

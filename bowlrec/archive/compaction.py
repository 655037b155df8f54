"""``runs compact``: rewrite segments that hold dead copies (removed, damaged, duplicate) and
merge small segments (one-run segments of interactive use) into segments of up to
``target_runs`` runs; with ``upgrade`` (``bowlrec archive migrate`` of a 2.x archive) the
segments of a format before the one this code writes instead. Nothing is rewritten in place.

Order (a kill at any point loses nothing and brings no removed run back):
1. the live runs of the chosen segments are written to new sealed segments;
2. one index transaction registers the new segments and drops the old ones;
3. the old files are deleted; then their tombstones (in the index and the tombstone files).
"""

from __future__ import annotations

import json
from collections import defaultdict
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

from bowlrec.atomic_files import atomic_path, fsync_dir
from bowlrec.errors import RunDamagedError, SegmentError

from . import faults
from .directory import ArchiveDir
from .index import transaction
from .maintenance import writer_index
from .quarantine import QUARANTINE_FORMAT
from .reading import load
from .tombstones import TOMBSTONE_FORMAT, Tombstone, read_tombstones
from .writing import seal

if TYPE_CHECKING:
    from .segment_file import SegmentFile
    from .segment_format import RunRecord, SegmentInfo

__all__ = ["compact"]


def _candidates(con: Any, target_runs: int) -> list[tuple[str, str, str]]:
    """(segment ID, path, provenance JSON) of the segments worth rewriting."""
    live = dict(
        con.execute(
            "SELECT s.segment_id, COUNT(*) FROM runs r JOIN segments s ON s.seg = r.seg "
            "GROUP BY r.seg"
        )
    )
    dead = {r[0] for r in con.execute("SELECT segment_id FROM tombstones")}
    dead |= {r[0] for r in con.execute("SELECT segment_id FROM shadowed")}
    rows = con.execute("SELECT segment_id, path, n_runs, provenance_json FROM segments").fetchall()
    small = [r for r in rows if live.get(r[0], 0) < target_runs // 4]
    chosen = {r[0] for r in rows if r[0] in dead or live.get(r[0], 0) < r[2]}
    if len(small) > 1:
        chosen |= {r[0] for r in small}
    return [(r[0], r[1], r[3]) for r in rows if r[0] in chosen]


def _older(
    d: ArchiveDir, con: Any, chosen: list[tuple[str, str, str]]
) -> list[tuple[str, str, str]]:
    """``chosen`` and every other registered segment of a format before the one this code
    writes for it (:data:`~bowlrec.archive.segment_format.SEGMENT_FORMAT_VERSION` for a segment
    holding samples, 2.3 for one without; an unreadable one is left for ``runs repair``)."""
    from .segment_file import SegmentFile
    from .segment_format import SCENE_FORMAT_VERSION, SEGMENT_FORMAT_VERSION, version_tuple

    have = {c[0] for c in chosen}
    out = list(chosen)
    for seg_id, rel, prov in con.execute(
        "SELECT segment_id, path, provenance_json FROM segments ORDER BY segment_id"
    ).fetchall():
        if seg_id in have:
            continue
        try:
            with SegmentFile(d.root / rel) as seg:
                current = SEGMENT_FORMAT_VERSION if seg.has_samples else SCENE_FORMAT_VERSION
                older = version_tuple(seg.format_version) < version_tuple(current)
        except (SegmentError, OSError):
            continue
        if older:
            out.append((seg_id, rel, prov))
    return out


def _carried(d: ArchiveDir, con: Any, seg: SegmentFile, seg_id: str) -> list[RunRecord]:
    """The runs of a chosen segment to rewrite: its live runs, and its duplicate copies whose
    live copy does not read back (so repair can still fall back to them). Raises
    RunDamagedError when a live run of this segment is damaged."""
    rows = con.execute(
        "SELECT row FROM runs WHERE seg = (SELECT seg FROM segments WHERE segment_id = ?) "
        "ORDER BY row",
        (seg_id,),
    ).fetchall()
    records = [seg.read_run(int(row)).to_record() for (row,) in rows]
    for run_id, row in con.execute(
        "SELECT run_id, row FROM shadowed WHERE segment_id = ?", (seg_id,)
    ).fetchall():
        try:
            load(d, run_id)
        except (RunDamagedError, KeyError):
            records.append(seg.read_run(int(row)).to_record())
    return records


def compact(d: ArchiveDir, *, target_runs: int = 10_000, upgrade: bool = False) -> dict[str, int]:
    """Rewrite and merge segments (see the module doc); counts of what was done. A segment
    that cannot be read whole is left as it is, for ``runs repair``. ``upgrade``: rewrite
    (and merge) the segments of an older format instead, into segments of this version."""
    from .registry import register_segment
    from .segment import SegmentBuilder
    from .segment_file import SegmentFile

    with d.writer_lock():
        con = writer_index(d)
        chosen = _older(d, con, []) if upgrade else _candidates(con, target_runs)
        groups: dict[str, list[tuple[str, str]]] = defaultdict(list)
        for seg_id, rel, prov in chosen:
            groups[prov].append((seg_id, rel))
        sealed: list[SegmentInfo] = []
        old: list[tuple[str, str]] = []
        skipped: list[str] = []
        moved = 0
        for prov, members in groups.items():
            provenance = {
                k: v
                for k, v in json.loads(prov).items()
                if k not in ("format", "format_version", "segment_id", "n_runs")
            }
            builder = SegmentBuilder(provenance)
            for seg_id, rel in sorted(members):
                try:
                    with SegmentFile(d.root / rel) as seg:
                        if seg.unknown_groups():
                            # a later 2.x version's record types would not be carried over
                            skipped.append(seg_id)
                            continue
                        records = _carried(d, con, seg, seg_id)
                except (SegmentError, OSError, RunDamagedError):
                    skipped.append(seg_id)  # left in place: `runs repair` quarantines damage
                    continue
                old.append((seg_id, rel))
                for record in records:
                    builder.append(record)
                    moved += 1
                    if len(builder) >= target_runs:
                        sealed.append(seal(d, builder))
                        builder = SegmentBuilder(provenance)
            if len(builder):
                sealed.append(seal(d, builder))
        faults.point("compaction-sealed")
        with transaction(con, write=True):
            for seg_id, _ in old:
                con.execute(
                    "DELETE FROM runs WHERE seg = (SELECT seg FROM segments WHERE segment_id = ?)",
                    (seg_id,),
                )
                con.execute("DELETE FROM shadowed WHERE segment_id = ?", (seg_id,))
                con.execute("DELETE FROM segments WHERE segment_id = ?", (seg_id,))
            for info in sealed:
                register_segment(con, info.path, d.relative(info.path), info=info)
        faults.point("compaction-switched")
        d.close()
        for _, rel in old:
            (d.root / rel).unlink(missing_ok=True)
        fsync_dir(d.segments_dir)  # the deletions reach the disk before the tombstones go
        faults.point("compaction-deleted")
        dropped = _drop_applied_tombstones(d, con, {seg_id for seg_id, _ in old})
    return {
        "segments_rewritten": len(old),
        "segments_written": len(sealed),
        "segments_left": len(skipped),
        "runs_moved": moved,
        "tombstone_files_deleted": dropped,
    }


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _keep_damage_records(d: ArchiveDir, entries: list[Tombstone]) -> None:
    """Damaged copies outlive their tombstones as quarantine reports (``runs list --damaged``
    still lists them after an index rebuild)."""

    by_segment: dict[str, list[Tombstone]] = defaultdict(list)
    for e in entries:
        if e.reason.startswith("damaged"):
            by_segment[e.segment_id].append(e)
    d.quarantine_dir.mkdir(exist_ok=True)
    for seg_id, items in by_segment.items():
        report = {
            "format": QUARANTINE_FORMAT,
            "segment_id": seg_id,
            "at": _now(),
            "damaged": [{"run_id": e.run_id, "reason": e.reason} for e in items],
            "salvaged_into": None,
            "salvaged_runs": 0,
        }
        target = d.quarantine_dir / f"{seg_id}.compacted.json"
        with atomic_path(target) as tmp:
            tmp.write_text(json.dumps(report, indent=1) + "\n")


def _drop_applied_tombstones(d: ArchiveDir, con: Any, removed: set[str]) -> int:
    """Delete the tombstones of the segments this compaction deleted (index rows and files);
    the count of tombstone files deleted."""

    deleted = 0
    with transaction(con, write=True):
        con.executemany(
            "DELETE FROM tombstones WHERE segment_id = ?", [(seg_id,) for seg_id in removed]
        )
    for path, entries in list(read_tombstones(d.tombstones_dir)):
        keep = [e for e in entries if e.segment_id not in removed]
        if len(keep) == len(entries):
            continue
        _keep_damage_records(d, [e for e in entries if e.segment_id in removed])
        if keep:
            doc = {"format": TOMBSTONE_FORMAT, "entries": [e.__dict__ for e in keep]}
            with atomic_path(path, hold_lock=True) as tmp:
                tmp.write_text(json.dumps(doc) + "\n")
        else:
            path.unlink(missing_ok=True)
            with transaction(con, write=True):
                con.execute("DELETE FROM tombstone_files WHERE name = ?", (path.name,))
            deleted += 1
    return deleted

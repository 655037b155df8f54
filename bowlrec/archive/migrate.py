"""``bowlrec archive migrate``: convert a format 1.0 archive (one HDF5 file per run) to 2.0,
and rewrite the segments of a 2.x archive written before the current segment format (2.0-2.2)
as segments of this version (2.3).

A 2.x archive is upgraded by compaction (:func:`bowlrec.archive.compaction.compact` with
``upgrade``): the older segments' live runs are written to new sealed segments first, one index
transaction switches to them, and only then are the old files deleted, so a migration killed at
any point loses nothing and is finished by running it again.

Run IDs do not change (the content hash is the same in both formats), so scenes and jobs run
before the migration find their runs after it and add no duplicates. The 1.0 files are moved,
not deleted, to ``ARCHIVE/v1-archive/`` first; every run file is then read and rewritten into
segments (grouped by the provenance it was made with), every library ball into a ball file,
and only then is ``archive.json`` switched to 2.0. A migration killed at any point is resumed
by running it again; ``v1-archive/`` can be deleted once the migrated archive looks right.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import sqlite3
from collections.abc import Callable, Iterator
from datetime import datetime
from pathlib import Path
from typing import Any

from bowlrec.atomic_files import atomic_path
from bowlrec.errors import MigrationError, RunFileError

from .ball_files import BALL_FILE_FORMAT, ball_sha
from .directory import ARCHIVE_FORMAT, ARCHIVE_FORMAT_VERSION
from .store import Archive
from .writing import pattern_label

__all__ = ["V1_BACKUP", "MigrationError", "migrate"]

#: where the 1.0 files go (inside the archive)
V1_BACKUP = "v1-archive"
_PROVENANCE_KEYS = (
    "bowlrec_version",
    "physics_version",
    "python_version",
    "platform",
    "numpy_version",
    "numba_version",
    "h5py_version",
    "hdf5_version",
)


@contextlib.contextmanager
def _locked(root: Path) -> Iterator[None]:
    with open(root / ".writer.lock", "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _is_v2_index(path: Path) -> bool:
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        try:
            rows = con.execute("SELECT value FROM meta WHERE key = 'index_format'").fetchall()
        finally:
            con.close()
    except sqlite3.DatabaseError:
        return False
    return bool(rows) and rows[0][0] == "2"


def _move_v1_files(root: Path, backup: Path) -> None:
    backup.mkdir(exist_ok=True)
    index = root / "index.sqlite"
    if index.exists() and not _is_v2_index(index):
        with contextlib.suppress(sqlite3.DatabaseError):  # fold the WAL into the file
            con = sqlite3.connect(index)
            con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
            con.close()
        for suffix in ("", "-wal", "-shm"):
            src = root / f"index.sqlite{suffix}"
            if src.exists():
                os.replace(src, backup / src.name)
    if (root / "runs").is_dir():
        os.replace(root / "runs", backup / "runs")


def _v1_balls(backup: Path) -> list[dict[str, Any]]:
    index = backup / "index.sqlite"
    if not index.exists():
        return []
    con = sqlite3.connect(f"file:{index}?mode=ro", uri=True)
    con.row_factory = sqlite3.Row
    try:
        return [dict(r) for r in con.execute("SELECT * FROM balls ORDER BY name, version")]
    except sqlite3.DatabaseError:
        return []
    finally:
        con.close()


def _ns(iso: str) -> int:
    return int(datetime.fromisoformat(iso).timestamp() * 1_000_000) * 1000


def migrate(
    root: str | os.PathLike[str],
    *,
    segment_runs: int = 1000,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Convert the format 1.0 archive at ``root`` to 2.0 in place; a report (counts, the run
    files that could not be read, where the 1.0 files were kept). ``progress(done, total)`` is
    called as run files are converted. A 2.x archive's segments of an older format are
    rewritten in the current one (the report says how many; ``already``: the archive's
    directory format)."""
    from bowlrec.sinks.common import RunData
    from bowlrec.sinks.hdf5_run import read_run_file

    from .segment import RunRecord, SegmentBuilder

    root = Path(root).expanduser()
    marker = root / "archive.json"
    try:
        meta = json.loads(marker.read_text())
    except (OSError, ValueError) as err:
        raise MigrationError(f"{root} is not a bowlrec archive ({err})") from None
    version = str(meta.get("format_version", ""))
    if meta.get("format") != ARCHIVE_FORMAT:
        raise MigrationError(f"{marker}: not a bowlrec archive marker")
    if version.split(".")[0] == "2":
        archive = Archive(root, create=False)
        upgraded = archive.compact(upgrade=True)
        return {
            "already": version,
            "runs": len(archive),
            "segments_rewritten": upgraded["segments_rewritten"],
            "segments_written": upgraded["segments_written"],
            "segments_left": upgraded["segments_left"],
        }
    if version.split(".")[0] != "1":
        raise MigrationError(f"{root}: archive format {version} cannot be migrated")
    backup = root / V1_BACKUP
    with _locked(root):
        _move_v1_files(root, backup)
        for d in ("segments", "balls", "tombstones", "quarantine"):  # a killed earlier attempt
            shutil.rmtree(root / d, ignore_errors=True)
        (root / "index.sqlite").unlink(missing_ok=True)
        for d in ("segments", "balls", "tombstones"):
            (root / d).mkdir()
        balls = _v1_balls(backup)
        for b in balls:
            doc = {
                "format": BALL_FILE_FORMAT,
                "name": b["name"],
                "version": int(b["version"]),
                "added_at": b["added_at"],
                "note": b["note"],
                "spec": json.loads(b["spec_json"]),
            }
            with atomic_path(root / "balls" / b["name"] / f"{b['version']}.json") as tmp:
                tmp.write_text(json.dumps(doc, indent=1) + "\n")
        files = sorted((backup / "runs").glob("*/*.h5"))
        builders: dict[tuple[Any, ...], SegmentBuilder] = {}
        unreadable: list[str] = []
        segments = 0
        for done, path in enumerate(files, 1):
            try:
                stored = read_run_file(path)
                run = RunData(
                    stored.scene, stored.scene.resolve(), stored.trajectory, stored.run_id
                )
            except (OSError, RunFileError, KeyError, ValueError) as err:
                unreadable.append(f"{path.relative_to(root)}: {err}")
                continue
            a = stored.attrs
            prov = {k: str(a.get(k, "unknown")) for k in _PROVENANCE_KEYS}
            key = tuple(prov.values())
            builder = builders.setdefault(key, SegmentBuilder(prov))
            builder.append(
                RunRecord.from_run(
                    run,
                    wall_time_s=float(a.get("wall_time_s", 0.0)),
                    ball_ref=str(a.get("ball_ref", "")),
                    solver=str(a.get("solver", "")),
                    ball_sha=ball_sha(stored.scene.ball),
                    pattern=pattern_label(stored.scene),
                    created_at_ns=_ns(str(a["created_at"])) if a.get("created_at") else None,
                )
            )
            if len(builder) >= segment_runs:
                builder.seal(root / "segments")
                segments += 1
                builders[key] = SegmentBuilder(prov)
            if progress is not None:
                progress(done, len(files))
        for builder in builders.values():
            if len(builder):
                builder.seal(root / "segments")
                segments += 1
        with atomic_path(marker) as tmp:
            doc = {"format": ARCHIVE_FORMAT, "format_version": ARCHIVE_FORMAT_VERSION}
            tmp.write_text(json.dumps(doc) + "\n")
    archive = Archive(root, create=False)  # takes the writer lock itself
    archive.reindex()
    return {
        "from": version,
        "to": ARCHIVE_FORMAT_VERSION,
        "runs": len(archive),
        "run_files": len(files),
        "unreadable_run_files": unreadable,
        "segments": segments,
        "balls": len(balls),
        "v1_files_kept_in": str(backup),
    }

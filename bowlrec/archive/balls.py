"""The archive's ball-spec library: named, versioned ball specs.

Each version is one JSON file in the archive (``balls/<name>/<version>.json``, the source of
truth; its format: :mod:`.ball_files`); the index lists them. Adding a spec under a name that
already has an identical latest spec is a no-op (same version); a changed spec becomes the next
version and the old versions stay. Runs reference the library entry they used as
``name@version``. Export/import is a JSON document (format ``bowlrec-ball-library``) holding
every version.
"""

from __future__ import annotations

import builtins
import json
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.atomic_files import atomic_path
from bowlrec.errors import BallNotFoundError, BallRefError, SpecError

from .ball_files import (
    BALL_FILE_FORMAT,
    NAME,
    BallEntry,
    ball_sha,
    entry_from_row,
    parse_ball,
    parse_ball_ref,
)
from .ball_import import LIBRARY_FORMAT, LIBRARY_FORMAT_VERSION, library_items
from .directory import ArchiveDir
from .index import transaction
from .maintenance import writer_index
from .rebuild import read_index

if TYPE_CHECKING:
    from .ball_files import AnyBall

__all__ = [
    "BALL_FILE_FORMAT",
    "LIBRARY_FORMAT",
    "BallEntry",
    "BallLibrary",
    "BallNotFoundError",
    "ball_sha",
    "parse_ball",
    "parse_ball_ref",
]


class BallLibrary:
    """Versioned ball specs of an archive.

    Each version is a file ``balls/<name>/<version>.json`` (written once, atomically); the
    index's ``balls`` table is derived from these files and answers the queries.
    """

    def __init__(self, directory: ArchiveDir) -> None:
        self.directory = directory
        #: ball-spec SHA-256 -> the newest library reference with that spec (read once)
        self._refs: dict[str, str] | None = None

    def _dir(self, name: str) -> Path:
        return self.directory.balls_dir / name

    def refs_by_sha(self) -> dict[str, str]:
        """SHA-256 of each library spec -> ``name@version`` of its newest entry (read once;
        forgotten when this library adds or removes a version)."""
        if self._refs is None:
            rows = read_index(self.directory).execute(
                "SELECT sha, name, version FROM balls ORDER BY added_at, version"
            )
            self._refs = {sha: f"{name}@{version}" for sha, name, version in rows}
        return self._refs

    def _versions_on_disk(self, name: str) -> builtins.list[int]:
        d = self._dir(name)
        if not d.is_dir():
            return []
        return sorted(int(p.stem) for p in d.glob("*.json") if p.stem.isdigit())

    def add(self, name: str, ball: AnyBall, note: str = "") -> tuple[BallEntry, bool]:
        """Store ``ball`` under ``name``; returns (entry, True if a new version was created)."""
        if not isinstance(name, str) or not NAME.fullmatch(name):
            raise BallRefError(
                f"ball name {name!r}: use 1-100 letters, digits, spaces and . _ + - "
                "(starting with a letter or digit; '@' separates the version)"
            )
        sha = ball_sha(ball)
        with self.directory.writer_lock():
            con = writer_index(self.directory)
            rows = con.execute(
                "SELECT * FROM balls WHERE name = ? ORDER BY version DESC LIMIT 1", (name,)
            ).fetchall()
            latest = rows[0] if rows else None
            if latest is not None and latest["sha"] == sha:
                return entry_from_row(latest), False
            on_disk = self._versions_on_disk(name)
            version = 1 + max([0, *on_disk] + ([] if latest is None else [int(latest["version"])]))
            added_at = datetime.now(UTC).isoformat(timespec="seconds")
            doc = {
                "format": BALL_FILE_FORMAT,
                "name": name,
                "version": version,
                "added_at": added_at,
                "note": note,
                "spec": ball.model_dump(mode="json"),
            }

            with atomic_path(self._dir(name) / f"{version}.json", hold_lock=True) as tmp:
                tmp.write_text(json.dumps(doc, indent=1) + "\n")
            self._refs = None
            with transaction(con, write=True):
                con.execute(
                    "INSERT OR REPLACE INTO balls (name, version, sha, spec_json, added_at, note) "
                    "VALUES (?, ?, ?, ?, ?, ?)",
                    (name, version, sha, ball.model_dump_json(), added_at, note),
                )
        return BallEntry(name, version, sha, ball, added_at, note), True

    def _query(self, sql: str, params: tuple[Any, ...] = ()) -> builtins.list[Any]:
        return read_index(self.directory).execute(sql, params).fetchall()

    def get(self, ref: str) -> BallEntry:
        """The entry for ``name`` (latest version) or ``name@version``."""
        name, version = parse_ball_ref(ref)
        if version is None:
            rows = self._query(
                "SELECT * FROM balls WHERE name = ? ORDER BY version DESC LIMIT 1", (name,)
            )
        else:
            rows = self._query(
                "SELECT * FROM balls WHERE name = ? AND version = ?", (name, version)
            )
        if not rows:
            raise BallNotFoundError(self._not_found(ref, name))
        return entry_from_row(rows[0])

    def _not_found(self, ref: str, name: str) -> str:
        """No ball ``ref``: the close names, or how many the library holds."""
        from bowlrec.suggest import did_you_mean, some_names

        known = {e.name for e in self.list()}
        if not known:
            return (
                f"no ball {ref!r} in the library: it is empty (`bowlrec balls add-examples` adds "
                "the curated spec sheets, `bowlrec balls add NAME FILE` your own)"
            )
        if name in known:  # the name is there, not this version
            return f"no ball {ref!r} in the library (`bowlrec balls list --all` lists versions)"
        hint = did_you_mean(name, known) or f"balls: {some_names(known)}"
        return f"no ball {ref!r} in the library; {hint} (`bowlrec balls list` lists them all)"

    def list(self, name: str | None = None, all_versions: bool = False) -> builtins.list[BallEntry]:
        """Entries sorted by name and version; only the latest per name unless ``all_versions``."""
        sql = "SELECT * FROM balls"
        params: tuple[Any, ...] = ()
        if name is not None:
            sql += " WHERE name = ?"
            params = (name,)
        entries = [entry_from_row(r) for r in self._query(sql + " ORDER BY name, version", params)]
        if all_versions:
            return entries
        latest: dict[str, BallEntry] = {}
        for e in entries:
            latest[e.name] = e
        return builtins.list(latest.values())

    def find(self, ball: AnyBall) -> BallEntry | None:
        """The newest entry whose spec equals ``ball`` (None if the library has none)."""
        return self.find_sha(ball_sha(ball))

    def find_sha(self, sha: str) -> BallEntry | None:
        """The newest entry whose spec has SHA-256 ``sha`` (None if the library has none)."""
        rows = self._query(
            "SELECT * FROM balls WHERE sha = ? ORDER BY added_at DESC, version DESC LIMIT 1",
            (sha,),
        )
        return entry_from_row(rows[0]) if rows else None

    def remove(self, name: str, version: int) -> None:
        """Delete one version (runs that used it keep their copy of the spec)."""
        if not NAME.fullmatch(name):  # no such ball can exist (and no path outside balls/)
            raise BallNotFoundError(f"no ball {name}@{version} in the library")
        with self.directory.writer_lock():
            con = writer_index(self.directory)
            path = self._dir(name) / f"{version}.json"
            known = con.execute(
                "SELECT 1 FROM balls WHERE name = ? AND version = ?", (name, version)
            ).fetchall()
            if not known and not path.exists():
                raise BallNotFoundError(f"no ball {name}@{version} in the library")
            path.unlink(missing_ok=True)  # the file first: a removed ball never comes back
            self._refs = None
            with transaction(con, write=True):
                con.execute("DELETE FROM balls WHERE name = ? AND version = ?", (name, version))

    def export_json(self, path: str | Path | None = None) -> dict[str, Any]:
        """Every version of every ball as a JSON document (written to ``path`` if given)."""
        doc = {
            "format": LIBRARY_FORMAT,
            "format_version": LIBRARY_FORMAT_VERSION,
            "balls": [e.to_json_dict() for e in self.list(all_versions=True)],
        }
        if path is not None:
            with atomic_path(path) as tmp:
                tmp.write_text(json.dumps(doc, indent=2) + "\n")
        return doc

    def import_json(
        self, source: str | Path | dict[str, Any]
    ) -> builtins.list[tuple[BallEntry, bool]]:
        """Add every spec of an exported document, oldest version first; (entry, added) each.

        Specs identical to any version already under that name are skipped, so importing twice
        adds nothing.
        Version numbers are assigned by this library (they continue its own sequence). Raises
        :class:`~bowlrec.errors.SpecError` for a document that is not an export or holds an
        invalid spec (nothing is added then).
        """
        doc: Any = source
        if isinstance(source, str | Path):
            try:
                doc = json.loads(Path(source).read_text(encoding="utf-8"))
            except (OSError, ValueError) as err:  # unreadable, not UTF-8 or not JSON
                reason = err.strerror if isinstance(err, OSError) else f"not JSON: {err}"
                raise SpecError(f"{source}: not a ball library export ({reason})") from None
        try:
            parsed = library_items(doc)
        except SpecError as err:
            if not isinstance(source, str | Path):
                raise
            raise SpecError(
                "\n".join(f"{source}: {line}" for line in str(err).splitlines())
            ) from None
        out = []
        for name, ball, note in parsed:
            sha = ball_sha(ball)
            same = [e for e in self.list(name, all_versions=True) if e.sha == sha]
            if same:
                out.append((same[-1], False))
            else:
                out.append(self.add(name, ball, note=note))
        return out

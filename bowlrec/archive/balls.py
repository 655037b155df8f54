"""The archive's ball-spec library: named, versioned ball specs.

An entry is a physical ball (:class:`~bowlrec.spec.Ball`: SI, principal axes and offset in the
lane frame at release) or a spec sheet in bowlers' units
(:class:`~bowlrec.bowling.ball.BowlerBall`, placed on the lane by a bowler scene's layout).

Each version is one JSON file in the archive (``balls/<name>/<version>.json``, the source of
truth); the index lists them. Adding a spec under a name that already has an identical latest
spec is a no-op (same version); a changed spec becomes the next version and the old versions
stay. Runs reference the library entry they used as ``name@version``. Export/import is a JSON
document (format ``bowlrec-ball-library``) holding every version.
"""

from __future__ import annotations

import builtins
import hashlib
import json
import re
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

from bowlrec.atomic_files import atomic_path
from bowlrec.errors import BallNotFoundError, BallRefError, SpecError

from .index import transaction

if TYPE_CHECKING:
    from bowlrec.bowling.ball import BowlerBall
    from bowlrec.spec import Ball

    from .store import Archive

    #: a library entry holds a physical ball (SI, lane frame at release) or a spec sheet
    AnyBall: TypeAlias = Ball | BowlerBall

__all__ = [
    "LIBRARY_FORMAT",
    "BallEntry",
    "BallLibrary",
    "BallNotFoundError",
    "ball_sha",
    "parse_ball_ref",
]

LIBRARY_FORMAT = "bowlrec-ball-library"
LIBRARY_FORMAT_VERSION = 1
#: format marker of one library entry's file (``balls/<name>/<version>.json``)
BALL_FILE_FORMAT = "bowlrec-ball"
#: a ball name, matched whole (``fullmatch``: a trailing newline is not part of a valid name)
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9 ._+\-]{0,99}")


def parse_ball(data: dict[str, Any]) -> AnyBall:
    """A physical :class:`~bowlrec.spec.Ball` or, when the mapping is a spec sheet (it has
    ``weight_lb``), a :class:`~bowlrec.bowling.ball.BowlerBall`."""
    if "weight_lb" in data:
        from bowlrec.bowling.ball import BowlerBall

        return BowlerBall.model_validate(data)
    from bowlrec.spec import Ball

    return Ball.model_validate(data)


def ball_sha(ball: AnyBall) -> str:
    """SHA-256 (hex) of the ball spec's canonical JSON: equal specs, equal hashes."""
    canon = json.dumps(ball.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canon.encode()).hexdigest()


def parse_ball_ref(ref: str) -> tuple[str, int | None]:
    """``"name"`` -> (name, None = latest); ``"name@3"`` -> (name, 3)."""
    name, sep, version = ref.rpartition("@")
    if not sep:
        return ref, None
    if not re.fullmatch(r"[0-9]{1,9}", version) or int(version) < 1:
        raise BallRefError(f"ball reference {ref!r}: the version after '@' must be an integer >= 1")
    return name, int(version)


@dataclass(frozen=True)
class BallEntry:
    """One version of one named ball spec."""

    name: str
    version: int
    sha: str
    ball: AnyBall
    added_at: str
    note: str = ""

    @property
    def ref(self) -> str:
        return f"{self.name}@{self.version}"

    def to_json_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "version": self.version,
            "added_at": self.added_at,
            "note": self.note,
            "spec": self.ball.model_dump(mode="json"),
        }


def _entry(row: Any) -> BallEntry:
    return BallEntry(
        name=row["name"],
        version=int(row["version"]),
        sha=row["sha"],
        ball=parse_ball(json.loads(row["spec_json"])),
        added_at=row["added_at"],
        note=row["note"],
    )


def ball_file_row(path: Path) -> tuple[str, int, str, str, str, str]:
    """(name, version, sha, spec_json, added_at, note) of a ball file, for the index."""
    doc = json.loads(path.read_text())
    if doc.get("format") != BALL_FILE_FORMAT:
        raise ValueError(f"{path}: not a bowlrec ball file (format = {doc.get('format')!r})")
    spec = parse_ball(doc["spec"])
    return (
        str(doc["name"]),
        int(doc["version"]),
        ball_sha(spec),
        spec.model_dump_json(),
        str(doc["added_at"]),
        str(doc.get("note", "")),
    )


class BallLibrary:
    """Versioned ball specs of an archive.

    Each version is a file ``balls/<name>/<version>.json`` (written once, atomically); the
    index's ``balls`` table is derived from these files and answers the queries.
    """

    def __init__(self, archive: Archive) -> None:
        self.archive = archive

    def _dir(self, name: str) -> Path:
        return self.archive.balls_dir / name

    def _versions_on_disk(self, name: str) -> builtins.list[int]:
        d = self._dir(name)
        if not d.is_dir():
            return []
        return sorted(int(p.stem) for p in d.glob("*.json") if p.stem.isdigit())

    def add(self, name: str, ball: AnyBall, note: str = "") -> tuple[BallEntry, bool]:
        """Store ``ball`` under ``name``; returns (entry, True if a new version was created)."""
        if not isinstance(name, str) or not _NAME.fullmatch(name):
            raise BallRefError(
                f"ball name {name!r}: use 1-100 letters, digits, spaces and . _ + - "
                "(starting with a letter or digit; '@' separates the version)"
            )
        sha = ball_sha(ball)
        with self.archive.writer_lock():
            con = self.archive.index_writer()
            rows = con.execute(
                "SELECT * FROM balls WHERE name = ? ORDER BY version DESC LIMIT 1", (name,)
            ).fetchall()
            latest = rows[0] if rows else None
            if latest is not None and latest["sha"] == sha:
                return _entry(latest), False
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
            self.archive._ball_refs = None
            with transaction(con, write=True):
                con.execute(
                    "INSERT OR REPLACE INTO balls (name, version, sha, spec_json, added_at, note) "
                    "VALUES (?, ?, ?, ?, ?, ?)",
                    (name, version, sha, ball.model_dump_json(), added_at, note),
                )
        return BallEntry(name, version, sha, ball, added_at, note), True

    def _query(self, sql: str, params: tuple[Any, ...] = ()) -> builtins.list[Any]:
        return self.archive.index_reader().execute(sql, params).fetchall()

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
            known = ", ".join(sorted({e.name for e in self.list()})) or "none"
            raise BallNotFoundError(f"no ball {ref!r} in the library (balls: {known})")
        return _entry(rows[0])

    def list(self, name: str | None = None, all_versions: bool = False) -> builtins.list[BallEntry]:
        """Entries sorted by name and version; only the latest per name unless ``all_versions``."""
        sql = "SELECT * FROM balls"
        params: tuple[Any, ...] = ()
        if name is not None:
            sql += " WHERE name = ?"
            params = (name,)
        entries = [_entry(r) for r in self._query(sql + " ORDER BY name, version", params)]
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
        return _entry(rows[0]) if rows else None

    def remove(self, name: str, version: int) -> None:
        """Delete one version (runs that used it keep their copy of the spec)."""
        if not _NAME.fullmatch(name):  # no such ball can exist (and no path outside balls/)
            raise BallNotFoundError(f"no ball {name}@{version} in the library")
        with self.archive.writer_lock():
            con = self.archive.index_writer()
            path = self._dir(name) / f"{version}.json"
            known = con.execute(
                "SELECT 1 FROM balls WHERE name = ? AND version = ?", (name, version)
            ).fetchall()
            if not known and not path.exists():
                raise BallNotFoundError(f"no ball {name}@{version} in the library")
            path.unlink(missing_ok=True)  # the file first: a removed ball never comes back
            self.archive._ball_refs = None
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
        from pydantic import ValidationError

        from bowlrec.spec import format_validation_error

        doc = source if isinstance(source, dict) else json.loads(Path(source).read_text())
        try:
            if doc.get("format") != LIBRARY_FORMAT:
                raise SpecError(
                    f"not a ball library export (format = {doc.get('format')!r}, "
                    f"expected {LIBRARY_FORMAT!r})"
                )
            items = sorted(doc.get("balls", []), key=lambda b: (b["name"], b.get("version", 0)))
            parsed = [
                (item["name"], parse_ball(item["spec"]), item.get("note", "")) for item in items
            ]
        except ValidationError as err:
            raise SpecError(format_validation_error(err)) from None
        except (AttributeError, KeyError, TypeError) as err:
            raise SpecError(f"not a ball library document: {err}") from None
        out = []
        for name, ball, note in parsed:
            sha = ball_sha(ball)
            same = [e for e in self.list(name, all_versions=True) if e.sha == sha]
            if same:
                out.append((same[-1], False))
            else:
                out.append(self.add(name, ball, note=note))
        return out

"""The archive's ball-spec library: named, versioned ball specs.

An entry is a physical ball (:class:`~bowlrec.spec.Ball`: SI, principal axes and offset in the
lane frame at release) or a spec sheet in bowlers' units
(:class:`~bowlrec.bowling.ball.BowlerBall`, placed on the lane by a bowler scene's layout).

Adding a spec under a name that already has an identical latest spec is a no-op (same version);
a changed spec becomes the next version and the old versions stay. Runs reference the library
entry they used as ``name@version``. Export/import is a JSON document (format
``bowlrec-ball-library``) holding every version.
"""

from __future__ import annotations

import builtins
import hashlib
import json
import re
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .index import connect

if TYPE_CHECKING:
    from bowlrec.bowling.ball import BowlerBall
    from bowlrec.spec import Ball

    #: a library entry holds a physical ball (SI, lane frame at release) or a spec sheet
    AnyBall = Ball | BowlerBall

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
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9 ._+\-]{0,99}$")


class BallNotFoundError(KeyError):
    """No library entry under that name (and version)."""

    def __str__(self) -> str:  # KeyError quotes its message; show it plainly
        return str(self.args[0])


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
    if not version.isdigit() or int(version) < 1:
        raise ValueError(f"ball reference {ref!r}: the version after '@' must be an integer >= 1")
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


class BallLibrary:
    """Versioned ball specs stored in the archive's index database (table ``balls``)."""

    def __init__(self, index_path: Path) -> None:
        self.index_path = index_path

    def add(self, name: str, ball: AnyBall, note: str = "") -> tuple[BallEntry, bool]:
        """Store ``ball`` under ``name``; returns (entry, True if a new version was created)."""
        if not _NAME.match(name):
            raise ValueError(
                f"ball name {name!r}: use 1-100 letters, digits, spaces and . _ + - "
                "(starting with a letter or digit; '@' separates the version)"
            )
        sha = ball_sha(ball)
        with connect(self.index_path) as con:
            latest = con.execute(
                "SELECT * FROM balls WHERE name = ? ORDER BY version DESC LIMIT 1", (name,)
            ).fetchone()
            if latest is not None and latest["sha"] == sha:
                return _entry(latest), False
            version = 1 if latest is None else int(latest["version"]) + 1
            added_at = datetime.now(UTC).isoformat(timespec="seconds")
            con.execute(
                "INSERT INTO balls (name, version, sha, spec_json, added_at, note) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (name, version, sha, ball.model_dump_json(), added_at, note),
            )
        return BallEntry(name, version, sha, ball, added_at, note), True

    def get(self, ref: str) -> BallEntry:
        """The entry for ``name`` (latest version) or ``name@version``."""
        name, version = parse_ball_ref(ref)
        with connect(self.index_path) as con:
            if version is None:
                row = con.execute(
                    "SELECT * FROM balls WHERE name = ? ORDER BY version DESC LIMIT 1", (name,)
                ).fetchone()
            else:
                row = con.execute(
                    "SELECT * FROM balls WHERE name = ? AND version = ?", (name, version)
                ).fetchone()
        if row is None:
            known = ", ".join(sorted({e.name for e in self.list()})) or "none"
            raise BallNotFoundError(f"no ball {ref!r} in the library (balls: {known})")
        return _entry(row)

    def list(self, name: str | None = None, all_versions: bool = False) -> list[BallEntry]:
        """Entries sorted by name and version; only the latest per name unless ``all_versions``."""
        sql = "SELECT * FROM balls"
        params: tuple[Any, ...] = ()
        if name is not None:
            sql += " WHERE name = ?"
            params = (name,)
        with connect(self.index_path) as con:
            rows = con.execute(sql + " ORDER BY name, version", params).fetchall()
        entries = [_entry(r) for r in rows]
        if all_versions:
            return entries
        latest: dict[str, BallEntry] = {}
        for e in entries:
            latest[e.name] = e
        return list(latest.values())

    def find(self, ball: AnyBall) -> BallEntry | None:
        """The newest entry whose spec equals ``ball`` (None if the library has none)."""
        with connect(self.index_path) as con:
            row = con.execute(
                "SELECT * FROM balls WHERE sha = ? ORDER BY added_at DESC, version DESC LIMIT 1",
                (ball_sha(ball),),
            ).fetchone()
        return None if row is None else _entry(row)

    def remove(self, name: str, version: int) -> None:
        """Delete one version (runs that used it keep their copy of the spec)."""
        with connect(self.index_path) as con:
            cur = con.execute("DELETE FROM balls WHERE name = ? AND version = ?", (name, version))
            if cur.rowcount == 0:
                raise BallNotFoundError(f"no ball {name}@{version} in the library")

    def export_json(self, path: str | Path | None = None) -> dict[str, Any]:
        """Every version of every ball as a JSON document (written to ``path`` if given)."""
        doc = {
            "format": LIBRARY_FORMAT,
            "format_version": LIBRARY_FORMAT_VERSION,
            "balls": [e.to_json_dict() for e in self.list(all_versions=True)],
        }
        if path is not None:
            from bowlrec.sinks.atomic import atomic_path

            with atomic_path(path) as tmp:
                tmp.write_text(json.dumps(doc, indent=2) + "\n")
        return doc

    def import_json(
        self, source: str | Path | dict[str, Any]
    ) -> builtins.list[tuple[BallEntry, bool]]:
        """Add every spec of an exported document, oldest version first; (entry, added) each.

        Specs identical to any version already under that name are skipped, so importing twice
        adds nothing.
        Version numbers are assigned by this library (they continue its own sequence).
        """
        doc = source if isinstance(source, dict) else json.loads(Path(source).read_text())
        if doc.get("format") != LIBRARY_FORMAT:
            raise ValueError(
                f"not a ball library export (format = {doc.get('format')!r}, "
                f"expected {LIBRARY_FORMAT!r})"
            )
        items = sorted(doc.get("balls", []), key=lambda b: (b["name"], b.get("version", 0)))
        out = []
        for item in items:
            ball = parse_ball(item["spec"])
            sha = ball_sha(ball)
            same = [e for e in self.list(item["name"], all_versions=True) if e.sha == sha]
            if same:
                out.append((same[-1], False))
            else:
                out.append(self.add(item["name"], ball, note=item.get("note", "")))
        return out

"""The ball library's entries: one JSON file per version (``balls/<name>/<version>.json``,
format ``bowlrec-ball``), its index row, its SHA-256 and its ``name@version`` reference.

An entry is a physical ball (:class:`~bowlrec.spec.Ball`: SI, principal axes and offset in the
lane frame at release) or a spec sheet in bowlers' units
(:class:`~bowlrec.bowling.ball.BowlerBall`, recognised by its ``weight_lb`` key).
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

from bowlrec.errors import BallRefError, IndexUnreadableError

if TYPE_CHECKING:
    from bowlrec.bowling.ball import BowlerBall
    from bowlrec.spec import Ball

    #: a library entry holds a physical ball (SI, lane frame at release) or a spec sheet
    AnyBall: TypeAlias = Ball | BowlerBall

__all__ = [
    "BALL_FILE_FORMAT",
    "NAME",
    "BallEntry",
    "ball_file_row",
    "ball_sha",
    "entry_from_row",
    "parse_ball",
    "parse_ball_ref",
]

#: format marker of one library entry's file (``balls/<name>/<version>.json``)
BALL_FILE_FORMAT = "bowlrec-ball"
#: a ball name, matched whole (``fullmatch``: a trailing newline is not part of a valid name)
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9 ._+\-]{0,99}")


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
    """One version of one named ball spec; ``added_at`` ISO 8601 UTC."""

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


def entry_from_row(row: Any) -> BallEntry:
    """The entry of a ``balls`` row of the index. A row whose spec does not parse raises
    :class:`~bowlrec.errors.IndexUnreadableError` naming the ball and the fix (the ball files
    are the truth; the index is rebuilt from them)."""
    try:
        ball = parse_ball(json.loads(row["spec_json"]))
    except (ValueError, TypeError) as err:  # JSONDecodeError and ValidationError are ValueErrors
        reason = " ".join(str(err).split("\n", 1)[0].split())
        raise IndexUnreadableError(
            f"ball {row['name']}@{row['version']}: its row in the index is damaged "
            f"({type(err).__name__}: {reason}); rebuild the index from the ball files with "
            "`bowlrec runs reindex` or `bowlrec runs repair`"
        ) from None
    return BallEntry(
        name=row["name"],
        version=int(row["version"]),
        sha=row["sha"],
        ball=ball,
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

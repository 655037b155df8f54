"""Comparing a session's shots with ones stored by an older physics version.

A physics version (``bowlrec.versions.PHYSICS_VERSION``) changes run IDs and moves results
within the integrator's tolerance (CHANGELOG.md, "Physics versions"); the committed session
fixtures keep what their version stored. :func:`assert_same_shots` checks that a replay is the
same play: every field equal, floats to 1e-6 relative (the sessions' rtol is 1e-9; a changed
shot, line or oil transfer moves them by far more), run IDs equal when the physics is the
same.
"""

from __future__ import annotations

from typing import Any

from bowlrec.versions import PHYSICS_VERSION

__all__ = ["assert_same_shots"]

#: the physics version that wrote the committed session fixtures (tests/fixtures/archive-v2*)
FIXTURE_PHYSICS_VERSION = "frohlich2004-dp54-3"


def _close(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) <= 1e-6 * max(abs(a), abs(b), 1.0)
    return bool(a == b)


def assert_same_shots(
    rows: list[dict[str, Any]],
    shots: list[dict[str, Any]],
    physics_version: str = FIXTURE_PHYSICS_VERSION,
) -> None:
    """Each row agrees with the stored shot on every key the shot has (see the module)."""
    assert len(rows) == len(shots)
    for row, shot in zip(rows, shots, strict=True):
        for key, want in shot.items():
            if key == "run_id" and physics_version != PHYSICS_VERSION:
                continue
            assert _close(row[key], want), (shot.get("shot"), key, row[key], want)

"""Signed lane-frame quantities as bowlers read them: a magnitude and its side.

Kept apart from :mod:`.report` (which loads the bowler-language models) so a summary table of a
physical scene names sides without importing them.
"""

from __future__ import annotations

import math

__all__ = ["sideways", "summary_rows"]


def sideways(value: float, spec: str, unit: str) -> str:
    """A signed lane-frame quantity (+y: the bowler's left, facing the pins) as its magnitude
    and its side: ``sideways(-1.08, ".2f", "m")`` -> "1.08 m to the right" (no side when it
    rounds to zero; a unit "°" follows the number without a space)."""
    text = f"{abs(value):{spec}}" + ("" if unit == "°" else " ") + unit
    if float(f"{abs(value):{spec}}") == 0.0:
        return text
    return f"{text} to the {'left' if value > 0 else 'right'}"


def summary_rows(hook_m: float | None, pocket_deg: float | None) -> list[tuple[str, str]]:
    """The hook and pocket-angle rows of a run's summary as a bowler reads them: magnitudes
    with their side named (the signed lane-frame values are the archive's ``hook_m`` and
    ``pocket_deg``); none for a ball that did not reach the pins."""
    if hook_m is None or pocket_deg is None or not math.isfinite(hook_m):
        return []
    return [
        ("hook", sideways(100.0 * hook_m, ".2f", "cm")),
        ("pocket angle", sideways(pocket_deg, ".3f", "deg")),
    ]

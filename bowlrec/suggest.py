""" "Did you mean ...?" for a name that is not known: a ball, a pattern, a field.

Close names are those :func:`difflib.get_close_matches` finds (Ratcliff-Obershelp similarity
>= 0.6), or those that hold the given text whole (``road`` -> ``storm-the-road-15lb``), so a
misspelt or shortened name gets its likely meaning instead of a list of every name.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = ["close_names", "did_you_mean", "some_names"]

#: how many close names a message offers, and how many names a list shows before "..."
MAX_SUGGESTIONS = 3
MAX_LISTED = 8


def close_names(name: str, known: Iterable[str], n: int = MAX_SUGGESTIONS) -> list[str]:
    """The known names closest to ``name`` (best first; case ignored), at most ``n``."""
    by_lower: dict[str, str] = {}
    for k in known:
        by_lower.setdefault(k.lower(), k)
    word = name.lower()
    found = difflib.get_close_matches(word, list(by_lower), n=n, cutoff=0.6)
    if len(word) >= 3:
        found += [k for k in sorted(by_lower) if word in k and k not in found]
    return [by_lower[k] for k in found[:n]]


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """``"did you mean 'x'?"`` or ``"did you mean 'x' or 'y'?"``; empty when no name is close."""
    found = close_names(name, known)
    if not found:
        return ""
    quoted = [repr(x) for x in found]
    head = ", ".join(quoted[:-1])
    return f"did you mean {head + ' or ' if head else ''}{quoted[-1]}?"


def some_names(known: Iterable[str], limit: int = MAX_LISTED) -> str:
    """The first ``limit`` names in sorted order, and how many more (``a, b, c and 38 more``)."""
    names = sorted(set(known))
    if len(names) <= limit:
        return ", ".join(names) or "none"
    return f"{', '.join(names[:limit])} and {len(names) - limit} more"

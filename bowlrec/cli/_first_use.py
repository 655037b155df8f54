"""The first-use notice: one line on stderr before a command compiles the kernels it needs.

numba compiles a kernel the first time a process calls it with no current entry in numba's
on-disk cache, which takes tens of seconds per kernel variant (once per install, and again after
an upgrade changes the sources). A command that simulates calls :func:`first_use` with the
variants it needs (:data:`bowlrec.core.warm.VARIANTS` or groups) before it starts; when numba's
cache lacks any of them (:func:`bowlrec.core.warm.missing`, which reads the cache without
importing numba), one line on stderr says why the wait is coming and that ``bowlrec warm``
builds them all. It is shown with ``--quiet`` and when stderr is not a terminal too: it is a
warning about the wait, not progress, and stdout stays the command's output.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import typer

__all__ = ["first_use", "first_use_of_file", "notice", "scene_variants"]

#: a bowler scene's format key, in JSON or YAML
_BOWLER = re.compile(r"""["']?format["']?\s*:\s*["']?bowler\b""")
#: whether this process printed the notice (once is enough)
_shown: list[str] = []


def notice(lacking: list[str]) -> str:
    """The line for the ``lacking`` variants (with a rough time from
    :func:`bowlrec.core.warm.compile_seconds`)."""
    from bowlrec.core.warm import compile_seconds

    seconds = 10 * math.ceil(compile_seconds(lacking) / 10)
    return (
        f"first use: compiling the kernels this command needs ({', '.join(lacking)}; about "
        f"{seconds} s, once per install; 'bowlrec warm' builds them all)"
    )


def first_use(*variants: str) -> list[str]:
    """Print the notice on stderr when numba's cache lacks any of ``variants`` (variants or
    groups of :mod:`bowlrec.core.warm`); returns the variants it lacks ([]: nothing to compile).
    Never fails a command: a cache it cannot read counts as warm."""
    from bowlrec.core.warm import missing

    try:
        lacking = missing(*variants)
    except (OSError, ValueError):
        return []
    if lacking and not _shown:
        typer.echo(notice(lacking), err=True)
        _shown.extend(lacking)
    return lacking


def first_use_of_file(path: Path) -> list[str]:
    """:func:`first_use` before a scene file is read, for a bowler scene (its format key says
    so), whose reading simulates already (its launch angle is solved on observed runs): the
    observed integrator and the integrator. Nothing for another file or one it cannot read."""
    try:
        text = Path(path).read_text(errors="replace")
    except OSError:
        return []
    return first_use("observe", "integrator") if _BOWLER.search(text) else []


def scene_variants(
    scene: Any, observed: bool = False, summary_only: bool = False
) -> tuple[str, ...]:
    """The variants simulating ``scene`` (a :class:`~bowlrec.spec.Scene`) loads: the closed form
    where it applies, else the integrator (``rate`` when it records samples); ``observed``: also
    the observed integrator (a bowler scene's report); ``summary_only``: the run records no
    samples whatever the scene asks. None when the scene does not resolve (the command reports
    that itself)."""
    from dataclasses import replace

    from bowlrec.core.arguments import use_closed_form
    from bowlrec.core.codes import RECORD_SUMMARY

    try:
        plan = scene.resolve()
    except Exception:  # noqa: BLE001 - the command reports an unusable scene itself
        return ()
    if summary_only:
        plan = replace(plan, record_mode=RECORD_SUMMARY)
    if use_closed_form(plan):
        base = "closed_form"
    else:
        base = "integrator" if plan.record_mode == RECORD_SUMMARY else "rate"
    return (base, "observe") if observed else (base,)

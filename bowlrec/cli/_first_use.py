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
from typing import Any

import typer

__all__ = ["first_use", "notice", "scene_variants"]


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
    if lacking:
        typer.echo(notice(lacking), err=True)
    return lacking


def scene_variants(scene: Any, observed: bool = False) -> tuple[str, ...]:
    """The variants simulating ``scene`` (a :class:`~bowlrec.spec.Scene`) loads: the closed form
    where it applies, else the integrator (``rate`` when it records samples); ``observed``: also
    the observed integrator (a bowler scene's report). None when the scene does not resolve
    (the command reports that itself)."""
    from bowlrec.core.arguments import use_closed_form
    from bowlrec.core.codes import RECORD_SUMMARY

    try:
        plan = scene.resolve()
    except Exception:  # noqa: BLE001 - the command reports an unusable scene itself
        return ()
    if use_closed_form(plan):
        base = "closed_form"
    else:
        base = "integrator" if plan.record_mode == RECORD_SUMMARY else "rate"
    return (base, "observe") if observed else (base,)

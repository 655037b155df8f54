"""Helpers shared by the CLI commands: errors, scene loading, the archive option, progress."""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NoReturn

import typer

if TYPE_CHECKING:
    from bowlrec.archive import Archive

QuietOption = Annotated[
    bool, typer.Option("--quiet", "-q", help="No progress output (also off when not a terminal).")
]
ArchiveOption = Annotated[
    Path | None,
    typer.Option(
        "--archive",
        "-a",
        help="Archive directory (default: $BOWLREC_ARCHIVE, the config file's 'archive', or "
        "~/.local/share/bowlrec/archive).",
        show_default=False,
    ),
]
JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON.")]


def interactive(quiet: bool) -> bool:
    """Show progress only on a terminal and without --quiet."""
    return not quiet and sys.stderr.isatty()


def fail(message: str, code: int = 2) -> NoReturn:
    """Print ``error: message`` (each line printable: control characters escaped, long lines
    cut) and exit with ``code``."""
    from bowlrec.spec.errors import printable

    typer.echo("error: " + "\n".join(printable(line) for line in message.split("\n")), err=True)
    raise typer.Exit(code)


def load_scene_or_exit(path: Path) -> Any:
    """The file's physical scene (a bowler scene converted); exits when invalid."""
    return parse_scene_or_exit(path).scene


def parse_scene_or_exit(path: Path) -> Any:
    """The file's scene parsed by :func:`bowlrec.scene_input.parse_scene_file` (library
    references are resolved by the caller); exits with the field-named message when invalid."""
    from bowlrec.scene_input import SceneInputError, parse_scene_file

    if not path.exists():
        fail(f"{path}: no such file")
    try:
        return parse_scene_file(path)
    except SceneInputError as err:
        fail(str(err))


def open_archive(path: Path | None, *, create: bool = True) -> Archive:
    """The archive at ``path`` or the configured default; exits with a clear error."""
    from bowlrec.archive import Archive, ArchiveError, default_archive_path

    if path is None:
        try:
            path, _source = default_archive_path()
        except ValueError as err:
            fail(str(err))
    try:
        return Archive(path, create=create)
    except (ArchiveError, OSError) as err:
        fail(str(err).removeprefix("[Errno 28] "))


@contextmanager
def archive_errors() -> Iterator[None]:
    """Turn archive lookups and writes that fail (unknown run or ball, bad filter, a damaged
    run, a full disk) into one clear line and an exit code. The error classes are imported
    only when something failed, so a listing never loads Pydantic or NumPy for them."""
    try:
        yield
    except Exception as err:
        _exit_for(err)
        raise


def _exit_for(err: Exception) -> None:
    """Exit with one line for the errors users cause or meet; return for anything else."""
    from bowlrec.archive.balls import BallNotFoundError
    from bowlrec.archive.errors import RunDamagedError
    from bowlrec.archive.store import ArchiveError, ArchiveWriteError, RunNotFoundError

    if isinstance(
        err,
        RunNotFoundError | BallNotFoundError | RunDamagedError | ArchiveError | ArchiveWriteError,
    ):
        fail(str(err), code=1)
    from pydantic import ValidationError

    if isinstance(err, ValidationError):
        from bowlrec.spec import format_validation_error

        fail(f"invalid spec\n{format_validation_error(err)}")
    if isinstance(err, ValueError):  # SamplesRequiredError, a bad filter, a bad reference
        fail(str(err))
    import sqlite3

    if isinstance(err, sqlite3.Error):  # e.g. "database or disk is full"
        fail(f"the archive's index: {err}; nothing already archived was lost", code=1)
    if isinstance(err, OSError):  # e.g. a full disk while removing, repairing or compacting
        reason = os.strerror(err.errno) if err.errno else " ".join(str(err).split())
        where = f" ({err.filename})" if getattr(err, "filename", None) else ""
        fail(f"{reason}{where}; nothing already archived was lost", code=1)


def with_status(message: str, quiet: bool, fn: Callable[..., Any], *args: Any) -> Any:
    """Run ``fn(*args)`` under a spinner (on a terminal)."""
    if not interactive(quiet):
        return fn(*args)
    from rich.console import Console

    with Console(stderr=True).status(message):
        return fn(*args)


def with_progress(
    quiet: bool, description: str, total: int, work: Callable[[Callable[[Any], None] | None], Any]
) -> Any:
    """``work(advance)`` under a progress bar (on a terminal and without --quiet); ``advance``
    is None otherwise. ``work`` calls ``advance(item)`` once per finished item."""
    if not interactive(quiet):
        return work(None)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn

    with Progress(
        "[progress.description]{task.description}",
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        transient=True,
    ) as progress:
        task = progress.add_task(description, total=total)
        return work(lambda _item: progress.advance(task))


def summary_json(summary: Any) -> dict[str, Any]:
    """The summary as the CLI prints it with --json (every :class:`Summary` field)."""
    return dict(summary.to_dict())

"""Helpers shared by the CLI commands: errors, scene loading, the archive option, progress.

Errors: a command lets every :class:`~bowlrec.errors.BowlrecError` propagate; the application
(:mod:`bowlrec.cli._app`) hands it to :func:`exit_for`, which prints one ``error:`` line and
exits with its category's code in :data:`EXIT_CODES`.
"""

from __future__ import annotations

import os
import sqlite3
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NoReturn

import typer

from bowlrec.errors import (
    BowlrecError,
    BusyError,
    ConflictError,
    DamagedError,
    InputError,
    NotFoundError,
    StorageError,
    UnavailableError,
)
from bowlrec.scene_input import parse_scene_file

if TYPE_CHECKING:
    from bowlrec.archive import Archive

QuietOption = Annotated[
    bool, typer.Option("--quiet", "-q", help="No progress output (also off when not a terminal).")
]
#: where the archive is when none is given (bowlrec.archive.location's order)
ARCHIVE_DEFAULT_HELP = (
    "default: $BOWLREC_ARCHIVE, the config file's 'archive', or ~/.local/share/bowlrec/archive"
)
ArchiveOption = Annotated[
    Path | None,
    typer.Option(
        "--archive",
        "-a",
        help=f"Archive directory ({ARCHIVE_DEFAULT_HELP}).",
        show_default=False,
    ),
]
JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON.")]


def interactive(quiet: bool) -> bool:
    """Show progress only without --quiet and when both stdout and stderr are a terminal (a
    command whose output is piped or redirected shows none, whatever stream it would use)."""
    return not quiet and sys.stderr.isatty() and sys.stdout.isatty()


def fail(message: str, code: int = 2) -> NoReturn:
    """Print ``error: message`` (each line printable: control characters escaped, long lines
    cut) and exit with ``code``."""
    from bowlrec.spec.errors import printable

    typer.echo("error: " + "\n".join(printable(line) for line in message.split("\n")), err=True)
    raise typer.Exit(code)


#: exit code after Ctrl-C (128 + SIGINT), as shells report it
EXIT_INTERRUPTED = 130
#: what a Ctrl-C that no command handles itself prints (on stderr)
INTERRUPTED_LINE = "\ninterrupted"

#: the exit code of each category of error (the first category an error belongs to): 2 for
#: what the command line asked that cannot be done as asked (fix the input or the request),
#: 1 for what went wrong while doing it
EXIT_CODES: dict[type[BowlrecError], int] = {
    InputError: 2,
    ConflictError: 2,
    NotFoundError: 1,
    DamagedError: 1,
    StorageError: 1,
    BusyError: 1,
    UnavailableError: 1,
}


def exit_code(err: BowlrecError) -> int:
    """The exit code of ``err``'s category (:data:`EXIT_CODES`; 1 for none)."""
    return next((code for kind, code in EXIT_CODES.items() if isinstance(err, kind)), 1)


def exit_for(err: BaseException) -> None:
    """Exit with one ``error:`` line for a :class:`~bowlrec.errors.BowlrecError` (its
    category's code), an invalid spec Pydantic rejected (code 2), or a file the system
    refused (an ``OSError``: an output path where no file can be created, a full disk; code
    1, the line names the file); return for anything else. Pydantic is imported only
    when the error is not a BowlrecError."""
    if isinstance(err, BowlrecError):
        fail(str(err), code=exit_code(err))
    if isinstance(err, OSError):
        fail(os_error_text(err), code=1)
    if not isinstance(err, ValueError):
        return
    from pydantic import ValidationError

    if isinstance(err, ValidationError):
        from bowlrec.spec import format_validation_error

        fail(format_validation_error(err))  # one line per problem, each naming its field


def load_scene_or_exit(path: Path, archive: Path | None = None) -> Any:
    """The file's physical scene (a bowler scene converted): :func:`parse_scene_or_exit`."""
    return parse_scene_or_exit(path, archive).scene


def parse_scene_or_exit(path: Path, archive: Path | None = None) -> Any:
    """The file's scene through the one way in for a scene,
    :func:`bowlrec.scene_input.parse_scene_file`; a ``ball: NAME`` names a ball of the ball
    library of ``archive`` (default: the user's archive), opened only for such a scene. A
    value that looks typed in another unit is a ``warning:`` line on stderr (:func:`warn`).
    Raises :class:`~bowlrec.errors.SceneInputError`, every line starting with the path, when
    the file is missing, unreadable or invalid; the application prints it as one ``error:``
    line per problem and exits 2."""
    return parse_scene_file(path, archive_balls(archive), warn=warn)


def warn(line: str) -> None:
    """One ``warning:`` line on stderr (shown with --quiet too: it is about the input, not
    progress)."""
    typer.echo(f"warning: {line}", err=True)


def archive_balls(archive: Path | None) -> Any:
    """A lookup of library balls (``name`` or ``name@version``) in the ball library of
    ``archive`` (default: the user's archive), which it opens at its first use."""
    from bowlrec.scene_input import library_lookup

    def lookup(ref: str) -> tuple[dict[str, Any], str]:
        from bowlrec.archive import Archive, default_archive_path
        from bowlrec.errors import ArchiveError, SceneInputError

        path = archive if archive is not None else default_archive_path()[0]
        try:
            store = Archive(path, create=False)
        except (ArchiveError, OSError):
            raise SceneInputError(
                f"ball: {ref!r} names a ball of the archive's library, and {path} is not an "
                "archive (give --archive, or add balls with `bowlrec balls add-examples` or "
                "`bowlrec balls add NAME FILE`)"
            ) from None
        result: tuple[dict[str, Any], str] = library_lookup(store.balls)(ref)
        return result

    return lookup


def open_archive(path: Path | None, *, create: bool = True) -> Archive:
    """The archive at ``path`` or the configured default; exits with a clear error when the
    directory cannot be opened (:class:`~bowlrec.errors.ArchiveError` when it is not an
    archive)."""
    from bowlrec.archive import Archive, default_archive_path

    if path is None:
        path, _source = default_archive_path()
    try:
        return Archive(path, create=create)
    except OSError as err:
        fail(str(err).removeprefix("[Errno 28] "))


@contextmanager
def archive_errors() -> Iterator[None]:
    """Within archive reads and writes, turn what the standard library raises into one line:
    a value the operation refused (code 2), an index or file that could not be written (code
    1: nothing already archived was lost). Errors of the hierarchy and invalid specs pass on
    to :func:`exit_for`."""
    try:
        yield
    except BowlrecError:
        raise
    except Exception as err:
        _exit_for_builtin(err)
        raise


def validated_options(model: Any, data: dict[str, Any], options: dict[str, str]) -> Any:
    """``model.model_validate(data)`` for fields set from command-line options; an invalid one
    is one ``error:`` line per problem naming the option that set it (``options``: field name
    -> option, e.g. ``{"board": "--pocket-board"}``), code 2."""
    from pydantic import ValidationError

    from bowlrec.spec.errors import format_errors

    try:
        return model.model_validate(data)
    except ValidationError as err:
        lines = []
        for e in err.errors(include_url=False):
            loc = tuple(e["loc"])
            message = format_errors([{**e, "loc": ("_",)}]).split(": ", 1)[1]
            if not loc:  # the options together (a board outside its window)
                lines.append(message)
            else:
                where = options.get(str(loc[0])) or format_errors([e]).split(": ", 1)[0]
                lines.append(f"{where}: {message}")
        fail("\n".join(lines))


def output_dir(path: Path, option: str) -> Path:
    """The output directory ``path`` (an ``option``'s value), created with its parents; one
    ``error:`` line when it names a file (code 2) or cannot be created (code 1)."""
    if path.exists() and not path.is_dir():
        fail(f"{option} {path}: a file, not a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        fail(f"{option} {os_error_text(err)}", code=1)
    return path


def os_error_text(err: OSError) -> str:
    """One line for an ``OSError``: the file it names (if any) and the system's reason."""
    reason = os.strerror(err.errno) if err.errno else " ".join(str(err).split())
    return f"{err.filename}: {reason}" if getattr(err, "filename", None) else reason


def _exit_for_builtin(err: Exception) -> None:

    if isinstance(err, ValueError):  # a value the writer refused, e.g. a plot's exaggeration
        from pydantic import ValidationError

        if not isinstance(err, ValidationError):
            fail(str(err))
    elif isinstance(err, sqlite3.Error):  # e.g. "database or disk is full"
        fail(f"the archive's index: {err}; nothing already archived was lost", code=1)
    elif isinstance(err, OSError):  # e.g. a full disk while removing, repairing or compacting
        fail(f"{os_error_text(err)}; nothing already archived was lost", code=1)


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


def print_table(table: Any) -> None:
    """Print a rich table without losing a character: in a terminal every column folds long
    values onto further lines instead of cutting them; piped or redirected, the table is as
    wide as its widest row needs (no terminal width applies, no colour codes)."""
    from rich.console import Console
    from rich.measure import Measurement

    for column in table.columns:
        column.overflow = "fold"
        column.no_wrap = False
    if sys.stdout.isatty():
        Console().print(table)
        return
    probe = Console(width=100_000, no_color=True, highlight=False)
    width = Measurement.get(probe, probe.options, table).maximum
    Console(width=max(width, 20), no_color=True, highlight=False, soft_wrap=False).print(table)


def summary_json(summary: Any) -> dict[str, Any]:
    """The summary as the CLI prints it with --json (every :class:`Summary` field)."""
    return dict(summary.to_dict())

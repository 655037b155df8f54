"""The Typer application the command modules register on."""

from __future__ import annotations

import platform
from typing import Annotated, Any

import typer
from typer.core import TyperGroup, TyperOption

from bowlrec.cli._common import EXIT_INTERRUPTED, INTERRUPTED_LINE, exit_for


class _Commands(TyperGroup):
    """The command group: an error raised by any command (sub-commands included) goes through
    :func:`bowlrec.cli._common.exit_for`, the one place errors become exit codes; a Ctrl-C
    that no command handles itself ends with one line and status 130 (128 + SIGINT), also while
    the command line is parsed (where typer itself would exit 130 without a word)."""

    def make_context(self, *args: Any, **kwargs: Any) -> Any:
        try:  # typer imports its parameter types (pydantic) while it parses the command line
            return super().make_context(*args, **kwargs)
        except KeyboardInterrupt:
            raise _interrupted() from None

    def invoke(self, ctx: Any) -> Any:  # typer's bundled click.Context
        try:
            return super().invoke(ctx)
        except (KeyboardInterrupt, Exception) as err:
            # a Ctrl-C, or what a compiled call made of one (a SystemError around it)
            if isinstance(err, KeyboardInterrupt) or _from_interrupt(err):
                raise _interrupted() from None
            exit_for(err)
            raise


def _interrupted() -> typer.Exit:
    """Print the one line a Ctrl-C ends a command with; the exit that ends it with 130."""
    typer.echo(INTERRUPTED_LINE, err=True)
    return typer.Exit(EXIT_INTERRUPTED)


def _from_interrupt(err: BaseException) -> bool:
    """Whether ``err`` was raised because of a Ctrl-C: a KeyboardInterrupt among its causes or
    contexts (a numba dispatcher interrupted while it loads a kernel raises SystemError
    "returned a result with an exception set" with the KeyboardInterrupt in that chain)."""
    seen: set[int] = set()
    todo: list[BaseException | None] = [err.__cause__, err.__context__]
    while todo:
        e = todo.pop()
        if e is None or id(e) in seen:
            continue
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        todo += [e.__cause__, e.__context__]
    return False


def _flag_type(self: TyperOption, ctx: Any) -> str | None:
    """An option's type in the help: none for a flag (``--quiet``, ``--browser/--no-browser``),
    which takes no value, so the help does not print ``<bool>`` after it."""
    return None if self.is_flag else _option_type(self, ctx)


# typer builds every option as a TyperOption and has no hook for its help's type column
_option_type = TyperOption.display_type_rich
TyperOption.display_type_rich = _flag_type  # type: ignore[method-assign]

app = typer.Typer(
    name="bowlrec",
    help="Bowling-ball motion simulator (Frohlich 2004 exact equations of motion) and "
    "trajectory archive.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode="markdown",
    cls=_Commands,
    # -h as well as --help, on every command (click passes the names down to sub-commands)
    context_settings={"help_option_names": ["-h", "--help"]},
)


def version_line() -> str:
    """``bowlrec X.Y.Z (physics N, bowler layer N; Python X.Y.Z)``: what ``--version``
    prints. The physics version is part of every run ID, so two installs with the same one
    give the same runs."""
    from bowlrec.versions import BOWLER_LAYER_VERSION, PHYSICS_VERSION, __version__

    return (
        f"bowlrec {__version__} (physics {PHYSICS_VERSION}, bowler layer "
        f"{BOWLER_LAYER_VERSION}; Python {platform.python_version()})"
    )


def _print_version(value: bool) -> None:
    if value:
        typer.echo(version_line())
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option(
            "--version",
            "-V",
            help="Print the version and exit.",
            callback=_print_version,
            is_eager=True,
        ),
    ] = False,
) -> None:
    """Bowling-ball motion simulator (Frohlich 2004 exact equations of motion) and trajectory
    archive."""

"""The ``bowlrec`` command line (Typer). Heavy modules are imported inside the commands.

Each command module registers its commands on :data:`bowlrec.cli._app.app` when it is
imported. :func:`main` imports only the module of the command it runs (:data:`COMMANDS`; all of
them for ``bowlrec --help``, no command or one it does not know); ``app``, this package's
attribute, is the application with every command registered.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ._app import app

__all__ = ["COMMANDS", "MODULES", "app", "load_commands", "main"]

#: the command modules, in the order their commands are listed by ``bowlrec --help``
MODULES = (
    "aim",
    "balls",
    "batch",
    "bowling",
    "carry",
    "demo",
    "drill",
    "pins",
    "runs",
    "scenes",
    "serve",
    "session",
    "warm",
)

#: each command and command group of ``bowlrec`` -> the module of :data:`MODULES` registering it
COMMANDS = {
    "aim": "aim",
    "variance": "aim",
    "tolerance": "aim",
    "balls": "balls",
    "batch": "batch",
    "patterns": "bowling",
    "sheet": "bowling",
    "bowler-scene": "bowling",
    "carry": "carry",
    "demo": "demo",
    "drill": "drill",
    "layout": "drill",
    "pins": "pins",
    "replay": "runs",
    "plot": "runs",
    "runs": "runs",
    "archive": "runs",
    "simulate": "scenes",
    "paper": "scenes",
    "schema": "scenes",
    "examples": "scenes",
    "validate": "scenes",
    "serve": "serve",
    "ui": "serve",
    "session": "session",
    "warm": "warm",
}


def load_commands(modules: Sequence[str] = MODULES) -> None:
    """Import the command ``modules`` (names of :data:`MODULES`), registering their commands."""
    for module in modules:
        importlib.import_module(f"{__name__}.{module}")


def _command_name(argv: Sequence[str]) -> str | None:
    """The command ``argv`` names: its first argument that is not an option (the application's
    own options, ``--version`` and ``--help``, take no value); None when there is none."""
    return next((arg for arg in argv if not arg.startswith("-")), None)


def main() -> None:
    """The ``bowlrec`` command: registers the commands it may run, then runs the application."""
    try:  # a Ctrl-C while the command's modules load: one line and 130, as inside a command
        module = COMMANDS.get(_command_name(sys.argv[1:]) or "")
        load_commands((module,) if module is not None else MODULES)
        from ._app import app
    except KeyboardInterrupt:
        from ._common import EXIT_INTERRUPTED, INTERRUPTED_LINE

        print(INTERRUPTED_LINE, file=sys.stderr)
        raise SystemExit(EXIT_INTERRUPTED) from None
    app()


def __getattr__(name: str) -> Any:
    if name == "app":  # the whole application: every command registered
        load_commands()
        from ._app import app

        return app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

"""The Typer application the command modules register on."""

from __future__ import annotations

from typing import Any

import typer
from typer.core import TyperGroup

from bowlrec.cli._common import exit_for


class _Commands(TyperGroup):
    """The command group: an error raised by any command (sub-commands included) goes through
    :func:`bowlrec.cli._common.exit_for`, the one place errors become exit codes."""

    def invoke(self, ctx: Any) -> Any:  # typer's bundled click.Context
        try:
            return super().invoke(ctx)
        except Exception as err:
            exit_for(err)
            raise


app = typer.Typer(
    name="bowlrec",
    help="Bowling-ball motion simulator (Frohlich 2004 exact equations of motion) and "
    "trajectory archive.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    cls=_Commands,
)


def main() -> None:
    app()

"""The Typer application the command modules register on."""

from __future__ import annotations

import typer

app = typer.Typer(
    name="bowlrec",
    help="Bowling-ball motion simulator (Frohlich 2004 exact equations of motion) and "
    "trajectory archive.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def main() -> None:
    app()

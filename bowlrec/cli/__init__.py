"""The ``bowlrec`` command line (Typer). Heavy modules are imported inside the commands."""

from . import aim, balls, batch, bowling, carry, demo, drill, pins, runs, scenes, serve, session  # noqa: F401  (each module registers its commands)
from ._app import app, main

__all__ = ["app", "main"]

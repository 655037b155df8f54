"""``bowlrec warm``: build every compiled kernel once, so no command waits for the compiler."""

from __future__ import annotations

import traceback
from typing import Annotated, Any

import typer

from ._app import app
from ._common import QuietOption, interactive


@app.command()
def warm(
    jobs: Annotated[
        int,
        typer.Option(
            "--jobs",
            "-j",
            min=1,
            help="Compile in this many processes at once (2 on 2+ cores: about 0.8x the time, "
            "more CPU).",
        ),
    ] = 1,
    quiet: QuietOption = False,
) -> None:
    """Build every compiled kernel into numba's on-disk cache (once per install or upgrade).

    Each kernel variant is loaded when the cache holds it for the current sources, else
    compiled (a few minutes in all on 2 cores): afterwards no command waits to compile.
    Prints one line: the time, the kernels compiled, the kernels loaded.
    """
    from bowlrec.core.warm import GROUPS, WarmUpError, missing, warm_up

    names = list(GROUPS["all"])
    lacking = set(missing(*names))
    bar = _Bar(interactive(quiet), names, lacking)
    try:
        with bar:
            result = warm_up(*names, jobs=jobs, progress=bar.step)
    except WarmUpError as err:
        if err.__cause__ is not None:
            traceback.print_exception(err.__cause__)
        typer.echo(f"error: {err}", err=True)
        raise typer.Exit(1) from None
    typer.echo(
        f"warm: {result.seconds:.1f} s, {result.compiled} kernels compiled, {result.loaded} "
        f"loaded from numba's cache"
    )


class _Bar:
    """A progress bar of one step per variant, naming the one under way (nothing when not
    ``show``); :meth:`step` is :func:`~bowlrec.core.warm.warm_up`'s ``progress``."""

    def __init__(self, show: bool, names: list[str], lacking: set[str]) -> None:
        self.show, self.names, self.lacking = show, names, lacking
        self.bar: Any = None
        self.task: Any = None
        self.running: list[str] = []

    def __enter__(self) -> _Bar:
        if self.show:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
            )

            self.bar = Progress(
                TextColumn("[progress.description]{task.description}"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeElapsedColumn(),
                transient=True,
            )
            self.bar.__enter__()
            self.task = self.bar.add_task("warm: kernels", total=len(self.names))
        return self

    def step(self, name: str, done: bool) -> None:
        if self.bar is None:
            return
        if done:
            self.running = [n for n in self.running if n != name]
        else:
            self.running.append(name)
        what = ", ".join(
            f"{'compiling' if n in self.lacking else 'loading'} {n}" for n in self.running
        )
        self.bar.update(self.task, advance=int(done), description=f"warm: {what or 'done'}")

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.__exit__(*exc)

"""``bowlrec demo``: the paper's Table III into the archive, with replay files to open."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from bowlrec.errors import MissingExtraError
from bowlrec.sinks.registry import sink_named

from ._app import app
from ._common import (
    ArchiveOption,
    QuietOption,
    fail,
    open_archive,
    output_dir,
    with_progress,
)
from ._first_use import first_use

#: the paper's Fig. 6 comparison; case 16 is written to MCAP and rerun
FIG6_CASES = (9, 10, 14, 16)
REPLAY_CASE = 16


def _scenes(record_dt_s: float) -> list[Any]:
    """The Table III scenes recording every ``record_dt_s`` (checked as a scene's
    ``options.record_dt_s`` is: one ``error:`` line naming the option when it is not)."""
    from pydantic import ValidationError

    from bowlrec.paper import TABLE_III, paper_scene
    from bowlrec.spec import format_validation_error

    scenes = []
    for case in range(1, len(TABLE_III) + 1):
        scene = paper_scene(case)
        data = scene.model_dump(mode="json")
        data["options"].update(record="rate", record_dt_s=record_dt_s)
        try:
            scenes.append(type(scene).model_validate(data))
        except ValidationError as err:
            reason = format_validation_error(err).splitlines()[0].split(": ", 1)[-1]
            fail(f"--record-dt-s {record_dt_s:g}: {reason}")
    return scenes


@app.command()
def demo(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Directory for the figure and replay files.")
    ] = Path("bowlrec-demo"),
    archive: ArchiveOption = None,
    record_dt_s: Annotated[
        float, typer.Option(help="Sampling interval of the stored runs (s).")
    ] = 0.005,
    quiet: QuietOption = False,
) -> None:
    """Simulate the paper's 18 Table III cases into the archive; write Fig. 6, MCAP and .rrd.

    Runs already in the archive are reused (content IDs), so a second demo is fast.
    """
    from bowlrec.sinks import RunData

    scenes = _scenes(record_dt_s)
    output_dir(out, "--out")  # before the simulations: a place that cannot be written fails now
    store = open_archive(archive)
    results = _simulate_all(store, scenes, quiet)
    added = sum(r.added for r in results)
    typer.echo(
        f"{len(results)} Table III runs in {store.root} ({added} new, "
        f"{len(results) - added} already archived)"
    )
    from bowlrec.paper import TABLE_III

    for paper, res in zip(TABLE_III, results, strict=True):
        s = res.trajectory.summary
        hook = "-" if s.hook_m is None else f"{100 * s.hook_m:5.1f} cm"
        slide = "no roll" if s.slide_m is None else f"{s.slide_m:5.2f} m"
        p_slide = "no roll" if paper.slide_m is None else f"{paper.slide_m:5.2f} m"
        typer.echo(
            f"  case {paper.case:2d}  {res.run_id[:10]}  slide {slide:>8} hook {hook:>8}"
            f"   (paper: slide {p_slide:>8} hook {100 * paper.hook_m:5.1f} cm)"
        )
    fig6 = [
        RunData(scenes[c - 1], scenes[c - 1].resolve(), results[c - 1].trajectory)
        for c in FIG6_CASES
    ]
    replay = results[REPLAY_CASE - 1]
    replay_run = RunData(
        scenes[REPLAY_CASE - 1], scenes[REPLAY_CASE - 1].resolve(), replay.trajectory, replay.run_id
    )
    files = [
        ("plot", fig6, out / "fig6-cases-9-10-14-16.png"),
        ("mcap", [replay_run], out / f"case{REPLAY_CASE}.mcap"),
        ("rrd", [replay_run], out / f"case{REPLAY_CASE}.rrd"),
    ]
    for name, runs, path in files:
        typer.echo(_written(name, runs, path))
    activate = activate_command()
    if activate is not None:
        typer.echo(f"next: {activate}   (once per shell: puts bowlrec and its Python on PATH)")
    typer.echo(f"{'then' if activate else 'next'}: bowlrec runs list")
    typer.echo(f"      bowlrec runs show {replay.run_id[:10]}")
    typer.echo(f"      bowlrec replay {replay.run_id[:10]} --rrd case16.rrd")


def activate_command() -> str | None:
    """``source .venv/bin/activate`` (the path as short as it can be written from here) when
    bowlrec runs from a virtual environment whose ``bin`` is not on PATH; None otherwise."""
    if sys.prefix == sys.base_prefix:
        return None
    bindir = Path(sys.prefix) / "bin"
    for entry in os.environ.get("PATH", "").split(os.pathsep):
        if entry and Path(entry).resolve() == bindir.resolve():
            return None
    script = bindir / "activate"
    try:
        relative = os.path.relpath(script)
    except ValueError:
        relative = str(script)
    shown = relative if len(relative) < len(str(script)) else str(script)
    return f"source {shown}"


def _written(name: str, runs: list[Any], path: Path) -> str:
    """The line for ``runs`` written to ``path`` by sink ``name``, or for the sink skipped when
    its optional libraries are not installed."""

    sink = sink_named(name)
    try:
        written = sink.write_many(runs, path) if len(runs) > 1 else sink.write(runs[0], path)
    except MissingExtraError:
        return f"{sink.label}: skipped (pip install 'bowlrec[{sink.extra}]')"
    return sink.line(written)


def _simulate_all(store: Any, scenes: list[Any], quiet: bool) -> list[Any]:
    from bowlrec.api import simulate_into

    def work(advance: Any) -> list[Any]:
        results = []
        for scene in scenes:
            results.append(simulate_into(store, scene))
            if advance is not None:
                advance(scene)
        return results

    first_use("rate")  # the scenes record samples
    return with_progress(
        quiet, "Table III into the archive (first run compiles)", len(scenes), work
    )

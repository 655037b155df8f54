"""Archive commands: ``runs list|show|export|rm|reindex|repair``, ``replay`` and ``plot``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from ._app import app
from ._common import ArchiveOption, JsonOption, archive_errors, fail, load_scene_or_exit
from ._common import open_archive as _open
from ._outputs import (
    ConnectOption,
    McapOption,
    PlotOption,
    RrdOption,
    SpawnOption,
    write_outputs,
)

runs_app = typer.Typer(help="List, show, export and remove archived runs.", no_args_is_help=True)
app.add_typer(runs_app, name="runs")

#: columns of the ``runs list`` table (the index has more; --json prints all of them)
LIST_COLUMNS = ("run_id", "name", "ball", "pattern", "outcome", "slide_m", "hook_m", "pocket_deg")


def _cell(row: dict[str, Any], column: str) -> str:
    if column == "ball":
        return "" if row["ball_name"] is None else f"{row['ball_name']}@{row['ball_version']}"
    value = row[column]
    if column == "run_id":
        return str(value)[:10]  # a unique prefix is enough for every command
    if value is None:
        return "-"
    if column == "hook_m":
        return f"{100 * value:.2f} cm"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


@runs_app.command("list")
def list_runs(
    archive: ArchiveOption = None,
    ball: Annotated[str | None, typer.Option(help="Library ball NAME or NAME@VERSION.")] = None,
    pattern: Annotated[str | None, typer.Option(help="Lane pattern (friction kind).")] = None,
    outcome: Annotated[str | None, typer.Option(help="pins, gutter, stopped, ...")] = None,
    name: Annotated[str | None, typer.Option(help="Scene name.")] = None,
    where: Annotated[
        list[str] | None,
        typer.Option(
            "--where",
            "-w",
            help="Condition on an index column, repeatable: 'hook_m>=0.1', 'speed_mps<8'.",
        ),
    ] = None,
    order_by: Annotated[
        str, typer.Option(help="Index column to sort by ('-' prefix: descending).")
    ] = "created_at",
    limit: Annotated[int | None, typer.Option(help="At most this many rows.")] = None,
    as_json: JsonOption = False,
) -> None:
    """List archived runs (reads only the index, not the run files)."""
    store = _open(archive, create=False)
    with archive_errors():
        rows = store.list_runs(
            ball=ball,
            pattern=pattern,
            outcome=outcome,
            name=name,
            where=where or (),
            order_by=order_by,
            limit=limit,
        )
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"{len(rows)} run(s) in {store.root}")
    for column in LIST_COLUMNS:
        if column == "run_id":
            table.add_column(column, no_wrap=True, min_width=10)
        else:
            left = column in ("name", "ball", "pattern")
            table.add_column(column, justify="left" if left else "right", overflow="fold")
    for row in rows:
        table.add_row(*(_cell(row, c) for c in LIST_COLUMNS))
    Console().print(table)


@runs_app.command("show")
def show(
    run: Annotated[str, typer.Argument(help="Run ID (or a unique prefix of 4+ characters).")],
    archive: ArchiveOption = None,
    as_json: JsonOption = False,
) -> None:
    """Show one run: its index row, provenance, events and the scene as given."""
    store = _open(archive, create=False)
    with archive_errors():
        stored = store.load(store.resolve_id(run))
        row = store.row(stored.run_id)
    events = [e.__dict__ for e in stored.trajectory.events]
    provenance = {k: v for k, v in stored.attrs.items() if k not in ("scene_json", "summary_json")}
    if as_json:
        doc = {
            "index": row,
            "provenance": provenance,
            "summary": stored.trajectory.summary.to_dict(),
            "events": events,
            "scene": json.loads(stored.attrs["scene_json"]),
        }
        typer.echo(json.dumps(doc, indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"run {stored.run_id} ({stored.scene.name})", show_header=False)
    for key, value in {**row, **provenance}.items():
        table.add_row(key, str(value))
    table.add_row(
        "events", "\n".join(f"{e['kind']} t={e['t_s']:.4f}s x={e['x_m']:.3f}m" for e in events)
    )
    table.add_row("samples", str(stored.trajectory.n_samples))
    Console().print(table)


@runs_app.command("export")
def export(
    runs: Annotated[
        list[str],
        typer.Argument(help="Run ID(s) or unique prefixes; several only for a batch .mcap."),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help="Destination: .h5 (the run file), .mcap, .rrd, .json (scene), .png/.svg (plot).",
        ),
    ],
    archive: ArchiveOption = None,
) -> None:
    """Export a run as its HDF5 file, MCAP, rerun recording, scene JSON or figure.

    Several runs go into one .mcap (each under its own topic prefix, lanes side by side).
    """
    store = _open(archive, create=False)
    suffix = out.suffix.lower()
    if len(runs) > 1 and suffix != ".mcap":
        fail(f"several runs can only be exported to one .mcap, not {suffix or 'no suffix'}")
    run = runs[0]
    with archive_errors():
        if len(runs) > 1:
            try:
                from bowlrec.sinks.mcap_file import write_mcap_batch
            except ImportError as err:
                fail(f"{err.name} is not installed; install it with: pip install 'bowlrec[mcap]'")
            batch = [store.run_data(store.resolve_id(r)) for r in runs]
            typer.echo(f"MCAP: {write_mcap_batch(batch, out)} ({len(batch)} runs)")
        elif suffix in (".h5", ".hdf5"):
            typer.echo(str(store.export(run, out)))
        elif suffix == ".json":
            stored = store.load(store.resolve_id(run))
            out.write_text(json.dumps(json.loads(stored.attrs["scene_json"]), indent=2) + "\n")
            typer.echo(str(out))
        elif suffix in (".mcap", ".rrd", ".png", ".svg"):
            data = store.run_data(store.resolve_id(run))
            lines = write_outputs(
                data,
                mcap=out if suffix == ".mcap" else None,
                rrd=out if suffix == ".rrd" else None,
                plot=out if suffix in (".png", ".svg") else None,
            )
            for line in lines:
                typer.echo(line)
        else:
            fail(f"--out {out}: unknown suffix {suffix!r} (.h5 .mcap .rrd .json .png .svg)")


@runs_app.command("rm")
def remove(
    runs: Annotated[list[str], typer.Argument(help="Run IDs (or unique prefixes).")],
    archive: ArchiveOption = None,
) -> None:
    """Remove runs from the archive (index row and file)."""
    store = _open(archive, create=False)
    with archive_errors():
        for run in runs:
            typer.echo(f"removed {store.remove(run)}")


@runs_app.command("reindex")
def reindex(archive: ArchiveOption = None) -> None:
    """Rebuild the index from the run files (they are the source of truth)."""
    store = _open(archive, create=False)
    typer.echo(f"{store.reindex()} run(s) indexed in {store.root}")


@runs_app.command("repair")
def repair(archive: ArchiveOption = None) -> None:
    """Clean up after killed writers: temporaries, unindexed files, rows without files."""
    store = _open(archive, create=False)
    typer.echo(json.dumps(store.repair()))


@app.command()
def replay(
    run: Annotated[str, typer.Argument(help="Run ID (or a unique prefix).")],
    archive: ArchiveOption = None,
    rrd: RrdOption = None,
    connect: ConnectOption = None,
    spawn: SpawnOption = False,
    mcap: McapOption = None,
    plot: PlotOption = None,
) -> None:
    """Replay an archived run in rerun (--rrd FILE, --connect URL or --spawn), MCAP or a plot."""
    if not any((rrd, connect, spawn, mcap, plot)):
        fail("nothing to do: give --rrd FILE, --connect URL, --spawn, --mcap FILE or --plot FILE")
    store = _open(archive, create=False)
    with archive_errors():
        data = store.run_data(store.resolve_id(run))
        for line in write_outputs(
            data, rrd=rrd, connect=connect, spawn=spawn, mcap=mcap, plot=plot
        ):
            typer.echo(line)


@app.command()
def plot(
    runs: Annotated[
        list[str], typer.Argument(help="Archived run IDs (or prefixes) and/or scene files.")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Figure file (.png or .svg).")] = Path(
        "bowlrec-plot.png"
    ),
    archive: ArchiveOption = None,
    title: Annotated[str | None, typer.Option(help="Figure title.")] = None,
    exaggerate: Annotated[
        float | None, typer.Option(help="Lane-width exaggeration (default 4.5, as the paper).")
    ] = None,
    series: Annotated[
        Path | None,
        typer.Option(help="Also write speed/rev rate/slip/mu vs time of the first run here."),
    ] = None,
) -> None:
    """Paper-style figure of one or several runs overlaid (lane, oil, paths, rotation axes)."""
    try:
        from bowlrec.sinks.plot import plot_runs, plot_series
    except ImportError as err:
        fail(f"{err.name} is not installed; install it with: pip install 'bowlrec[plot]'")
    data = []
    with archive_errors():
        for item in runs:
            path = Path(item)
            if path.suffix.lower() in (".json", ".yaml", ".yml"):
                data.append(_simulated(load_scene_or_exit(path)))
            else:
                store = _open(archive, create=False)
                data.append(store.run_data(store.resolve_id(item)))
        typer.echo(str(plot_runs(data, out, title=title, exaggerate=exaggerate)))
        if series is not None:
            typer.echo(str(plot_series(data[0], series)))


def _simulated(scene: Any) -> Any:
    """A scene file simulated on the spot (sampled at 5 ms if the scene is summary-only)."""
    import bowlrec
    from bowlrec.sinks import RunData

    if scene.options.record == "summary":
        options = scene.options.model_copy(update={"record": "rate", "record_dt_s": 0.005})
        scene = scene.model_copy(update={"options": options})
    return RunData(scene, scene.resolve(), bowlrec.simulate(scene))

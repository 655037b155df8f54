"""Archive commands: ``runs list|show|export|rm|reindex|repair|compact``, ``replay``, ``plot``
and ``archive migrate|info``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from bowlrec.archive.index import cell_text
from bowlrec.archive.migrate import migrate as run_migration
from bowlrec.cli._common import interactive
from bowlrec.sinks.registry import sink_for, sink_named

from ._app import app
from ._common import (
    ArchiveOption,
    JsonOption,
    QuietOption,
    archive_errors,
    fail,
    load_scene_or_exit,
    print_table,
)
from ._common import open_archive as _open
from ._first_use import first_use
from ._outputs import (
    ConnectOption,
    McapOption,
    PlotOption,
    RrdOption,
    SpawnOption,
    requested_files,
    write_outputs,
)

runs_app = typer.Typer(help="List, show, export and remove archived runs.", no_args_is_help=True)
app.add_typer(runs_app, name="runs")
archive_app = typer.Typer(
    help="The archive as a whole: format migration, info.", no_args_is_help=True
)
app.add_typer(archive_app, name="archive")

#: the ``runs list`` table: (header, index column, scale to the header's unit, format); the
#: index has more columns, and --json prints all of them in SI units as stored
LIST_COLUMNS: tuple[tuple[str, str, float, str], ...] = (
    ("run_id", "run_id", 1.0, ""),
    ("created (UTC)", "created_at", 1.0, ""),
    ("name", "name", 1.0, ""),
    ("ball", "ball", 1.0, ""),
    ("pattern", "pattern", 1.0, ""),
    ("outcome", "outcome", 1.0, ""),
    ("slide (m)", "slide_m", 1.0, ".3f"),
    ("hook (cm)", "hook_m", 100.0, ".2f"),
    ("pocket (deg)", "pocket_deg", 1.0, ".2f"),
)
#: the pins' columns, shown after ``outcome`` when any listed run has pin action
PIN_COLUMNS: tuple[tuple[str, str, float, str], ...] = (
    ("leave", "leave", 1.0, ""),
    ("pinfall", "pinfall", 1.0, ""),
)


def list_columns(rows: list[dict[str, Any]]) -> tuple[tuple[str, str, float, str], ...]:
    """The ``runs list`` table's columns for ``rows``: the pins' columns only when a run has
    pin action (``options.pins``), so an archive without pins lists as before."""
    if not any(row.get("pinfall") is not None for row in rows):
        return LIST_COLUMNS
    at = [c for _h, c, _s, _f in LIST_COLUMNS].index("outcome") + 1
    return LIST_COLUMNS[:at] + PIN_COLUMNS + LIST_COLUMNS[at:]


#: how many runs ``runs list`` shows unless --limit says otherwise
DEFAULT_LIST_LIMIT = 20


def _cell(row: dict[str, Any], column: str, scale: float, fmt: str) -> str:
    if column == "run_id":
        return str(row[column])[:10]  # a unique prefix is enough for every command
    return cell_text(row, column, scale, fmt, missing="-")


@runs_app.command("list")
def list_runs(
    archive: ArchiveOption = None,
    ball: Annotated[str | None, typer.Option(help="Library ball NAME or NAME@VERSION.")] = None,
    pattern: Annotated[str | None, typer.Option(help="Lane pattern (friction kind).")] = None,
    outcome: Annotated[str | None, typer.Option(help="pins, gutter, stopped, ...")] = None,
    name: Annotated[str | None, typer.Option(help="Scene name.")] = None,
    leave: Annotated[
        str | None,
        typer.Option(
            help="Runs with pin action that left this leave, as listed: strike, '10 pin', "
            "'7-10 split'.",
        ),
    ] = None,
    pinfall: Annotated[
        int | None,
        typer.Option(
            min=0, max=10, help="Runs with pin action with this many pins down (ranges: -w)."
        ),
    ] = None,
    strikes: Annotated[
        bool, typer.Option("--strikes", help="Only strikes (runs with pin action).")
    ] = False,
    where: Annotated[
        list[str] | None,
        typer.Option(
            "--where",
            "-w",
            help="Condition on an index column, repeatable: 'hook_m>=0.1', 'speed_mps<8', "
            "'pinfall<=8'.",
        ),
    ] = None,
    order_by: Annotated[
        str,
        typer.Option(
            help="Index column to sort by ('-' prefix: descending); newest first by default."
        ),
    ] = "-created_at",
    limit: Annotated[
        int, typer.Option("--limit", "-n", min=0, help="At most this many runs (0: all).")
    ] = DEFAULT_LIST_LIMIT,
    ids: Annotated[
        bool,
        typer.Option(
            "--ids", help="Print only the full run IDs, one per line (for scripts: ID=$(...))."
        ),
    ] = False,
    damaged: Annotated[
        bool,
        typer.Option(
            "--damaged", help="List the damaged copies of runs found so far (see `runs repair`)."
        ),
    ] = False,
    as_json: JsonOption = False,
) -> None:
    """List archived runs (reads only the index, not the segment files)."""
    store = _open(archive, create=False)
    if damaged:
        with archive_errors():
            items = store.damaged()
        if as_json:
            typer.echo(json.dumps(items, indent=2))
            return
        for item in items:
            typer.echo(f"{item['run_id']}  segment {item['segment_id']}: {item['reason']}")
        typer.echo(f"{len(items)} damaged run copies in {store.root}", err=True)
        return
    with archive_errors():
        rows = store.list_runs(
            ball=ball,
            pattern=pattern,
            outcome=outcome,
            name=name,
            leave=leave,
            pinfall=pinfall,
            strikes=strikes,
            where=where or (),
            order_by=order_by,
            limit=None if limit == 0 else limit + 1,  # one more tells whether more match
        )
    more = limit != 0 and len(rows) > limit
    rows = rows[:limit] if more else rows
    if ids:
        for row in rows:
            typer.echo(row["run_id"])
        return
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
        return
    from rich.table import Table

    title = f"{len(rows)} run(s) in {store.root}"
    table = Table(
        title=title, caption="more runs match: --limit N or --limit 0 for all" if more else None
    )
    columns = list_columns(rows)
    for header, column, _scale, _fmt in columns:
        left = column in ("name", "ball", "pattern", "outcome", "leave", "created_at", "run_id")
        table.add_column(header, justify="left" if left else "right")
    from bowlrec.versions import PHYSICS_VERSION

    older = 0
    for row in rows:
        cells = [_cell(row, c, scale, fmt) for _h, c, scale, fmt in columns]
        if row.get("physics_version") not in (None, PHYSICS_VERSION):
            older += 1
            cells[0] += " *"
        table.add_row(*cells)
    print_table(table)
    if older:
        typer.echo(
            f"* {older} run(s) made with an older physics version than {PHYSICS_VERSION}: "
            "`runs show ID` says which; simulating their scenes again gives new run IDs",
            err=True,
        )


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
    from bowlrec.provenance import bowler_layer_warning, physics_version_warning

    warnings = [
        w for w in (physics_version_warning(provenance), bowler_layer_warning(provenance)) if w
    ]
    pins = stored.trajectory.pins
    if as_json:
        doc = {
            "index": row,
            "provenance": provenance,
            "warnings": warnings,
            "summary": stored.trajectory.summary.to_dict(),
            "pins": None if pins is None else pins.to_dict(),
            "events": events,
            "scene": json.loads(stored.attrs["scene_json"]),
        }
        typer.echo(json.dumps(doc, indent=2))
        return
    from rich.table import Table

    table = Table(title=f"run {stored.run_id} ({stored.scene.name})", show_header=False)
    for key, value in {**row, **provenance}.items():
        if value is None or value == "":  # not applicable to this run (no library ball, no pins)
            continue
        table.add_row(key, f"{value:.10g}" if isinstance(value, float) else str(value))
    table.add_row(
        "events", "\n".join(f"{e['kind']} t={e['t_s']:.4f}s x={e['x_m']:.3f}m" for e in events)
    )
    table.add_row("samples", str(stored.trajectory.n_samples))
    if pins is not None:
        table.add_row("pins", pins.line())
    for warning in warnings:
        table.add_row("warning", warning)
    print_table(table)
    typer.echo("scene (as given):")
    typer.echo(json.dumps(json.loads(stored.attrs["scene_json"]), indent=2))


@runs_app.command("export")
def export(
    runs: Annotated[
        list[str],
        typer.Argument(
            help="Run ID(s) or unique prefixes; several go into one .mcap, .csv (a summary "
            "row each) or figure."
        ),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help="Destination; its suffix picks the format: .h5/.hdf5 (the run file), .mcap, "
            ".rrd, .npz (samples), .csv (samples, or the summary row of a summary-only run), "
            ".json (scene), .png/.svg (plot).",
        ),
    ],
    archive: ArchiveOption = None,
) -> None:
    """Export a run as its HDF5 file, MCAP, rerun recording, NumPy arrays, scene JSON or
    figure.

    Several runs go into one .mcap (each under its own topic prefix, lanes side by side), one
    .csv (a summary row per run) or one figure (overlaid).
    """

    sink = sink_for(out)
    store = _open(archive, create=False)
    with archive_errors():
        data = [store.run_data(store.resolve_id(r)) for r in runs]
        if len(data) > 1:
            typer.echo(sink.line(sink.write_many(data, out), note=f"{len(data)} runs"))
        else:
            typer.echo(sink.line(sink.write(data[0], out)))


@runs_app.command("rm")
def remove(
    runs: Annotated[list[str], typer.Argument(help="Run IDs (or unique prefixes).")],
    archive: ArchiveOption = None,
) -> None:
    """Remove runs from the archive (a tombstone: `runs compact` reclaims the space)."""
    store = _open(archive, create=False)
    with archive_errors():
        for run in runs:
            typer.echo(f"removed {store.remove(run)}")


@runs_app.command("reindex")
def reindex(archive: ArchiveOption = None, as_json: JsonOption = False) -> None:
    """Rebuild the index from the data files (segments, ball files, tombstones); readers see
    the old index until the new one replaces it whole.

    A segment that cannot be read is named (its runs cannot be indexed); `runs repair` sets it
    aside. Exit code 1 when one was found.
    """
    store = _open(archive, create=False)
    with archive_errors():
        report = store.rebuild_index()
    unreadable = report["unreadable_segments"]
    if as_json:
        typer.echo(json.dumps(report, indent=2))
    else:
        typer.echo(f"{report['runs']} run(s) indexed in {store.root}")
        _recovered_lines(report["recovered"])
        for item in unreadable:
            typer.echo(f"unreadable: segment {item['segment_id']}: {item['reason']}")
        if unreadable:
            typer.echo(
                f"{len(unreadable)} segment(s) could not be read and their runs are not "
                "indexed: run `bowlrec runs repair` to set them aside (quarantine)"
            )
    if unreadable:
        raise typer.Exit(1)


def _recovered_lines(counts: dict[str, int], *, skip: tuple[str, ...] = ()) -> None:
    """What recovery did (but the ``skip`` counts, reported otherwise), one line each."""
    said = {
        "temporaries_removed": "temporaries of interrupted writers removed",
        "segments_registered": "sealed segment(s) the index lacked registered",
        "tombstone_files_applied": "tombstone file(s) the index lacked applied",
        "ball_files_indexed": "ball file(s) the index lacked indexed",
        "repairs_finished": "interrupted repair(s) finished",
    }
    for key, text in said.items():
        if key not in skip and counts.get(key):
            typer.echo(f"recovered: {counts[key]} {text}")


@runs_app.command("repair")
def repair(archive: ArchiveOption = None, as_json: JsonOption = False) -> None:
    """Check every stored run against its checksum and the index against the segments.

    Damaged segments move to ARCHIVE/quarantine/ (their healthy runs are rewritten to a new
    segment), and so do segments that cannot be read at all; damaged runs are named here and by
    `runs list --damaged`. Also finishes what killed writers left (and says what). Exit code 1
    when damage was found.
    """
    store = _open(archive, create=False)
    with archive_errors():
        report = store.repair()
    damaged, unreadable = report["damaged_runs"], report["unreadable_segments"]
    if as_json:
        typer.echo(json.dumps(report, indent=2))
    else:
        typer.echo(
            f"checked {report['runs_checked']} run(s) in {report['segments_checked']} "
            f"segment(s) in {report['seconds']:.1f} s; {len(damaged)} damaged, "
            f"{len(report['quarantined_segments'])} segment(s) quarantined; "
            f"{report['segments_registered']} unregistered segment(s) indexed, "
            f"{report['temporaries_removed']} temporaries removed"
        )
        _recovered_lines(report, skip=("temporaries_removed", "segments_registered"))
        if report["ball_rows_fixed"]:
            typer.echo(f"{report['ball_rows_fixed']} ball row(s) of the index rebuilt")
        for item in damaged:
            typer.echo(
                f"damaged: {item['run_id']} (segment {item['segment_id']}): {item['reason']}"
            )
        for item in unreadable:
            typer.echo(
                f"quarantined: segment {item['segment_id']} (cannot be read): {item['reason']}"
            )
    if damaged or unreadable:
        raise typer.Exit(1)


@runs_app.command("compact")
def compact(
    archive: ArchiveOption = None,
    target_runs: Annotated[
        int, typer.Option("--target-runs", min=1, help="Runs per rewritten segment, at most.")
    ] = 10_000,
) -> None:
    """Reclaim the space of removed and duplicate runs and merge small segments (segments are
    rewritten into new files, never in place)."""
    store = _open(archive, create=False)
    with archive_errors():
        report = store.compact(target_runs=target_runs)
    typer.echo(
        f"{report['segments_rewritten']} segment(s) rewritten into {report['segments_written']}"
        f" ({report['runs_moved']} run(s) moved, {report['tombstone_files_deleted']} tombstone "
        "file(s) applied and deleted)"
    )
    if report["segments_left"]:
        typer.echo(
            f"{report['segments_left']} segment(s) were left as they are (damaged or unreadable: "
            "run `bowlrec runs repair`; or written by a later bowlrec with record types this "
            "one cannot rewrite)",
            err=True,
        )


@archive_app.command("migrate")
def migrate(
    archive: Annotated[Path, typer.Argument(help="Archive directory (format 1.0 or 2.x).")],
    quiet: QuietOption = False,
) -> None:
    """Convert a format 1.0 archive (one file per run) to format 2.0 in place, or rewrite a 2.x
    archive's segments of an older segment format in the current ones (2.3 for summary-only
    segments, 3.0 for segments holding samples).

    Run IDs stay the same. The 1.0 files are kept in ARCHIVE/v1-archive/ (delete it once the
    migrated archive looks right); a migration that was interrupted resumes when run again.
    """

    if interactive(quiet):
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn

        with Progress(
            "migrating run files", BarColumn(), MofNCompleteColumn(), TimeElapsedColumn()
        ) as bar:
            task = bar.add_task("migrate", total=None)
            report = run_migration(
                archive,
                progress=lambda done, total: bar.update(task, completed=done, total=total),
            )
    else:
        report = run_migration(archive)
    if "already" in report:
        typer.echo(
            f"{archive} is format {report['already']} ({report['runs']} runs): "
            f"{report['segments_rewritten']} segment(s) of an older segment format rewritten "
            f"into {report['segments_written']}"
            + (
                f", {report['segments_left']} left as they are (damaged or unreadable: "
                "`bowlrec runs repair`)"
                if report["segments_left"]
                else ""
            )
        )
        return
    typer.echo(
        f"{archive}: format {report['from']} -> {report['to']}: {report['runs']} run(s) in "
        f"{report['segments']} segment(s), {report['balls']} ball version(s); the 1.0 files "
        f"are kept in {report['v1_files_kept_in']}"
    )
    for item in report["unreadable_run_files"]:
        typer.echo(f"not migrated (unreadable): {item}", err=True)
    if report["unreadable_run_files"]:
        raise typer.Exit(1)


@archive_app.command("info")
def info(archive: ArchiveOption = None, as_json: JsonOption = False) -> None:
    """Format, run and segment counts, sizes on disk and damage found so far."""
    store = _open(archive, create=False)
    with archive_errors():
        summary = store.info()
    if as_json:
        typer.echo(json.dumps(summary, indent=2))
        return
    for key, value in summary.items():
        typer.echo(f"{key}: {value}")


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
    files = requested_files(rrd=rrd, mcap=mcap, plot=plot)
    store = _open(archive, create=False)
    from bowlrec.archive.replay import replay_data

    with archive_errors():
        data = replay_data(store, store.resolve_id(run))
        if data.provenance and "rerecorded_dt_s" in data.provenance:
            dt_ms = 1000 * float(data.provenance["rerecorded_dt_s"])
            typer.echo(
                f"summary-only run: re-recorded from its stored scene at {dt_ms:g} ms "
                "(checked against the stored summary)"
            )
        for line in write_outputs(data, files, connect=connect, spawn=spawn):
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

    plot_runs = sink_named("plot").attribute("plot_runs")  # MissingExtraError without matplotlib
    from bowlrec.figures.series import plot_series

    data = []
    with archive_errors():
        for item in runs:
            path = Path(item)
            if path.suffix.lower() in (".json", ".yaml", ".yml"):
                data.append(_simulated(load_scene_or_exit(path, archive)))
            else:  # a summary-only run is re-recorded from its stored scene
                from bowlrec.archive.replay import replay_data

                store = _open(archive, create=False)
                data.append(replay_data(store, store.resolve_id(item)))
        typer.echo(str(plot_runs(data, out, title=title, exaggerate=exaggerate)))
        if series is not None:
            typer.echo(str(plot_series(data[0], series)))


def _simulated(scene: Any) -> Any:
    """A scene file simulated on the spot (sampled at 5 ms if the scene is summary-only)."""
    from bowlrec.archive.replay import simulate_sampled

    first_use("rate")
    return simulate_sampled(scene)

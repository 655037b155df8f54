"""``bowlrec carry``: a carry map from a carry job (the ``bowlrec[pins]`` extra)."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Annotated, Any

import typer

from ._app import app
from ._common import JsonOption, QuietOption, fail, with_progress

_COLUMNS = (
    "board",
    "angle_deg",
    "speed_mph",
    "axis_tilt_deg",
    "n",
    "strikes",
    "strike_probability",
    "strike_se",
    "mean_pinfall",
    "mean_exit_board",
    "leaves",
)


def _write_table(cells: list[dict[str, Any]], path: Path) -> None:
    """The cells as JSON (every field) or CSV (:data:`_COLUMNS`, the leaves as JSON text),
    written under a temporary name and renamed."""
    from bowlrec.atomic_files import atomic_path

    with atomic_path(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as fh:
        if path.suffix.lower() == ".json":
            json.dump(cells, fh, indent=1)
            fh.write("\n")
            return
        writer = csv.writer(fh)
        writer.writerow(_COLUMNS)
        for c in cells:
            row = [c[k] for k in _COLUMNS[:-1]]
            writer.writerow(["" if v is None else v for v in row] + [json.dumps(c["leaves"])])


@app.command()
def carry(
    job: Annotated[
        Path, typer.Argument(help="Carry job file (.json, .yaml), format bowlrec-carry.")
    ],
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers",
            "-j",
            min=0,
            help="Local worker processes (default: all cores; 0 or 1: in this process).",
        ),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="Write the cells' table (.csv or .json)."),
    ] = None,
    plot: Annotated[
        Path | None, typer.Option("--plot", help="Write the heat map (.png or .svg).")
    ] = None,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Run a carry map: strike percentage over entry board x entry angle (x speed x axis tilt),
    every cell thrown at many racks whose pins vary within USBC's tolerances.

    Prints one line with the deliveries, the wall time and the best cell; --out writes one row
    per cell (strikes, standard error, leaves), --plot the heat map coaches use. Needs the pins
    extra: pip install 'bowlrec[pins]'.
    """
    from bowlrec.pins.carry import carry_map
    from bowlrec.pins.carry_job import load_carry_job
    from bowlrec.pins.engine import require_mujoco

    if out is not None and out.suffix.lower() not in (".csv", ".json"):
        fail(f"--out {out}: give a .csv or .json path")
    if plot is not None and plot.suffix.lower() not in (".png", ".svg"):
        fail(f"--plot {plot}: give a .png or .svg path")
    spec = load_carry_job(job)
    require_mujoco()
    grid = spec.grid()

    def run(advance: Any) -> Any:
        done = [0]

        def progress(finished: int, _total: int) -> None:
            if advance is not None:
                for _ in range(finished - done[0]):
                    advance(None)
            done[0] = finished

        count = None if workers is None else max(1, workers)
        return carry_map(grid, spec.pin_plan(), workers=count, progress=progress)

    cmap = with_progress(quiet, f"{spec.name}: {grid.size:,} deliveries", grid.size, run)
    cells = [c.to_dict() for c in cmap.cells]
    if out is not None:
        _write_table(cells, out)
    if plot is not None:
        from bowlrec.figures.carry import write_carry_figure

        write_carry_figure(cmap, plot, title=f"{spec.name} ({spec.hand}-hander)")
    best = max(cmap.cells, key=lambda c: c.strike_probability)
    e = best.entry
    if as_json:
        typer.echo(json.dumps(cmap.to_dict()))
        return
    typer.echo(
        f"{spec.name}: {len(cmap.cells)} cells x {grid.repeats} racks = {grid.size:,} "
        f"deliveries in {cmap.wall_time_s:.1f} s on {cmap.workers} worker(s); best cell: board "
        f"{e.board:g} at {e.angle_deg:g} deg, {100 * best.strike_probability:.0f} % strikes"
    )
    if out is not None:
        typer.echo(f"table: {out}")
    if plot is not None:
        typer.echo(f"figure: {plot}")

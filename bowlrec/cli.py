"""The ``bowlrec`` command line (Typer). Heavy modules are imported inside the commands."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

app = typer.Typer(
    name="bowlrec",
    help="Bowling-ball motion simulator (Frohlich 2004 exact equations of motion).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

QuietOption = Annotated[
    bool, typer.Option("--quiet", "-q", help="No progress output (also off when not a terminal).")
]


def _interactive(quiet: bool) -> bool:
    return not quiet and sys.stderr.isatty()


def _fail(message: str, code: int = 2) -> None:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code)


def _load_scene_or_exit(path: Path) -> Any:
    from pydantic import ValidationError

    from .spec import format_validation_error, load_scene

    if not path.exists():
        _fail(f"{path}: no such file")
    try:
        return load_scene(path)
    except ValidationError as err:
        _fail(f"{path}: invalid scene\n{format_validation_error(err)}")
    except (ValueError, OSError) as err:
        _fail(f"{path}: {err}")


def _summary_json(summary: Any) -> dict[str, Any]:
    d = summary.to_dict()
    return {
        "outcome": d["outcome"],
        "message": d["message"],
        "slide_m": d["slide_m"],
        "hook_m": d["hook_m"],
        "pocket_deg": d["pocket_deg"],
        "time_s": d["time_s"],
        "x_end_m": d["x_end_m"],
        "y_end_m": d["y_end_m"],
        "speed_end_mps": d["speed_end_mps"],
        "rev_rate_end_rpm": d["rev_rate_end_rpm"],
        "n_steps": d["n_steps"],
        "n_rhs": d["n_rhs"],
        "n_events": d["n_events"],
    }


@app.command()
def simulate(
    scene: Annotated[Path, typer.Argument(help="Scene file (.json, .yaml, .yml).")],
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
    out: Annotated[
        Path | None, typer.Option("--out", help="Save the trajectory to a .npz file.")
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Simulate one delivery and print its summary."""
    from dataclasses import replace

    scene_obj = _load_scene_or_exit(scene)
    plan = scene_obj.resolve()
    from .core.plan import RECORD_STEPS, RECORD_SUMMARY

    if out is None and plan.record_mode != RECORD_SUMMARY:
        plan = replace(plan, record_mode=RECORD_SUMMARY)  # nothing will read the samples
    elif out is not None and plan.record_mode == RECORD_SUMMARY:
        plan = replace(plan, record_mode=RECORD_STEPS)
    traj = _with_status("compiling/loading kernels", quiet, _solve, plan)
    if out is not None:
        traj.save_npz(out)
    if as_json:
        typer.echo(json.dumps(_summary_json(traj.summary)))
        return
    _print_summary(scene_obj.name, traj, out)


def _solve(plan: Any) -> Any:
    from .core.solver import solve

    return solve(plan)


def _with_status(message: str, quiet: bool, fn: Any, *args: Any) -> Any:
    if not _interactive(quiet):
        return fn(*args)
    from rich.console import Console

    with Console(stderr=True).status(message):
        return fn(*args)


def _print_summary(name: str, traj: Any, out: Path | None) -> None:
    from rich.console import Console
    from rich.table import Table

    s = traj.summary
    table = Table(title=f"bowlrec: {name}", show_header=False)
    table.add_row("outcome", f"{s.outcome} ({s.message})")
    table.add_row("slide", "never rolls" if s.slide_m is None else f"{s.slide_m:.4f} m")
    if s.hook_m is not None:
        table.add_row("hook", f"{100 * s.hook_m:.2f} cm")
        table.add_row("pocket angle", f"{s.pocket_deg:.3f} deg")
    table.add_row("time", f"{s.time_s:.4f} s")
    table.add_row("end position", f"x = {s.x_end_m:.4f} m, y = {s.y_end_m:.4f} m")
    table.add_row("end speed", f"{s.speed_end_mps:.3f} m/s")
    table.add_row("end rev rate", f"{s.rev_rate_end_rpm:.1f} rpm")
    table.add_row("events", ", ".join(f"{e.kind}@{e.x_m:.2f}m" for e in traj.events))
    table.add_row("solver", f"{s.n_steps} steps, {s.n_rhs} right-hand-side evaluations")
    if out is not None:
        table.add_row("trajectory", f"{out} ({traj.n_samples} samples)")
    Console().print(table)


@app.command()
def paper(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON rows.")] = False,
    markdown: Annotated[bool, typer.Option("--markdown", help="Print a Markdown table.")] = False,
    rtol: Annotated[float | None, typer.Option(help="Integrator tolerance override.")] = None,
    update_readme: Annotated[
        Path | None, typer.Option(help="Rewrite the Table III block of this README.")
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Simulate the paper's 18 Table III cases and print them beside the paper's values."""
    from .paper_table import HEADER, NOTE_TEXT, markdown_table, run_paper_cases, table_cells

    rows = _run_with_progress(quiet, lambda cb: run_paper_cases(rtol=rtol, progress=cb))
    if update_readme is not None:
        from .paper_table import update_readme as _update

        changed = _update(update_readme, markdown_table(rows))
        typer.echo(f"{update_readme}: {'updated' if changed else 'already up to date'}")
        return
    if as_json:
        out = [
            {
                "case": r.paper.case,
                "paper": {
                    "slide_m": r.paper.slide_m,
                    "hook_m": r.paper.hook_m,
                    "pocket_deg": r.paper.pocket_deg,
                },
                "as_written": _summary_json(r.as_written),
                "best_fit": _summary_json(r.best_fit),
                "note": r.note,
            }
            for r in rows
        ]
        typer.echo(json.dumps(out, indent=2))
        return
    if markdown:
        typer.echo(markdown_table(rows), nl=False)
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title="Frohlich (2004) Table III: the paper vs bowlrec (as written, best fit)")
    for h in HEADER:
        table.add_column(h.replace(" (", "\n("), justify="right")
    for cells in table_cells(rows):
        table.add_row(*cells)
    console = Console()
    console.print(table)
    for key, text in NOTE_TEXT.items():
        console.print(f"({key}) {text}")


def _run_with_progress(quiet: bool, work: Any) -> Any:
    if not _interactive(quiet):
        return work(None)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn

    with Progress(
        "[progress.description]{task.description}",
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        transient=True,
    ) as progress:
        task = progress.add_task("Table III (first run compiles the kernels)", total=18)
        return work(lambda _case: progress.advance(task))


@app.command()
def schema(
    out: Annotated[Path, typer.Option(help="Directory for the JSON Schema files.")] = Path(
        "schemas"
    ),
) -> None:
    """Export the JSON Schemas of the scene models."""
    from .spec.schema_export import export_schemas

    for p in export_schemas(out):
        typer.echo(str(p))


@app.command()
def examples(
    out: Annotated[Path, typer.Option(help="Directory for the Table III scene files.")] = Path(
        "examples/paper"
    ),
) -> None:
    """Write the 18 Table III scenes as JSON scene files."""
    from .paper import write_paper_examples

    for p in write_paper_examples(out):
        typer.echo(str(p))


@app.command()
def validate(
    scene: Annotated[Path, typer.Argument(help="Scene file (.json, .yaml, .yml).")],
) -> None:
    """Check a scene file and print the resolved physical parameters."""
    scene_obj = _load_scene_or_exit(scene)
    plan = scene_obj.resolve()
    typer.echo(f"{scene}: valid scene {scene_obj.name!r}")
    typer.echo(f"  inertia per mass k^2 (m^2): {list(plan.inertia_per_mass_m2)}")
    typer.echo(f"  r_Delta body (m): {list(plan.r_delta_body_m)}")
    typer.echo(f"  q0 (w, x, y, z): {list(plan.q0)}")
    typer.echo(
        f"  scalar inertia: {plan.scalar_inertia}, offset: {plan.has_offset}, "
        f"constant friction: {plan.constant_friction}"
    )


def main() -> None:
    app()


if __name__ == "__main__":
    main()

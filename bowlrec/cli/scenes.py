"""Scene commands: simulate, paper, validate, schema, examples."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any

import typer

from bowlrec.core.codes import RECORD_SUMMARY
from bowlrec.errors import SceneInputError
from bowlrec.scene_input import ParsedScene, parse_scene

from ._app import app
from ._common import (
    ArchiveOption,
    JsonOption,
    QuietOption,
    archive_errors,
    fail,
    load_scene_or_exit,
    open_archive,
    output_dir,
    parse_scene_or_exit,
    print_table,
    summary_json,
    with_progress,
    with_status,
)
from ._first_use import first_use, first_use_of_file, scene_variants
from ._outputs import (
    ConnectOption,
    McapOption,
    OutOption,
    PlotOption,
    RrdOption,
    SpawnOption,
    requested_files,
    wants_samples,
    write_outputs,
)


@app.command()
def simulate(
    scene: Annotated[
        Path | None,
        typer.Argument(help="Scene file (.json, .yaml, .yml); omitted: the default scene."),
    ] = None,
    archive: ArchiveOption = None,
    no_archive: Annotated[
        bool, typer.Option("--no-archive", help="Do not store the run in the archive.")
    ] = False,
    ball: Annotated[
        str | None,
        typer.Option("--ball", help="Use this library ball (NAME or NAME@VERSION) instead."),
    ] = None,
    as_json: JsonOption = False,
    out: OutOption = None,
    mcap: McapOption = None,
    rrd: RrdOption = None,
    connect: ConnectOption = None,
    spawn: SpawnOption = False,
    plot: PlotOption = None,
    quiet: QuietOption = False,
) -> None:
    """Simulate one delivery, store it in the archive and print its summary.

    The run ID is a content hash: simulating the same scene again reuses the stored run.
    """
    from bowlrec.spec import Scene

    if scene is not None:
        first_use_of_file(scene)  # a bowler scene simulates as it is read
    parsed = parse_scene_or_exit(scene, archive) if scene is not None else ParsedScene(Scene())
    run_parsed_scene(
        parsed,
        archive=archive,
        no_archive=no_archive,
        ball=ball,
        as_json=as_json,
        files=requested_files(out=out, mcap=mcap, rrd=rrd, plot=plot),
        connect=connect,
        spawn=spawn,
        quiet=quiet,
    )


def run_parsed_scene(
    parsed: ParsedScene,
    *,
    archive: Path | None,
    no_archive: bool,
    ball: str | None,
    as_json: bool,
    files: Any,
    connect: str | None,
    spawn: bool,
    quiet: bool,
) -> None:
    """Simulate a parsed scene (with the library ball ``ball`` in place of its own), store it
    unless ``no_archive``, write ``files``, stream it, and print its summary (with its pins
    when the scene asks for pin action) or its JSON: ``bowlrec simulate`` and ``bowlrec
    pins``."""
    store = None if no_archive else open_archive(archive)
    if ball is not None:
        with archive_errors():
            parsed = _with_library_ball(parsed, ball, store or open_archive(archive))
    scene_obj, ball_ref = parsed.scene, parsed.ball_ref
    needs_samples = wants_samples(files, stream=connect is not None or spawn)
    if needs_samples and scene_obj.options.record == "summary":
        options = scene_obj.options.model_copy(update={"record": "steps"})
        scene_obj = scene_obj.model_copy(update={"options": options})
        if not quiet:
            typer.echo(
                "note: recording every step (options.record = 'steps') for the outputs", err=True
            )
    summary_only = store is None and not (needs_samples or files)  # see _solve_unarchived
    first_use(*scene_variants(scene_obj, parsed.bowler is not None, summary_only))
    status = "simulating (first run compiles kernels)"
    if scene_obj.options.pins is not False:
        status = "simulating the lane and the pins (first run compiles kernels)"
    with archive_errors():
        if store is not None:
            from bowlrec.api import simulate_into

            result = with_status(
                status, quiet, lambda: simulate_into(store, scene_obj, ball_ref=ball_ref)
            )
            traj, run_id, added = result.trajectory, result.run_id, result.added
        else:
            traj = with_status(
                status,
                quiet,
                _solve_unarchived,
                scene_obj,
                needs_samples or bool(files),  # a file gets the samples the scene records
            )
            run_id, added = None, False
        from bowlrec.sinks import RunData

        run = RunData(scene_obj, scene_obj.resolve(), traj, run_id)
        lines = write_outputs(run, files, connect=connect, spawn=spawn)
    bowler = _bowler_report(parsed, run.plan)
    if as_json:
        payload = summary_json(traj.summary)
        payload.update(
            {
                "run_id": run_id,
                "archived": added,
                "archive": None if store is None else str(store.root),
            }
        )
        if bowler is not None:
            payload["bowler"] = bowler
        if traj.pins is not None:
            payload["pins"] = traj.pins.to_dict()
        typer.echo(json.dumps(payload))
        return
    _print_summary(scene_obj.name, traj, run_id, added, store)
    if bowler is not None:
        _print_bowler(bowler)
    if traj.pins is not None:
        _print_pins(traj.pins)
    for line in lines:
        typer.echo(line)


def _with_library_ball(parsed: Any, ref: str, store: Any) -> Any:
    """The parsed scene with library ball ``ref`` in place of its ball: a physical ball in a
    physical scene, a spec sheet in a bowler scene (laid out by its layout and PAP)."""

    source = parsed.bowler if parsed.bowler is not None else parsed.scene
    data = source.model_dump(mode="json")  # a bowler scene keeps its "format": "bowler"
    try:
        return parse_scene({**data, "ball": ref}, store.balls)
    except SceneInputError as err:
        raise SceneInputError(f"--ball {ref}: {err}") from None


def _bowler_report(parsed: Any, plan: Any) -> dict[str, Any] | None:
    """The report in bowlers' terms for a bowler-language scene, else None: from a summary-only
    run of ``plan`` observing what the report reads (a run that records samples weighs the
    orientation fully, so the two agree to the integrator's tolerance, not bit for bit)."""
    if parsed.bowler is None:
        return None
    from bowlrec.bowling.report import bowler_report, observed_run

    bs = parsed.bowler
    traj = observed_run(replace(plan, record_mode=RECORD_SUMMARY), bs.lane)
    return bowler_report(traj, bs.lane, bs.delivery.handedness).to_dict()


def _print_bowler(report: dict[str, Any]) -> None:
    from rich.table import Table

    from bowlrec.bowling.report import board_count

    title = f"in bowlers' terms (boards: {board_count(report['handedness'])})"
    table = Table(title=title, show_header=False)
    for key, value in report.items():
        text = f"{value:.2f}" if isinstance(value, float) else str(value)
        table.add_row(key, text)
    print_table(table)


def _solve_unarchived(scene: Any, needs_samples: bool) -> Any:

    from bowlrec.api import with_pins
    from bowlrec.core.solver import run_plan

    plan = scene.resolve()
    if not needs_samples:
        plan = replace(plan, record_mode=RECORD_SUMMARY)  # nothing will read the samples
    return with_pins(plan, run_plan(plan))


def _print_pins(pins: Any) -> None:
    from rich.table import Table

    from bowlrec.pins.diagram import deck_diagram

    table = Table(title="at the pins", show_header=False)
    table.add_row("leave", f"{pins.leave} ({pins.pinfall} down, {pins.hand}-hander's names)")
    table.add_row("deck", deck_diagram(pins.standing, pins.set_pins))
    table.add_row("ball touched", "-".join(str(p) for p in pins.touched) or "no pin")
    if pins.exit_board is not None:
        table.add_row(
            "ball off the deck",
            f"board {pins.exit_board:.1f} (bowler's count), deflected "
            f"{pins.deflection_boards:+.1f} boards",
        )
    if pins.action is not None:
        state = "at rest" if pins.action.at_rest else "stopped at max_time_s"
        table.add_row("pin action", f"{pins.action.time_s:.2f} s ({state}), {pins.action.engine}")
    print_table(table)


def _print_summary(name: str, traj: Any, run_id: str | None, added: bool, store: Any) -> None:
    from rich.table import Table

    from bowlrec.bowling.sides import summary_rows

    s = traj.summary
    table = Table(title=f"bowlrec: {name}", show_header=False)
    table.add_row("outcome", f"{s.outcome} ({s.message})")
    table.add_row("slide", "never rolls" if s.slide_m is None else f"{s.slide_m:.4f} m")
    for label, text in summary_rows(s.hook_m, s.pocket_deg):  # sides named, not signs
        table.add_row(label, text)
    table.add_row("time", f"{s.time_s:.4f} s")
    table.add_row("end position", f"x = {s.x_end_m:.4f} m, y = {s.y_end_m:.4f} m (lane frame)")
    table.add_row("end speed", f"{s.speed_end_mps:.3f} m/s")
    table.add_row("end rev rate", f"{s.rev_rate_end_rpm:.1f} rpm")
    table.add_row("events", ", ".join(f"{e.kind}@{e.x_m:.2f}m" for e in traj.events))
    table.add_row("solver", f"{s.n_steps} steps, {s.n_rhs} right-hand-side evaluations")
    if run_id is not None:
        state = "stored" if added else "already archived (reused)"
        table.add_row("run", f"{run_id} {state} in {store.root}")
    print_table(table)


@app.command()
def paper(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON rows.")] = False,
    markdown: Annotated[bool, typer.Option("--markdown", help="Print a Markdown table.")] = False,
    rtol: Annotated[
        float | None, typer.Option(help="Integrator tolerance override, in [1e-14, 1e-3].")
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Simulate the paper's 18 Table III cases and print them beside the paper's values."""
    from bowlrec.paper_table import HEADER, NOTE_TEXT, markdown_table, run_paper_cases, table_cells

    if rtol is not None and not 1e-14 <= rtol <= 1e-3:  # as a scene's options.rtol
        fail(f"--rtol {rtol:g}: must be in [1e-14, 1e-3]")

    first_use("closed_form", "integrator")  # summaries: uniform balls and the others
    rows = with_progress(
        quiet,
        "Table III (first run compiles the kernels)",
        18,
        lambda cb: run_paper_cases(rtol=rtol, progress=cb),
    )
    if as_json:
        out = [
            {
                "case": r.paper.case,
                "paper": {
                    "slide_m": r.paper.slide_m,
                    "hook_m": r.paper.hook_m,
                    "pocket_deg": r.paper.pocket_deg,
                },
                "as_written": summary_json(r.as_written),
                "best_fit": summary_json(r.best_fit),
                "note": r.note,
            }
            for r in rows
        ]
        typer.echo(json.dumps(out, indent=2))
        return
    if markdown:
        typer.echo(markdown_table(rows), nl=False)
        return
    from rich.table import Table

    table = Table(title="Frohlich (2004) Table III: the paper vs bowlrec (as written, best fit)")
    for h in HEADER:
        table.add_column(h.replace(" (", "\n("), justify="right")
    for cells in table_cells(rows):
        table.add_row(*cells)
    print_table(table)
    for key, text in NOTE_TEXT.items():
        typer.echo(f"({key}) {text}")


@app.command()
def schema(
    name: Annotated[
        str | None,
        typer.Argument(
            help="scene (default), bowler-scene, job, or a part of the scene: ball, lane, "
            "delivery, options.",
            show_default=False,
        ),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            "-o",
            help="Write NAME.schema.json into this directory (every schema when no NAME is "
            "given) instead of printing one.",
        ),
    ] = None,
) -> None:
    """Print the JSON Schema of a scene, bowler scene or batch job (for editors and
    validators), or write the schema files into a directory."""
    from .schemas import SCHEMAS, export_schemas

    if name is not None and name not in SCHEMAS:
        fail(f"schema {name!r}: there is no such schema; the schemas are {', '.join(SCHEMAS)}")
    if out is None:
        typer.echo(SCHEMAS[name or "scene"](), nl=False)
        return
    for p in export_schemas(out, None if name is None else [name]):
        typer.echo(str(p))


@app.command()
def examples(
    out: Annotated[
        Path,
        typer.Argument(
            help="Directory for the Table III scene files (the repository's: examples/paper)."
        ),
    ],
) -> None:
    """Write the 18 Table III scenes as JSON scene files (case01.json ... case18.json)."""
    from bowlrec.paper import write_paper_examples

    for p in write_paper_examples(output_dir(out, "OUT")):
        typer.echo(str(p))


def _floats(values: Any) -> str:
    """``[a, b, c]`` with each value to 10 significant digits (``0.004761``, not the binary
    float's ``0.0047610000000000005``)."""
    return "[" + ", ".join(f"{float(v):.10g}" for v in values) + "]"


@app.command()
def validate(
    scene: Annotated[Path, typer.Argument(help="Scene file (.json, .yaml, .yml).")],
) -> None:
    """Check a scene file and print the resolved physical parameters."""
    scene_obj = load_scene_or_exit(scene)
    plan = scene_obj.resolve()
    typer.echo(f"{scene}: valid scene {scene_obj.name!r}")
    typer.echo(f"  inertia per mass k^2 (m^2): {_floats(plan.inertia_per_mass_m2)}")
    typer.echo(f"  r_Delta body (m): {_floats(plan.r_delta_body_m)}")
    typer.echo(f"  q0 (w, x, y, z): {_floats(plan.q0)}")
    typer.echo(
        f"  scalar inertia: {plan.scalar_inertia}, offset: {plan.has_offset}, "
        f"constant friction: {plan.constant_friction}"
    )

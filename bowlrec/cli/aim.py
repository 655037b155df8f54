"""``aim``: the shot of a bowler scene that enters the pocket (entry board, or board and angle)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from ._app import app
from ._common import (
    JsonOption,
    QuietOption,
    fail,
    parse_scene_or_exit,
    print_table,
    validated_options,
    with_status,
)
from ._first_use import first_use

VaryOption = Annotated[
    list[str] | None,
    typer.Option(
        "--vary",
        "-v",
        help="Free variable: target, launch, laydown or speed. Once: solve the entry board; "
        "twice: the first for the entry angle, the second for the board. Default: target.",
    ),
]
PocketBoardOption = Annotated[
    float | None, typer.Option("--pocket-board", help="Entry board to aim at (default 17.5).")
]
BoardWindowOption = Annotated[
    tuple[float, float] | None,
    typer.Option("--board-window", help="Pocket window, lowest and highest board (17 18)."),
]
AngleOption = Annotated[
    float | None, typer.Option("--angle", help="Entry angle to aim at, deg (default 5).")
]
AngleWindowOption = Annotated[
    tuple[float, float] | None,
    typer.Option("--angle-window", help="Entry angle window, deg (4 6)."),
]
BreakpointOption = Annotated[
    float | None,
    typer.Option(
        "--breakpoint-board",
        help="With two variables: put the breakpoint on this board (instead of solving the "
        "entry angle); the angle is what the ball then gives.",
    ),
]
RuleOf31Option = Annotated[
    bool,
    typer.Option(
        "--rule-of-31",
        help="With two variables: the breakpoint one board outside the rule of 31's exit "
        "board (pattern length in ft - 32), as the calibration plays every pattern.",
    ),
]


def pocket_from_options(
    board: float | None,
    board_window: tuple[float, float] | None,
    angle: float | None,
    angle_window: tuple[float, float] | None,
) -> Any:
    """The pocket the options describe (the default where an option is not given)."""
    from bowlrec.bowling.pocket import POCKET, Pocket

    data = POCKET.model_dump()
    if board is not None:
        data["board"] = board
    if board_window is not None:
        data["board_min"], data["board_max"] = board_window
    if angle is not None:
        data["angle_deg"] = angle
    if angle_window is not None:
        data["angle_min_deg"], data["angle_max_deg"] = angle_window
    return validated_options(
        Pocket,
        data,
        {
            "board": "--pocket-board",
            "board_min": "--board-window",
            "board_max": "--board-window",
            "angle_deg": "--angle",
            "angle_min_deg": "--angle-window",
            "angle_max_deg": "--angle-window",
        },
    )


def bowler_scene_or_exit(path: Path) -> Any:
    """The bowler scene in ``path``; exits when it is a physical scene."""
    parsed = parse_scene_or_exit(path)
    if parsed.bowler is None:
        fail(f'{path}: a bowler scene is needed (top level "format": "bowler")')
    return parsed.bowler


def _fmt(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


@app.command()
def aim(
    scene: Annotated[Path, typer.Argument(help="Bowler scene file (.json, .yaml).")],
    vary: VaryOption = None,
    pocket_board: PocketBoardOption = None,
    board_window: BoardWindowOption = None,
    angle: AngleOption = None,
    angle_window: AngleWindowOption = None,
    breakpoint_board: BreakpointOption = None,
    rule_of_31: RuleOf31Option = False,
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Write the aimed bowler scene (.json).")
    ] = None,
    as_json: JsonOption = False,
) -> None:
    """Find the shot that enters the pocket: vary one variable for the entry board, or two for
    the entry board and angle (or the entry board and a breakpoint board). Exits 1 when no
    shot within the bounds enters the pocket window, board and angle (with
    --breakpoint-board: the board); the closest is shown, and --out is not written."""
    from bowlrec.bowling.aim import aim as solve_aim

    if out is not None and out.suffix.lower() != ".json":
        fail(f"--out {out}: the aimed scene is written as JSON; give a .json path")
    if rule_of_31 and breakpoint_board is not None:
        fail("--rule-of-31 and --breakpoint-board: give one (the rule decides the board)")
    pocket = pocket_from_options(pocket_board, board_window, angle, angle_window)
    first_use("observe")  # reading the bowler scene simulates already
    bowler = bowler_scene_or_exit(scene)
    if rule_of_31:
        from bowlrec.bowling.calibration import breakpoint_board_for, pattern_length_ft

        breakpoint_board = breakpoint_board_for(pattern_length_ft(bowler.pattern_model()))
    result = solve_aim(bowler, vary or ["target"], pocket, breakpoint_board=breakpoint_board)
    # with a breakpoint board the angle is what the ball gives; otherwise the shot must be in
    # both windows (one variable solves the board alone: its angle may still be outside)
    aimed = result.found and (breakpoint_board is not None or _in_window(result))
    written = out if out is not None and aimed else None
    if written is not None:
        from bowlrec.atomic_files import atomic_path

        with atomic_path(written) as tmp:
            tmp.write_text(json.dumps(result.scene.model_dump(mode="json"), indent=2) + "\n")
    if as_json:
        doc = result.to_dict()
        doc["aimed"] = aimed
        doc["written"] = None if written is None else str(written)
        typer.echo(json.dumps(doc))
    else:
        _print(result, aimed, written)
        if out is not None and written is None:
            typer.echo(f"{out}: not written (the shot does not enter the pocket window)")
    if not aimed:
        raise typer.Exit(1)


def _in_window(result: Any) -> bool:
    """Whether the result's shot enters both the pocket's board and angle windows."""
    shot = result.shot
    return bool(result.pocket.contains(shot.entry_board, shot.entry_angle_deg))


def _print(result: Any, aimed: bool, out: Path | None) -> None:
    from rich.table import Table

    shot = result.shot
    if aimed:
        title = "aimed"
    elif result.found:
        title = "entry board solved, entry angle outside its window"
    else:
        title = "no solution: closest shot"
    table = Table(title=f"bowlrec aim: {title}", show_header=False)
    for name, value in result.values.items():
        unit = {"target": "board at the arrows", "launch": "deg", "laydown": "board"}.get(
            name, "mph"
        )
        table.add_row(name, f"{value:.3f} {unit}")
    table.add_row("launch angle", f"{shot.launch_angle_deg:.3f} deg")
    table.add_row("arrows board", _fmt(shot.arrows_board))
    table.add_row(
        "breakpoint", f"board {_fmt(shot.breakpoint_board)} at {_fmt(shot.breakpoint_ft, 1)} ft"
    )
    table.add_row("entry board", _fmt(shot.entry_board))
    table.add_row("entry angle", f"{_fmt(shot.entry_angle_deg)} deg")
    r = shot.report
    table.add_row(
        "Specto windows",
        f"entry angle 51-55 ft {_fmt(r.specto_entry_angle_deg)} deg, board at 59.5 ft "
        f"{_fmt(r.specto_entry_board)}, launch angle 0-10 ft {_fmt(r.specto_launch_angle_deg)} deg",
    )
    in_window = _in_window(result)
    table.add_row(
        "pocket window", f"{result.pocket.describe()}: {'in' if in_window else 'out of'} window"
    )
    table.add_row("search", f"{result.evaluations} shots in {1000 * result.seconds:.0f} ms")
    print_table(table)
    typer.echo(result.message)
    if out is not None:
        typer.echo(f"{out}: the aimed scene; simulate it with: bowlrec simulate {out}")


@app.command()
def variance(
    scene: Annotated[Path, typer.Argument(help="Bowler scene file (.json, .yaml).")],
    preset: Annotated[
        str, typer.Option("--preset", "-p", help="Release scatter: robot, pro or league.")
    ] = "league",
    n: Annotated[
        int | None,
        typer.Option("--n", min=1, max=100_000, help="Repeats (default: 2000; 200 with --pins)."),
    ] = None,
    seed: Annotated[
        int, typer.Option("--seed", min=0, help="Random seed, >= 0 (reproducible).")
    ] = 0,
    plot: Annotated[
        Path | None, typer.Option("--plot", help="Write the figure (.png or .svg).")
    ] = None,
    pins: Annotated[
        bool,
        typer.Option(
            "--pins",
            help="Also throw every repeat through the pins: the shot's strike percentage, "
            "carry and leaves (needs 'bowlrec[pins]'; about 0.1-0.5 s per repeat per core).",
        ),
    ] = False,
    pocket_board: PocketBoardOption = None,
    board_window: BoardWindowOption = None,
    angle: AngleOption = None,
    angle_window: AngleWindowOption = None,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Repeat a shot with a bowler's release scatter and report how often it enters the
    pocket (entry board and angle distributions, share in the window) and, with --pins, how
    often it strikes."""
    from bowlrec.bowling.variance import PRESETS, release_scatter

    if n is None:
        n = 200 if pins else 2000
    if preset not in PRESETS:
        fail(f"--preset {preset!r}: choose one of {', '.join(PRESETS)}")
    if plot is not None and plot.suffix.lower() not in (".png", ".svg"):
        fail(f"--plot {plot}: give a .png or .svg path")
    pocket = pocket_from_options(pocket_board, board_window, angle, angle_window)
    first_use("observe", "batch_parallel")  # reading the bowler scene simulates already
    bowler = bowler_scene_or_exit(scene)
    result = with_status(
        f"{n} repeats", quiet, lambda: release_scatter(bowler, PRESETS[preset], n, seed, pocket)
    )
    if plot is not None:
        from bowlrec.figures.variance import write_scatter_figure

        write_scatter_figure(result, plot, title=f"{bowler.name}, {preset}")
    doc = {"preset": preset, **result.to_dict()}
    carry = None
    if pins:
        from bowlrec.bowling.shot_carry import shot_carry

        carry = with_status(
            f"{n} repeats through the pins",
            quiet,
            lambda: shot_carry(bowler, PRESETS[preset], n, seed, pocket),
        )
        doc["pins"] = carry.to_dict()
    if as_json:
        typer.echo(json.dumps(doc))
        return
    board, ang = doc["entry_board"], doc["entry_angle_deg"]
    typer.echo(
        f"{bowler.name}, {preset} scatter, {n} repeats (seed {seed}) in {result.seconds:.2f} s"
    )
    typer.echo(
        f"in the pocket ({pocket.describe()}): {100 * result.pocket_share:.1f} % "
        f"(± {100 * result.pocket_share_se:.1f}); reach the pins: "
        f"{100 * result.pins_share:.1f} %"
    )
    if board["mean"] is not None:
        typer.echo(
            f"entry board {board['mean']:.2f} ± {board['std']:.2f} (5-95 %: {board['p05']:.1f}"
            f"-{board['p95']:.1f}); entry angle {ang['mean']:.2f} ± {ang['std']:.2f} deg "
            f"(5-95 %: {ang['p05']:.2f}-{ang['p95']:.2f})"
        )
    if carry is not None:
        hits = "no repeat" if carry.carry is None else f"{100 * carry.carry:.0f} %"
        leaves = ", ".join(f"{name} {k}" for name, k in carry.leave_counts()[:6])
        typer.echo(
            f"strikes: {100 * carry.strike_share:.1f} % (± {100 * carry.strike_share_se:.1f}); "
            f"carry of pocket hits: {hits}; leaves: {leaves} ({carry.seconds:.1f} s)"
        )
    if plot is not None:
        typer.echo(f"figure: {plot}")


@app.command()
def tolerance(
    scene: Annotated[Path, typer.Argument(help="Bowler scene file (.json, .yaml).")],
    plot: Annotated[
        Path | None, typer.Option("--plot", help="Write the map (.png or .svg).")
    ] = None,
    pocket_board: PocketBoardOption = None,
    board_window: BoardWindowOption = None,
    angle: AngleOption = None,
    angle_window: AngleWindowOption = None,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Map the entry board over target board at the arrows x speed around the scene's shot:
    how far the bowler can miss the target or the speed and still enter the pocket window."""
    from bowlrec.bowling.variance import tolerance_map

    if plot is not None and plot.suffix.lower() not in (".png", ".svg"):
        fail(f"--plot {plot}: give a .png or .svg path")
    pocket = pocket_from_options(pocket_board, board_window, angle, angle_window)
    first_use("observe", "batch_parallel", "closed_form")  # reading the scene simulates already
    bowler = bowler_scene_or_exit(scene)
    tmap = with_status("mapping", quiet, lambda: tolerance_map(bowler, pocket=pocket))
    if plot is not None:
        from bowlrec.figures.variance import write_tolerance_figure

        write_tolerance_figure(tmap, plot, title=bowler.name)
    doc = tmap.to_dict()
    if as_json:
        typer.echo(json.dumps(doc))
        return
    tr, sr = doc["target_range_at_scene_speed"], doc["speed_range_at_scene_target"]
    typer.echo(
        f"{bowler.name}: target {doc['scene_target']:.2f} at the arrows, "
        f"{doc['scene_speed_mph']:.2f} mph; pocket {pocket.describe()}"
    )
    if tr is None or sr is None:
        typer.echo("the scene's own shot does not enter the pocket's board window: aim it first")
    else:
        typer.echo(
            f"entry in the board window for targets {tr[0]:.2f}-{tr[1]:.2f} "
            f"({tr[1] - tr[0]:.2f} boards) at its speed and for {sr[0]:.2f}-{sr[1]:.2f} mph "
            f"({sr[1] - sr[0]:.2f} mph) at its target"
        )
    if plot is not None:
        typer.echo(f"figure: {plot}")

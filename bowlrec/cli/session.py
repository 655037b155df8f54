"""``bowlrec session``: play sessions (bowlers, games, one lane whose oil changes shot by shot)."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ._app import app
from ._common import (
    ArchiveOption,
    JsonOption,
    QuietOption,
    fail,
    open_archive,
    output_dir,
    with_progress,
)
from ._first_use import first_use

if TYPE_CHECKING:
    from bowlrec.session.runner import SessionResult

#: the shots table's columns (ShotRow fields), units in the names
TABLE_COLUMNS = (
    "shot",
    "game",
    "frame",
    "ball",
    "bowler",
    "run_id",
    "outcome",
    "pocket",
    "entry_board",
    "entry_angle_deg",
    "breakpoint_board",
    "breakpoint_ft",
    "laydown_board",
    "target_board",
    "lane_oil_ul",
    "lifted_ul",
    "deposited_ul",
    "absorbed_ul",
    "ball_load_ul",
    "simulated",
    "pinfall",
    "leave",
    "standing",
    "mark",
    "score",
    "key_pin",
    "spare_board",
)
#: the games table's columns (GameRow fields; frame_scores space-separated)
GAME_COLUMNS = ("bowler", "game", "score", "marks", "frame_scores", "finished")


@app.command()
def session(
    files: Annotated[
        list[Path], typer.Argument(help="Session files (format bowlrec-session, JSON or YAML).")
    ],
    archive: ArchiveOption = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            "-o",
            help="Directory for each session's shots table and figures (default: "
            "FILE-session/ in the current directory, FILE without its suffix; one "
            "subdirectory per session when several).",
        ),
    ] = None,
    workers: Annotated[
        int,
        typer.Option(
            "--workers",
            "-w",
            min=1,
            help="Sessions played at once, one process each (the shots of a session are "
            "sequential: each changes the lane for the next).",
        ),
    ] = 1,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="dask.distributed scheduler address: play the sessions on that cluster "
            "(its workers need this archive's and the output directory's filesystem).",
        ),
    ] = None,
    max_shots: Annotated[
        int | None,
        typer.Option("--max-shots", min=1, help="Stop each session after this many shots."),
    ] = None,
    json_out: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Play sessions shot by shot into the archive: the oil grid after every shot is stored
    with it, and rerunning a session resumes after its last archived shot. A file with a
    ``sweep`` plays one session per point; sessions run in parallel with --workers or
    --scheduler.

    Balls are scored by the pins that fall when the pins extra (MuJoCo) is installed or the
    session says ``pins: true`` (ten-pin games, spares shot with the 3-6-9 system), else by the
    pocket-window rule; the summary says which.

    Writes per session: shots.csv (one row per shot), games.csv (each bowler's games, with
    pins), oil.svg/png (the oil before and after) and drift.svg/png (breakpoint, entry board
    and angle over the session).
    """
    from bowlrec.session.spec import load_sessions

    sessions = []
    for f in files:
        if not f.exists():
            fail(f"{f}: no such file")
        sessions.append((f, load_sessions(f)))
    store = open_archive(archive)
    root = str(store.root)
    store.close()
    several = len(files) > 1
    first_use("observe", "integrator")  # bowler-language shots
    tasks = [
        (spec.model_dump_json(), _out_dir(out, f, several, spec.name if len(specs) > 1 else None))
        for f, specs in sessions
        for spec in specs
    ]
    for _, directory in tasks:  # before any shot: a place that cannot be written fails now
        output_dir(directory, "--out")
    if (workers > 1 or scheduler is not None) and len(tasks) > 1:
        from bowlrec.batch.runner import worker_pool

        with worker_pool(min(workers, len(tasks)), scheduler) as pool:
            futures = [
                pool.pool.submit(_play_one, text, root, str(d), max_shots, True)
                for text, d in tasks
            ]
            summaries = [fut.result() for fut in futures]
    else:
        summaries = [_play_one(text, root, str(d), max_shots, quiet) for text, d in tasks]
    if json_out:
        import json

        typer.echo(json.dumps(summaries, indent=2))
        return
    for s in summaries:
        for name, message in s["aims"].items():
            if not message.startswith("enters the pocket"):
                typer.echo(
                    f"warning: {s['name']}: {name} aimed on the fresh lane: {message}", err=True
                )
        typer.echo(
            f"{s['name']}: {s['shots']} shots ({s['simulated']} simulated, {s['resumed']} read "
            f"back from the archive) in {s['seconds']:.1f} s; lane oil {s['oil_before_ul']:.0f} "
            f"-> {s['oil_after_ul']:.0f} uL; strikes {s['strikes']}/{s['first_balls']}; "
            f"scored by {s['rule']}",
            err=True,
        )
        for line in game_lines(s["games"]):
            typer.echo(f"  {line}", err=True)
        if not quiet:
            tables = "shots.csv, games.csv" if s["games"] else "shots.csv"
            typer.echo(f"  {s['out']}/: {tables}, oil.svg/png, drift.svg/png", err=True)


def game_lines(games: list[dict[str, Any]]) -> list[str]:
    """One line per bowler: the game scores in order (an unfinished game marked with ``+``:
    its score so far) and the marks of each game."""
    by_bowler: dict[str, list[dict[str, Any]]] = {}
    for g in games:
        by_bowler.setdefault(g["bowler"], []).append(g)
    lines = []
    for name, own in by_bowler.items():
        scores = ", ".join(f"{g['score']}{'' if g['finished'] else '+'}" for g in own)
        total = sum(g["score"] for g in own)
        lines.append(f"{name}: {scores} (series {total})")
        lines.extend(f"  game {g['game']}: {g['marks']}" for g in own)
    return lines


def _out_dir(out: Path | None, file: Path, several: bool, point: str | None) -> Path:
    """FILE-session/ in the current directory (or --out), per file when several, per sweep
    point when a sweep."""
    base = Path(f"{file.stem}-session") if out is None else out
    if out is not None and several:
        base = base / file.stem
    return base / point if point is not None else base


def _play_one(
    spec_json: str, archive_root: str, out_dir: str, max_shots: int | None, quiet: bool
) -> dict[str, Any]:
    """Play one session into the archive and write its outputs (in a worker when several run
    at once); a summary dict."""
    from bowlrec.archive import Archive
    from bowlrec.session.spec import SessionSpec

    spec = SessionSpec.model_validate_json(spec_json)
    store = Archive(archive_root, create=False)
    try:
        result = _run(spec, store, max_shots, quiet)
    finally:
        store.close()
    paths = write_outputs(result, Path(out_dir))
    if result.pins:  # every ball at a full rack (the tenth frame's bonus balls too)
        first = [r for r in result.rows if r.key_pin is None]
        strikes = sum(r.mark == "X" for r in first)
    else:
        first = [r for r in result.rows if r.ball == 1]
        strikes = sum(r.pocket for r in first)
    return {
        "name": spec.name,
        "session_id": result.session_id,
        "shots": len(result.rows),
        "simulated": result.simulated,
        "resumed": result.resumed,
        "seconds": result.seconds,
        "oil_before_ul": float(result.fresh.volume_ul.sum()),
        "oil_after_ul": float(result.final.volume_ul.sum()),
        "rule": result.rule,
        "strikes": strikes,
        "first_balls": len(first),
        "games": [g.to_dict() for g in result.games],
        "aims": result.aims,
        "out": str(Path(out_dir)),
        "files": [str(p) for p in paths],
    }


def _run(spec: Any, store: Any, max_shots: int | None, quiet: bool) -> SessionResult:
    """``run_session`` under a progress bar counting frames (on a terminal, without --quiet)."""
    from bowlrec.session.runner import FRAMES, run_session

    def work(advance: Any) -> SessionResult:
        def on_shot(row: Any) -> None:
            if row.ball == 1:
                advance(row)

        hook = None if advance is None else on_shot
        return run_session(spec, store, on_shot=hook, max_shots=max_shots)

    frames = spec.games * FRAMES * len(spec.bowlers)
    result: SessionResult = with_progress(quiet, f"session {spec.name} (frames)", frames, work)
    return result


def _cell(value: Any) -> Any:
    """A CSV cell: empty for None, pin numbers space-separated."""
    if value is None:
        return ""
    if isinstance(value, tuple | list):
        return " ".join(str(v) for v in value)
    return value


def write_outputs(result: SessionResult, out_dir: Path) -> list[Path]:
    """The shots table (CSV), the games table (CSV, with pins) and the figures (SVG and PNG)
    of a session, written atomically."""
    from bowlrec.atomic_files import atomic_path
    from bowlrec.figures.render import figure_bytes
    from bowlrec.figures.session import drift_figure, oil_before_after_figure

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [out_dir / "shots.csv"]
    with atomic_path(paths[0], durable=False) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(TABLE_COLUMNS)
        for r in result.rows:
            d = r.to_dict()
            w.writerow([_cell(d[c]) for c in TABLE_COLUMNS])
    if result.games:
        paths.append(out_dir / "games.csv")
        with atomic_path(paths[-1], durable=False) as tmp, open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(GAME_COLUMNS)
            for g in result.games:
                d = g.to_dict()
                w.writerow([_cell(d[c]) for c in GAME_COLUMNS])
    name = result.spec.name
    figures = {
        "oil": oil_before_after_figure(
            result.fresh, result.final, title=f"{name}: oil before and after"
        ),
    }
    if result.rows:
        figures["drift"] = drift_figure([r.to_dict() for r in result.rows])
    for stem, fig in figures.items():
        for fmt in ("svg", "png"):
            path = out_dir / f"{stem}.{fmt}"
            with atomic_path(path, durable=False) as tmp:
                Path(tmp).write_bytes(figure_bytes(fig, fmt))
            paths.append(path)
    return paths

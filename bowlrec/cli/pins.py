"""``bowlrec pins``: a scene's delivery through the pins (the ``bowlrec[pins]`` extra)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from ._app import app
from ._common import ArchiveOption, JsonOption, QuietOption, parse_scene_or_exit
from ._first_use import first_use_of_file
from ._outputs import (
    ConnectOption,
    McapOption,
    OutOption,
    PlotOption,
    RrdOption,
    SpawnOption,
    requested_files,
)


def _pin_list(text: str | None) -> list[int] | None:
    if text is None:
        return None
    try:
        return [int(p) for p in text.replace("-", ",").split(",") if p.strip()]
    except ValueError:
        raise typer.BadParameter(f"{text!r}: give pin numbers 1-10, e.g. 2,4,5,8") from None


@app.command()
def pins(
    scene: Annotated[
        Path | None,
        typer.Argument(help="Scene file (.json, .yaml, .yml); omitted: the default scene."),
    ] = None,
    seed: Annotated[
        int | None,
        typer.Option(
            "--seed",
            help="Draw the pins' weights, centres of gravity and spotting within USBC's "
            "tolerances from this seed (default: nominal pins on their spots).",
        ),
    ] = None,
    standing: Annotated[
        str | None,
        typer.Option(
            "--standing", help="The pins set before the ball, e.g. 2,4,5,8 (default: all ten)."
        ),
    ] = None,
    hand: Annotated[
        str | None,
        typer.Option("--hand", help="Name the leave as a right- or left-hander would: right|left."),
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
    """Simulate a delivery down the lane and through the pins; print the leave.

    The scene's own `options.pins` (restitution and friction per pair, tolerances) is used
    when it has one, else the pin model's defaults; `--seed`, `--standing` and `--hand`
    override it. Needs the pins extra: pip install 'bowlrec[pins]'.
    """
    from bowlrec.scene_input import ParsedScene, parse_scene
    from bowlrec.spec import Scene

    from .scenes import run_parsed_scene

    if scene is not None:
        first_use_of_file(scene)  # a bowler scene simulates as it is read
    parsed = parse_scene_or_exit(scene, archive) if scene is not None else ParsedScene(Scene())
    updates: dict[str, Any] = {}
    if seed is not None:
        updates["seed"] = seed
    pins_given = _pin_list(standing)
    if pins_given is not None:
        updates["standing"] = pins_given
    if hand is not None:
        updates["hand"] = hand
    parsed = _with_pins(parsed, updates, parse_scene)
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


def _with_pins(parsed: Any, updates: dict[str, Any], parse_scene: Any) -> Any:
    """The parsed scene with ``options.pins`` on (its own parameters, or the defaults) and
    ``updates`` applied, validated again through the one way in (so a bad --standing is one
    line naming the field)."""
    source = parsed.bowler if parsed.bowler is not None else parsed.scene
    data = source.model_dump(mode="json")
    options = dict(data.get("options") or {})
    current = options.get("pins")
    pins = dict(current) if isinstance(current, dict) else {}
    pins.update(updates)
    options["pins"] = pins
    data["options"] = options
    return parse_scene(data)

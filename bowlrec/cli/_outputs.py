"""Write a run to the requested replay formats (MCAP, rerun .rrd / live stream, plot)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ._common import fail

if TYPE_CHECKING:
    from bowlrec.sinks import RunData

McapOption = Annotated[
    Path | None, typer.Option("--mcap", help="Write the run to this .mcap file (Foxglove).")
]
RrdOption = Annotated[
    Path | None, typer.Option("--rrd", help="Write a rerun recording (.rrd) to this file.")
]
ConnectOption = Annotated[
    str | None,
    typer.Option(
        "--connect",
        help="Stream live to a running rerun viewer, e.g. rerun+http://127.0.0.1:9876/proxy.",
    ),
]
SpawnOption = Annotated[
    bool, typer.Option("--spawn", help="Start a rerun viewer and stream to it (needs a display).")
]
PlotOption = Annotated[
    Path | None, typer.Option("--plot", help="Write a paper-style figure (.png or .svg).")
]


def wants_samples(*outputs: object) -> bool:
    """True when any replay output was asked for (they all need a sampled trajectory)."""
    return any(o not in (None, False) for o in outputs)


def _missing_extra(err: ImportError, extra: str) -> None:
    fail(f"{err.name or err} is not installed; install it with: pip install 'bowlrec[{extra}]'")


def write_outputs(
    run: RunData,
    *,
    mcap: Path | None = None,
    rrd: Path | None = None,
    connect: str | None = None,
    spawn: bool = False,
    plot: Path | None = None,
) -> list[str]:
    """Write every requested output; returns one line per output for the user."""
    done: list[str] = []
    if mcap is not None:
        try:
            from bowlrec.sinks.mcap_file import write_mcap
        except ImportError as err:
            _missing_extra(err, "mcap")
        done.append(f"MCAP: {write_mcap(run, mcap)}  (open in Foxglove: File > Open)")
    if rrd is not None or connect is not None or spawn:
        try:
            from bowlrec.sinks import rerun_recording as rr_sink
        except ImportError as err:
            _missing_extra(err, "rerun")
        if rrd is not None:
            done.append(f"rerun: {rr_sink.write_rrd(run, rrd)}  (open with: rerun {rrd})")
        if connect is not None or spawn:
            try:
                rr_sink.stream_run(run, connect_url=connect, spawn=spawn)
            except rr_sink.ViewerUnavailableError as err:
                fail(str(err), code=1)
            done.append(f"rerun: streamed to {'a new viewer' if spawn else connect}")
    if plot is not None:
        try:
            from bowlrec.sinks.plot import plot_runs
        except ImportError as err:
            _missing_extra(err, "plot")
        done.append(f"plot: {plot_runs([run], plot)}")
    return done

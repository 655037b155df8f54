"""Write a run to the requested files (:mod:`bowlrec.sinks.registry`) and live viewers."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from bowlrec.errors import UnknownFormatError
from bowlrec.sinks.registry import known_suffixes, sink_for, sink_named

if TYPE_CHECKING:
    from bowlrec.sinks import RunData
    from bowlrec.sinks.registry import Sink

OutOption = Annotated[
    Path | None,
    typer.Option(
        "--out",
        help="Also write the run to this file; its suffix picks the format: "
        f"{' '.join(known_suffixes())} (.npz: the samples as NumPy arrays).",
    ),
]
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


def requested_files(
    *,
    out: Path | None = None,
    mcap: Path | None = None,
    rrd: Path | None = None,
    plot: Path | None = None,
) -> list[tuple[Sink, Path]]:
    """The (sink, file) pairs asked for: ``out`` by its suffix (UnknownFormatError for one
    no sink has), the others by their option (UnknownFormatError when the file's suffix is
    not the option's format: ``--mcap run.json`` would write MCAP under a JSON name)."""
    pairs = [(sink_for(out), out)] if out is not None else []
    for name, path in (("mcap", mcap), ("rrd", rrd), ("plot", plot)):
        if path is None:
            continue
        sink = sink_named(name)
        if path.suffix.lower() not in sink.suffixes:
            raise UnknownFormatError(
                f"--{name} {path}: --{name} writes {sink.label}, whose files end in "
                + " or ".join(sink.suffixes)
                + f" (--out FILE picks the format by its suffix: {' '.join(known_suffixes())})"
            )
        pairs.append((sink, path))
    return pairs


def wants_samples(files: list[tuple[Sink, Path]], *, stream: bool = False) -> bool:
    """True when a requested file needs a sampled trajectory, or the run is streamed live."""
    return stream or any(sink.needs_samples for sink, _ in files)


def write_outputs(
    run: RunData,
    files: list[tuple[Sink, Path]],
    *,
    connect: str | None = None,
    spawn: bool = False,
) -> list[str]:
    """Write every requested file and stream to a viewer when asked; one line per output for
    the user."""
    done = [sink.line(sink.write(run, path)) for sink, path in files]
    if connect is not None or spawn:
        stream_run = sink_named("rrd").attribute("stream_run")
        stream_run(run, connect_url=connect, spawn=spawn)
        done.append(f"rerun: streamed to {'a new viewer' if spawn else connect}")
    return done

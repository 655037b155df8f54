"""The file formats a run can be written to, each declared once and found by file suffix.

A :class:`Sink` names a format, its suffixes, what it writes, whether it needs a sampled
trajectory (``options.record`` other than ``'summary'``), the ``bowlrec[extra]`` its libraries
come from, and its writer: a function ``write(run, path) -> Path`` taking a
:class:`~bowlrec.spec.run.RunData` and the file to write, in the module that implements the
format (the writers of :mod:`bowlrec.sinks`; the figures' writer for PNG and SVG,
:mod:`bowlrec.figures.trajectory`). That module is imported when the sink is first used, so
this registry, ``import bowlrec`` and ``bowlrec --help`` load no format library (h5py, mcap,
rerun, matplotlib, pandas).

The command line (``simulate --out/--mcap/--rrd/--plot``, ``replay``, ``runs export``), the
service (``GET /runs/ID/files/KIND``) and batch jobs (``formats``) all write through it::

    from bowlrec.sinks.registry import sink_for

    sink = sink_for("run.mcap")  # UnknownFormatError for a suffix no sink has
    sink.write(run, "run.mcap")  # MissingExtraError when the mcap extra is not installed
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.errors import MissingExtraError, UnknownFormatError

if TYPE_CHECKING:
    from bowlrec.spec.run import RunData

__all__ = ["SINKS", "Sink", "known_suffixes", "sink_for", "sink_named"]


@dataclass(frozen=True)
class Sink:
    """One file format a run can be written to.

    name: the format's name (batch ``formats``, the service's file kinds); suffixes: the file
    suffixes that select it, lower case, the first the one it is written under by default;
    label: how lines printed for the user name it; description: what the file holds;
    needs_samples: it draws or stores the path, so a summary-only run is refused (the
    command line records samples for it); module, writer: where ``write(run, path) -> Path``
    is; many: the module's ``write(runs, path) -> Path`` putting several runs into one file,
    if it has one; extra: the ``bowlrec[extra]`` that installs the module's libraries; hint:
    how to open the file (``{path}`` is replaced by its path).
    """

    name: str
    suffixes: tuple[str, ...]
    label: str
    description: str
    needs_samples: bool
    module: str
    writer: str
    many: str | None = None
    extra: str | None = None
    hint: str = ""

    @property
    def suffix(self) -> str:
        """The suffix files of this format are written under by default."""
        return self.suffixes[0]

    def attribute(self, name: str) -> Any:
        """``name`` from the sink's module, imported now; :class:`MissingExtraError` when a
        library the module needs is not installed."""
        try:
            module = importlib.import_module(self.module)
        except ImportError as err:
            missing = err.name or str(err)
            if self.extra is None or missing.startswith("bowlrec"):
                raise
            raise MissingExtraError(
                f"{self.label} needs {missing}, which is not installed; install it with: "
                f"pip install 'bowlrec[{self.extra}]'",
                name=missing,
            ) from None
        return getattr(module, name)

    def write(self, run: RunData, path: str | os.PathLike[str]) -> Path:
        """Write ``run`` to ``path`` in this format (whatever the path's suffix); the path."""
        written: Path = self.attribute(self.writer)(run, Path(path))
        return written

    def write_many(self, runs: Sequence[RunData], path: str | os.PathLike[str]) -> Path:
        """Write several runs into the one file ``path``; UnknownFormatError when this format
        holds one run per file."""
        if self.many is None:
            into = ", ".join(s for sink in SINKS if sink.many for s in sink.suffixes)
            raise UnknownFormatError(
                f"{os.fspath(path)}: a {self.label} file holds one run; several runs go into "
                f"one {into} file"
            )
        written: Path = self.attribute(self.many)(runs, Path(path))
        return written

    def line(self, path: str | os.PathLike[str], note: str = "") -> str:
        """One line for the user: the format, the file, ``note`` and how to open it."""
        text = f"{self.label}: {path}" + (f" ({note})" if note else "")
        return text + (f"  ({self.hint.format(path=path)})" if self.hint else "")


SINKS: tuple[Sink, ...] = (
    Sink(
        "hdf5",
        (".h5", ".hdf5"),
        "HDF5",
        "the run as one self-contained HDF5 run file (format bowlrec-run)",
        False,
        "bowlrec.sinks.hdf5_run",
        "write_run",
    ),
    Sink(
        "mcap",
        (".mcap",),
        "MCAP",
        "a replay for Foxglove (several runs: lanes side by side)",
        True,
        "bowlrec.sinks.mcap_file",
        "write_mcap",
        many="write_mcap_batch",
        extra="mcap",
        hint="open in Foxglove: File > Open",
    ),
    Sink(
        "rrd",
        (".rrd",),
        "rerun",
        "a rerun recording with its default blueprint",
        True,
        "bowlrec.sinks.rerun_recording",
        "write_rrd",
        extra="rerun",
        hint="open with: rerun {path}",
    ),
    Sink(
        "npz",
        (".npz",),
        "NumPy",
        "the samples, events and summary as a compressed NumPy archive",
        True,
        "bowlrec.sinks.npz",
        "write_run_npz",
    ),
    Sink(
        "csv",
        (".csv",),
        "CSV",
        "the samples as a table, one row per sample, columns named with their units "
        "(a summary-only run: its summary as one row; several runs: one summary row each)",
        False,
        "bowlrec.sinks.csv_file",
        "write_run_csv",
        many="write_csv_many",
    ),
    Sink(
        "plot",
        (".png", ".svg"),
        "plot",
        "a paper-style lane figure (several runs: overlaid)",
        True,
        "bowlrec.figures.trajectory",
        "write_plot",
        many="plot_runs",
        extra="plot",
    ),
    Sink(
        "scene",
        (".json",),
        "scene",
        "the scene as simulated (JSON; simulating it again gives the same run)",
        False,
        "bowlrec.sinks.scene_json",
        "write_scene_json",
    ),
)


def known_suffixes() -> list[str]:
    """Every suffix a sink is found by, in the order the sinks are declared."""
    return [s for sink in SINKS for s in sink.suffixes]


def sink_for(path: str | os.PathLike[str]) -> Sink:
    """The sink of the file ``path`` by its suffix (any case); :class:`UnknownFormatError`
    naming the suffix and the known ones otherwise."""
    suffix = Path(path).suffix.lower()
    for sink in SINKS:
        if suffix in sink.suffixes:
            return sink
    what = f"unknown suffix {suffix!r}" if suffix else "no suffix to tell the format by"
    raise UnknownFormatError(f"{os.fspath(path)}: {what} (known: {' '.join(known_suffixes())})")


def sink_named(name: str) -> Sink:
    """The sink called ``name`` (``"mcap"``, ``"rrd"``, ...); :class:`UnknownFormatError`
    otherwise."""
    for sink in SINKS:
        if sink.name == name:
            return sink
    raise UnknownFormatError(
        f"unknown output format {name!r} (known: {' '.join(s.name for s in SINKS)})"
    )

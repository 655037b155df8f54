"""Writers of finished runs to files and viewers: HDF5, MCAP, rerun, NumPy, CSV, JSON.

Sinks know formats, never physics: each takes a :class:`RunData` (the scene as given, its
resolved :class:`~bowlrec.core.plan.Plan`, and the :class:`~bowlrec.core.trajectory.Trajectory`;
:mod:`bowlrec.spec.run`) and writes it. :mod:`bowlrec.sinks.registry` declares every file format
once and finds it by suffix (PNG and SVG figures are written by :mod:`bowlrec.figures`). Heavy
libraries (NumPy, h5py, mcap, foxglove, rerun, matplotlib) are imported by the modules that use
them, on first use, so ``import bowlrec`` and the command line's start-up stay fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from bowlrec.errors import SamplesRequiredError

if TYPE_CHECKING:
    from .common import RunData

__all__ = ["RunData", "SamplesRequiredError"]


def __getattr__(name: str) -> Any:
    if name == "RunData":
        from .common import RunData

        return RunData
    raise AttributeError(f"module 'bowlrec.sinks' has no attribute {name!r}")

"""Provenance of a run: versions, solver settings, timing and creation time (root attributes)."""

from __future__ import annotations

import platform
import sys
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from bowlrec.sinks.common import RunData

__all__ = ["provenance"]


def _version(module: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(module)
    except PackageNotFoundError:
        return "unknown"


def provenance(run: RunData, *, wall_time_s: float, ball_ref: str, solver: str) -> dict[str, Any]:
    """Root attributes describing how and when ``run`` was produced.

    wall_time_s: the solver's wall time (s); ball_ref: "name@version" of the library ball or "";
    solver: "integrator" or "closed_form" (what actually ran).
    """
    import h5py

    import bowlrec

    opts = run.scene.options
    return {
        "created_at": datetime.now(UTC).isoformat(timespec="microseconds"),
        "bowlrec_version": bowlrec.__version__,
        "physics_version": bowlrec.PHYSICS_VERSION,
        "ball_ref": ball_ref,
        "solver": solver,
        "rtol": opts.rtol,
        "record": opts.record,
        "record_dt_s": opts.record_dt_s,
        "record_terms": opts.record_terms,
        "slide_to_roll": opts.slide_to_roll,
        "wall_time_s": float(wall_time_s),
        "python_version": sys.version.split()[0],
        "platform": platform.platform(),
        "numpy_version": _version("numpy"),
        "numba_version": _version("numba"),
        "h5py_version": h5py.version.version,
        "hdf5_version": h5py.version.hdf5_version,
    }

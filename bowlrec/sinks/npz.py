"""A run's trajectory as a compressed NumPy archive (``.npz``).

One array per per-sample quantity of :meth:`~bowlrec.core.trajectory.Trajectory.arrays` (SI
units, named with their unit: ``t_s``, ``position_m``, ``omega_radps``, ``torque_<term>``, ...;
first axis = sample), and two JSON strings: ``events_json`` (the events, each ``t_s``,
``kind``, ``x_m``, ``y_m``, ``mu``, ``phase``) and ``summary_json`` (the summary metrics).
Read it back with ``numpy.load``. The file is written whole or not at all.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bowlrec.atomic_files import atomic_path

if TYPE_CHECKING:
    from bowlrec.core.trajectory import Trajectory

    from .common import RunData

__all__ = ["write_npz", "write_run_npz"]


def write_npz(trajectory: Trajectory, path: str | os.PathLike[str]) -> Path:
    """Write the samples, events and summary of ``trajectory`` to the ``.npz`` file ``path``
    (replaced if it exists; no suffix is added); return the path."""
    target = Path(path)
    arrays: dict[str, Any] = {
        "events_json": json.dumps([asdict(e) for e in trajectory.events]),
        "summary_json": json.dumps(trajectory.summary.to_dict()),
        **trajectory.arrays(),
    }
    with atomic_path(target) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    return target


def write_run_npz(run: RunData, path: str | os.PathLike[str]) -> Path:
    """:func:`write_npz` of the run's trajectory (the registry's writer)."""
    return write_npz(run.trajectory, path)

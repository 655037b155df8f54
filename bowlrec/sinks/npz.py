"""A run's trajectory as a compressed NumPy archive (``.npz``).

One array per per-sample quantity of :meth:`~bowlrec.core.trajectory.Trajectory.arrays` (SI
units, named with their unit: ``t_s``, ``position_m``, ``omega_radps``, ``torque_<term>``, ...;
first axis = sample), and two JSON strings: ``events_json`` (the events, each ``t_s``,
``kind``, ``x_m``, ``y_m``, ``mu``, ``phase``) and ``summary_json`` (the summary metrics).

A run with pin action (``options.pins``) adds ``pins_json`` (``outcome``: the result as
``PinOutcome.to_dict()`` gives it; ``action``: the engine's ``time_s``, ``at_rest``,
``n_steps``, ``wall_time_s``, ``exit_y_m``, ``engine`` and ``extras``; ``entry``: the ball's
state at the hand-off; null when the ball never reached the pins; NaN written as null) and, when
the ball reached the pins, their recorded motion as the archive's ``pins/`` group holds it
(:mod:`bowlrec.pins.records`): ``pins/t_s`` (s after the hand-off), ``pins/pin_position_m``
(n, 10, 3), ``pins/pin_quaternion_wxyz`` (n, 10, 4; pin p is column p - 1, NaN for a pin not
set), ``pins/ball_position_m``, ``pins/ball_quaternion_wxyz``, ``pins/energy_J``; lane frame with
the lane's surface at z = 0. A run without pins is written exactly as before.
Read it back with ``numpy.load``. The file is written whole or not at all.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bowlrec.atomic_files import atomic_path

if TYPE_CHECKING:
    from bowlrec.core.trajectory import Trajectory
    from bowlrec.pins.outcome import PinOutcome

    from .common import RunData

__all__ = ["pin_arrays", "write_npz", "write_run_npz"]


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def pin_arrays(outcome: PinOutcome) -> dict[str, Any]:
    """The ``.npz`` entries of a run's pins: ``pins_json`` and the ``pins/...`` arrays."""
    from bowlrec.pins.records import pin_groups

    action, entry = outcome.action, outcome.entry
    values = {
        "outcome": outcome.to_dict(),
        "action": None
        if action is None
        else {
            "time_s": action.time_s,
            "at_rest": action.at_rest,
            "n_steps": action.n_steps,
            "wall_time_s": action.wall_time_s,
            "exit_y_m": action.exit_y_m,
            "engine": action.engine,
            "extras": dict(action.extras),
        },
        "entry": None if entry is None else asdict(entry),
    }
    out: dict[str, Any] = {"pins_json": json.dumps(_plain(values), allow_nan=False)}
    for name, arr in pin_groups(outcome).get("pins", {}).items():
        out[f"pins/{name}"] = arr
    return out


def write_npz(trajectory: Trajectory, path: str | os.PathLike[str]) -> Path:
    """Write the samples, events and summary of ``trajectory`` to the ``.npz`` file ``path``
    (replaced if it exists; no suffix is added); return the path."""
    target = Path(path)
    arrays: dict[str, Any] = {
        "events_json": json.dumps([asdict(e) for e in trajectory.events]),
        "summary_json": json.dumps(trajectory.summary.to_dict()),
        **trajectory.arrays(),
    }
    if trajectory.pins is not None:
        arrays.update(pin_arrays(trajectory.pins))
    with atomic_path(target) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    return target


def write_run_npz(run: RunData, path: str | os.PathLike[str]) -> Path:
    """:func:`write_npz` of the run's trajectory (the registry's writer)."""
    return write_npz(run.trajectory, path)

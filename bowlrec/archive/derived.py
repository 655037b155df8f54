"""Per-sample quantities derived on read (segment format 3.0, docs/archive-format.md).

A segment of format 3.0 stores each sample's state as the kernel recorded it (time, position,
velocity, orientation, angular velocity, phase, friction coefficient and the friction's
direction); the contact forces, slip, energy and angular acceleration are computed from it
when a run is read, by the same compiled function that computed them when the run was
simulated (:func:`bowlrec.core.solver.sample_arrays`), so they read back equal to what a
2.x segment stores.

A run whose derived quantities are not exactly what its state gives (a run read from a 2.x
segment or a run file, whose friction direction is not the kernel's, or a trajectory built
by hand) would not read back as it was given: :func:`given_samples` finds those, and the
segment stores their derived quantities too (``DERIVED_FIELDS``), read as stored.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.core.trajectory import DERIVED_SAMPLE_FIELDS

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Trajectory

__all__ = ["DERIVED_FIELDS", "derived_samples", "given_samples", "plan_samples"]

#: the per-sample quantities format 3.0 derives from the state on read (the rest of
#: TRAJECTORY_FIELDS is the state), in the digest's order
DERIVED_FIELDS = DERIVED_SAMPLE_FIELDS


def plan_samples(state: dict[str, NDArray[Any]], plan: Plan) -> dict[str, NDArray[Any]]:
    """Every per-sample array of a run (the trajectory's fields by name, ``friction_dir``
    included) from its stored state and its resolved scene ``plan``."""
    from bowlrec.core.arguments import kernel_params
    from bowlrec.core.solver import sample_arrays, sample_rows

    arrays, _ = sample_arrays(sample_rows(state), kernel_params(plan), plan.mass_kg, False, plan)
    return arrays


def derived_samples(state: dict[str, NDArray[Any]], scene_json: str) -> dict[str, NDArray[Any]]:
    """:func:`plan_samples` with the plan of a scene (compact JSON), resolved again: what a
    reader derives."""
    from bowlrec.spec import Scene

    return plan_samples(state, Scene.model_validate_json(scene_json).resolve())


def given_samples(
    state: dict[str, NDArray[Any]], traj: Trajectory, plan: Plan | None
) -> dict[str, NDArray[Any]]:
    """The trajectory's DERIVED_FIELDS arrays when its state does not give them back bit for
    bit under ``plan`` (the segment must store them as given), else an empty mapping (the
    state is enough). A state the kernel cannot derive from counts as not giving them back; a
    trajectory marked as derived from its state (the kernel's, or one read from a 3.0 segment:
    :meth:`~bowlrec.core.trajectory.Trajectory.derived_from_state`) is not derived again."""
    if traj.derived_from_state():
        return {}
    assert plan is not None, "a trajectory not derived from its state needs its plan"
    try:
        again = plan_samples(state, plan)
    except (ValueError, KeyError, TypeError):
        again = {}
    given = {k: np.ascontiguousarray(getattr(traj, k)) for k in DERIVED_FIELDS}
    for name, arr in given.items():
        mine = again.get(name)
        if mine is None or mine.dtype != arr.dtype or mine.shape != arr.shape:
            return given
        if mine.tobytes() != arr.tobytes():
            return given
    return {}

"""Per-sample quantities derived on read (segment format 3.0, docs/archive-format.md).

A segment of format 3.0 stores each sample's state as the kernel recorded it (time, position,
velocity, orientation, angular velocity, phase, friction coefficient and the friction's
direction); the contact forces, slip, energy and angular acceleration are computed from it
when a run is read, by the same compiled function that computed them when the run was
simulated (:func:`bowlrec.core.solver.sample_arrays`), so they read back equal to what a
2.x segment stores.
"""

from __future__ import annotations

from typing import Any

from numpy.typing import NDArray

__all__ = ["derived_samples"]


def derived_samples(state: dict[str, NDArray[Any]], scene_json: str) -> dict[str, NDArray[Any]]:
    """Every per-sample array of a run (the trajectory's fields by name, ``friction_dir``
    included) from its stored state and its scene (compact JSON): the kernel parameters are
    the scene's, resolved again."""
    from bowlrec.core.arguments import kernel_params
    from bowlrec.core.solver import sample_arrays, sample_rows
    from bowlrec.spec import Scene

    plan = Scene.model_validate_json(scene_json).resolve()
    arrays, _ = sample_arrays(sample_rows(state), kernel_params(plan), plan.mass_kg, False, plan)
    return arrays

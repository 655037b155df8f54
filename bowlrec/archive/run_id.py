"""Content IDs of runs: a hash of the resolved scene (the Plan) and the physics version.

Two scenes that resolve to the same Plan (the same physical numbers, solver and recording
settings) under the same physics version have the same ID, so simulating them twice stores one
run. Names, descriptions and other labels do not enter the hash: they do not change the result.
Floats are hashed exactly (``float.hex``), so any change of any parameter changes the ID.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from typing import TYPE_CHECKING, Any

from bowlrec.versions import PHYSICS_VERSION

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan

__all__ = ["RUN_ID_LENGTH", "canonical_plan", "run_id"]

#: hex digits kept from the SHA-256 (80 bits: collisions are not a practical concern)
RUN_ID_LENGTH = 20


def _canonical(value: Any) -> Any:
    if type(value) is float:  # the common case first: what the float branch below gives
        return value.hex()
    import numpy as np

    from bowlrec.core.plan import PinPlan

    if isinstance(value, PinPlan):
        return {f.name: _canonical(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, tuple):
        return [_canonical(v) for v in value]

    if isinstance(value, np.ndarray):
        if value.dtype == np.float64:  # each element's float(v).hex(), as below, in one pass
            data = [v.hex() for v in value.ravel().tolist()]
        else:
            data = [_canonical(v) for v in value.ravel()]
        return {"shape": list(value.shape), "data": data}
    if isinstance(value, float | np.floating):
        return float(value).hex()
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"cannot hash a Plan field of type {type(value).__name__}")


def canonical_plan(plan: Plan) -> dict[str, Any]:
    """The Plan's physics-relevant fields as exact, JSON-serializable values (labels dropped,
    and the optional external terms' fields at their defaults, and ``pins`` when None: scenes
    without these keep the IDs they had before the fields existed; see
    ``bowlrec.core.plan.EXTERNAL_FIELDS``). Pin action enters with its model version and every
    parameter, so a cached run never answers with another pin model's pinfall."""
    from bowlrec.core.plan import external_field_at_default

    return {
        f.name: _canonical(getattr(plan, f.name))
        for f in dataclasses.fields(plan)
        if f.name != "labels"
        and not external_field_at_default(plan, f.name)
        and not (f.name == "pins" and plan.pins is None)
    }


def run_id(plan: Plan, physics_version: str | None = None) -> str:
    """The run's content ID: SHA-256 of the canonical Plan and the physics version (hex)."""
    if physics_version is None:
        physics_version = PHYSICS_VERSION
    payload = json.dumps(
        {"physics_version": physics_version, "plan": canonical_plan(plan)},
        sort_keys=True,
        separators=(",", ":"),
    )
    return hashlib.sha256(payload.encode()).hexdigest()[:RUN_ID_LENGTH]

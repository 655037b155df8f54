"""What every sink needs from a run, computed once: geometry, markings and tidy columns.

Nothing here imports a file-format library. Lane frame (paper convention): x from the foul line
toward the pins, y from the right gutter toward the left, z up; the ball's geometric center sits
at z = 0 and the lane surface at z = -R, so viewers draw the lane at z = -R. The run as the
writers take it (:class:`RunData`), the lane's friction cells and the per-sample series are
:mod:`bowlrec.spec.run`'s, named here too for the writers.
"""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.errors import SamplesRequiredError
from bowlrec.spec.run import FrictionCell, RunData, friction_cells, rev_rate_rpm, series_columns

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Trajectory

Array = NDArray[np.float64]

__all__ = [
    "FrictionCell",
    "RunData",
    "SamplesRequiredError",
    "body_to_lane",
    "friction_cells",
    "markings_body",
    "quaternion_xyzw",
    "rev_rate_rpm",
    "series_columns",
]


def markings_body(plan: Plan) -> dict[str, Array]:
    """Unit vectors in the body frame for the ball's markings, only those that exist.

    - ``pin``: the low-RG (smallest moment) principal axis, present when the inertia is not
      scalar (the pin is where this axis meets the surface; its sign is a convention: +axis).
    - ``cg``: the center-of-mass side, from the geometric center toward the center of mass
      (= -r_Delta), present when the offset is non-zero.
    - ``mass_bias``: the high-RG (largest moment) principal axis, present when all three
      moments differ (asymmetric core; the bowlers' PSA / mass-bias marker).
    """
    k = np.asarray(plan.inertia_per_mass_m2, dtype=np.float64)
    out: dict[str, Array] = {}
    if not (k[0] == k[1] == k[2]):
        pin = np.zeros(3)
        pin[int(np.argmin(k))] = 1.0
        out["pin"] = pin
        if k[0] != k[1] and k[1] != k[2] and k[0] != k[2]:
            bias = np.zeros(3)
            bias[int(np.argmax(k))] = 1.0
            out["mass_bias"] = bias
    r = np.asarray(plan.r_delta_body_m, dtype=np.float64)
    n = float(np.linalg.norm(r))
    if n > 0.0:
        out["cg"] = -r / n
    return out


def quaternion_xyzw(q_wxyz: Array) -> Array:
    """(n, 4) quaternions reordered from (w, x, y, z) to (x, y, z, w) (rerun, Foxglove)."""
    q = np.asarray(q_wxyz, dtype=np.float64)
    return np.ascontiguousarray(q[..., [1, 2, 3, 0]])


def body_to_lane(q_wxyz: Array, v_body: Array) -> Array:
    """Rotate the body-frame vector ``v_body`` (3,) by each quaternion of ``q_wxyz`` (n, 4)."""
    q = np.atleast_2d(np.asarray(q_wxyz, dtype=np.float64))
    w, u = q[:, :1], q[:, 1:]
    v = np.broadcast_to(np.asarray(v_body, dtype=np.float64), u.shape)
    t = 2.0 * np.cross(u, v)
    return np.asarray(v + w * t + np.cross(u, t))


def summary_text(traj: Trajectory) -> str:
    """One line for captions and titles in the command line's units: outcome, slide (m), hook
    (cm) and pocket angle (deg)."""
    s = traj.summary
    parts = [s.outcome]
    if s.slide_m is not None:
        parts.append(f"slide {s.slide_m:.2f} m")
    if s.hook_m is not None:
        parts.append(f"hook {100 * s.hook_m:.2f} cm")
    if s.pocket_deg is not None:
        parts.append(f"pocket angle {s.pocket_deg:.2f} deg")
    return ", ".join(parts)


def jsonable(value: Any) -> Any:
    """``value`` with NumPy scalars/arrays and non-finite floats made JSON-safe (NaN -> None)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def dumps(value: Any) -> str:
    """Compact JSON of :func:`jsonable` (value)."""
    return json.dumps(jsonable(value), separators=(",", ":"), allow_nan=False)

"""What every sink needs from a run, computed once: geometry, markings and tidy columns.

Nothing here imports a file-format library. Lane frame (paper convention): x from the foul line
toward the pins, y from the right gutter toward the left, z up; the ball's geometric center sits
at z = 0 and the lane surface at z = -R, so viewers draw the lane at z = -R.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.errors import SamplesRequiredError

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Trajectory
    from bowlrec.spec import Scene

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


@dataclass(frozen=True, repr=False)
class RunData:
    """One finished run as the sinks see it.

    scene: the scene as given (validated); plan: its resolved SI parameters; trajectory: the
    result; run_id: the archive's content ID when known (None for an unarchived run);
    provenance: what produced an archived run (package versions, solver settings, wall time,
    created-at, segment), as a run file stores it (None for an unarchived run).
    """

    scene: Scene
    plan: Plan
    trajectory: Trajectory
    run_id: str | None = None
    provenance: Mapping[str, str | int | float | bool] | None = None

    @property
    def name(self) -> str:
        return self.scene.name

    def __repr__(self) -> str:
        """One line: the scene's name, the run ID and the trajectory's short repr."""
        return (
            f"RunData(name={self.name!r}, run_id={self.run_id!r}, trajectory={self.trajectory!r})"
        )

    def scene_json(self) -> str:
        """The scene as given, as compact JSON (loads back into an equal Scene)."""
        return self.scene.model_dump_json()

    def require_samples(self, what: str) -> None:
        """Raise :class:`SamplesRequiredError` when the trajectory has no samples."""
        if self.trajectory.n_samples == 0:
            raise SamplesRequiredError(
                f"{what} needs samples, but scene {self.name!r} was run with "
                "options.record = 'summary'; use record = 'rate' (e.g. record_dt_s = 0.005) "
                "or 'steps'"
            )


@dataclass(frozen=True)
class FrictionCell:
    """A lane rectangle of constant friction: x in [x0, x1], y in [y0, y1] (m), coefficient mu."""

    x0_m: float
    x1_m: float
    y0_m: float
    y1_m: float
    mu: float


def friction_cells(plan: Plan) -> list[FrictionCell]:
    """The plan's piecewise-constant friction map as rectangles clipped to the lane.

    Cells are listed x-major (foul line first, then from the right gutter leftward); empty cells
    (outside the lane) are dropped.
    """
    xs = np.concatenate([[0.0], plan.friction_x_edges_m, [plan.lane_length_m]])
    ys = np.concatenate([[0.0], plan.friction_y_edges_m, [plan.lane_width_m]])
    xs = np.clip(xs, 0.0, plan.lane_length_m)
    ys = np.clip(ys, 0.0, plan.lane_width_m)
    cells: list[FrictionCell] = []
    for i in range(xs.size - 1):
        for j in range(ys.size - 1):
            if xs[i + 1] > xs[i] and ys[j + 1] > ys[j]:
                mu = float(plan.friction_mu[i, j])
                cells.append(
                    FrictionCell(float(xs[i]), float(xs[i + 1]), float(ys[j]), float(ys[j + 1]), mu)
                )
    return cells


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


def series_columns(traj: Trajectory) -> dict[str, tuple[Array, str]]:
    """Per-sample scalar series for plots and state channels: name -> (values (n,), units).

    speed (m/s), rev rate (rpm), slip speed |slip| (m/s), mu under the ball, normal force (N),
    friction force magnitude (N), energy (J), phase (0 sliding / 1 rolling).
    """
    return {
        "speed_mps": (traj.speed_mps, "m/s"),
        "rev_rate_rpm": (rev_rate_rpm(traj.omega_radps), "rpm"),
        "slip_speed_mps": (np.linalg.norm(traj.slip_mps, axis=1), "m/s"),
        "mu": (np.asarray(traj.mu, dtype=np.float64), "1"),
        "normal_force_N": (np.asarray(traj.normal_force_N, dtype=np.float64).reshape(-1), "N"),
        "friction_force_N": (np.linalg.norm(traj.friction_force_N, axis=1), "N"),
        "energy_J": (np.asarray(traj.energy_J, dtype=np.float64), "J"),
        "phase": (np.asarray(traj.phase, dtype=np.float64), "0 sliding / 1 rolling"),
    }


def rev_rate_rpm(omega_radps: Array) -> Array:
    """The rev rate |omega| in rpm (rev/min) of each (n, 3) angular velocity in rad/s."""
    return np.asarray(np.linalg.norm(omega_radps, axis=1) * 60.0 / (2.0 * math.pi))


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

"""One finished run: the scene as given, its resolved plan and its trajectory, and what the
writers and the figures read off the plan and the trajectory (the lane's friction cells, the
per-sample series).

Nothing here imports a file-format or plotting library, nor anything of bowlrec above the scene
layer at run time: the archive, the writers (:mod:`bowlrec.sinks`), the figures
(:mod:`bowlrec.figures`), the batch engine and the sessions all take a :class:`RunData`. Lane
frame (paper convention): x from the foul line toward the pins, y from the right gutter toward
the left.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from bowlrec.errors import SamplesRequiredError

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Trajectory

    from .scene import Scene

Array = NDArray[np.float64]

__all__ = ["FrictionCell", "RunData", "friction_cells", "rev_rate_rpm", "series_columns"]


@dataclass(frozen=True, repr=False)
class RunData:
    """One finished run, as the writers and the figures take it.

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

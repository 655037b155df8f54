"""The hand-off: where the lane's kernel gives the ball to the pins, and its state there.

The pins take over where the ball could first touch a pin: its centre one ball radius plus the
pin's belly radius (2.383 in) before the head pin's spot, less :data:`MARGIN_M` (half an inch),
so about half a foot before 60 ft (7.1 in for a 4.25 in ball). No ball reaches a pin before that
station, whatever its board, because the head pin is the front pin and its belly its widest
part. The ball's state there comes from the kernel itself: the same Plan run to the hand-off's
station with every sample kept, whose last sample is the state at the station (located by the
kernel's end event on its dense output). Until the station the two runs take the same steps;
the entry board and angle stay those of the full run at 60 ft.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from bowlrec.units import IN_M

from .engine import BallEntry
from .profile import radius_m

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan

__all__ = ["MARGIN_M", "ball_entry", "handoff_x_m"]

#: the hand-off's distance before the first possible touch (m)
MARGIN_M = 0.5 * IN_M
#: the pin's largest radius (m), at its belly
_BELLY_M = 4.766 / 2.0 * IN_M


def handoff_x_m(plan: Plan) -> float:
    """x of the hand-off (m): the head pin's spot less the ball's and the belly's radii and the
    margin."""
    assert abs(float(radius_m(4.5 * IN_M)) - _BELLY_M) < 1e-9
    return plan.lane_length_m - plan.radius_m - _BELLY_M - MARGIN_M


def _friction_at(plan: Plan, x_m: float, y_m: float) -> float:
    ix = int(np.searchsorted(plan.friction_x_edges_m, x_m, side="right"))
    iy = int(np.searchsorted(plan.friction_y_edges_m, y_m, side="right"))
    return float(plan.friction_mu[ix, iy])


def ball_entry(plan: Plan) -> BallEntry | None:
    """The ball's state at the hand-off, or None when it does not get there (a gutter ball, a
    ball that stops or a run cut short): the kernel runs ``plan`` to :func:`handoff_x_m` with
    every step recorded."""
    from bowlrec.core.codes import RECORD_STEPS
    from bowlrec.core.solver import solve

    to_station = dataclasses.replace(
        plan,
        lane_length_m=handoff_x_m(plan),
        record_mode=RECORD_STEPS,
        record_terms=False,
        pins=None,
    )
    traj = solve(to_station, "integrator")
    if traj.summary.outcome != "pins" or traj.n_samples == 0:
        return None
    x, y = (float(v) for v in traj.position_m[-1, :2])
    vx, vy = (float(v) for v in traj.velocity_mps[-1, :2])
    w = traj.omega_radps[-1]
    q = traj.quaternion_wxyz[-1]
    k2 = plan.inertia_per_mass_m2
    rd = plan.r_delta_body_m
    return BallEntry(
        t_s=float(traj.t_s[-1]),
        position_m=(x, y),
        velocity_mps=(vx, vy),
        omega_radps=(float(w[0]), float(w[1]), float(w[2])),
        quaternion_wxyz=(float(q[0]), float(q[1]), float(q[2]), float(q[3])),
        mass_kg=float(plan.mass_kg),
        radius_m=float(plan.radius_m),
        inertia_per_mass_m2=(float(k2[0]), float(k2[1]), float(k2[2])),
        r_delta_body_m=(float(rd[0]), float(rd[1]), float(rd[2])),
        deck_friction=_friction_at(plan, x, y),
    )

"""A ball arriving at the pins as bowlers and carry studies describe it: entry board and angle
at the head pin's line (60 ft), speed there and the tilt of its axis, rolling.

Carry maps and pin studies (USBC's with its robot, coaches' heat maps) set the ball's entry
directly rather than through a lane; :func:`entry_state` gives the engine's
:class:`~bowlrec.pins.engine.BallEntry` for such an entry. The ball rolls without slipping (a
ball at the pins has long since rolled out on a dry back end), along a straight line over the
last half foot to the hand-off (:func:`bowlrec.pins.handoff.handoff_x_m`). Rolling fixes the
horizontal part of its spin (speed / radius, about the horizontal axis across its path: 630 rpm
at 16 mph), so a rolling ball's only free spin is about the vertical, given here by the tilt of
its axis from horizontal (tilted up on the bowler's side, as a hook ball's axis is); its rev rate
at the pins is the rolling spin over cos(tilt). Its mass is spread evenly (no mass offset, equal
principal moments from the radius of gyration).

Conventions: boards from the bowler's own gutter, fractional (board 17.5 is a right-hander's
pocket); the angle is positive toward the head pin side, i.e. toward the left for a
right-hander, to the right for a left-hander.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from bowlrec.units import BOARDS, FT_M, IN_M, LB_KG, MPH_MPS

from .engine import BallEntry

__all__ = ["PinEntry", "entry_state", "rev_rate_rpm"]

#: the ball's diameter (m): 8.5 in, USBC's maximum (27 in around)
_BALL_RADIUS_M = 27.0 / (2.0 * math.pi) * IN_M
_BELLY_M = 4.766 / 2.0 * IN_M
_MARGIN_M = 0.5 * IN_M


@dataclass(frozen=True)
class PinEntry:
    """A ball at the pins: board and angle (deg) at the head pin's line, speed (mph) there, the
    tilt of its axis (deg), weight (lb), radius of gyration (in), the deck's friction under the
    ball, the hand and the lane's size (ft, in)."""

    board: float = 17.5
    angle_deg: float = 6.0
    speed_mph: float = 16.0
    axis_tilt_deg: float = 10.0
    weight_lb: float = 15.0
    rg_in: float = 2.5
    deck_friction: float = 0.25
    hand: Literal["right", "left"] = "right"
    lane_length_ft: float = 60.0
    lane_width_in: float = 41.5


def entry_state(entry: PinEntry) -> BallEntry:
    """The ball's state at the hand-off for ``entry`` (lane frame, SI)."""
    lane_w = entry.lane_width_in * IN_M
    board_w = lane_w / BOARDS
    side = 1.0 if entry.hand == "right" else -1.0
    d = (entry.board - 0.5) * board_w
    y60 = d if entry.hand == "right" else lane_w - d
    a = math.radians(entry.angle_deg) * side  # toward +y (left) for a right-hander
    v = entry.speed_mph * MPH_MPS
    vx, vy = v * math.cos(a), v * math.sin(a)
    r = _BALL_RADIUS_M
    x60 = entry.lane_length_ft * FT_M
    x = x60 - r - _BELLY_M - _MARGIN_M
    y = y60 - (x60 - x) * math.tan(a)
    # rolling: the contact point's velocity v + w x (-r z) vanishes, so w_x = -vy / r and
    # w_y = vx / r; the tilt sets the spin about the vertical (positive for a right-hander)
    w_roll = v / r
    omega = (-vy / r, vx / r, side * w_roll * math.tan(math.radians(entry.axis_tilt_deg)))
    mass = entry.weight_lb * LB_KG
    k2 = (entry.rg_in * IN_M) ** 2
    return BallEntry(
        t_s=0.0,
        position_m=(x, y),
        velocity_mps=(vx, vy),
        omega_radps=omega,
        quaternion_wxyz=(1.0, 0.0, 0.0, 0.0),
        mass_kg=mass,
        radius_m=r,
        inertia_per_mass_m2=(k2, k2, k2),
        r_delta_body_m=(0.0, 0.0, 0.0),
        deck_friction=entry.deck_friction,
    )


def rev_rate_rpm(entry: PinEntry) -> float:
    """The ball's rev rate at the pins (rpm): the rolling spin over cos(tilt)."""
    w = entry.speed_mph * MPH_MPS / _BALL_RADIUS_M
    return w / math.cos(math.radians(entry.axis_tilt_deg)) * 60.0 / (2.0 * math.pi)

"""The MuJoCo model of the deck, the pins and the ball (MJCF text; no MuJoCo import here).

Frame: the deck's (:mod:`bowlrec.pins.deck`), lane-frame x and y, z up from the lane's surface.
Bodies: ``ball`` (a sphere whose frame origin is its geometric centre, with the kernel's mass,
principal moments and centre-of-mass offset) and ``pin1`` ... ``pin10`` (origin at the base
centre, z along the axis; mass, centre of gravity and moments from :mod:`.profile`, collision
shape the profile's convex pieces). All free.

**Which parameters a contact uses.** MuJoCo takes a contact's parameters from the geom of higher
``priority``, and collides two geoms when ``contype`` of one shares a bit with ``conaffinity`` of
the other. The surfaces the ball touches and those the pins touch are therefore separate geoms
in the same place, each seen by one kind of body, each carrying its pair's parameters:

=====================  =======  ===========  ========  ======================================
geom                   contype  conaffinity  priority  parameters
=====================  =======  ===========  ========  ======================================
ball                   1        2            2         ball-pin
pin pieces             2        3            1         pin-pin
deck/gutters (ball)    4        1            3         ball-deck: the lane model's friction
deck/gutters/pit (pin) 8        2            3         pin-deck
kickbacks (ball)       4        1            3         ball-kickback (= pin-kickback's)
kickbacks, cushion     8        2            3         pin-kickback
=====================  =======  ===========  ========  ======================================

Each pair's restitution is a damping ratio of MuJoCo's soft contact (``solref`` = (time
constant, damping ratio), with a constant impedance ``solimp``); :mod:`.contact` finds the
damping ratio that gives the asked restitution, measured in the engine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .deck import (
    CUSHION_M,
    GUTTER_DEPTH_M,
    GUTTER_WIDTH_M,
    KICKBACK_HEIGHT_M,
    KICKBACK_START_M,
    PIT_DEPTH_M,
    Deck,
    PinSet,
)
from .profile import convex_pieces, mass_properties

__all__ = ["BallBody", "SurfaceParams", "model_xml"]

#: constant impedance of every contact (MuJoCo solimp: d0 = d_width = 0.99, width 1 mm)
SOLIMP = "0.99 0.99 0.001 0.5 2"
#: torsional and rolling friction of pins on the deck (m): bowlrec's own, so that a pin lying
#: on the deck comes to rest instead of rolling on for ever
PIN_DECK_SPIN_M = 0.005
PIN_DECK_ROLL_M = 0.0005


@dataclass(frozen=True)
class BallBody:
    """The ball as MuJoCo takes it: mass (kg), radius (m), principal moments (kg m^2, body
    axes), the centre of mass in the body frame relative to the geometric centre (m)."""

    mass_kg: float
    radius_m: float
    inertia_kgm2: tuple[float, float, float]
    com_body_m: tuple[float, float, float]


@dataclass(frozen=True)
class SurfaceParams:
    """One contact kind's MuJoCo parameters: friction coefficient and solref (time constant s,
    damping ratio)."""

    friction: float
    timeconst_s: float
    dampratio: float

    def attrs(self, *, spin_m: float = 0.0, roll_m: float = 0.0, condim: int = 3) -> str:
        return (
            f'friction="{self.friction!r} {spin_m!r} {roll_m!r}" condim="{condim}" '
            f'solref="{self.timeconst_s!r} {self.dampratio!r}" solimp="{SOLIMP}"'
        )


def _f(values: NDArray[np.float64] | tuple[float, ...]) -> str:
    return " ".join(repr(float(v)) for v in values)


def _box(name: str, center: tuple[float, float, float], half: tuple[float, float, float]) -> str:
    return f'name="{name}" type="box" pos="{_f(center)}" size="{_f(half)}"'


def model_xml(
    deck: Deck,
    pinset: PinSet,
    ball: BallBody,
    *,
    ball_pin: SurfaceParams,
    pin_pin: SurfaceParams,
    pin_deck: SurfaceParams,
    pin_kickback: SurfaceParams,
    ball_deck: SurfaceParams,
    timestep_s: float,
    gravity_mps2: float,
    deck_from_x_m: float,
) -> str:
    """The MJCF of one shot's pin deck: ``deck`` with the pins ``pinset`` (the others are not
    in the model), the ball (placed later, by the engine), the contact parameters per pair, and
    the lane's surface from ``deck_from_x_m`` on (where the ball is handed off)."""
    pieces = convex_pieces()
    assets = "\n".join(
        f'    <mesh name="pin_piece{k}" vertex="{_f(v.ravel())}"/>' for k, v in enumerate(pieces)
    )
    width = deck.lane_width_m
    x0, x1 = deck_from_x_m - 0.1, deck.end_x_m
    xc, hx = (x0 + x1) / 2.0, (x1 - x0) / 2.0
    thick = 0.05
    g_lo, g_hi = -GUTTER_WIDTH_M, width + GUTTER_WIDTH_M
    kick_x0 = deck.lane_length_m - KICKBACK_START_M
    pit_x1 = x1 + CUSHION_M
    surfaces = {
        "deck": ((xc, width / 2.0, -thick), (hx, width / 2.0, thick)),
        "gutter_r": ((xc, g_lo / 2.0, -GUTTER_DEPTH_M - thick), (hx, -g_lo / 2.0, thick)),
        "gutter_l": (
            (xc, (width + g_hi) / 2.0, -GUTTER_DEPTH_M - thick),
            (hx, (g_hi - width) / 2.0, thick),
        ),
        "pit": (
            ((x1 + pit_x1) / 2.0, width / 2.0, -PIT_DEPTH_M - thick),
            ((pit_x1 - x1) / 2.0, (g_hi - g_lo) / 2.0 + 0.2, thick),
        ),
    }
    walls = {
        "kick_r": (
            ((kick_x0 + pit_x1) / 2.0, g_lo - thick, KICKBACK_HEIGHT_M / 2.0 - PIT_DEPTH_M),
            ((pit_x1 - kick_x0) / 2.0, thick, KICKBACK_HEIGHT_M / 2.0 + PIT_DEPTH_M),
        ),
        "kick_l": (
            ((kick_x0 + pit_x1) / 2.0, g_hi + thick, KICKBACK_HEIGHT_M / 2.0 - PIT_DEPTH_M),
            ((pit_x1 - kick_x0) / 2.0, thick, KICKBACK_HEIGHT_M / 2.0 + PIT_DEPTH_M),
        ),
        "cushion": (
            (pit_x1 + thick, width / 2.0, KICKBACK_HEIGHT_M / 2.0 - PIT_DEPTH_M),
            (thick, (g_hi - g_lo) / 2.0 + 0.2, KICKBACK_HEIGHT_M / 2.0 + PIT_DEPTH_M),
        ),
    }
    world = []
    deck_pin = pin_deck.attrs(spin_m=PIN_DECK_SPIN_M, roll_m=PIN_DECK_ROLL_M, condim=6)
    for name, (c, h) in surfaces.items():
        if name != "pit":
            world.append(
                f'    <geom {_box(name + "_ball", c, h)} contype="4" conaffinity="1" '
                f'priority="3" {ball_deck.attrs()}/>'
            )
        world.append(
            f'    <geom {_box(name + "_pin", c, h)} contype="8" conaffinity="2" '
            f'priority="3" {deck_pin}/>'
        )
    for name, (c, h) in walls.items():
        world.append(
            f'    <geom {_box(name + "_ball", c, h)} contype="4" conaffinity="1" '
            f'priority="3" {pin_kickback.attrs()}/>'
        )
        world.append(
            f'    <geom {_box(name + "_pin", c, h)} contype="8" conaffinity="2" '
            f'priority="3" {pin_kickback.attrs()}/>'
        )
    bodies = []
    for pin in pinset.pins:
        props = mass_properties(pinset.mass_kg[pin], pinset.cg_height_m[pin])
        x, y = pinset.base_xy_m[pin]
        moments = (props.transverse_kgm2, props.transverse_kgm2, props.axial_kgm2)
        geoms = "\n".join(
            f'      <geom name="pin{pin}_piece{k}" type="mesh" mesh="pin_piece{k}" '
            f'contype="2" conaffinity="3" priority="1" {pin_pin.attrs()}/>'
            for k in range(len(pieces))
        )
        bodies.append(
            f'    <body name="pin{pin}" pos="{_f((x, y, 0.0))}">\n'
            f'      <freejoint name="pin{pin}_free"/>\n'
            f'      <inertial pos="0 0 {props.cg_height_m!r}" mass="{props.mass_kg!r}" '
            f'diaginertia="{_f(moments)}"/>\n'
            f"{geoms}\n"
            f"    </body>"
        )
    i1, i2, i3 = ball.inertia_kgm2
    bodies.append(
        f'    <body name="ball" pos="{_f((x0, width / 2.0, ball.radius_m))}">\n'
        f'      <freejoint name="ball_free"/>\n'
        f'      <inertial pos="{_f(ball.com_body_m)}" mass="{ball.mass_kg!r}" '
        f'diaginertia="{_f((i1, i2, i3))}"/>\n'
        f'      <geom name="ball" type="sphere" size="{ball.radius_m!r}" contype="1" '
        f'conaffinity="2" priority="2" {ball_pin.attrs()}/>\n'
        f"    </body>"
    )
    return "\n".join(
        [
            '<mujoco model="bowlrec-pin-deck">',
            '  <compiler angle="radian"/>',
            f'  <option timestep="{timestep_s!r}" gravity="0 0 {-gravity_mps2!r}" '
            'integrator="implicitfast" cone="elliptic" impratio="10">',
            '    <flag sleep="enable"/>',
            "  </option>",
            f'  <size memory="{16 + 2 * len(pinset.pins)}M"/>',
            "  <asset>",
            assets,
            "  </asset>",
            "  <worldbody>",
            *world,
            *bodies,
            "  </worldbody>",
            "</mujoco>",
        ]
    )

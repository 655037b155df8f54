"""The pin engine's closed-form checks for the validation page (:mod:`benchmarks.pins`): the
restitution achieved per pair in MuJoCo (ball-pin and pin-pin head on, gravity and friction
off, measured at separation; pin-deck, a drop), momentum conservation, the pin's speed against
(1 + e) M / (M + m), and the tipping angle.

Velocities are read from the engine's state after separation (SI units); restitution is the
normal speed of separation over the speed of approach.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: the test ball: 7 kg (15.4 lb), radius 0.1085 m (8.54 in across), solid-sphere moments
M_BALL = 7.0
R_BALL = 0.1085
V0_MPS = 5.0


def _deck() -> Any:
    from bowlrec.pins.deck import Deck
    from bowlrec.units import IN_M

    return Deck(60 * 0.3048, 41.5 * IN_M)


def _model(pins: Any, plan: Any, *, gravity: float, ball_y: float | None = None) -> Any:
    import mujoco

    from bowlrec.pins.engine import _surface
    from bowlrec.pins.model import BallBody, model_xml

    deck = _deck()
    xml = model_xml(
        deck,
        pins,
        BallBody(M_BALL, R_BALL, (0.4 * M_BALL * R_BALL**2,) * 3, (0.0, 0.0, 0.0)),
        ball_pin=_surface(plan.ball_pin_restitution, 0.0, plan),
        pin_pin=_surface(plan.pin_pin_restitution, 0.0, plan),
        pin_deck=_surface(plan.pin_deck_restitution, 0.0, plan),
        pin_kickback=_surface(plan.pin_kickback_restitution, 0.0, plan),
        ball_deck=_surface(plan.pin_deck_restitution, 0.0, plan),
        timestep_s=plan.timestep_s,
        gravity_mps2=gravity,
        deck_from_x_m=deck.lane_length_m - 0.5,
    )
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    return mujoco, model, data, deck


def _body(mujoco: Any, model: Any, name: str) -> tuple[int, int, int]:
    b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
    j = model.body_jntadr[b]
    return b, model.jnt_qposadr[j], model.jnt_dofadr[j]


def _touching(model: Any, data: Any, a: int, b: int | None = None) -> Any:
    """The first contact between bodies ``a`` and ``b`` (``b`` None: any other body), or
    None."""
    for c in range(data.ncon):
        con = data.contact[c]
        pair = {int(model.geom_bodyid[con.geom1]), int(model.geom_bodyid[con.geom2])}
        if a in pair and (b is None or b in pair):
            return con
    return None


def _point_velocity(v6: np.ndarray, cg: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The velocity of a body's material point ``point`` from its CG's (angular, linear)."""
    return v6[3:] + np.cross(v6[:3], point - cg)


def _cg_velocity(mujoco: Any, model: Any, data: Any, body: int) -> np.ndarray:
    vel = np.zeros(6)
    mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, body, vel, 0)
    return vel  # (angular, linear) at the CG, world frame


def ball_pin(plan: Any, *, through_cg: bool) -> dict[str, float]:
    """A ball at 5 m/s meeting the head pin head on. ``through_cg``: the pin's CG is set at
    the ball's centre height (the closed form of two free bodies); else the real pin, hit
    1.5 in below its CG at the belly."""
    import dataclasses

    from bowlrec.pins.deck import set_pins
    from bowlrec.pins.profile import mass_properties

    deck = _deck()
    ps = set_pins(deck, (1,))
    if through_cg:
        ps = dataclasses.replace(ps, cg_height_m={1: R_BALL})
    mujoco, model, data, _ = _model(ps, plan, gravity=0.0)
    ball, bq, bd = _body(mujoco, model, "ball")
    pin, _, _ = _body(mujoco, model, "pin1")
    x_pin = ps.base_xy_m[1][0]
    data.qpos[bq : bq + 3] = (x_pin - 0.19, ps.base_xy_m[1][1], R_BALL)
    data.qvel[bd : bd + 3] = (V0_MPS, 0.0, 0.0)
    mujoco.mj_forward(model, data)
    m = ps.mass_kg[1]
    p0 = M_BALL * V0_MPS
    touched = False
    point = np.zeros(3)
    for _ in range(int(0.08 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        con = _touching(model, data, ball, pin)
        if con is not None:
            touched, point = True, np.array(con.pos)
        if touched and con is None:
            break
    vb = _cg_velocity(mujoco, model, data, ball)[3]
    vpin = _cg_velocity(mujoco, model, data, pin)
    vp = vpin[3]
    # the pin's material point at the contact, as it separates
    vc = _point_velocity(vpin, np.array(data.xipos[pin]), point)[0]
    e = (vc - vb) / V0_MPS
    props = mass_properties(m, ps.cg_height_m[1])
    out = {
        "pin_mass_kg": m,
        "ball_mass_kg": M_BALL,
        "e_achieved": e,
        "momentum_residual": (M_BALL * vb + m * vp - p0) / p0,
        "pin_over_ball_speed": vp / V0_MPS,
        "closed_form_free": (1 + e) * M_BALL / (M_BALL + m),
        "contact_height_m": float(point[2]),
        "pin_spin_radps": float(np.linalg.norm(vpin[:3])),
    }
    if not through_cg:
        # hit a distance d below the CG: a free pin's effective mass 1 / (1/m + d^2 / I)
        d = props.cg_height_m - R_BALL
        m_eff = 1.0 / (1.0 / m + d * d / props.transverse_kgm2)
        j = (1 + e) * M_BALL * m_eff / (M_BALL + m_eff) * V0_MPS
        out["lever_below_cg_m"] = d
        out["closed_form_free_with_rotation"] = j / m / V0_MPS
        out["impulse_check"] = (M_BALL * (V0_MPS - vb)) / m / vp
    return out


def pin_pin(plan: Any, *, through_cg: bool) -> dict[str, float]:
    """The head pin sliding at 3 m/s (gravity and friction off) into the 5 pin behind it, belly
    to belly. ``through_cg``: both pins' CGs set at the belly's height (the closed form of two
    free bodies); else the real pins, met 1.3 in below their CGs (restitution then measured at
    the contact point)."""
    import dataclasses

    from bowlrec.pins.deck import set_pins

    deck = _deck()
    ps = set_pins(deck, (1, 5))
    if through_cg:
        h = 4.5 * 0.0254
        ps = dataclasses.replace(ps, cg_height_m={1: h, 5: h})
    mujoco, model, data, _ = _model(ps, plan, gravity=0.0)
    ball, bq, _ = _body(mujoco, model, "ball")
    data.qpos[bq + 1] = 0.2  # the ball out of the way
    p1, _, d1 = _body(mujoco, model, "pin1")
    p5, _, _ = _body(mujoco, model, "pin5")
    v0 = 3.0
    data.qvel[d1] = v0
    mujoco.mj_forward(model, data)
    touched = False
    point = np.zeros(3)
    for _ in range(int(0.5 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        con = _touching(model, data, p1, p5)
        if con is not None:
            touched, point = True, np.array(con.pos)
        if touched and con is None:
            break
    w1 = _cg_velocity(mujoco, model, data, p1)
    w5 = _cg_velocity(mujoco, model, data, p5)
    c1 = _point_velocity(w1, np.array(data.xipos[p1]), point)[0]
    c5 = _point_velocity(w5, np.array(data.xipos[p5]), point)[0]
    m1, m5 = ps.mass_kg[1], ps.mass_kg[5]
    return {
        "e_achieved": (c5 - c1) / v0,
        "cg_speed_ratio": (w5[3] - w1[3]) / v0,
        "contact_height_m": float(point[2]),
        "momentum_residual": (m1 * w1[3] + m5 * w5[3] - m1 * v0) / (m1 * v0),
    }


def pin_deck(plan: Any) -> dict[str, float]:
    """A pin lying on its side dropped 5 cm onto the deck: the rebound's vertical speed over
    the impact's."""
    from bowlrec.pins.deck import set_pins

    deck = _deck()
    ps = set_pins(deck, (1,))
    mujoco, model, data, _ = _model(ps, plan, gravity=9.81)
    ball, bq, _ = _body(mujoco, model, "ball")
    data.qpos[bq + 1] = 0.2
    pin, pq, pd = _body(mujoco, model, "pin1")
    from bowlrec.pins.profile import radius_m

    belly = float(radius_m(4.5 * 0.0254))
    # lying along +y: rotate the pin's axis (z) onto y, about x by -90 deg
    h = math.sqrt(0.5)
    data.qpos[pq + 3 : pq + 7] = (h, -h, 0.0, 0.0)
    data.qpos[pq + 2] = belly + 0.05
    mujoco.mj_forward(model, data)
    v_in = v_out = 0.0
    in_contact = False
    for _ in range(int(0.4 / model.opt.timestep)):
        vz = _cg_velocity(mujoco, model, data, pin)[5]
        mujoco.mj_step(model, data)
        touching = _touching(model, data, pin) is not None
        if touching and not in_contact:
            in_contact, v_in = True, -vz
        if in_contact:
            v_out = max(v_out, _cg_velocity(mujoco, model, data, pin)[5])
            if not touching:
                break
    return {"impact_speed_mps": v_in, "e_achieved": v_out / v_in if v_in else math.nan}


def tipping(plan: Any) -> dict[str, Any]:
    """A lone pin released at rest leaning over its base's edge 1 deg past and 1 deg short of
    atan(base radius / CG height): does it fall?"""
    from bowlrec.pins.deck import set_pins
    from bowlrec.pins.profile import radius_m, tipping_angle_rad

    tip = tipping_angle_rad()

    def falls(tilt: float) -> bool:
        ps = set_pins(_deck(), (1,))
        mujoco, model, data, _ = _model(ps, plan, gravity=9.81)
        _, bq, _ = _body(mujoco, model, "ball")
        data.qpos[bq + 1] = 0.2
        body, pq, _ = _body(mujoco, model, "pin1")
        rb = float(radius_m(0.0)) * 1.0065  # the 16-gon's corner on the tilt's side
        x0, y0 = ps.base_xy_m[1]
        data.qpos[pq : pq + 3] = (x0 + rb - rb * math.cos(tilt), y0, rb * math.sin(tilt))
        data.qpos[pq + 3 : pq + 7] = (math.cos(tilt / 2), 0.0, math.sin(tilt / 2), 0.0)
        mujoco.mj_step(model, data, nstep=int(1.5 / model.opt.timestep))
        return bool(data.xmat[body][8] < math.cos(math.radians(45)))

    return {
        "tipping_angle_deg": math.degrees(tip),
        "falls_1deg_past": falls(tip + math.radians(1.0)),
        "falls_1deg_short": falls(tip - math.radians(1.0)),
    }

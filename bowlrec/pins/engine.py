"""Pin action: the ball from the hand-off through the pins until everything is at rest (MuJoCo).

:func:`simulate_pins` builds the deck's model (:mod:`.model`) with the pins set for the shot
(:mod:`.deck`), puts the ball in it with its exact state at the hand-off (:class:`BallEntry`,
from :mod:`.handoff`), steps MuJoCo and returns a :class:`PinAction`: the pins standing at rest,
the pins the ball touched (in order), the ball's path through the deck and where it left it,
and every body's recorded motion.

**When it is decided.** Every ``record_dt_s`` the engine samples every body. Pin action is
over when the ball has left the deck (or stopped on it) and, on :data:`REST_SAMPLES` samples
in a row, no pin on its base leans between
:data:`STANDING_TILT_DEG` and :data:`DOWN_TILT_DEG` (one that may yet right itself or fall),
and either no pin is upright or every upright pin moves slower than
:data:`REST_SPEED_MPS` and turns slower than :data:`REST_SPIN_RADPS`, and everything else still
in play (the ball, pins down, pins falling) holds less mechanical energy than it takes to tip
one pin over (:func:`tipping_energy_j`, about 35 mJ; kinetic energy plus the potential energy
above lying on the deck): from then on nothing can knock a pin down. Otherwise it stops at
``max_time_s``. A pin or the ball that falls into the pit (behind the deck, below its surface)
is out of play: the pit's cushion and curtain stop it, and the engine takes it out of the
model.

**Standing.** A pin stands at the end when its base is on the deck (not in a gutter or the pit)
and its axis leans less than :data:`STANDING_TILT_DEG` from vertical; it may have moved off its
spot (a "moved" pin counts as standing, as in the game).

**Touches.** While the ball is on the deck the engine reads MuJoCo's contacts after every step
and records each pin the ball touches first, in order; after it has left the deck, steps run in
blocks between samples.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .contact import dampratio_for
from .deck import Deck, PinSet
from .model import BallBody, SurfaceParams, model_xml
from .profile import base_radius_m

if TYPE_CHECKING:
    from bowlrec.core.plan import PinPlan

__all__ = [
    "DOWN_TILT_DEG",
    "REST_SAMPLES",
    "REST_SPEED_MPS",
    "REST_SPIN_RADPS",
    "STANDING_TILT_DEG",
    "tipping_energy_j",
    "BallEntry",
    "PinAction",
    "engine_version",
    "require_mujoco",
    "simulate_pins",
]

REST_SPEED_MPS = 0.01
REST_SPIN_RADPS = 0.2
REST_SAMPLES = 4
STANDING_TILT_DEG = 15.0
#: a pin leaning more than this from vertical is down for good (it cannot right itself)
DOWN_TILT_DEG = 45.0
#: a body whose origin is this far below the deck's surface has left the deck (m)
_BELOW_DECK_M = 0.02
#: where a body that fell into the pit is parked (m below the deck)
_PARKED_Z_M = -1000.0


@dataclass(frozen=True)
class BallEntry:
    """The ball where the pins take over, as the lane's kernel left it (lane frame, SI).

    position_m: the geometric centre (x, y); velocity_mps: its velocity (vx, vy);
    omega_radps: the angular velocity (lane frame); quaternion_wxyz: body -> lane rotation;
    mass_kg, radius_m, inertia_per_mass_m2 (principal k_i^2, body axes) and r_delta_body_m (from
    the centre of mass to the geometric centre, body frame) as the kernel's Plan has them;
    deck_friction: the lane's friction coefficient under the ball there; t_s: the time since
    release.
    """

    t_s: float
    position_m: tuple[float, float]
    velocity_mps: tuple[float, float]
    omega_radps: tuple[float, float, float]
    quaternion_wxyz: tuple[float, float, float, float]
    mass_kg: float
    radius_m: float
    inertia_per_mass_m2: tuple[float, float, float]
    r_delta_body_m: tuple[float, float, float]
    deck_friction: float

    def mirrored(self, lane_width_m: float) -> BallEntry:
        """The same ball mirrored across the lane's centre line (y -> W - y): a left-hander's
        shot of this right-hander's. The body frame is mirrored with the lane, so its principal
        axes keep their moments and the offset its body components with the second axis
        reversed; the quaternion is conjugated by the reflection."""
        w, x, y, z = self.quaternion_wxyz
        ox, oy, oz = self.omega_radps
        rx, ry, rz = self.r_delta_body_m
        # reflection S = diag(1, -1, 1) in both frames: R' = S R S, a rotation again
        return BallEntry(
            t_s=self.t_s,
            position_m=(self.position_m[0], lane_width_m - self.position_m[1]),
            velocity_mps=(self.velocity_mps[0], -self.velocity_mps[1]),
            omega_radps=(-ox, oy, -oz),
            quaternion_wxyz=(w, -x, y, -z),
            mass_kg=self.mass_kg,
            radius_m=self.radius_m,
            inertia_per_mass_m2=self.inertia_per_mass_m2,
            r_delta_body_m=(rx, -ry, rz),
            deck_friction=self.deck_friction,
        )


@dataclass(frozen=True)
class PinAction:
    """What the pins did (lane frame with the lane's surface at z = 0, SI).

        set_pins: the pins set before the ball; standing: those standing at the end; touched: the
        pins the ball touched, in the order of first touch; t_s (n,) the sample times since the
        hand-off; pin_position_m (n, k, 3) and pin_quaternion_wxyz (n, k, 4): each set pin's base
        centre and orientation (pin frame -> lane frame; the pin's axis is the frame's z) in the
        order of ``set_pins``; ball_position_m (n, 3) and ball_quaternion_wxyz (n, 4): the ball's
        geometric centre and orientation; energy_J (n,): the kinetic and gravitational potential
    energy of the bodies in play (J; the lane's surface is the zero of height; a body that leaves
    for the pit takes its energy with it); exit_y_m: where the ball's centre crossed the deck's end
        (None if it did not); time_s: simulated time; at_rest: whether everything came to rest
        before ``max_time_s``; n_steps: engine steps; wall_time_s; engine: MuJoCo's version.
    """

    set_pins: tuple[int, ...]
    standing: tuple[int, ...]
    touched: tuple[int, ...]
    t_s: NDArray[np.float64]
    pin_position_m: NDArray[np.float64]
    pin_quaternion_wxyz: NDArray[np.float64]
    ball_position_m: NDArray[np.float64]
    ball_quaternion_wxyz: NDArray[np.float64]
    energy_J: NDArray[np.float64]
    exit_y_m: float | None
    time_s: float
    at_rest: bool
    n_steps: int
    wall_time_s: float
    engine: str
    extras: dict[str, float] = field(default_factory=dict)

    def __eq__(self, other: object) -> bool:
        """Field by field, the recorded motion's arrays by their values (NaN equal to NaN)."""
        if not isinstance(other, PinAction):
            return NotImplemented
        for f in fields(self):
            a, b = getattr(self, f.name), getattr(other, f.name)
            if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
                if not np.array_equal(a, b, equal_nan=True):
                    return False
            elif a != b:
                return False
        return True

    @property
    def knocked(self) -> tuple[int, ...]:
        """The set pins that are down."""
        return tuple(p for p in self.set_pins if p not in self.standing)

    @property
    def pinfall(self) -> int:
        return len(self.set_pins) - len(self.standing)


def require_mujoco() -> Any:
    """The ``mujoco`` module; MissingExtraError naming the extra when it is not installed."""
    try:
        import mujoco
    except ImportError as err:
        from bowlrec.errors import MissingExtraError

        raise MissingExtraError(
            "pin action (options.pins) needs MuJoCo: pip install 'bowlrec[pins]'"
        ) from err
    return mujoco


def engine_version() -> str:
    """MuJoCo's version string (``mujoco 3.x.y``)."""
    import mujoco

    return f"mujoco {mujoco.__version__}"


def _surface(restitution: float, friction: float, pins: PinPlan) -> SurfaceParams:
    return SurfaceParams(
        friction=friction,
        timeconst_s=pins.contact_timeconst_s,
        dampratio=dampratio_for(restitution, pins.timestep_s, pins.contact_timeconst_s),
    )


def _quat_mul(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def _to_body(q_wxyz: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """A lane-frame vector in the body frame of the body -> lane rotation ``q``."""
    conj = np.array([q_wxyz[0], -q_wxyz[1], -q_wxyz[2], -q_wxyz[3]])
    return _quat_mul(_quat_mul(conj, np.array([0.0, *v])), q_wxyz)[1:]


def tipping_energy_j(mass_kg: float, cg_height_m: float, gravity_mps2: float = 9.81) -> float:
    """The energy that tips a standing pin over (J): its centre of gravity raised from its
    height to the distance from the base's edge, m g (sqrt(r_b^2 + h^2) - h)."""
    return mass_kg * gravity_mps2 * (math.hypot(base_radius_m(), cg_height_m) - cg_height_m)


def _mechanical_energy(
    model: object,
    data: object,
    body: int,
    vel: NDArray[np.float64],
    gravity_mps2: float,
    lying_m: float = 0.0605,
) -> float:
    """A body's kinetic energy plus its potential energy with its centre of mass above
    ``lying_m`` (J; by default the height of a pin lying on the deck, so that a pin lying
    there holds no potential energy, floored at 0); ``vel``: its (angular, linear) velocity at
    the centre of mass, lane frame."""
    import mujoco

    assert isinstance(model, mujoco.MjModel) and isinstance(data, mujoco.MjData)
    mass = float(model.body_mass[body])
    rot = data.ximat[body].reshape(3, 3)
    w_inertial = rot.T @ vel[:3]
    kinetic = 0.5 * mass * float(vel[3:] @ vel[3:]) + 0.5 * float(
        model.body_inertia[body] @ (w_inertial * w_inertial)
    )
    lift = float(data.xipos[body][2]) - lying_m
    return kinetic + mass * gravity_mps2 * (max(0.0, lift) if lying_m > 0.0 else lift)


def _retire_pit(model: object, data: object, bodies: NDArray[np.int_], end_x: float) -> None:
    """Take the bodies that have fallen into the pit (behind the deck's end and below its
    surface) out of the model: each goes to a parking place far below, at rest, where it
    touches nothing. The pit's cushion and curtain stop what falls there; nothing comes back."""
    import mujoco

    assert isinstance(model, mujoco.MjModel) and isinstance(data, mujoco.MjData)
    for k, b in enumerate(bodies):
        pos = data.xpos[b]
        if pos[0] > end_x and pos[2] < -_BELOW_DECK_M and pos[2] > _PARKED_Z_M / 2:
            qpos = model.jnt_qposadr[model.body_jntadr[b]]
            dof = model.jnt_dofadr[model.body_jntadr[b]]
            data.qpos[qpos : qpos + 3] = (end_x + 1.0 * k, 0.0, _PARKED_Z_M)
            data.qvel[dof : dof + 6] = 0.0


def simulate_pins(
    entry: BallEntry,
    pins: PinPlan,
    deck: Deck,
    pinset: PinSet,
    *,
    gravity_mps2: float = 9.81,
) -> PinAction:
    """Pin action of ``entry`` on the pins ``pinset`` of ``deck`` with the model ``pins``
    (MissingExtraError without the ``pins`` extra)."""
    mujoco = require_mujoco()

    start = time.perf_counter()
    k2 = np.asarray(entry.inertia_per_mass_m2, dtype=np.float64)
    ball = BallBody(
        mass_kg=entry.mass_kg,
        radius_m=entry.radius_m,
        inertia_kgm2=tuple(float(v) for v in entry.mass_kg * k2),  # type: ignore[arg-type]
        # r_delta points from the centre of mass to the geometric centre
        com_body_m=tuple(-float(v) for v in entry.r_delta_body_m),  # type: ignore[arg-type]
    )
    xml = model_xml(
        deck,
        pinset,
        ball,
        ball_pin=_surface(pins.ball_pin_restitution, pins.ball_pin_friction, pins),
        pin_pin=_surface(pins.pin_pin_restitution, pins.pin_pin_friction, pins),
        pin_deck=_surface(pins.pin_deck_restitution, pins.pin_deck_friction, pins),
        pin_kickback=_surface(pins.pin_kickback_restitution, pins.pin_kickback_friction, pins),
        ball_deck=_surface(pins.pin_deck_restitution, entry.deck_friction, pins),
        timestep_s=pins.timestep_s,
        gravity_mps2=gravity_mps2,
        deck_from_x_m=entry.position_m[0],
    )
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    ball_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "ball")
    pin_ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"pin{p}") for p in pinset.pins]
    ball_geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "ball")
    pin_of_body = {b: p for b, p in zip(pin_ids, pinset.pins, strict=True)}

    # the ball: free joint qpos = origin (geometric centre) and body -> world quaternion; qvel =
    # the origin's velocity (world) and the angular velocity in the body frame
    ball_qpos = model.jnt_qposadr[model.body_jntadr[ball_id]]
    ball_qvel = model.jnt_dofadr[model.body_jntadr[ball_id]]
    q = np.asarray(entry.quaternion_wxyz, dtype=np.float64)
    q = q / np.linalg.norm(q)
    data.qpos[ball_qpos : ball_qpos + 3] = (
        entry.position_m[0],
        entry.position_m[1],
        entry.radius_m,
    )
    data.qpos[ball_qpos + 3 : ball_qpos + 7] = q
    data.qvel[ball_qvel : ball_qvel + 3] = (entry.velocity_mps[0], entry.velocity_mps[1], 0.0)
    data.qvel[ball_qvel + 3 : ball_qvel + 6] = _to_body(q, np.asarray(entry.omega_radps))
    mujoco.mj_forward(model, data)

    every = max(1, int(round(pins.record_dt_s / pins.timestep_s)))
    max_steps = int(math.ceil(pins.max_time_s / pins.timestep_s))
    end_x = deck.end_x_m
    bodies = np.array([ball_id, *pin_ids])
    times: list[float] = []
    energies: list[float] = []
    positions: list[NDArray[np.float64]] = []
    quats: list[NDArray[np.float64]] = []
    touched: list[int] = []
    exit_y: float | None = None
    quiet = 0
    steps = 0
    prev_ball = data.xpos[ball_id].copy()

    def in_play_energy() -> float:
        vel = np.zeros(6)
        total = 0.0
        for b in bodies:
            if data.xpos[b][2] < _PARKED_Z_M / 2:
                continue
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, int(b), vel, 0)
            total += _mechanical_energy(model, data, int(b), vel, gravity_mps2, lying_m=0.0)
        return total

    def sample() -> None:
        times.append(float(data.time))
        energies.append(in_play_energy())
        positions.append(data.xpos[bodies].copy())
        quats.append(data.xquat[bodies].copy())

    cos_tilt = math.cos(math.radians(STANDING_TILT_DEG))
    cos_down = math.cos(math.radians(DOWN_TILT_DEG))
    tip_energy = min(
        tipping_energy_j(pinset.mass_kg[p], pinset.cg_height_m[p], gravity_mps2)
        for p in pinset.pins
    )

    def upright(b: int) -> bool:
        base = data.xpos[b]
        return bool(
            data.xmat[b][8] >= cos_tilt
            and abs(base[2]) < _BELOW_DECK_M
            and deck.on_deck(base[0], base[1])
        )

    def in_doubt(b: int) -> bool:
        """A pin on its base on the deck leaning between upright and down for good."""
        base = data.xpos[b]
        return bool(
            cos_down < data.xmat[b][8] < cos_tilt
            and abs(base[2]) < _BELOW_DECK_M
            and deck.on_deck(base[0], base[1])
        )

    def decided() -> bool:
        """Every upright pin at rest, and the rest in play too weak to tip one over."""
        vel = np.zeros(6)
        loose = 0.0
        if ball_on_deck or any(in_doubt(int(b)) for b in pin_ids):
            return False
        if not any(upright(int(b)) for b in pin_ids):
            return True  # nothing left to knock down
        for b in bodies:
            if data.xpos[b][2] < _PARKED_Z_M / 2:
                continue  # in the pit: out of play
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, int(b), vel, 0)
            if b != ball_id and upright(int(b)):
                if (
                    np.linalg.norm(vel[3:]) > REST_SPEED_MPS
                    or np.linalg.norm(vel[:3]) > REST_SPIN_RADPS
                ):
                    return False
                continue
            loose += _mechanical_energy(model, data, int(b), vel, gravity_mps2)
        return loose < tip_energy

    sample()
    ball_on_deck = True
    while steps < max_steps:
        if ball_on_deck:
            for _ in range(every):
                mujoco.mj_step(model, data)
                steps += 1
                for c in range(data.ncon):
                    con = data.contact[c]
                    if con.geom1 == ball_geom or con.geom2 == ball_geom:
                        other = con.geom2 if con.geom1 == ball_geom else con.geom1
                        pin = pin_of_body.get(int(model.geom_bodyid[other]))
                        if pin is not None and pin not in touched:
                            touched.append(pin)
                ball_now = data.xpos[ball_id]
                if exit_y is None and ball_now[0] >= end_x > prev_ball[0]:
                    f = (end_x - prev_ball[0]) / (ball_now[0] - prev_ball[0])
                    exit_y = float(prev_ball[1] + f * (ball_now[1] - prev_ball[1]))
                prev_ball = ball_now.copy()
                if ball_now[0] > end_x or ball_now[2] < entry.radius_m - _BELOW_DECK_M:
                    ball_on_deck = False
                elif np.linalg.norm(data.qvel[ball_qvel : ball_qvel + 3]) < REST_SPEED_MPS:
                    ball_on_deck = False  # stopped on the deck
        else:
            mujoco.mj_step(model, data, nstep=every)
            steps += every
        _retire_pit(model, data, bodies, end_x)
        sample()
        quiet = quiet + 1 if decided() else 0
        if quiet >= REST_SAMPLES:
            break

    standing = [pin for pin, b in zip(pinset.pins, pin_ids, strict=True) if upright(b)]
    pos = np.array(positions)
    quat = np.array(quats)
    return PinAction(
        set_pins=tuple(pinset.pins),
        standing=tuple(standing),
        touched=tuple(touched),
        t_s=np.array(times),
        pin_position_m=pos[:, 1:, :],
        pin_quaternion_wxyz=quat[:, 1:, :],
        ball_position_m=pos[:, 0, :],
        ball_quaternion_wxyz=quat[:, 0, :],
        energy_J=np.array(energies),
        exit_y_m=exit_y,
        time_s=float(data.time),
        at_rest=quiet >= REST_SAMPLES,
        n_steps=steps,
        wall_time_s=time.perf_counter() - start,
        engine=engine_version(),
    )

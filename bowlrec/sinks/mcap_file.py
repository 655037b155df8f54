"""MCAP export of finished runs, viewable in Foxglove (File > Open) and readable by any MCAP tool.

One file per run (:func:`write_mcap`), or several runs side by side (:func:`write_mcap_batch`).
Written with the foxglove SDK (protobuf well-known schemas, zstd chunks, every CRC computed) into
a temporary file in the target directory, then moved into place with :func:`os.replace`
(:func:`~bowlrec.atomic_files.atomic_path`), so the final name only ever holds a complete file.

Topics of a single-run file (a batch file prefixes each with ``/<run key>``):

- ``/tf`` foxglove.FrameTransform, one per sample: parent frame ``lane``, child frame ``ball``;
  translation = geometric center (m), rotation = body->lane quaternion. The translation and
  rotation are the trajectory's float64 values, bit for bit.
- ``/scene`` foxglove.SceneUpdate, one message at the first sample: the lane (a thin slab whose
  top is the lane surface z = -R), one slab per friction cell colored by mu (blue = oily,
  orange = dry), the head pin, the path on the lane surface (pink sliding, green rolling), the
  events, and the ball: a sphere of diameter 2R with three body-axis great circles and the
  pin / cg / mass_bias markings, drawn in the ``ball`` frame (``frame_locked``) so that ``/tf``
  moves and turns it.
- ``/ball/state`` JSON (schema ``bowlrec.BallState``, units in each field's description), one
  per sample: the full physics state, including per-term torques when they were recorded.
- ``/events`` JSON (schema ``bowlrec.Event``), one per event at its time.

With pin action (``options.pins``; poses from :mod:`bowlrec.sinks.pin_replay`), ``/tf`` holds the
kernel's samples before the hand-off, then the pin engine's (the ball through the deck), and:

- ``/pins/tf`` foxglove.FrameTransforms, one per engine sample at hand-off time + the engine's
  time: for each set pin ``n`` a transform from ``lane`` to the frame ``pin<n>`` (translation =
  the pin's base centre, m; rotation = pin -> lane, the pin's axis is the frame's z). A pin the
  engine retired into the pit keeps its last pose in play.
- ``/pins/scene`` foxglove.SceneUpdate: at the hand-off, the entity ``pins/deck`` (the deck's
  outline, the ten spots and the ball's path through the deck, frame ``lane``) and one entity
  ``pins/<n>`` per set pin (the revolved profile as a triangle list with the pin's number, in
  its frame ``pin<n>``, ``frame_locked`` so ``/pins/tf`` moves it); when pin action ends, the
  entity ``pins/leave`` (the leave as text above the deck).
- ``/pins/result`` JSON (schema ``bowlrec.PinResult``), one message when pin action ends: the
  leave, pinfall, standing, touched pins, exit board and deflection.
- metadata ``pins``: the same result, each field as JSON text.

Records: metadata ``scene`` (scene_json, run_id, name, bowlrec_version, physics_version),
metadata ``summary`` (every :class:`~bowlrec.core.trajectory.Summary` field as JSON text, plus a
one-line ``text``) and the attachment ``scene.json``.

Time: log time (ns) = round(t_s * 1e9), the simulated time since release with epoch 0, so
Foxglove shows 1970-01-01 00:00:00 plus the delivery time. No wall clock is read anywhere, and
compression is single-threaded: writing the same run twice gives byte-identical files.
"""

from __future__ import annotations

import heapq
import json
import math
import os
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple, Protocol

import foxglove
import numpy as np
from foxglove.channels import FrameTransformChannel, FrameTransformsChannel, SceneUpdateChannel
from foxglove.mcap import MCAPCompression, MCAPWriteOptions, MCAPWriter
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    FrameTransforms,
    KeyValuePair,
    LinePrimitive,
    LinePrimitiveLineType,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    SpherePrimitive,
    TextPrimitive,
    Timestamp,
    TriangleListPrimitive,
    Vector3,
)
from numpy.typing import NDArray

from bowlrec.atomic_files import atomic_path
from bowlrec.core.codes import EVENT_KINDS
from bowlrec.core.trajectory import Event, Trajectory
from bowlrec.versions import PHYSICS_VERSION, __version__

from .common import Array, RunData, friction_cells, markings_body, series_columns, summary_text
from .pin_replay import PinReplay, deck_outline, pin_mesh, pin_replay

__all__ = [
    "EVENT_SCHEMA",
    "PIN_RESULT_SCHEMA",
    "event_message",
    "frame_transforms",
    "read_mcap_positions",
    "run_keys",
    "state_messages",
    "state_schema",
    "write_mcap",
    "write_mcap_batch",
]

#: lateral gap between neighbouring lanes in a batch file (m)
LANE_GAP_M = 0.5
#: thickness of the lane slab drawn below the lane surface (m)
LANE_THICKNESS_M = 0.02
#: thickness of a friction-cell slab, drawn just above the lane surface (m)
FRICTION_THICKNESS_M = 0.001
#: height of the path line and event markers above the lane surface (m)
TRACE_LIFT_M = 0.003
#: mu at which the friction color saturates to "dry" (0 is fully "oily")
MU_COLOR_MAX = 0.25
#: head pin, drawn as a tapered cylinder: widest diameter 4.766 in, height 15 in (m)
PIN_DIAMETER_M = 0.121
PIN_HEIGHT_M = 0.381

_XYZ = ("x", "y", "z")
_WXYZ = ("w", "x", "y", "z")
_PHASES = ("sliding", "rolling")
_IDENTITY = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
_LANE_COLOR = Color(r=0.82, g=0.68, b=0.48, a=1.0)
_OIL_RGB = (0.15, 0.55, 0.95)
_DRY_RGB = (0.95, 0.55, 0.15)
_PHASE_COLORS = (Color(r=0.95, g=0.25, b=0.65, a=1.0), Color(r=0.1, g=0.8, b=0.2, a=1.0))
_EVENT_COLOR = Color(r=1.0, g=0.9, b=0.1, a=1.0)
_BALL_COLOR = Color(r=0.12, g=0.16, b=0.45, a=1.0)
_CIRCLE_COLOR = Color(r=0.85, g=0.85, b=0.9, a=1.0)
_MARK_COLORS = {
    "pin": Color(r=0.9, g=0.1, b=0.1, a=1.0),
    "cg": Color(r=1.0, g=0.85, b=0.0, a=1.0),
    "mass_bias": Color(r=0.1, g=0.85, b=0.3, a=1.0),
}


# ----------------------------------------------------------------------------------------------
# JSON schemas and JSON messages
# ----------------------------------------------------------------------------------------------


def _number(description: str) -> dict[str, Any]:
    return {"type": "number", "description": description}


def _vector(description: str, keys: tuple[str, ...] = _XYZ) -> dict[str, Any]:
    return {
        "type": "object",
        "description": description,
        "properties": {k: {"type": "number"} for k in keys},
        "required": list(keys),
        "additionalProperties": False,
    }


def _object(title: str, description: str, properties: dict[str, Any]) -> dict[str, Any]:
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        "required": list(properties),
        "additionalProperties": False,
    }


#: JSON schema of one ``/events`` message
EVENT_SCHEMA: dict[str, Any] = _object(
    "bowlrec.Event",
    "Something that happened at one instant: a phase change, a zone crossing or the end.",
    {
        "t_s": _number("simulated time since release [s]"),
        "kind": {
            "type": "string",
            "enum": list(EVENT_KINDS.values()),
            "description": "what happened",
        },
        "x_m": _number("x of the ball center, from the foul line toward the pins [m]"),
        "y_m": _number("y of the ball center, from the right gutter leftward [m]"),
        "mu": _number("friction coefficient under the ball after the event [1]"),
        "phase": {
            "type": "string",
            "enum": list(_PHASES),
            "description": "contact phase after the event",
        },
    },
)


def _integers(description: str) -> dict[str, Any]:
    return {
        "type": "array",
        "items": {"type": "integer", "minimum": 1, "maximum": 10},
        "description": description,
    }


def _optional_number(description: str) -> dict[str, Any]:
    return {"type": ["number", "null"], "description": description}


#: JSON schema of the ``/pins/result`` message
PIN_RESULT_SCHEMA: dict[str, Any] = _object(
    "bowlrec.PinResult",
    "The pins after the ball (boards from the bowler's own gutter).",
    {
        "t_s": _number("when pin action ended, simulated time since release [s]"),
        "leave": {"type": "string", "description": "the standing pins in bowlers' names"},
        "pinfall": {"type": "integer", "description": "how many of the set pins are down"},
        "standing": _integers("the pins standing at the end"),
        "set_pins": _integers("the pins set before the ball"),
        "touched": _integers("the pins the ball touched, in the order of first touch"),
        "hand": {"type": "string", "enum": ["right", "left"], "description": "whose names"},
        "exit_board": _optional_number("where the ball's centre left the deck [board]"),
        "deflection_boards": _optional_number(
            "how far the pins pushed the ball off its line, toward the bowler's gutter [board]"
        ),
        "handoff_t_s": _number("when the pin engine took the ball, since release [s]"),
        "at_rest": {"type": "boolean", "description": "everything came to rest in time"},
    },
)


def pin_result_message(replay: PinReplay) -> bytes:
    """The ``/pins/result`` message (compact JSON, UTF-8) of a run's pins."""
    o = replay.outcome
    return _json_bytes(
        {
            "t_s": replay.rest_t_s,
            "leave": o.leave,
            "pinfall": o.pinfall,
            "standing": list(o.standing),
            "set_pins": list(o.set_pins),
            "touched": list(o.touched),
            "hand": o.hand,
            "exit_board": o.exit_board,
            "deflection_boards": o.deflection_boards,
            "handoff_t_s": replay.handoff_t_s,
            "at_rest": bool(o.action.at_rest) if o.action is not None else False,
        }
    )


def state_schema(traj: Trajectory) -> dict[str, Any]:
    """JSON schema of one ``/ball/state`` message of ``traj`` (torques only when recorded).

    Vectors are objects ``{x, y, z}`` in the lane frame (x toward the pins, y leftward, z up);
    the quaternion is ``{w, x, y, z}``. Units are in square brackets in each description.
    """
    units = {name: u for name, (_, u) in series_columns(traj).items()}
    props: dict[str, Any] = {
        "t_s": _number("simulated time since release [s]"),
        "phase": {"type": "string", "enum": list(_PHASES), "description": "contact phase"},
        "position_m": _vector("geometric center; z = 0 is the center plane, lane at z = -R [m]"),
        "velocity_mps": _vector("velocity of the geometric center [m/s]"),
        "speed_mps": _number(f"speed |velocity| [{units['speed_mps']}]"),
        "quaternion_wxyz": _vector("orientation, unit quaternion body -> lane [1]", _WXYZ),
        "omega_radps": _vector("angular velocity, lane frame [rad/s]"),
        "rev_rate_rpm": _number(f"rev rate |omega| [{units['rev_rate_rpm']}]"),
        "alpha_radps2": _vector("angular acceleration, lane frame [rad/s^2]"),
        "mu": _number(f"friction coefficient under the ball [{units['mu']}]"),
        "slip_mps": _vector("slip R_con x omega - v (minus the contact-point velocity) [m/s]"),
        "slip_speed_mps": _number(f"slip speed |slip| [{units['slip_speed_mps']}]"),
        "normal_force_N": _number(
            f"normal force of the lane on the ball [{units['normal_force_N']}]"
        ),
        "friction_force_N": _vector("friction force of the lane on the ball [N]"),
        "friction_force_magnitude_N": _number(
            f"friction force magnitude |friction_force_N| [{units['friction_force_N']}]"
        ),
        "energy_J": _number(f"mechanical energy [{units['energy_J']}]"),
    }
    if traj.torques_Nm:
        props["torques_Nm"] = {
            "type": "object",
            "description": "per-term torques of Eqs. (6)/(7), inertia terms as I_k alpha [N m]",
            "properties": {name: _vector(f"term {name} [N m]") for name in traj.torques_Nm},
            "required": list(traj.torques_Nm),
            "additionalProperties": False,
        }
    return _object("bowlrec.BallState", "Physics state of the ball at one sample.", props)


def _json_bytes(value: Any) -> bytes:
    return json.dumps(value, separators=(",", ":"), allow_nan=False).encode("utf-8")


def _finite(name: str, values: Array) -> Array:
    arr = np.asarray(values, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} has non-finite values; JSON has no NaN or infinity")
    return arr


def _vector_texts(name: str, values: Array, keys: tuple[str, ...]) -> list[str]:
    """Each row of ``values`` (n, len(keys)) as the JSON object ``{"x":...,...}``."""
    template = "{" + ",".join(f'"{k}":%r' for k in keys) + "}"
    return [template % tuple(row) for row in _finite(name, values).tolist()]


def _scalar_texts(name: str, values: Array) -> list[str]:
    return [repr(v) for v in _finite(name, values).reshape(-1).tolist()]


def state_messages(traj: Trajectory) -> Iterator[bytes]:
    """The ``/ball/state`` messages of ``traj`` as compact JSON (UTF-8), one per sample.

    Every float is written as Python's shortest round-trip ``repr`` (what :func:`json.dumps`
    writes), so it loads back bit for bit. Raises ValueError on a non-finite value.
    """
    series = {name: values for name, (values, _) in series_columns(traj).items()}
    phases = [f'"{_PHASES[int(p)]}"' for p in np.asarray(traj.phase).tolist()]
    columns: list[tuple[str, list[str]]] = [
        ("t_s", _scalar_texts("t_s", traj.t_s)),
        ("phase", phases),
        ("position_m", _vector_texts("position_m", traj.position_m, _XYZ)),
        ("velocity_mps", _vector_texts("velocity_mps", traj.velocity_mps, _XYZ)),
        ("speed_mps", _scalar_texts("speed_mps", series["speed_mps"])),
        ("quaternion_wxyz", _vector_texts("quaternion_wxyz", traj.quaternion_wxyz, _WXYZ)),
        ("omega_radps", _vector_texts("omega_radps", traj.omega_radps, _XYZ)),
        ("rev_rate_rpm", _scalar_texts("rev_rate_rpm", series["rev_rate_rpm"])),
        ("alpha_radps2", _vector_texts("alpha_radps2", traj.alpha_radps2, _XYZ)),
        ("mu", _scalar_texts("mu", traj.mu)),
        ("slip_mps", _vector_texts("slip_mps", traj.slip_mps, _XYZ)),
        ("slip_speed_mps", _scalar_texts("slip_speed_mps", series["slip_speed_mps"])),
        ("normal_force_N", _scalar_texts("normal_force_N", traj.normal_force_N)),
        ("friction_force_N", _vector_texts("friction_force_N", traj.friction_force_N, _XYZ)),
        (
            "friction_force_magnitude_N",
            _scalar_texts("friction_force_magnitude_N", series["friction_force_N"]),
        ),
        ("energy_J", _scalar_texts("energy_J", traj.energy_J)),
    ]
    if traj.torques_Nm:
        torques = [
            (name, _vector_texts(f"torque {name}", arr, _XYZ))
            for name, arr in traj.torques_Nm.items()
        ]
        columns.append(("torques_Nm", _join_objects(torques, traj.n_samples)))
    yield from (text.encode("utf-8") for text in _join_objects(columns, traj.n_samples))


def _join_objects(columns: list[tuple[str, list[str]]], n: int) -> list[str]:
    """``n`` JSON objects; object i has the key ``name`` -> JSON text ``texts[i]`` per column."""
    keys = [json.dumps(name) + ":" for name, _ in columns]
    texts = [t for _, t in columns]
    return [
        "{" + ",".join([k + t[i] for k, t in zip(keys, texts, strict=True)]) + "}" for i in range(n)
    ]


def event_message(event: Event) -> bytes:
    """One ``/events`` message (compact JSON, UTF-8) for ``event``."""
    return _json_bytes(
        {
            "t_s": float(event.t_s),
            "kind": event.kind,
            "x_m": float(event.x_m),
            "y_m": float(event.y_m),
            "mu": float(event.mu),
            "phase": event.phase,
        }
    )


# ----------------------------------------------------------------------------------------------
# Foxglove messages
# ----------------------------------------------------------------------------------------------


def _log_time_ns(t_s: float | Array) -> NDArray[np.int64]:
    """Log time(s) in ns for simulated time(s) ``t_s`` (s), epoch 0."""
    return np.rint(np.asarray(t_s, dtype=np.float64) * 1e9).astype(np.int64)


def _timestamp(ns: int) -> Timestamp:
    return Timestamp(ns // 1_000_000_000, ns % 1_000_000_000)


def _vec3(x: float, y: float, z: float) -> Vector3:
    return Vector3(x=x, y=y, z=z)


def _pose(x: float, y: float, z: float) -> Pose:
    return Pose(position=_vec3(x, y, z), orientation=_IDENTITY)


def _mu_color(mu: float, alpha: float = 0.55) -> Color:
    """Blue (mu = 0, oily) to orange (mu >= MU_COLOR_MAX, dry)."""
    t = min(max(mu / MU_COLOR_MAX, 0.0), 1.0)
    r, g, b = (o + t * (d - o) for o, d in zip(_OIL_RGB, _DRY_RGB, strict=True))
    return Color(r=r, g=g, b=b, a=alpha)


def frame_transforms(traj: Trajectory, parent: str, child: str) -> Iterator[FrameTransform]:
    """One FrameTransform per sample: ``child`` (the ball) in ``parent`` (the lane)."""
    for _, transform in _transforms(traj.t_s, traj.position_m, traj.quaternion_wxyz, parent, child):
        yield transform


def _transforms(
    t_s: Array, position: Array, quaternion_wxyz: Array, parent: str, child: str
) -> Iterator[tuple[int, FrameTransform]]:
    """(log time in ns, FrameTransform) per row: ``child`` at ``position`` (n, 3) turned by the
    quaternions (n, 4) in ``parent``, stamped ``t_s`` (n,)."""
    for ns, p, q in zip(
        _log_time_ns(t_s).tolist(),
        np.asarray(position).tolist(),
        np.asarray(quaternion_wxyz).tolist(),
        strict=True,
    ):
        yield (
            ns,
            FrameTransform(
                timestamp=_timestamp(ns),
                parent_frame_id=parent,
                child_frame_id=child,
                translation=Vector3(x=p[0], y=p[1], z=p[2]),
                rotation=Quaternion(x=q[1], y=q[2], z=q[3], w=q[0]),
            ),
        )


@dataclass(frozen=True)
class _Names:
    """Topic, frame and record names of one run in a file; ``key`` is "" in a single-run file."""

    key: str = ""

    def topic(self, name: str) -> str:
        return f"/{self.key}{name}" if self.key else name

    def frame(self, name: str) -> str:
        return f"{self.key}/{name}" if self.key else name

    record = frame


def _lane_entity(run: RunData, names: _Names, stamp: Timestamp) -> SceneEntity:
    """The lane slab, the foul line and (without pin action) a marker for the head pin."""
    plan, r = run.plan, run.plan.radius_m
    length, width = plan.lane_length_m, plan.lane_width_m
    slab = CubePrimitive(
        pose=_pose(length / 2, width / 2, -r - LANE_THICKNESS_M / 2),
        size=_vec3(length, width, LANE_THICKNESS_M),
        color=_LANE_COLOR,
    )
    pin = CylinderPrimitive(
        pose=_pose(length, width / 2, -r + PIN_HEIGHT_M / 2),
        size=_vec3(PIN_DIAMETER_M, PIN_DIAMETER_M, PIN_HEIGHT_M),
        bottom_scale=1.0,
        top_scale=0.4,
        color=Color(r=0.97, g=0.97, b=0.97, a=1.0),
    )
    foul_line = LinePrimitive(
        type=LinePrimitiveLineType.LineStrip,
        pose=_pose(0.0, 0.0, 0.0),
        thickness=0.02,
        points=[
            Point3(x=0.0, y=0.0, z=-r + TRACE_LIFT_M),
            Point3(x=0.0, y=width, z=-r + TRACE_LIFT_M),
        ],
        color=Color(r=0.8, g=0.1, b=0.1, a=1.0),
    )
    return SceneEntity(
        timestamp=stamp,
        frame_id=names.frame("lane"),
        id="lane",
        metadata=[
            KeyValuePair(key="length_m", value=repr(length)),
            KeyValuePair(key="width_m", value=repr(width)),
            KeyValuePair(key="surface_z_m", value=repr(-r)),
        ],
        cubes=[slab],
        cylinders=[] if pin_replay(run) is not None else [pin],
        lines=[foul_line],
    )


def _friction_entities(run: RunData, names: _Names, stamp: Timestamp) -> list[SceneEntity]:
    z = -run.plan.radius_m + FRICTION_THICKNESS_M
    entities = []
    for i, cell in enumerate(friction_cells(run.plan)):
        cube = CubePrimitive(
            pose=_pose((cell.x0_m + cell.x1_m) / 2, (cell.y0_m + cell.y1_m) / 2, z),
            size=_vec3(cell.x1_m - cell.x0_m, cell.y1_m - cell.y0_m, FRICTION_THICKNESS_M),
            color=_mu_color(cell.mu),
        )
        meta = {"mu": cell.mu, "x0_m": cell.x0_m, "x1_m": cell.x1_m}
        meta |= {"y0_m": cell.y0_m, "y1_m": cell.y1_m}
        entities.append(
            SceneEntity(
                timestamp=stamp,
                frame_id=names.frame("lane"),
                id=f"friction/{i}",
                metadata=[KeyValuePair(key=k, value=repr(v)) for k, v in meta.items()],
                cubes=[cube],
            )
        )
    return entities


def _path_entity(run: RunData, names: _Names, stamp: Timestamp) -> SceneEntity:
    traj = run.trajectory
    z = -run.plan.radius_m + TRACE_LIFT_M
    points = [Point3(x=x, y=y, z=z) for x, y in traj.position_m[:, :2].tolist()]
    colors = [_PHASE_COLORS[int(p)] for p in np.asarray(traj.phase).tolist()]
    line = LinePrimitive(
        type=LinePrimitiveLineType.LineStrip,
        pose=_pose(0.0, 0.0, 0.0),
        thickness=0.01,
        points=points,
        colors=colors,
    )
    return SceneEntity(timestamp=stamp, frame_id=names.frame("lane"), id="path", lines=[line])


def _events_entity(run: RunData, names: _Names, stamp: Timestamp) -> SceneEntity:
    z = -run.plan.radius_m + TRACE_LIFT_M
    size = _vec3(0.03, 0.03, 0.03)
    spheres, texts = [], []
    for e in run.trajectory.events:
        spheres.append(SpherePrimitive(pose=_pose(e.x_m, e.y_m, z), size=size, color=_EVENT_COLOR))
        label = f"{e.kind} t={e.t_s:.3f} s"
        texts.append(
            TextPrimitive(
                pose=_pose(e.x_m, e.y_m, z + 0.15),
                billboard=True,
                font_size=14.0,
                scale_invariant=True,
                color=_EVENT_COLOR,
                text=label,
            )
        )
    return SceneEntity(
        timestamp=stamp, frame_id=names.frame("lane"), id="events", spheres=spheres, texts=texts
    )


def _great_circle(normal_axis: int, radius: float, n: int = 48) -> LinePrimitive:
    """A closed circle of ``radius`` about the body axis ``normal_axis`` (0, 1 or 2)."""
    a, b = [k for k in range(3) if k != normal_axis]
    points = []
    for k in range(n):
        xyz = [0.0, 0.0, 0.0]
        xyz[a] = radius * math.cos(2 * math.pi * k / n)
        xyz[b] = radius * math.sin(2 * math.pi * k / n)
        points.append(Point3(x=xyz[0], y=xyz[1], z=xyz[2]))
    return LinePrimitive(
        type=LinePrimitiveLineType.LineLoop,
        pose=_pose(0.0, 0.0, 0.0),
        thickness=0.003,
        points=points,
        color=_CIRCLE_COLOR,
    )


def _x_axis_to(u: Array) -> Quaternion:
    """The shortest rotation taking +x to the unit vector ``u`` (arrows point along +x)."""
    x, y, z = (float(c) for c in u)
    if x < -1.0 + 1e-12:  # u = -x: half turn about z
        return Quaternion(x=0.0, y=0.0, z=1.0, w=0.0)
    # q = (1 + x.u, x cross u) normalized; x cross u = (0, -z, y)
    w, qy, qz = 1.0 + x, -z, y
    n = math.sqrt(w * w + qy * qy + qz * qz)
    return Quaternion(x=0.0, y=qy / n, z=qz / n, w=w / n)


def _ball_entity(run: RunData, names: _Names, stamp: Timestamp) -> SceneEntity:
    """The ball in its own (body) frame; ``frame_locked`` so it follows ``/tf``.

    A sphere of diameter 2R, three great circles about the body axes (so any rotation shows),
    spheres on the surface at the pin and mass_bias markings, and an arrow out of the surface
    at the cg marking (it may coincide with the pin).
    """
    r = run.plan.radius_m
    d, mark_d = 2.0 * r, 0.2 * r
    spheres = [SpherePrimitive(pose=_pose(0.0, 0.0, 0.0), size=_vec3(d, d, d), color=_BALL_COLOR)]
    arrows = []
    marks = markings_body(run.plan)
    for name, u in marks.items():
        x, y, z = (float(c) * r for c in u)
        if name == "cg":
            arrows.append(
                ArrowPrimitive(
                    pose=Pose(position=_vec3(x, y, z), orientation=_x_axis_to(u)),
                    shaft_length=0.3 * r,
                    shaft_diameter=0.05 * r,
                    head_length=0.12 * r,
                    head_diameter=0.12 * r,
                    color=_MARK_COLORS[name],
                )
            )
        else:
            size = _vec3(mark_d, mark_d, mark_d)
            spheres.append(
                SpherePrimitive(pose=_pose(x, y, z), size=size, color=_MARK_COLORS[name])
            )
    meta = [KeyValuePair(key="radius_m", value=repr(r))]
    meta += [KeyValuePair(key=name, value=json.dumps(u.tolist())) for name, u in marks.items()]
    return SceneEntity(
        timestamp=stamp,
        frame_id=names.frame("ball"),
        id="ball",
        frame_locked=True,
        metadata=meta,
        arrows=arrows,
        spheres=spheres,
        lines=[_great_circle(axis, 1.004 * r) for axis in range(3)],
    )


def _scene_update(run: RunData, names: _Names, ns: int) -> SceneUpdate:
    """The static scene of one run (lane, friction cells, pin, path, events, ball) at ``ns``."""
    stamp = _timestamp(ns)
    return SceneUpdate(
        entities=[
            _lane_entity(run, names, stamp),
            *_friction_entities(run, names, stamp),
            _path_entity(run, names, stamp),
            _events_entity(run, names, stamp),
            _ball_entity(run, names, stamp),
        ]
    )


# ----------------------------------------------------------------------------------------------
# Writing
# ----------------------------------------------------------------------------------------------


class _Loggable(Protocol):
    def log(self, message: Any, /, *, log_time: int | None = ...) -> None: ...


class _Message(NamedTuple):
    log_time: int
    channel: _Loggable
    payload: Any


def _check_run(run: RunData) -> None:
    run.require_samples("MCAP export")
    traj = run.trajectory
    for name, arr in traj.arrays().items():
        if not np.all(np.isfinite(np.asarray(arr, dtype=np.float64))):
            raise ValueError(f"MCAP export: scene {run.name!r} has non-finite values in {name}")
    if traj.t_s[0] < 0.0:
        raise ValueError(f"MCAP export: scene {run.name!r} starts at t = {traj.t_s[0]} s < 0")


def _run_messages(run: RunData, names: _Names, ctx: foxglove.Context) -> Iterator[_Message]:
    """Every message of one run in log-time order (at equal times: the scene, events, the
    ball's transform, its state, then the pins' messages)."""
    traj = run.trajectory
    tf = FrameTransformChannel(names.topic("/tf"), context=ctx)
    scene = SceneUpdateChannel(names.topic("/scene"), context=ctx)
    state = foxglove.Channel(names.topic("/ball/state"), schema=state_schema(traj), context=ctx)
    events = foxglove.Channel(names.topic("/events"), schema=EVENT_SCHEMA, context=ctx)
    pins = pin_replay(run)

    sample_ns = _log_time_ns(traj.t_s).tolist()
    pending = [(int(_log_time_ns(e.t_s)), event_message(e)) for e in traj.events]
    pending.sort(key=lambda item: item[0])
    lane, ball = names.frame("lane"), names.frame("ball")
    track = (traj.t_s, traj.position_m, traj.quaternion_wxyz)
    if pins is not None:
        track = pins.ball_track(run)
    transforms = _transforms(*track, lane, ball)
    streams: list[Iterable[_Message]] = [
        [_Message(sample_ns[0], scene, _scene_update(run, names, sample_ns[0]))],
        (_Message(ns, events, body) for ns, body in pending),
        (_Message(ns, tf, t) for ns, t in transforms),
        (_Message(ns, state, b) for ns, b in zip(sample_ns, state_messages(traj), strict=True)),
    ]
    if pins is not None:
        streams.append(_pin_messages(run, pins, names, ctx))
    yield from heapq.merge(*streams, key=lambda m: m.log_time)


def _pin_messages(
    run: RunData, pins: PinReplay, names: _Names, ctx: foxglove.Context
) -> Iterator[_Message]:
    """The pins' messages in log-time order: the scene at the hand-off, a FrameTransforms per
    engine sample, then the leave and the result when pin action ends."""
    tf = FrameTransformsChannel(names.topic("/pins/tf"), context=ctx)
    scene = SceneUpdateChannel(names.topic("/pins/scene"), context=ctx)
    result = foxglove.Channel(names.topic("/pins/result"), schema=PIN_RESULT_SCHEMA, context=ctx)
    lane = names.frame("lane")
    frames = [names.frame(f"pin{p}") for p in pins.pins]
    sample_ns = _log_time_ns(pins.t_s).tolist()
    yield _Message(sample_ns[0], scene, _pins_scene(run, pins, names, _timestamp(sample_ns[0])))
    positions = pins.pin_position_m.tolist()
    quaternions = pins.pin_quaternion_wxyz.tolist()
    for i, ns in enumerate(sample_ns):
        stamp = _timestamp(ns)
        yield _Message(
            ns,
            tf,
            FrameTransforms(
                transforms=[
                    FrameTransform(
                        timestamp=stamp,
                        parent_frame_id=lane,
                        child_frame_id=frame,
                        translation=Vector3(x=p[0], y=p[1], z=p[2]),
                        rotation=Quaternion(x=q[1], y=q[2], z=q[3], w=q[0]),
                    )
                    for frame, p, q in zip(frames, positions[i], quaternions[i], strict=True)
                ]
            ),
        )
    rest_ns = max(int(_log_time_ns(pins.rest_t_s)), sample_ns[-1])
    yield _Message(rest_ns, scene, _leave_update(run, pins, names, _timestamp(rest_ns)))
    yield _Message(rest_ns, result, pin_result_message(pins))


_DECK_COLOR = Color(r=0.25, g=0.25, b=0.25, a=1.0)
_SPOT_COLOR = Color(r=0.45, g=0.45, b=0.45, a=1.0)
_LEAVE_COLOR = Color(r=0.95, g=0.2, b=0.2, a=1.0)


def _pins_scene(run: RunData, pins: PinReplay, names: _Names, stamp: Timestamp) -> SceneUpdate:
    """The deck (outline, spots, the ball's path through it) and the pins' models."""
    from bowlrec.pins.profile import HEIGHT_M

    outline = deck_outline(run)
    z = -run.plan.radius_m + TRACE_LIFT_M
    loop = LinePrimitive(
        type=LinePrimitiveLineType.LineStrip,
        pose=_pose(0.0, 0.0, 0.0),
        thickness=0.008,
        points=[Point3(x=x, y=y, z=zz) for x, y, zz in outline.corners(z).tolist()],
        color=_DECK_COLOR,
    )
    path = LinePrimitive(
        type=LinePrimitiveLineType.LineStrip,
        pose=_pose(0.0, 0.0, 0.0),
        thickness=0.01,
        points=[Point3(x=x, y=y, z=z) for x, y in pins.ball_position_m[:, :2].tolist()],
        color=_BALL_COLOR,
    )
    spot_d = 0.0286  # a spot is 2 1/4 in across
    spots = [
        CylinderPrimitive(
            pose=_pose(x, y, z),
            size=_vec3(spot_d, spot_d, 0.001),
            bottom_scale=1.0,
            top_scale=1.0,
            color=_SPOT_COLOR,
        )
        for _, (x, y) in sorted(outline.spots_m.items())
    ]
    deck = SceneEntity(
        timestamp=stamp,
        frame_id=names.frame("lane"),
        id="pins/deck",
        metadata=[
            KeyValuePair(key="x0_m", value=repr(outline.x0_m)),
            KeyValuePair(key="x1_m", value=repr(outline.x1_m)),
            KeyValuePair(key="surface_z_m", value=repr(-run.plan.radius_m)),
        ],
        lines=[loop, path],
        cylinders=spots,
    )
    verts, tris, _normals, colors = pin_mesh()
    points = [Point3(x=x, y=y, z=zz) for x, y, zz in verts.tolist()]
    vertex_colors = [Color(r=r, g=g, b=b, a=1.0) for r, g, b in colors.tolist()]
    indices = tris.reshape(-1).tolist()
    entities = [deck]
    for p in pins.pins:
        model = TriangleListPrimitive(
            pose=_pose(0.0, 0.0, 0.0), points=points, colors=vertex_colors, indices=indices
        )
        label = TextPrimitive(
            pose=_pose(0.0, 0.0, HEIGHT_M + 0.04),
            billboard=True,
            font_size=12.0,
            scale_invariant=True,
            color=_LEAVE_COLOR,
            text=str(p),
        )
        entities.append(
            SceneEntity(
                timestamp=stamp,
                frame_id=names.frame(f"pin{p}"),
                id=f"pins/{p}",
                frame_locked=True,
                metadata=[KeyValuePair(key="pin", value=str(p))],
                triangles=[model],
                texts=[label],
            )
        )
    return SceneUpdate(entities=entities)


def _leave_update(run: RunData, pins: PinReplay, names: _Names, stamp: Timestamp) -> SceneUpdate:
    """The leave as text above the middle of the deck."""
    outline = deck_outline(run)
    text = TextPrimitive(
        pose=_pose(
            0.5 * (outline.x0_m + outline.x1_m), 0.5 * outline.width_m, -run.plan.radius_m + 0.6
        ),
        billboard=True,
        font_size=20.0,
        scale_invariant=True,
        color=_LEAVE_COLOR,
        text=pins.outcome.line(),
    )
    return SceneUpdate(
        entities=[
            SceneEntity(
                timestamp=stamp,
                frame_id=names.frame("lane"),
                id="pins/leave",
                metadata=[KeyValuePair(key="leave", value=pins.outcome.leave)],
                texts=[text],
            )
        ]
    )


def _write_records(writer: MCAPWriter, run: RunData, names: _Names) -> None:
    """Metadata ``scene`` and ``summary`` and the attachment ``scene.json`` of one run."""
    scene_json = run.scene_json()
    writer.write_metadata(
        names.record("scene"),
        {
            "scene_json": scene_json,
            "run_id": run.run_id or "",
            "name": run.name,
            "bowlrec_version": __version__,
            "physics_version": PHYSICS_VERSION,
        },
    )
    summary = {
        k: v if isinstance(v, str) else json.dumps(v)
        for k, v in run.trajectory.summary.to_dict().items()
    }
    summary["text"] = summary_text(run.trajectory)
    writer.write_metadata(names.record("summary"), summary)
    if run.trajectory.pins is not None:
        result = run.trajectory.pins.to_dict() | {"line": run.trajectory.pins.line()}
        writer.write_metadata(
            names.record("pins"),
            {k: v if isinstance(v, str) else json.dumps(v) for k, v in result.items()},
        )
    writer.attach(
        log_time=0,
        create_time=0,
        name=names.record("scene.json"),
        media_type="application/json",
        data=scene_json.encode("utf-8"),
    )


def _writer_options() -> MCAPWriteOptions:
    # single-threaded zstd: the output bytes do not depend on the machine's core count
    return MCAPWriteOptions(compression=MCAPCompression.Zstd, compression_threads=0)


def _write_file(
    path: str | os.PathLike[str], fill: Callable[[MCAPWriter, foxglove.Context], None]
) -> Path:
    """Write with ``fill(writer, context)`` to a temporary file beside ``path``, then move it
    into place (:func:`~bowlrec.atomic_files.atomic_path`: on any error the temporary is
    removed and ``path`` is left as it was)."""
    with atomic_path(path) as tmp:
        ctx = foxglove.Context()
        # the temporary exists already (atomic_path creates it): the SDK must overwrite it
        with foxglove.open_mcap(
            tmp, allow_overwrite=True, context=ctx, writer_options=_writer_options()
        ) as writer:
            fill(writer, ctx)
    return Path(path)


def _log_all(messages: Iterable[_Message]) -> None:
    for m in messages:
        m.channel.log(m.payload, log_time=m.log_time)


def write_mcap(run: RunData, path: str | os.PathLike[str]) -> Path:
    """Write one run to the MCAP file ``path`` (replaced if it exists) and return its path.

    Raises :class:`~bowlrec.sinks.SamplesRequiredError` for a summary-only run (nothing is
    written). See the module docstring for topics, records and time stamps.
    """
    _check_run(run)
    names = _Names()

    def fill(writer: MCAPWriter, ctx: foxglove.Context) -> None:
        _log_all(_run_messages(run, names, ctx))
        _write_records(writer, run, names)

    return _write_file(path, fill)


def run_keys(runs: Sequence[RunData]) -> list[str]:
    """Topic-safe unique keys of ``runs``: run_id if set, else the scene name; '-2', '-3' on
    repeats. Characters outside ``[A-Za-z0-9_.-]`` become '_'."""
    keys: list[str] = []
    for run in runs:
        base = re.sub(r"[^A-Za-z0-9_.-]+", "_", run.run_id or run.name) or "run"
        key, n = base, 1
        while key in keys:
            n += 1
            key = f"{base}-{n}"
        keys.append(key)
    return keys


def write_mcap_batch(runs: Sequence[RunData], path: str | os.PathLike[str]) -> Path:
    """Write several runs into one MCAP file, lanes side by side, and return its path.

    Each run's topics, frames and records are prefixed by its key from :func:`run_keys`
    (``/<key>/tf``, frames ``<key>/lane`` and ``<key>/ball``, metadata ``<key>/scene``, ...).
    ``/tf_static`` (foxglove.FrameTransforms, once at t = 0) places lane ``i`` in the frame
    ``world`` at y = i * (widest lane + LANE_GAP_M). Metadata ``batch`` lists the keys in order.
    Messages of all runs are interleaved in log-time order.
    """
    if not runs:
        raise ValueError("MCAP batch export needs at least one run")
    for run in runs:
        _check_run(run)
    keys = run_keys(runs)
    pitch = max(run.plan.lane_width_m for run in runs) + LANE_GAP_M

    def fill(writer: MCAPWriter, ctx: foxglove.Context) -> None:
        statics = FrameTransformsChannel("/tf_static", context=ctx)
        placements = [
            FrameTransform(
                timestamp=_timestamp(0),
                parent_frame_id="world",
                child_frame_id=f"{key}/lane",
                translation=_vec3(0.0, i * pitch, 0.0),
                rotation=_IDENTITY,
            )
            for i, key in enumerate(keys)
        ]
        statics.log(FrameTransforms(transforms=placements), log_time=0)
        streams = [
            _run_messages(run, _Names(key), ctx) for run, key in zip(runs, keys, strict=True)
        ]
        _log_all(heapq.merge(*streams, key=lambda m: m.log_time))
        for run, key in zip(runs, keys, strict=True):
            _write_records(writer, run, _Names(key))
        writer.write_metadata("batch", {"runs": json.dumps(keys)})

    return _write_file(path, fill)


# ----------------------------------------------------------------------------------------------
# Reading
# ----------------------------------------------------------------------------------------------


def read_mcap_positions(
    path: str | os.PathLike[str], run: str | None = None
) -> tuple[Array, Array, Array]:
    """Read back ``(t_s (n,), position_m (n, 3), quaternion_wxyz (n, 4))`` from an MCAP file.

    Reads the ``/ball/state`` channel (``/<run>/ball/state`` in a batch file) with the mcap
    reader, validating the CRC of every chunk it reads. The values are the written float64
    values exactly (JSON shortest repr). Needs only the ``mcap`` package.
    """
    from mcap.reader import make_reader

    topic = _Names(run or "").topic("/ball/state")
    t: list[float] = []
    pos: list[list[float]] = []
    quat: list[list[float]] = []
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        for _, channel, message in reader.iter_messages(topics=[topic]):
            if channel.message_encoding != "json":
                raise ValueError(f"{path}: {topic} is {channel.message_encoding!r}, not json")
            state = json.loads(message.data)
            p, q = state["position_m"], state["quaternion_wxyz"]
            t.append(state["t_s"])
            pos.append([p["x"], p["y"], p["z"]])
            quat.append([q["w"], q["x"], q["y"], q["z"]])
    if not t:
        raise ValueError(f"{path}: no messages on {topic}")
    return (
        np.asarray(t, dtype=np.float64),
        np.asarray(pos, dtype=np.float64).reshape(-1, 3),
        np.asarray(quat, dtype=np.float64).reshape(-1, 4),
    )

"""What the replay formats show of a run's pins: poses on the run's clock, the pin's mesh and
the deck's outline, computed once from :class:`~bowlrec.pins.outcome.PinOutcome`.

Frames: the sinks' lane frame (:mod:`bowlrec.sinks.common`: x toward the pins, y leftward,
z up, the ball's centre plane at z = 0 and the lane's surface at z = -R). The pin engine's own
frame has the surface at z = 0, so every engine height is lowered by the ball's radius R here.
Time: seconds since release, the run's own clock; the engine's sample ``i`` is at
``hand-off time + action.t_s[i]``.

A body the engine retired into the pit (parked 1 km below the deck, out of play) keeps its
last pose in play here, lying in the pit behind the deck, and is marked ``in_pit``.

Nothing here imports a file-format library; NumPy and :mod:`bowlrec.pins` (no MuJoCo) only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from bowlrec.pins.outcome import PinOutcome

    from .common import RunData

__all__ = [
    "DeckOutline",
    "PinReplay",
    "deck_outline",
    "pin_mesh",
    "pin_replay",
    "pins_json",
]

Float = NDArray[np.float64]

#: an engine height below this (m) is a parked body (the engine parks them at -1000 m)
_PARKED_BELOW_M = -100.0
#: the pin's red neck stripes (in above the base): two bands either side of the neck
_STRIPES_IN = ((9.25, 9.6), (10.3, 10.65))


@dataclass(frozen=True)
class PinReplay:
    """A run's pins for the replay formats (SI; lane frame of the sinks, see the module).

    pins: the set pins' numbers; t_s (n,): the engine's samples on the run's clock (s since
    release); handoff_t_s: when the pins took over; rest_t_s: when pin action ended;
    pin_position_m (n, k, 3): each pin's base centre; pin_quaternion_wxyz (n, k, 4): pin ->
    lane (the pin's axis is its frame's z); in_pit (n, k): retired into the pit;
    ball_position_m (n, 3), ball_quaternion_wxyz (n, 4): the ball's geometric centre and
    orientation; ball_in_pit (n,); lane_cut: how many of the kernel's samples come before the
    hand-off (those the ball's pose stream keeps); outcome: the engine's result.
    """

    pins: tuple[int, ...]
    t_s: Float
    handoff_t_s: float
    rest_t_s: float
    pin_position_m: Float
    pin_quaternion_wxyz: Float
    in_pit: NDArray[np.bool_]
    ball_position_m: Float
    ball_quaternion_wxyz: Float
    ball_in_pit: NDArray[np.bool_]
    lane_cut: int
    outcome: PinOutcome

    @property
    def n_samples(self) -> int:
        return int(self.t_s.size)

    def ball_track(self, run: RunData) -> tuple[Float, Float, Float]:
        """The ball's whole path: ``(t_s (m,), position_m (m, 3), quaternion_wxyz (m, 4))``,
        the kernel's samples before the hand-off, then the engine's."""
        traj = run.trajectory
        cut = self.lane_cut
        return (
            np.concatenate([np.asarray(traj.t_s[:cut], dtype=np.float64), self.t_s]),
            np.concatenate(
                [np.asarray(traj.position_m[:cut], dtype=np.float64), self.ball_position_m]
            ),
            np.concatenate(
                [
                    np.asarray(traj.quaternion_wxyz[:cut], dtype=np.float64),
                    self.ball_quaternion_wxyz,
                ]
            ),
        )

    def leave_text(self) -> str:
        """The result in one line (:meth:`PinOutcome.line`)."""
        return self.outcome.line()


def _hold_parked(position: Float, quaternion: Float) -> tuple[Float, Float, NDArray[np.bool_]]:
    """Positions/quaternions (n, ..., 3/4) with each parked sample replaced by the body's last
    sample in play, and the parked mask (n, ...)."""
    pos = np.array(position, dtype=np.float64)
    quat = np.array(quaternion, dtype=np.float64)
    parked = pos[..., 2] < _PARKED_BELOW_M
    for i in range(1, pos.shape[0]):
        m = parked[i]
        if np.any(m):
            pos[i][m] = pos[i - 1][m]
            quat[i][m] = quat[i - 1][m]
    return pos, quat, parked


def pin_replay(run: RunData) -> PinReplay | None:
    """The pins of ``run`` as the formats show them; None when the run has no pin action (no
    ``options.pins``, or the ball never reached the pins)."""
    outcome = run.trajectory.pins
    if outcome is None or outcome.action is None or outcome.entry is None:
        return None
    action = outcome.action
    radius = float(run.plan.radius_m)
    t0 = float(outcome.entry.t_s)
    lower = np.array([0.0, 0.0, radius])
    pin_pos, pin_quat, in_pit = _hold_parked(action.pin_position_m, action.pin_quaternion_wxyz)
    ball_pos, ball_quat, ball_pit = _hold_parked(
        action.ball_position_m[:, None, :], action.ball_quaternion_wxyz[:, None, :]
    )
    lane_t = np.asarray(run.trajectory.t_s, dtype=np.float64)
    return PinReplay(
        pins=tuple(action.set_pins),
        t_s=t0 + np.asarray(action.t_s, dtype=np.float64),
        handoff_t_s=t0,
        rest_t_s=t0 + float(action.time_s),
        pin_position_m=pin_pos - lower,
        pin_quaternion_wxyz=pin_quat,
        in_pit=in_pit,
        ball_position_m=ball_pos[:, 0, :] - lower,
        ball_quaternion_wxyz=ball_quat[:, 0, :],
        ball_in_pit=ball_pit[:, 0],
        lane_cut=int(np.searchsorted(lane_t, t0, side="left")),
        outcome=outcome,
    )


@dataclass(frozen=True)
class DeckOutline:
    """The deck seen from above (lane frame, m): from ``x0_m`` (a foot before the head pin) to
    the tail plank's back edge ``x1_m``, across the lane's width; the spots' centres."""

    x0_m: float
    x1_m: float
    width_m: float
    spots_m: dict[int, tuple[float, float]]

    def corners(self, z_m: float) -> Float:
        """The outline as a closed loop of 5 points at height ``z_m``."""
        x0, x1, w = self.x0_m, self.x1_m, self.width_m
        return np.array(
            [[x0, 0.0, z_m], [x1, 0.0, z_m], [x1, w, z_m], [x0, w, z_m], [x0, 0.0, z_m]]
        )


def deck_outline(run: RunData) -> DeckOutline:
    """The deck of ``run``'s lane (:class:`bowlrec.pins.deck.Deck`)."""
    from bowlrec.pins.deck import Deck
    from bowlrec.units import IN_M

    deck = Deck(float(run.plan.lane_length_m), float(run.plan.lane_width_m))
    spots = {p: deck.spot_m(p) for p in range(1, 11)}
    return DeckOutline(deck.lane_length_m - 12.0 * IN_M, deck.end_x_m, deck.lane_width_m, spots)


@cache
def pin_mesh(sides: int = 24, rings: int = 61) -> tuple[Float, NDArray[np.int32], Float, Float]:
    """The pin as a triangle mesh: the solid of revolution of
    :func:`bowlrec.pins.profile.radius_m`, in the pin's frame (base centre at the origin, axis
    +z, m).

    Returns ``(vertices (v, 3), triangles (t, 3) counter-clockwise seen from outside,
    normals (v, 3), colors (v, 3) in 0..1: white with the two red neck stripes)``. The base is
    closed by a fan around its centre; the top ring has radius 0 (the head's arc ends there).
    """
    from bowlrec.pins.profile import HEIGHT_M, radius_m
    from bowlrec.units import IN_M

    edges = sorted({z * IN_M for band in _STRIPES_IN for z in band})
    z = np.unique(np.concatenate([np.linspace(0.0, HEIGHT_M, rings), edges]))
    r = np.asarray(radius_m(z), dtype=np.float64)
    r[-1] = 0.0
    dr = np.gradient(r, z)
    angles = 2.0 * math.pi * np.arange(sides) / sides
    c, s = np.cos(angles), np.sin(angles)
    verts = np.stack(
        [
            r[:, None] * c[None, :],
            r[:, None] * s[None, :],
            np.broadcast_to(z[:, None], (z.size, sides)),
        ],
        axis=-1,
    ).reshape(-1, 3)
    normals = np.stack(
        [
            np.broadcast_to(c, (z.size, sides)),
            np.broadcast_to(s, (z.size, sides)),
            -dr[:, None] * np.ones(sides),
        ],
        axis=-1,
    ).reshape(-1, 3)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    red = np.zeros(z.size, dtype=bool)
    for lo, hi in _STRIPES_IN:
        red |= (z >= lo * IN_M - 1e-9) & (z <= hi * IN_M + 1e-9)
    ring_rgb = np.where(red[:, None], [0.8, 0.1, 0.1], [0.97, 0.97, 0.95])
    colors = np.repeat(ring_rgb, sides, axis=0)
    tris = []
    for i in range(z.size - 1):
        for j in range(sides):
            a, b = i * sides + j, i * sides + (j + 1) % sides
            tris.append((a, b, b + sides))
            tris.append((a, b + sides, a + sides))
    centre = verts.shape[0]
    verts = np.vstack([verts, [[0.0, 0.0, 0.0]]])
    normals = np.vstack([normals, [[0.0, 0.0, -1.0]]])
    colors = np.vstack([colors, ring_rgb[:1]])
    for j in range(sides):
        tris.append((centre, (j + 1) % sides, j))
    return verts, np.array(tris, dtype=np.int32), normals, colors


def _round(values: Float, digits: int = 4) -> Any:
    return np.round(np.asarray(values, dtype=np.float64), digits).tolist()


def pins_json(run: RunData) -> dict[str, Any] | None:
    """The pins of ``run`` for the web app's pin-deck view (JSON-safe); None without pin action.

    Keys: the result (``leave``, ``line``, ``pinfall``, ``standing``, ``set_pins``,
    ``touched``, ``hand``, ``exit_board``, ``exit_y_m`` (where the ball's centre crossed the
    deck's end, lane y), ``deflection_boards``, ``time_s``, ``at_rest``),
    ``handoff_t_s``, ``t_s`` (the samples, s since the hand-off), ``deck`` (``x0_m``, ``x1_m``,
    ``width_m``, ``head_pin_x_m``, ``spots`` pin -> [x, y], ``pin_radius_m`` the belly's,
    ``pin_height_m``, ``ball_radius_m``, ``boards``), ``pins``: one entry per set pin with
    ``pin``, ``base`` and ``head`` (per sample [x, y] of its base centre and of the top of its
    axis, m), ``in_pit`` (per sample, 0/1); ``ball`` (per sample [x, y]) and ``approach`` (the
    kernel's [x, y] from the deck's start to the hand-off). Lengths in m, lane frame, 0.1 mm.
    """
    replay = pin_replay(run)
    outcome = run.trajectory.pins
    if outcome is None:
        return None
    from bowlrec.pins.profile import HEIGHT_M, radius_m
    from bowlrec.units import BOARDS, IN_M

    outline = deck_outline(run)
    result: dict[str, Any] = outcome.to_dict()
    result["line"] = outcome.line()
    result["exit_y_m"] = None if outcome.action is None else outcome.action.exit_y_m
    deck = {
        "x0_m": outline.x0_m,
        "x1_m": outline.x1_m,
        "width_m": outline.width_m,
        "head_pin_x_m": float(run.plan.lane_length_m),
        "spots": {str(p): list(xy) for p, xy in outline.spots_m.items()},
        "pin_radius_m": float(radius_m(4.5 * IN_M)),
        "pin_height_m": HEIGHT_M,
        "ball_radius_m": float(run.plan.radius_m),
        "boards": BOARDS,
    }
    result["deck"] = deck
    if replay is None:
        result.update(handoff_t_s=None, t_s=[], pins=[], ball=[], approach=[])
        return result
    axis = _axes(replay.pin_quaternion_wxyz)  # (n, k, 3)
    head = replay.pin_position_m + HEIGHT_M * axis
    pins = [
        {
            "pin": p,
            "base": _round(replay.pin_position_m[:, k, :2]),
            "head": _round(head[:, k, :2]),
            "in_pit": replay.in_pit[:, k].astype(int).tolist(),
        }
        for k, p in enumerate(replay.pins)
    ]
    lane = np.asarray(run.trajectory.position_m[: replay.lane_cut, :2], dtype=np.float64)
    approach = lane[lane[:, 0] >= outline.x0_m - 1.0]
    result.update(
        handoff_t_s=replay.handoff_t_s,
        t_s=_round(replay.t_s - replay.handoff_t_s, 6),
        pins=pins,
        ball=_round(replay.ball_position_m[:, :2]),
        approach=_round(approach),
    )
    return result


def _axes(q_wxyz: Float) -> Float:
    """The pin frame's z axis in the lane frame for quaternions (..., 4) (pin -> lane)."""
    w, x, y, z = (q_wxyz[..., i] for i in range(4))
    return np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=-1)

"""A run's pins as plain arrays: the record groups the archive stores (segment format 2.2;
docs/archive-format.md, "Pins") and the one-run files write.

:func:`pin_groups` turns a :class:`~bowlrec.pins.outcome.PinOutcome` into plain arrays, one
record group each for the outcome (one row), the engine's result and the ball's entry state
(one row each, when the ball reached the pins), the recorded motion (a row per sample) and the
engine's extra values (a row each); :func:`pin_outcome_of` reads them back into an equal
``PinOutcome``.

Nothing here imports the pin engine (MuJoCo): the result types are plain dataclasses.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from bowlrec.pins.outcome import PinOutcome

__all__ = [
    "PIN_GROUPS",
    "PIN_SLOTS",
    "PIN_MEANINGS",
    "decoded",
    "pin_engine",
    "pin_groups",
    "pin_outcome_of",
]

#: the record groups of a run's pins
PIN_GROUPS = ("pin_outcome", "pin_action", "pin_entry", "pins", "pin_extras")
#: pin slots per row: pin p is column p - 1 of the per-sample pin arrays and a pin list holds
#: at most ten numbers (0 after the last)
PIN_SLOTS = 10

#: PinAction's per-sample arrays as the ``pins`` group names them (the same names)
_SAMPLE_FIELDS = (
    "t_s",
    "pin_position_m",
    "pin_quaternion_wxyz",
    "ball_position_m",
    "ball_quaternion_wxyz",
    "energy_J",
)
#: BallEntry's fields: the ``pin_entry`` group's datasets (the same names)
_ENTRY_FIELDS = (
    "t_s",
    "position_m",
    "velocity_mps",
    "omega_radps",
    "quaternion_wxyz",
    "mass_kg",
    "radius_m",
    "inertia_per_mass_m2",
    "r_delta_body_m",
    "deck_friction",
)

#: dataset path -> (units, meaning) of the pin groups' datasets whose names carry no unit
#: suffix, or whose values need saying what they mean
PIN_MEANINGS: dict[str, tuple[str, str]] = {
    "pin_outcome/pinfall": ("1", "set pins down (count)"),
    "pin_outcome/leave": ("1", "the standing pins in bowlers' names (UTF-8)"),
    "pin_outcome/hand": ("1", "whose names the leave uses: right or left"),
    "pin_outcome/set_pins": ("1", "the pins set before the ball, in order; 0 after the last"),
    "pin_outcome/standing": ("1", "the pins standing at rest, in order; 0 after the last"),
    "pin_outcome/touched": ("1", "the pins the ball touched, first touch first; 0 after the last"),
    "pin_outcome/exit_board": (
        "board",
        "where the ball's centre left the deck, board from the bowler's gutter; NaN: it did not",
    ),
    "pin_outcome/deflection_boards": (
        "board",
        "the ball pushed off its line by the deck's end, toward the bowler's gutter; NaN: none",
    ),
    "pin_action/at_rest": ("1", "1: everything came to rest before max_time_s, else 0"),
    "pin_action/n_steps": ("1", "pin engine steps (count)"),
    "pin_action/exit_y_m": ("m", "where the ball's centre crossed the deck's end; NaN: it did not"),
    "pin_action/engine": ("1", "the pin engine and its version (UTF-8)"),
    "pin_action/wall_time_s": ("s", "the pin engine's wall time"),
    "pin_entry/quaternion_wxyz": ("1", "unit quaternion (w, x, y, z), body -> lane frame"),
    "pin_entry/deck_friction": ("1", "friction coefficient of the lane under the ball"),
    "pins/pin_position_m": ("m", "each pin's base centre (n, pin - 1, xyz); NaN: pin not set"),
    "pins/pin_quaternion_wxyz": (
        "1",
        "each pin's orientation, pin frame -> lane frame (n, pin - 1, wxyz); NaN: pin not set",
    ),
    "pins/ball_quaternion_wxyz": ("1", "the ball's orientation, body -> lane frame (w, x, y, z)"),
    "pins/energy_J": ("J", "kinetic and potential energy of the bodies in play"),
    "pin_extras/name": ("1", "an extra value of the pin engine: its name (UTF-8)"),
    "pin_extras/value": ("1", "an extra value of the pin engine: its value"),
}


def _pin_list(pins: tuple[int, ...]) -> NDArray[np.int8]:
    if len(pins) > PIN_SLOTS or any(not 1 <= p <= PIN_SLOTS for p in pins):
        raise ValueError(f"pins {pins} are not at most ten pin numbers 1-10")
    out = np.zeros((1, PIN_SLOTS), dtype=np.int8)
    out[0, : len(pins)] = pins
    return out


def _pins_of(row: NDArray[Any]) -> tuple[int, ...]:
    return tuple(int(p) for p in row if p != 0)


def _text(value: str) -> NDArray[np.bytes_]:
    return np.array([value.encode()], dtype=np.bytes_)


def _float(value: float | None) -> NDArray[np.float64]:
    return np.array([np.nan if value is None else value], dtype=np.float64)


def _optional(value: Any) -> float | None:
    v = float(value)
    return None if np.isnan(v) else v


def decoded(value: Any) -> str:
    return bytes(value).decode()


def pin_groups(outcome: PinOutcome, *, samples: bool = True) -> dict[str, dict[str, NDArray[Any]]]:
    """The record groups of a run's pins (docs/archive-format.md, "Pins"): ``pin_outcome``
    always, ``pin_action`` and ``pin_entry`` when the ball reached the pins, ``pins`` its
    recorded motion (every sample with ``samples``, else only the last: where the pins came to
    rest), ``pin_extras`` when the engine gave extra values."""
    groups: dict[str, dict[str, NDArray[Any]]] = {
        "pin_outcome": {
            "pinfall": np.array([outcome.pinfall], dtype=np.int64),
            "leave": _text(outcome.leave),
            "hand": _text(outcome.hand),
            "set_pins": _pin_list(outcome.set_pins),
            "standing": _pin_list(outcome.standing),
            "touched": _pin_list(outcome.touched),
            "exit_board": _float(outcome.exit_board),
            "deflection_boards": _float(outcome.deflection_boards),
        }
    }
    action, entry = outcome.action, outcome.entry
    if action is not None:
        if (action.set_pins, action.standing, action.touched) != (
            outcome.set_pins,
            outcome.standing,
            outcome.touched,
        ):
            raise ValueError("a pin outcome whose pins differ from its action's cannot be stored")
        groups["pin_action"] = {
            "time_s": _float(action.time_s),
            "at_rest": np.array([action.at_rest], dtype=np.int8),
            "n_steps": np.array([action.n_steps], dtype=np.int64),
            "wall_time_s": _float(action.wall_time_s),
            "exit_y_m": _float(action.exit_y_m),
            "engine": _text(action.engine),
        }
        n = int(action.t_s.shape[0])
        keep = slice(None) if samples else slice(max(0, n - 1), n)
        slots = [p - 1 for p in action.set_pins]
        rows: dict[str, NDArray[Any]] = {}
        for name in _SAMPLE_FIELDS:
            arr = np.asarray(getattr(action, name), dtype=np.float64)[keep]
            if name.startswith("pin_"):
                full = np.full((arr.shape[0], PIN_SLOTS, arr.shape[2]), np.nan)
                full[:, slots, :] = arr
                arr = full
            rows[name] = np.ascontiguousarray(arr)
        groups["pins"] = rows
        if action.extras:
            groups["pin_extras"] = {
                "name": np.array([k.encode() for k in action.extras], dtype=np.bytes_),
                "value": np.array(list(action.extras.values()), dtype=np.float64),
            }
    if entry is not None:
        groups["pin_entry"] = {
            name: np.asarray([getattr(entry, name)], dtype=np.float64) for name in _ENTRY_FIELDS
        }
    return groups


def pin_outcome_of(records: dict[str, dict[str, NDArray[Any]]]) -> PinOutcome | None:
    """The :class:`~bowlrec.pins.outcome.PinOutcome` of a run's record groups (None when the
    run has no ``pin_outcome`` row); the inverse of :func:`pin_groups`."""
    out = records.get("pin_outcome")
    if not out or int(out["pinfall"].shape[0]) == 0:
        return None
    from bowlrec.pins.engine import BallEntry, PinAction
    from bowlrec.pins.outcome import PinOutcome

    set_pins = _pins_of(out["set_pins"][0])
    standing = _pins_of(out["standing"][0])
    touched = _pins_of(out["touched"][0])
    action = entry = None
    head = records.get("pin_action")
    if head and int(head["time_s"].shape[0]):
        slots = [p - 1 for p in set_pins]
        motion = records.get("pins") or {}
        arrays: dict[str, NDArray[np.float64]] = {}
        for name in _SAMPLE_FIELDS:
            arr = np.asarray(motion[name], dtype=np.float64) if name in motion else None
            if arr is None:
                shape = {"t_s": (0,), "energy_J": (0,), "ball_position_m": (0, 3)}
                arr = np.zeros(shape.get(name, (0, 4)))
            if name.startswith("pin_"):
                width = 3 if name == "pin_position_m" else 4
                arr = arr[:, slots, :] if arr.size else np.zeros((0, len(slots), width))
            arrays[name] = np.ascontiguousarray(arr)
        extras = records.get("pin_extras") or {}
        action = PinAction(
            set_pins=set_pins,
            standing=standing,
            touched=touched,
            **arrays,
            exit_y_m=_optional(head["exit_y_m"][0]),
            time_s=float(head["time_s"][0]),
            at_rest=bool(head["at_rest"][0]),
            n_steps=int(head["n_steps"][0]),
            wall_time_s=float(head["wall_time_s"][0]),
            engine=decoded(head["engine"][0]),
            extras={
                decoded(k): float(v)
                for k, v in zip(extras.get("name", ()), extras.get("value", ()), strict=True)
            },
        )
    ent = records.get("pin_entry")
    if ent and int(ent["t_s"].shape[0]):
        values: dict[str, Any] = {}
        for name in _ENTRY_FIELDS:
            v = ent[name][0]
            values[name] = tuple(float(x) for x in v) if np.ndim(v) else float(v)
        entry = BallEntry(**values)
    return PinOutcome(
        set_pins=set_pins,
        standing=standing,
        leave=decoded(out["leave"][0]),
        hand=decoded(out["hand"][0]),
        touched=touched,
        exit_board=_optional(out["exit_board"][0]),
        deflection_boards=_optional(out["deflection_boards"][0]),
        action=action,
        entry=entry,
    )


def pin_engine(records: dict[str, dict[str, NDArray[Any]]]) -> str | None:
    """The pin engine's version string of a run's record groups (None without pin action)."""
    head = records.get("pin_action")
    if not head or not int(head["engine"].shape[0]):
        return None
    return decoded(head["engine"][0])

"""One delivery's pins: the kernel's run handed to the pin engine, and the result in bowlers'
terms (the leave, the pinfall, the pins the ball touched, where it left the deck).

Boards here are counted from the bowler's own gutter (a right-hander's board 1 is the right
edge, a left-hander's the left), fractional, as everywhere in the bowlers' layer.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from bowlrec.units import BOARDS

from .deck import Deck, set_pins
from .engine import BallEntry, PinAction, simulate_pins
from .handoff import ball_entry
from .leaves import name_leave

if TYPE_CHECKING:
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Trajectory

__all__ = ["PinOutcome", "pin_outcome", "standing_offsets_m", "with_pins"]


@dataclass(frozen=True)
class PinOutcome:
    """The pins after one ball.

    set_pins: the pins set before it; standing: those standing after it; leave: the standing
    pins in bowlers' names ("strike", "10 pin", "7-10 split", ...; after a ball at a partial
    rack "spare" when none stand); hand: whose names ("right" or "left"); touched: the pins the
    ball touched, in order; exit_board: where the ball's centre left the deck (board from the
    bowler's gutter; None if it did not reach the deck's end); deflection_boards: how far the
    pins pushed the ball off its line at the hand-off by the deck's end (boards, positive
    toward the bowler's own gutter, the way a pocket hit deflects a hook); action: the engine's
    full result with the recorded motion (None when the ball never reached the pins);
    entry: the ball's state at the hand-off (None likewise).
    """

    set_pins: tuple[int, ...]
    standing: tuple[int, ...]
    leave: str
    hand: str
    touched: tuple[int, ...]
    exit_board: float | None
    deflection_boards: float | None
    action: PinAction | None
    entry: BallEntry | None

    @property
    def pinfall(self) -> int:
        """How many of the set pins are down."""
        return len(self.set_pins) - len(self.standing)

    @property
    def strike(self) -> bool:
        """All ten pins set and none standing."""
        return len(self.set_pins) == 10 and not self.standing

    def to_dict(self) -> dict[str, Any]:
        """The result's plain values (no recorded motion), as summaries and JSON show them."""
        return {
            "pinfall": self.pinfall,
            "leave": self.leave,
            "standing": list(self.standing),
            "set_pins": list(self.set_pins),
            "touched": list(self.touched),
            "hand": self.hand,
            "exit_board": self.exit_board,
            "deflection_boards": self.deflection_boards,
            "time_s": None if self.action is None else self.action.time_s,
            "at_rest": None if self.action is None else self.action.at_rest,
        }

    def line(self) -> str:
        """The result in one line of words."""
        if self.action is None:
            return f"{self.leave}: the ball did not reach the pins ({self.pinfall} down)"
        touched = "-".join(str(p) for p in self.touched) or "none"
        where = (
            ""
            if self.exit_board is None
            else f"; the ball left the deck at board {self.exit_board:.1f}, "
            f"deflected {self.deflection_boards:+.1f} boards"
        )
        return f"{self.leave} ({self.pinfall} down; the ball touched {touched}{where})"


def standing_offsets_m(
    outcome: PinOutcome, lane_length_m: float, lane_width_m: float
) -> dict[int, tuple[float, float]]:
    """Where the standing pins came to rest: pin -> (dx, dy), its base centre's offset from its
    spot's centre (m), as ``options.pins.moved`` takes it for the next ball (a pinsetter sets
    standing pins back where it picked them up). Empty when the ball reached no pin."""
    action = outcome.action
    if action is None:
        return {}
    deck = Deck(lane_length_m, lane_width_m)
    out = {}
    for k, pin in enumerate(action.set_pins):
        if pin in outcome.standing:
            x, y = (float(v) for v in action.pin_position_m[-1, k, :2])
            sx, sy = deck.spot_m(pin)
            out[pin] = (x - sx, y - sy)
    return out


def _board(y_m: float, lane_width_m: float, hand: str) -> float:
    board_w = lane_width_m / BOARDS
    d = y_m if hand == "right" else lane_width_m - y_m
    return d / board_w + 0.5


def pin_outcome(plan: Plan, trajectory: Trajectory) -> PinOutcome:
    """The pins after the delivery ``plan`` (whose kernel run is ``trajectory``), by the pin
    model of ``plan.pins``: the ball handed off at its exact state (:mod:`.handoff`) to the
    engine (:mod:`.engine`) on the pins set for it (:func:`.deck.set_pins`)."""
    pins = plan.pins
    assert pins is not None, "the plan asks for no pin action"
    first_ball = len(pins.standing) == 10
    entry = ball_entry(plan) if trajectory.summary.outcome == "pins" else None
    hand = pins.hand
    if entry is None:
        if hand == "auto":
            hand = "right"
        leave = name_leave(pins.standing, hand=hand, first_ball=first_ball)  # type: ignore[arg-type]
        return PinOutcome(pins.standing, pins.standing, leave, hand, (), None, None, None, None)
    if hand == "auto":
        hand = "right" if entry.velocity_mps[1] >= 0.0 else "left"
    deck = Deck(plan.lane_length_m, plan.lane_width_m)
    at = {}
    for pin, dx, dy in pins.moved:
        x, y = deck.spot_m(pin)
        at[pin] = (x + dx, y + dy)
    pinset = set_pins(deck, pins.standing, seed=pins.seed, at=at)
    action = simulate_pins(entry, pins, deck, pinset, gravity_mps2=plan.g_mps2)
    exit_board = deflection = None
    if action.exit_y_m is not None:
        exit_board = _board(action.exit_y_m, plan.lane_width_m, hand)
        (x0, y0), (vx, vy) = entry.position_m, entry.velocity_mps
        line_y = y0 + vy / vx * (deck.end_x_m - x0)
        line_board = _board(line_y, plan.lane_width_m, hand)
        # toward the bowler's own gutter is toward lower boards in the bowler's count
        deflection = line_board - exit_board
    leave = name_leave(action.standing, hand=hand, first_ball=first_ball)  # type: ignore[arg-type]
    return PinOutcome(
        set_pins=action.set_pins,
        standing=action.standing,
        leave=leave,
        hand=hand,
        touched=action.touched,
        exit_board=exit_board,
        deflection_boards=deflection,
        action=action,
        entry=entry,
    )


def with_pins(plan: Plan, trajectory: Trajectory) -> Trajectory:
    """``trajectory`` with its pins (:func:`pin_outcome`) when ``plan`` asks for pin action,
    else as it is. MissingExtraError without the ``pins`` extra."""
    if plan.pins is None:
        return trajectory
    from .engine import require_mujoco

    require_mujoco()
    return trajectory.replaced(pins=pin_outcome(plan, trajectory))

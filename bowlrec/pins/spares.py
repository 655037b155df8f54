"""A stated spare system to aim the second ball with: the 3-6-9 system, shot cross-lane.

The 3-6-9 system, as taught: "move your feet on the approach in increments of three boards in
the opposite direction of the key pin you're trying to cover and roll your ball over the same
spot on the lane as your strike shot. To make the 2-pin (or 8 pin), the bowler would move his
feet three boards to the right of the starting point for a strike ball. To make the 4-pin, he'd
move 6 boards to the right, and for the 7-pin, he'd move 9 boards to the right. When shooting
spares to the right of the head pin, he'd move his feet left 3 boards for a 3-pin (or 9 pin), 6
boards for a 6 pin, and 9 boards for a 10-pin." (Mike Hawkins, "Making Your Spares ... It's as
easy as 3-6-9", http://beta.dailyadvance.com/Sports/2018/01/02/Making-Your-Spares-It-s-as-easy-as-3-6-9.html;
the same moves in boards, "a 14-10 line should ensure a hit on the 2-pin ..., 11-10 ... a
4-pin hit, and an 8-10 line ... the 7-pin" from a 17-10 strike line:
http://www.probowluk.co.uk/pbInstruction_LaneCraft02.php). So the move is 3 boards per pin
column off the head pin's, away from the key pin, the target kept: the ball then crosses the
lane toward the key pin from the other side, which is the cross-lane rule ("standing on the
opposite side and throwing across to the corner", https://bowlrevolution.com/technique/spare-systems/).
A left-hander's moves are the mirror image (pins 2-3, 4-6, 7-10, 8-9 swapped).

Boards are counted from the bowler's own gutter (board 1 at the right gutter for a
right-hander, at the left for a left-hander), fractional, with the lane's geometry of
:mod:`bowlrec.units` (39 boards over 41.5 in, the head pin on board 20's centre). Pin spots are
12 in apart on the triangle (USBC), so a pin's board is 20 plus its lateral offset from the
head pin (6 in per half spacing, :data:`bowlrec.pins.leaves.PIN_PLACES`) in boards: the 3 pin
at 14.36 and the 10 pin at 3.08 for a right-hander (the 10 spot's centre 2.75 in from the
edge).

The key pin (:func:`key_pin`): the standing pin nearest the bowler (the front-most row); in a
row, the pin in the larger group of touching pins (spots 12 in apart), then the one nearer the
centre line, then the one on the side away from the bowling hand (a right-hander's left).

The target (:func:`spare_target`), the board the ball's centre crosses at the head pin's line
(60 ft), taken as the board at the key pin (a straight spare line of up to 3 degrees drifts at
most 1.6 in, 1.5 boards, over the deck's 31 in, which this rule does not correct):

* one pin: the pin's board;
* otherwise the key pin's board moved toward the middle of the leave (midway between its
  leftmost and rightmost pins), by at most 6 in (half the pin spacing, inside the 6.68 in at
  which the centre of a ball up to 8.595 in across still touches a pin 4.766 in across at the
  belly), so the ball drives through the key pin into the side where the others stand; two
  pins side by side (2-3, 4-5, 5-6, ...) are so aimed at midway, where the ball touches both;
  a leave centred on the key pin (the 2-4-5-8 bucket, 1-2-3)
  gets the hand's pocket hit, 2.5 boards to the bowler's own side (the strike pocket at board
  17.5 against the head pin's 20: USBC via ``shared/domain-notes.md`` [BBC-POCK]).

The stance move is the system's for the key pin's column, so it can sit a column off the
target board for a leave (5-6: the move of the 5 pin, the target at the 3 pin's board). Wide
splits (7-10, 4-6) get the rule's nominal line through their key pin; it plans no pin thrown
into another.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

from bowlrec.units import BOARDS, HEAD_PIN_BOARD, LANE_WIDTH_IN

from .leaves import PIN_PLACES, PinNumberError, leave_label

__all__ = [
    "BOARDS_PER_COLUMN",
    "POCKET_OFFSET_BOARDS",
    "SYSTEM",
    "SpareTarget",
    "key_pin",
    "pin_board",
    "spare_target",
]

Hand = Literal["right", "left"]

SYSTEM = "3-6-9 cross-lane"
#: the 3-6-9 stance move per pin column off the head pin's (boards)
BOARDS_PER_COLUMN = 3
#: the strike pocket's offset from the head pin's board centre (boards): 20 - 17.5
POCKET_OFFSET_BOARDS = HEAD_PIN_BOARD - 17.5
#: half the 12 in pin spacing (in): one step of PIN_PLACES' lateral
HALF_SPACING_IN = 6.0


@dataclass(frozen=True)
class SpareTarget:
    """Where the 3-6-9 system aims the ball at a leave, for a bowler of ``hand``.

    key_pin: the pin the ball must hit; target_board: the board (from the bowler's gutter) the
    ball's centre crosses at 60 ft; stance_move_boards: how far the feet move from the strike
    stance (boards; positive toward the bowler's higher boards, i.e. left for a right-hander
    and right for a left-hander), the target over the arrows unchanged; crosses_from: the side
    of the lane the bowler moves to ("left", "right", or "middle" for a key pin in the head
    pin's column, shot from the strike stance), opposite the key pin (the cross-lane rule);
    system: the system's name.
    """

    key_pin: int
    target_board: float
    stance_move_boards: int
    crosses_from: Literal["left", "right", "middle"]
    hand: Hand
    system: str = SYSTEM


def _side(hand: Hand) -> int:
    """+1 when the bowler's boards grow to the lane's left (+y), -1 when they grow to its right."""
    if hand == "right":
        return 1
    if hand == "left":
        return -1
    raise ValueError(f"hand must be 'right' or 'left', not {hand!r}")


def _board_of_lateral(lateral_in: float, hand: Hand) -> float:
    """The board (from ``hand``'s gutter) of a point ``lateral_in`` inches left of the head pin."""
    return HEAD_PIN_BOARD + _side(hand) * lateral_in / (LANE_WIDTH_IN / BOARDS)


def _lateral_in(pin: int) -> float:
    return PIN_PLACES[pin][1] * HALF_SPACING_IN


def pin_board(pin: int, hand: Hand = "right") -> float:
    """The board (fractional, from ``hand``'s gutter) of ``pin``'s spot centre."""
    if pin not in PIN_PLACES:
        raise PinNumberError(f"pins are numbered 1-10, not {pin!r}")
    return _board_of_lateral(_lateral_in(pin), hand)


def _touching(a: int, b: int) -> bool:
    """Spots 12 in apart: neighbours on the triangle."""
    (ra, la), (rb, lb) = PIN_PLACES[a], PIN_PLACES[b]
    return (ra == rb and abs(la - lb) == 2) or (abs(ra - rb) == 1 and abs(la - lb) == 1)


def _group(pin: int, standing: frozenset[int]) -> set[int]:
    """The standing pins joined to ``pin`` through touching standing pins."""
    group, todo = {pin}, [pin]
    while todo:
        p = todo.pop()
        for q in standing - group:
            if _touching(p, q):
                group.add(q)
                todo.append(q)
    return group


def _standing(standing: Iterable[int]) -> frozenset[int]:
    label = leave_label(standing)  # checks the pin numbers
    if not label:
        raise PinNumberError("no pins are standing: there is no spare to aim at")
    return frozenset(int(p) for p in label.split("-"))


def key_pin(standing: Iterable[int], hand: Hand = "right") -> int:
    """The key pin of the leave ``standing`` for a bowler of ``hand`` (module docstring)."""
    up = _standing(standing)
    front = min(PIN_PLACES[p][0] for p in up)
    row = [p for p in up if PIN_PLACES[p][0] == front]
    side = _side(hand)
    return max(
        row, key=lambda p: (len(_group(p, up)), -abs(PIN_PLACES[p][1]), side * PIN_PLACES[p][1])
    )


def spare_target(standing: Iterable[int], hand: Hand = "right") -> SpareTarget:
    """The 3-6-9 cross-lane aim at the leave ``standing`` for a bowler of ``hand``: the key
    pin, the board at 60 ft and the stance move (module docstring)."""
    up = _standing(standing)
    key = key_pin(up, hand)
    side = _side(hand)
    lateral = _lateral_in(key)
    col = PIN_PLACES[key][1]
    if len(up) == 1:
        aim = lateral
    else:
        lats = [_lateral_in(p) for p in up]
        toward = (min(lats) + max(lats)) / 2.0 - lateral
        if toward == 0.0:
            pocket_in = POCKET_OFFSET_BOARDS * LANE_WIDTH_IN / BOARDS
            aim = lateral - side * pocket_in  # toward the bowler's own gutter
        else:
            aim = lateral + max(-HALF_SPACING_IN, min(HALF_SPACING_IN, toward))
    column = side * col  # pin columns off the head pin's, toward the bowler's higher boards
    move = -BOARDS_PER_COLUMN * column
    crosses: Literal["left", "right", "middle"]
    if move == 0:
        crosses = "middle"
    else:
        crosses = "left" if move * side > 0 else "right"
    return SpareTarget(
        key_pin=key,
        target_board=_board_of_lateral(aim, hand),
        stance_move_boards=move,
        crosses_from=crosses,
        hand=hand,
    )

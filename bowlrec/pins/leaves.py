"""The leave (the pins standing after a ball) in bowlers' words, and the USBC split rule.

Pins are numbered as a right-hander sees them from the foul line: row 1 pin 1 (the head pin);
row 2 pins 2 (left), 3; row 3 pins 4, 5, 6; row 4 pins 7, 8, 9, 10 (left to right). A pin's
place on the triangle is (row, lateral) with row 0 for the head pin to 3 for the back row and
lateral counted in half pin spacings (6 in) to the LEFT of the head pin's board (+y of the lane
frame): pin 2 is (1, +1), pin 10 is (3, -3). A left-hander's mirror image maps pins 1-1, 2-3,
4-6, 5-5, 7-10, 8-9 (lateral -> -lateral).

Split, USBC Playing Rules, rule 3 (wording as quoted in the project's issue 31; the stored copy
of the rule book found, https://docslib.org/doc/2410441/usbc-bowling-rules, is cut before this
definition, so the wording is unverified here): "a setup of pins remaining standing after the
first delivery, provided the head pin is down, and: a) at least one pin is down between two or
more pins which remain standing (e.g. 7-9, 3-10); b) at least one pin is down immediately ahead
of two or more pins which remain standing (e.g. 5-6)." Encoded on the triangle:

* "between" (clause a): pin P is between standing pins A and B when P's lateral lies strictly
  between theirs and P's row lies in the rows from A's to B's (the box they span on the deck):
  8 is between 7 and 9, 6 between 3 and 10, 5 and 8 between 4 and 9; nothing is between 2 and 8
  (one directly behind the other, "double wood"), and the head pin is between no two pins.
  Clause a holds for a pair when the pins between them are all down: a standing pin between
  two pins joins them (2-4-5-9 is no split although 8 is down, because 5 stands between 4
  and 9), while 2-4-5-7-9 is one, by the rule's own 7-9 with 8 down.
* "immediately ahead" (clause b): the pin in the row in front touching both of two neighbours
  of one row: 1 ahead of 2-3, 2 of 4-5, 3 of 5-6, 4 of 7-8, 5 of 8-9, 6 of 9-10. So the
  side-by-side leaves 2-3, 4-5, 5-6, 7-8, 8-9, 9-10 are splits when the pin ahead is down (the
  rule's own 5-6 and its mirror 4-5).

Names (first ball; hand-independent unless said), from these pages:

* baby split 2-7, 3-10; big four 4-6-7-10; big five 2-4-6-7-10, 3-4-6-7-10; greek church
  4-6-7-8-10, 4-6-7-9-10; sour apple (also "lily") 5-7-10; christmas tree 2-7-10, 3-7-10;
  washout 1-2-10, 1-2-4-10, 1-3-7, 1-3-6-7 ("not considered splits because the headpin is
  still standing"): http://champbowltour.blogspot.com/2008/09/splits-have-their-names.html;
  baby split and big four also https://dictionaryofgambling.com/gambling_terms/bowling/b/,
  greek church also https://probsee.com/p/Split_(bowling), lily / sour apple also
  https://www.rookieroad.com/bowling/split/.
* bucket 2-4-5-8 or 3-5-6-9 ("a four-pin grouping on the right or left side"):
  http://blog.syracuse.com/sports/2009/01/popular_lane_lingo.html (the 3-5-6-9 as the
  left-hander's: http://mnbowling.com/nickelsworthgotlingo.shtml); picket fence 1-2-4-7,
  1-3-6-10: the same Syracuse page.
* stone 9: the 9 pin a right-hander's pocket hit leaves (the ball strikes 1-3-5-9 and the 9
  stands), the 8 pin for a left-hander ("stone 8"): https://blogall.co.kr/pin (pins 1, 3, 5, 9,
  "for left-handers, these would be pins 1, 2, 5, and 8").

Rules of this module: a named leave reads "<name> (<pins>)", e.g. "baby split (3-10)"; any
other split "<pins> split" ("7-10 split", "4-9 split"); a washout (head pin standing, clause a
holding among the other pins) "washout (<pins>)"; one pin "<n> pin" or the hand's "stone 9" /
"stone 8"; anything else the pins joined by "-". Splits, washouts and nicknames are first-ball
leaves: after a second ball an empty deck is a "spare", one pin "<n> pin", else the pins.
"""

from __future__ import annotations

from collections.abc import Iterable
from itertools import combinations
from typing import Literal

from bowlrec.errors import InputError

__all__ = [
    "PIN_NUMBERS",
    "PIN_PLACES",
    "PinNumberError",
    "is_split",
    "is_washout",
    "leave_label",
    "mirror_pins",
    "name_leave",
]

Hand = Literal["right", "left"]

PIN_NUMBERS: tuple[int, ...] = tuple(range(1, 11))

#: pin -> (row from the head pin, lateral in half pin spacings (6 in) to the left, +y)
PIN_PLACES: dict[int, tuple[int, int]] = {
    1: (0, 0),
    2: (1, 1),
    3: (1, -1),
    4: (2, 2),
    5: (2, 0),
    6: (2, -2),
    7: (3, 3),
    8: (3, 1),
    9: (3, -1),
    10: (3, -3),
}

_MIRROR = {1: 1, 2: 3, 3: 2, 4: 6, 5: 5, 6: 4, 7: 10, 8: 9, 9: 8, 10: 7}

#: pin -> the two pins of the next row that it stands immediately ahead of
_AHEAD_OF = {1: (2, 3), 2: (4, 5), 3: (5, 6), 4: (7, 8), 5: (8, 9), 6: (9, 10)}

#: nicknames of first-ball leaves (sorted pins -> name), for either hand
_NAMES: dict[tuple[int, ...], str] = {
    (2, 7): "baby split",
    (3, 10): "baby split",
    (4, 6, 7, 10): "big four",
    (2, 4, 6, 7, 10): "big five",
    (3, 4, 6, 7, 10): "big five",
    (4, 6, 7, 8, 10): "greek church",
    (4, 6, 7, 9, 10): "greek church",
    (5, 7, 10): "sour apple",
    (2, 7, 10): "christmas tree",
    (3, 7, 10): "christmas tree",
    (2, 4, 5, 8): "bucket",
    (3, 5, 6, 9): "bucket",
    (1, 2, 4, 7): "picket fence",
    (1, 3, 6, 10): "picket fence",
}

#: the pin a pocket hit leaves standing ("stone"), by hand
_STONE = {"right": 9, "left": 8}


class PinNumberError(InputError, ValueError):
    """A pin number outside 1-10, or a pin given twice."""


def _pins(standing: Iterable[int]) -> tuple[int, ...]:
    """``standing`` sorted, checked: pin numbers 1-10, each at most once."""
    pins = tuple(standing)
    bad = [p for p in pins if p not in _MIRROR]
    if bad:
        raise PinNumberError(f"pins are numbered 1-10, not {bad}")
    if len(set(pins)) != len(pins):
        raise PinNumberError(f"a pin is given twice in {sorted(pins)}")
    return tuple(sorted(pins))


def leave_label(standing: Iterable[int]) -> str:
    """The standing pins in ascending order joined by "-" ("2-4-5"); "" for none."""
    return "-".join(str(p) for p in _pins(standing))


def mirror_pins(pins: Iterable[int]) -> tuple[int, ...]:
    """The pins' mirror images through the lane's centre line (a right-hander's pins as the
    left-hander's), in the given order: 1-1, 2-3, 4-6, 5-5, 7-10, 8-9."""
    out = tuple(pins)
    _pins(out)
    return tuple(_MIRROR[p] for p in out)


def _between(p: int, a: int, b: int) -> bool:
    """Pin ``p`` lies between pins ``a`` and ``b`` (its lateral strictly between theirs, its
    row within theirs)."""
    (rp, lp), (ra, la), (rb, lb) = PIN_PLACES[p], PIN_PLACES[a], PIN_PLACES[b]
    return min(la, lb) < lp < max(la, lb) and min(ra, rb) <= rp <= max(ra, rb)


def _gap_between(standing: frozenset[int]) -> bool:
    """Clause a: two standing pins with pins between them, all of them down."""
    for a, b in combinations(standing, 2):
        between = [p for p in PIN_NUMBERS if _between(p, a, b)]
        if between and not standing.intersection(between):
            return True
    return False


def _gap_ahead(standing: frozenset[int]) -> bool:
    """Clause b: some pin that is down stands immediately ahead of two standing pins."""
    return any(
        p not in standing and a in standing and b in standing for p, (a, b) in _AHEAD_OF.items()
    )


def is_split(standing: Iterable[int]) -> bool:
    """Whether the pins standing after a first ball are a split by the USBC rule (module
    docstring): the head pin down and clause a or b holding."""
    up = frozenset(_pins(standing))
    if 1 in up or len(up) < 2:
        return False
    return _gap_between(up) or _gap_ahead(up)


def is_washout(standing: Iterable[int]) -> bool:
    """Whether the pins are a washout: the head pin standing, and a pin down between two of
    the other standing pins (clause a of the split rule among them; 1-2-10, 1-3-7)."""
    up = frozenset(_pins(standing))
    return 1 in up and _gap_between(up - {1})


def name_leave(standing: Iterable[int], *, hand: Hand = "right", first_ball: bool = True) -> str:
    """The leave's name as bowlers say it (module docstring), for a bowler of ``hand``;
    ``first_ball`` False after a ball at a partial rack (no splits, stones or nicknames)."""
    if hand not in _STONE:
        raise ValueError(f"hand must be 'right' or 'left', not {hand!r}")
    pins = _pins(standing)
    label = leave_label(pins)
    if not pins:
        return "strike" if first_ball else "spare"
    if len(pins) == 1:
        return "stone " + label if first_ball and pins[0] == _STONE[hand] else label + " pin"
    if not first_ball:
        return label
    if pins in _NAMES:
        return f"{_NAMES[pins]} ({label})"
    if is_washout(pins):
        return f"washout ({label})"
    if is_split(pins):
        return label + " split"
    return label

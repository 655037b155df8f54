"""The leave in bowlers' words and the USBC split rule (:mod:`bowlrec.pins.leaves`)."""

from __future__ import annotations

from itertools import combinations

import pytest

from bowlrec.pins.leaves import (
    PIN_NUMBERS,
    PinNumberError,
    is_split,
    is_washout,
    leave_label,
    mirror_pins,
    name_leave,
)

ALL_LEAVES = [c for k in range(11) for c in combinations(PIN_NUMBERS, k)]


@pytest.mark.parametrize(
    "leave",
    [
        (7, 9),  # the rule's clause a examples
        (3, 10),
        (5, 6),  # the rule's clause b example
        (4, 5),  # its mirror image: 2 down immediately ahead of 4 and 5
        (2, 3),
        (8, 9),
        (7, 10),
        (4, 6),
        (2, 7),
        (8, 10),
        (4, 9),
        (6, 7, 10),
        (4, 6, 7, 10),
        (5, 7, 10),
        (2, 10),
        (3, 7),
        (2, 4, 5, 7, 9),  # 7 and 9 with 8 down between them
    ],
)
def test_splits_by_the_usbc_rule(leave: tuple[int, ...]) -> None:
    assert is_split(leave)


@pytest.mark.parametrize(
    "leave",
    [
        (2, 4),
        (2, 4, 5, 8),  # the bucket: 2 stands ahead of 4-5
        (2, 8),  # one directly behind the other: nothing between
        (3, 9),
        (3, 6, 10),
        (4, 7),
        (6, 10),
        (5, 8),
        (5, 9),
        (2, 4, 5, 9),  # 5 stands between 4 and 9
        (4, 7, 8),
        (10,),
        (),
    ],
)
def test_leaves_that_are_not_splits(leave: tuple[int, ...]) -> None:
    assert not is_split(leave)


def test_a_leave_with_the_head_pin_is_never_a_split() -> None:
    with_head = [c for c in ALL_LEAVES if 1 in c]
    assert not any(is_split(c) for c in with_head)
    # ...though the same pins behind it often are
    assert sum(is_split(tuple(p for p in c if p != 1)) for c in with_head) > 100


def test_the_split_rule_is_mirror_symmetric() -> None:
    for leave in ALL_LEAVES:
        assert is_split(leave) == is_split(mirror_pins(leave)), leave


def test_washouts_keep_the_head_pin_with_a_gap_behind_it() -> None:
    for leave in [(1, 2, 10), (1, 2, 4, 10), (1, 3, 7), (1, 3, 6, 7)]:
        assert is_washout(leave) and name_leave(leave) == f"washout ({leave_label(leave)})"
    for leave in [(1, 2, 3), (1, 2, 4, 7), (1, 5), (1, 10), (2, 10)]:
        assert not is_washout(leave), leave


def test_mirror_pins_maps_each_pin_and_keeps_the_order() -> None:
    assert mirror_pins(PIN_NUMBERS) == (1, 3, 2, 6, 5, 4, 10, 9, 8, 7)
    assert mirror_pins((3, 1, 10)) == (2, 1, 7)
    assert all(mirror_pins(mirror_pins(c)) == c for c in ALL_LEAVES)


def test_leave_label_sorts_and_joins() -> None:
    assert leave_label([8, 2, 5, 4]) == "2-4-5-8"
    assert leave_label([]) == ""


@pytest.mark.parametrize(
    ("standing", "hand", "first_ball", "name"),
    [
        ((), "right", True, "strike"),
        ((), "right", False, "spare"),
        ((10,), "right", True, "10 pin"),
        ((7,), "right", True, "7 pin"),
        ((4,), "right", True, "4 pin"),
        ((5,), "right", True, "5 pin"),
        ((9,), "right", True, "stone 9"),
        ((9,), "left", True, "9 pin"),
        ((8,), "left", True, "stone 8"),
        ((8,), "right", True, "8 pin"),
        ((9,), "right", False, "9 pin"),
        ((7, 10), "right", True, "7-10 split"),
        ((4, 6), "left", True, "4-6 split"),
        ((8, 10), "right", True, "8-10 split"),
        ((7, 9), "left", True, "7-9 split"),
        ((2, 7), "right", True, "baby split (2-7)"),
        ((3, 10), "right", True, "baby split (3-10)"),
        ((4, 6, 7, 10), "right", True, "big four (4-6-7-10)"),
        ((3, 4, 6, 7, 10), "right", True, "big five (3-4-6-7-10)"),
        ((4, 6, 7, 9, 10), "right", True, "greek church (4-6-7-9-10)"),
        ((4, 6, 7, 8, 10), "left", True, "greek church (4-6-7-8-10)"),
        ((2, 4, 5, 8), "right", True, "bucket (2-4-5-8)"),
        ((3, 5, 6, 9), "left", True, "bucket (3-5-6-9)"),
        ((5, 7, 10), "right", True, "sour apple (5-7-10)"),
        ((1, 2, 10), "right", True, "washout (1-2-10)"),
        ((1, 2, 4, 7), "right", True, "picket fence (1-2-4-7)"),
        ((4, 9), "right", True, "4-9 split"),
        ((2, 4, 5), "right", True, "2-4-5"),
        ((3, 6, 10), "right", True, "3-6-10"),
        ((7, 10), "right", False, "7-10"),
        ((1, 2, 10), "right", False, "1-2-10"),
    ],
)
def test_name_leave(standing: tuple[int, ...], hand: str, first_ball: bool, name: str) -> None:
    assert name_leave(standing, hand=hand, first_ball=first_ball) == name  # type: ignore[arg-type]


def test_names_take_the_pins_in_any_order() -> None:
    assert name_leave([10, 7]) == name_leave((7, 10)) == "7-10 split"


@pytest.mark.parametrize("bad", [(0,), (11,), (3, 3), (-1, 2)])
def test_bad_pin_numbers_are_refused(bad: tuple[int, ...]) -> None:
    with pytest.raises(PinNumberError):
        name_leave(bad)
    with pytest.raises(ValueError):
        is_split(bad)


def test_an_unknown_hand_is_refused() -> None:
    with pytest.raises(ValueError, match="hand"):
        name_leave((10,), hand="both")  # type: ignore[arg-type]

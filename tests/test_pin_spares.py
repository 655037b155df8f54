"""The 3-6-9 cross-lane spare system (:mod:`bowlrec.pins.spares`)."""

from __future__ import annotations

from itertools import combinations

import pytest

from bowlrec.pins.leaves import PIN_NUMBERS, PinNumberError, mirror_pins
from bowlrec.pins.spares import key_pin, pin_board, spare_target
from bowlrec.units import BOARDS, LANE_WIDTH_IN

LEAVES = [c for k in range(1, 10) for c in combinations(PIN_NUMBERS, k)]
BOARD_IN = LANE_WIDTH_IN / BOARDS


def test_pin_boards_follow_the_deck() -> None:
    assert pin_board(1) == 20.0 and pin_board(5) == 20.0
    # 6 in per half spacing: the 3 pin 6 in right of the head pin, the 2 pin 6 in left
    assert (20.0 - pin_board(3)) * BOARD_IN == pytest.approx(6.0)
    assert (pin_board(2) - 20.0) * BOARD_IN == pytest.approx(6.0)
    # the 10 and 7 spots 2.75 in from the lane's edges (boards 0.5 and 39.5)
    assert (pin_board(10) - 0.5) * BOARD_IN == pytest.approx(2.75)
    assert (39.5 - pin_board(7)) * BOARD_IN == pytest.approx(2.75)
    assert pin_board(8) == pytest.approx(pin_board(2)) and pin_board(9) == pin_board(3)
    # a left-hander counts from the other gutter
    assert pin_board(10, "left") == pytest.approx(pin_board(7))


@pytest.mark.parametrize(
    ("leave", "key"),
    [
        ((2, 4, 5, 8), 2),
        ((3, 6, 10), 3),
        ((1, 2, 4, 7), 1),
        ((6, 10), 6),
        ((4, 7), 4),
        ((5, 8, 9), 5),
        ((4, 5), 5),  # in a row, the pin nearer the centre line
        ((8, 10), 8),
        ((4, 6, 9, 10), 6),  # the larger group of the row
        ((7, 10), 7),  # the side away from a right hand
    ],
)
def test_key_pins(leave: tuple[int, ...], key: int) -> None:
    assert key_pin(leave) == key
    assert key_pin(mirror_pins(leave), "left") == mirror_pins((key,))[0]


@pytest.mark.parametrize("pin", PIN_NUMBERS)
def test_a_single_pin_is_aimed_at_its_board(pin: int) -> None:
    for hand in ("right", "left"):
        target = spare_target([pin], hand)  # type: ignore[arg-type]
        assert target.key_pin == pin
        assert target.target_board == pytest.approx(pin_board(pin, hand))  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("pin", "move", "side"),
    [
        (10, 9, "left"),
        (6, 6, "left"),
        (3, 3, "left"),
        (9, 3, "left"),
        (1, 0, "middle"),
        (5, 0, "middle"),
        (2, -3, "right"),
        (8, -3, "right"),
        (4, -6, "right"),
        (7, -9, "right"),
    ],
)
def test_the_369_moves_of_a_right_hander(pin: int, move: int, side: str) -> None:
    target = spare_target([pin], "right")
    assert target.stance_move_boards == move
    assert target.crosses_from == side


def test_a_left_hander_moves_the_mirror_way() -> None:
    ten = spare_target([10], "left")  # the left-hander's far corner... on the lane's right
    assert ten.stance_move_boards == -9 and ten.crosses_from == "left"
    seven = spare_target([7], "left")  # the left-hander's own corner
    assert seven.stance_move_boards == 9 and seven.crosses_from == "right"


def test_the_system_is_mirror_symmetric() -> None:
    for leave in LEAVES:
        right = spare_target(leave, "right")
        left = spare_target(mirror_pins(leave), "left")
        assert left.key_pin == mirror_pins((right.key_pin,))[0], leave
        assert left.target_board == pytest.approx(right.target_board), leave
        assert left.stance_move_boards == right.stance_move_boards, leave
        assert {left.crosses_from, right.crosses_from} in ({"middle"}, {"left", "right"}), leave


def test_leaves_are_hit_on_the_side_of_the_other_pins() -> None:
    # 6-10: the 6 on its right side, toward the 10 (lower boards for a right-hander)
    assert pin_board(10) < spare_target([6, 10]).target_board < pin_board(6)
    # 4-7: the 4 on its left side
    assert pin_board(4) < spare_target([4, 7]).target_board < pin_board(7)
    # 3-6-10: through the 3 toward the middle of the leave, the 6's board
    assert spare_target([3, 6, 10]).target_board == pytest.approx(pin_board(6))
    # side by side: midway, where the ball touches both
    assert spare_target([5, 6]).target_board == pytest.approx(pin_board(3))
    # the bucket, centred on the 2: the right-hander's pocket side of the 2 (2.5 boards)
    assert spare_target([2, 4, 5, 8]).target_board == pytest.approx(pin_board(2) - 2.5)
    assert spare_target([3, 5, 6, 9], "left").target_board == pytest.approx(pin_board(2) - 2.5)


def test_every_target_touches_its_key_pin() -> None:
    # the ball's centre within 6.68 in of the pin's (ball 8.595 in, pin belly 4.766 in across)
    reach_boards = (8.595 + 4.766) / 2.0 / BOARD_IN
    for leave in LEAVES:
        for hand in ("right", "left"):
            t = spare_target(leave, hand)  # type: ignore[arg-type]
            assert abs(t.target_board - pin_board(t.key_pin, hand)) < reach_boards  # type: ignore[arg-type]
            assert t.key_pin in leave


def test_no_spare_without_pins_and_bad_pins_are_refused() -> None:
    with pytest.raises(PinNumberError, match="no pins"):
        spare_target([])
    with pytest.raises(PinNumberError):
        key_pin([0, 3])
    with pytest.raises(ValueError, match="hand"):
        spare_target([3], "both")  # type: ignore[arg-type]

"""Ten-pin scoring (:mod:`bowlrec.pins.scoring`) against games scored by hand."""

from __future__ import annotations

import pytest

from bowlrec.pins.scoring import Game, ScoringError, frames_of, score_game

# World Bowling's universal playing rules 2.1.2 sheet (https://bowling.sport/?p=6749), the
# foul in frame 6 as a 0: X X X 7 2 8/ F9 X 7/ 9- XX8
RULEBOOK_GAME = [10, 10, 10, 7, 2, 8, 2, 0, 9, 10, 7, 3, 9, 0, 10, 10, 8]
RULEBOOK_SCORES = [30, 57, 76, 85, 95, 104, 124, 143, 152, 180]


def test_a_perfect_game() -> None:
    sheet = score_game([10] * 12)
    assert sheet.total == 300 and sheet.finished
    assert sheet.frame_scores == tuple(range(30, 301, 30))
    assert sheet.marks == "X X X X X X X X X XXX"


def test_all_gutters() -> None:
    sheet = score_game([0] * 20)
    assert sheet.total == 0 and sheet.finished
    assert sheet.marks == " ".join(["--"] * 10)


def test_all_spares_of_five() -> None:
    sheet = score_game([5] * 21)
    assert sheet.total == 150 and sheet.finished
    assert sheet.frame_scores[:3] == (15, 30, 45)
    assert sheet.marks == " ".join(["5/"] * 9 + ["5/5"])


def test_all_nine_and_a_miss() -> None:
    sheet = score_game([9, 0] * 10)
    assert sheet.total == 90 and sheet.finished
    assert sheet.marks == " ".join(["9-"] * 10)


def test_the_rulebook_game() -> None:
    sheet = score_game(RULEBOOK_GAME)
    assert list(sheet.frame_scores) == RULEBOOK_SCORES
    assert sheet.marks == "X X X 72 8/ -9 X 7/ 9- XX8"
    assert sheet.frames[9] == (10, 10, 8)


@pytest.mark.parametrize(
    ("tenth", "count", "marks"),
    [
        ([10, 10, 10], 30, "XXX"),
        ([10, 7, 3], 20, "X7/"),
        ([10, 7, 2], 19, "X72"),
        ([10, 10, 8], 28, "XX8"),
        ([9, 1, 10], 20, "9/X"),
        ([0, 10, 4], 14, "-/4"),
        ([9, 0], 9, "9-"),
    ],
)
def test_tenth_frame_variants(tenth: list[int], count: int, marks: str) -> None:
    sheet = score_game([0] * 18 + tenth)
    assert sheet.finished and sheet.total == count
    assert sheet.marks.split()[-1] == marks


def test_bonuses_wait_for_their_balls() -> None:
    assert score_game([10]).frame_scores == (None,)
    assert score_game([10, 10]).frame_scores == (None, None)
    assert score_game([10, 10, 4]).frame_scores == (24, None, None)
    assert score_game([10, 3, 4]).frame_scores == (17, 24)
    assert score_game([7, 3]).frame_scores == (None,)
    assert score_game([7, 3, 5]).frame_scores == (15, None)
    assert score_game([7, 3, 5]).total == 15
    assert score_game([]).total == 0


@pytest.mark.parametrize(
    ("balls", "message"),
    [
        ([7, 5], "5 pins down but 3 were standing"),  # more than 10 in a frame
        ([0] * 18 + [10, 7, 5], "3 were standing"),  # after X 7 in the tenth, 3 stand
        ([0] * 18 + [9, 0, 1], "over"),  # no bonus ball without a mark
        ([0] * 21, "over"),
        ([10] * 13, "over"),
        ([11], "11 pins down"),
        ([-1], "integer"),
        ([True], "integer"),
        ([2.0], "integer"),
    ],
)
def test_impossible_games_are_refused(balls: list[int], message: str) -> None:
    with pytest.raises(ScoringError, match=message):
        score_game(balls)


def test_frames_of_groups_balls() -> None:
    assert frames_of([10, 7, 3, 9, 0]) == [[10], [7, 3], [9, 0]]
    assert frames_of([0] * 18 + [10, 10, 10])[-1] == [10, 10, 10]


def test_game_ball_by_ball() -> None:
    game = Game()
    seen = []
    for pins in RULEBOOK_GAME:
        seen.append((game.frame, game.ball_in_frame, game.needs_reset(), game.pins_standing))
        game.roll(pins)
    assert game.finished and game.score == 180
    assert game.frame_scores() == RULEBOOK_SCORES
    assert game.marks() == score_game(RULEBOOK_GAME).marks
    assert seen[:5] == [(1, 1, True, 10), (2, 1, True, 10), (3, 1, True, 10), (4, 1, True, 10)] + [
        (4, 2, False, 3)
    ]
    # the tenth: X (reset), X (reset), 8 at a full rack (reset)
    assert seen[-3:] == [(10, 1, True, 10), (10, 2, True, 10), (10, 3, True, 10)]
    assert (game.frame, game.ball_in_frame, game.needs_reset(), game.pins_standing) == (
        10,
        3,
        False,
        0,
    )


def test_tenth_frame_resets() -> None:
    spare = Game([0] * 18 + [9])
    assert (spare.ball_in_frame, spare.needs_reset(), spare.pins_standing) == (2, False, 1)
    spare.roll(1)
    assert (spare.ball_in_frame, spare.needs_reset(), spare.pins_standing) == (3, True, 10)
    after_strike = Game([0] * 18 + [10, 6])
    assert (after_strike.needs_reset(), after_strike.pins_standing) == (False, 4)
    open_tenth = Game([0] * 18 + [9, 0])
    assert open_tenth.finished and open_tenth.score == 9


def test_a_gutter_first_ball_leaves_the_rack_standing_but_not_reset() -> None:
    game = Game([0])
    assert game.pins_standing == 10 and not game.needs_reset()


def test_a_refused_roll_leaves_the_game_as_it_was() -> None:
    game = Game([7])
    with pytest.raises(ScoringError):
        game.roll(4)
    assert game.balls == (7,) and game.pins_standing == 3
    done = Game([10] * 12)
    with pytest.raises(ScoringError, match="over"):
        done.roll(0)
    assert done.score == 300

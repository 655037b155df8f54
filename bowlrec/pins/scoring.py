"""Ten-pin scoring from the pinfall of each ball: frame scores with bonuses, the score sheet's
marks, and a game a session plays ball by ball.

Rules (USBC Playing Rules, rule 2, https://docslib.org/doc/2410441/usbc-bowling-rules; World
Bowling's universal playing rules 2.1, https://bowling.sport/?p=6749): a game is ten frames;
two balls a frame unless the first is a strike (all ten pins with the first ball of a frame);
"the count for one strike is 10 plus the number of pins knocked down on the player's next two
deliveries"; a spare (the pins left by the first ball all down with the second) counts "10 plus
the number of pins knocked down by the player's next delivery"; "in the 10th frame, a player
delivers three balls if a strike or spare is scored": after a strike in the tenth the next ball
is at a full rack, and so is the one after a second strike or after a spare; otherwise the
third ball is at the pins the second left. The tenth frame counts its pins (its bonus balls are
its own), so twelve strikes make 300.

Marks as on a score sheet: "X" a strike (a ball that downs a full rack), "/" the ball that
completes a spare, "-" a ball that downs nothing, otherwise the pinfall's digit; frames
separated by a space ("X 7/ 9- ... X7/"). Fouls are not modelled (a foul ball is a 0 here).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from bowlrec.errors import InputError

__all__ = ["FRAMES", "PINS", "Game", "ScoreSheet", "ScoringError", "frames_of", "score_game"]

FRAMES = 10
PINS = 10


class ScoringError(InputError, ValueError):
    """A sequence of balls no game can have: more pins than stand, or a ball after the end."""


@dataclass(frozen=True)
class ScoreSheet:
    """A game's score sheet so far.

    frames: the pinfall of each ball, frame by frame (frames begun); frame_scores: the
    cumulative score at the end of each begun frame, None while the frame or its bonus balls
    are not yet thrown; total: the last cumulative score decided (0 before any); marks: the
    marks, frames separated by spaces; finished: all ten frames are complete.
    """

    frames: tuple[tuple[int, ...], ...]
    frame_scores: tuple[int | None, ...]
    total: int
    marks: str
    finished: bool


def _complete(frame: Sequence[int], tenth: bool) -> bool:
    """Whether no more balls belong to ``frame``."""
    if not tenth:
        return len(frame) == 2 or (len(frame) == 1 and frame[0] == PINS)
    if len(frame) < 2:
        return False
    return len(frame) == 3 or frame[0] + frame[1] < PINS


def _reset_before_next(frame: Sequence[int], tenth: bool) -> bool:
    """Whether the next ball of ``frame`` (or of the next frame) is at a full, newly set rack."""
    if not frame or _complete(frame, tenth):
        return True
    if len(frame) == 1:
        return tenth and frame[0] == PINS
    first, second = frame[0], frame[1]  # the tenth's third ball
    return second == PINS if first == PINS else first + second == PINS


def _standing(frame: Sequence[int], tenth: bool) -> int:
    """Pins standing for the next ball of an incomplete ``frame``."""
    if _reset_before_next(frame, tenth):
        return PINS
    return PINS - (frame[-1] if tenth and frame[0] == PINS else sum(frame))


def frames_of(balls: Sequence[int]) -> list[list[int]]:
    """The balls (pins down by each, in order) grouped into frames; raises
    :class:`ScoringError` for a ball that downs more pins than stand, a negative or non-integer
    ball, or a ball after the tenth frame is complete."""
    frames: list[list[int]] = []
    for i, pins in enumerate(balls, start=1):
        if isinstance(pins, bool) or not isinstance(pins, int) or pins < 0:
            raise ScoringError(f"ball {i}: pins down must be an integer 0-10, not {pins!r}")
        if not frames or _complete(frames[-1], len(frames) == FRAMES):
            if len(frames) == FRAMES:
                raise ScoringError(f"ball {i}: the game is over after ten frames")
            frames.append([])
        n = len(frames)
        up = _standing(frames[-1], n == FRAMES)
        if pins > up:
            raise ScoringError(f"ball {i} (frame {n}): {pins} pins down but {up} were standing")
        frames[-1].append(pins)
    return frames


def _frame_counts(balls: Sequence[int], frames: Sequence[Sequence[int]]) -> list[int | None]:
    """Each begun frame's own count (with its bonus), None while undecided."""
    counts: list[int | None] = []
    start = 0
    for n, frame in enumerate(frames, start=1):
        tenth = n == FRAMES
        if not _complete(frame, tenth):
            counts.append(None)
        elif tenth or sum(frame) < PINS:
            counts.append(sum(frame))
        else:
            bonus = balls[start + len(frame) : start + 3]  # strike: two balls, spare: one
            counts.append(sum(frame) + sum(bonus) if len(frame) + len(bonus) == 3 else None)
        start += len(frame)
    return counts


def _marks(frames: Sequence[Sequence[int]]) -> str:
    out = []
    for n, frame in enumerate(frames, start=1):
        tenth = n == FRAMES
        marks = ""
        for k, pins in enumerate(frame):
            full = _reset_before_next(frame[:k], tenth)
            if full and pins == PINS:
                marks += "X"
            elif not full and pins == _standing(frame[:k], tenth):
                marks += "/"
            else:
                marks += "-" if pins == 0 else str(pins)
        out.append(marks)
    return " ".join(out)


def score_game(balls: Sequence[int]) -> ScoreSheet:
    """The score sheet of a game (complete or not) from the pins each ball downed, in order;
    raises :class:`ScoringError` for an impossible sequence (:func:`frames_of`)."""
    frames = frames_of(balls)
    running = 0
    cumulative: list[int | None] = []
    decided = True
    for count in _frame_counts(balls, frames):
        decided = decided and count is not None
        if decided and count is not None:
            running += count
        cumulative.append(running if decided else None)
    finished = len(frames) == FRAMES and _complete(frames[-1], True)
    return ScoreSheet(
        frames=tuple(tuple(f) for f in frames),
        frame_scores=tuple(cumulative),
        total=running,
        marks=_marks(frames),
        finished=finished,
    )


class Game:
    """One bowler's game, played ball by ball: :meth:`roll` the pins each ball downs.

    ``frame`` and ``ball_in_frame`` name the next ball (frame 1-10, ball 1-3); once the game
    is finished they stay at the last ball thrown. :meth:`needs_reset` says whether the next
    ball meets a full, newly set rack (the first ball of a frame; in the tenth also the ball
    after a strike or a spare); ``pins_standing`` how many pins stand for it.
    """

    def __init__(self, balls: Sequence[int] = ()) -> None:
        self._balls: list[int] = []
        self._frames: list[list[int]] = []
        for pins in balls:
            self.roll(pins)

    def roll(self, pins_down: int) -> None:
        """Record the next ball's pinfall; raises :class:`ScoringError` (leaving the game as
        it was) if more pins fall than stand or the game is over."""
        self._frames = frames_of([*self._balls, pins_down])
        self._balls.append(pins_down)

    @property
    def balls(self) -> tuple[int, ...]:
        """The pinfall of every ball so far, in order."""
        return tuple(self._balls)

    @property
    def finished(self) -> bool:
        """All ten frames complete."""
        return len(self._frames) == FRAMES and _complete(self._frames[-1], True)

    def _next(self) -> tuple[int, list[int]]:
        """The frame number of the next ball and the balls already in that frame."""
        if not self._frames:
            return 1, []
        n, last = len(self._frames), self._frames[-1]
        if self.finished or not _complete(last, n == FRAMES):
            return n, last
        return n + 1, []

    @property
    def frame(self) -> int:
        """The frame (1-10) of the next ball (10 once finished)."""
        return self._next()[0]

    @property
    def ball_in_frame(self) -> int:
        """The next ball's number in its frame, 1-3 (once finished: the tenth's last ball's)."""
        n, balls = self._next()
        return len(balls) if self.finished else len(balls) + 1

    def needs_reset(self) -> bool:
        """Whether the next ball is thrown at a full, newly set rack (False once finished)."""
        if self.finished:
            return False
        n, balls = self._next()
        return _reset_before_next(balls, n == FRAMES)

    @property
    def pins_standing(self) -> int:
        """How many pins stand for the next ball (0 once finished)."""
        if self.finished:
            return 0
        n, balls = self._next()
        return _standing(balls, n == FRAMES)

    def sheet(self) -> ScoreSheet:
        """The score sheet so far."""
        return score_game(self._balls)

    @property
    def score(self) -> int:
        """The last cumulative score decided (the final score once finished)."""
        return self.sheet().total

    def frame_scores(self) -> list[int | None]:
        """The cumulative score after each begun frame, None while undecided."""
        return list(self.sheet().frame_scores)

    def marks(self) -> str:
        """The score sheet's marks ("X 7/ 9- ...")."""
        return self.sheet().marks

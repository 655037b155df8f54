"""Lane geometry in bowlers' terms: feet, inches, boards and arrows, for either hand.

Conventions (lane frame of :mod:`bowlrec.spec`: x from the foul line toward the pins, y from the
RIGHT gutter toward the left, z up; m):

* The lane is ``width_in`` wide (default 41.5 in, the USBC nominal width; 42 in reproduces the
  paper) and ``length_ft`` from the foul line to the head pin (default 60 ft). It has 39 boards of
  equal width ``w = width / 39``.
* Boards are counted from the gutter on the bowler's hand side: board 1 at the RIGHT gutter for a
  right-hander, at the LEFT gutter for a left-hander. Board numbers are continuous ("fractional
  boards"): a point at distance ``d`` from the bowler's gutter is on board ``b = d / w + 0.5``.
  So integer ``n`` is the CENTER of board n (``d = (n - 0.5) w``), board n spans
  ``d in [(n - 1) w, n w]``, ``n + 0.5`` is the edge between boards n and n + 1 (the pocket's
  "17.5 board" is the edge between 17 and 18), and the lane edges are boards 0.5 and 39.5.
* Board 20 is the center board (``d = 19.5 w = width / 2``): the head pin stands on it.
* The arrows are 15 ft past the foul line, on boards 5, 10, ..., 35 (board centers).
* Mirroring between hands is the reflection through the lane's center line,
  ``y -> width - y``: board b of a right-hander and board b of a left-hander are mirror images.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from bowlrec.spec import Friction, Lane
from bowlrec.spec._base import PositiveFloat, SpecModel
from bowlrec.units import (
    ARROWS_FT,
    BOARDS,
    FT_M,
    HEAD_PIN_BOARD,
    IN_M,
    LANE_LENGTH_FT,
    LANE_WIDTH_IN,
)

__all__ = [
    "ARROW_BOARDS",
    "BowlerLane",
    "HANDEDNESS",
    "Handedness",
    "LANE_WIDTH_MAX_IN",
    "LANE_WIDTH_MIN_IN",
    "PAPER_LANE_WIDTH_IN",
]

#: which hand delivers the ball; sets where board 1 is (the gutter on that hand's side)
Handedness = Literal["right", "left"]
#: the allowed values of :data:`Handedness`
HANDEDNESS: tuple[Handedness, ...] = ("right", "left")
#: boards the seven arrows sit on (board centers), counted from the bowler's gutter
ARROW_BOARDS: tuple[int, ...] = (5, 10, 15, 20, 25, 30, 35)
#: lane width tolerance (in): USBC 41.5 in +- 0.5 in
#: the physical limit (bowlrec.spec.limits) in feet, rounded down
MAX_LANE_FT = 32_800.0
LANE_WIDTH_MIN_IN = 41.0
LANE_WIDTH_MAX_IN = 42.0
#: Frohlich (2004) lane width (in)
PAPER_LANE_WIDTH_IN = 42.0


class BowlerLane(SpecModel):
    """A lane's geometry in feet, inches and boards (no friction; the oil pattern is separate).

    All conversions take a ``handedness`` ("right" or "left", default "right") because boards
    are counted from the bowler's own gutter; positions are lane-frame y in meters from the RIGHT
    gutter.
    """

    length_ft: PositiveFloat = Field(
        default=LANE_LENGTH_FT,
        le=MAX_LANE_FT,
        description=(
            f"Foul line to the head pin's center (ft), in (0, {MAX_LANE_FT:g}]; 60 ft by rule."
        ),
    )
    width_in: float = Field(
        default=LANE_WIDTH_IN,
        ge=LANE_WIDTH_MIN_IN,
        le=LANE_WIDTH_MAX_IN,
        allow_inf_nan=False,
        description=(
            "Width between the gutters (in), in [41, 42] (USBC 41.5 +- 0.5 in); 41.5 is the "
            "nominal width, 42 the paper's."
        ),
    )

    # --- extents in SI -------------------------------------------------------------------

    @property
    def length_m(self) -> float:
        """Foul line to the head pin (m)."""
        return self.length_ft * FT_M

    @property
    def width_m(self) -> float:
        """Width between the gutters (m)."""
        return self.width_in * IN_M

    @property
    def board_width_m(self) -> float:
        """Width of one board (m): width / 39."""
        return self.width_m / BOARDS

    @property
    def arrows_x_m(self) -> float:
        """Distance of the arrows from the foul line (m): 15 ft."""
        return ARROWS_FT * FT_M

    @property
    def head_pin_y_m(self) -> float:
        """Lane-frame y of the head pin (m): the center of board 20, the lane's center line."""
        return self.board_to_y_m(HEAD_PIN_BOARD)

    # --- boards <-> lane-frame y ---------------------------------------------------------

    def board_to_y_m(self, board: float, handedness: Handedness = "right") -> float:
        """Lane-frame y (m, from the right gutter) of fractional board ``board``.

        ``board`` is counted from the bowler's gutter; an integer is a board's center.
        """
        d = (board - 0.5) * self.board_width_m
        return d if handedness == "right" else self.mirror_y_m(d)

    def y_to_board(self, y_m: float, handedness: Handedness = "right") -> float:
        """Fractional board (counted from the bowler's gutter) at lane-frame y (m)."""
        d = y_m if handedness == "right" else self.mirror_y_m(y_m)
        return d / self.board_width_m + 0.5

    def board_edges_y_m(self, board: int, handedness: Handedness = "right") -> tuple[float, float]:
        """Lane-frame y (m) of the two edges of board ``board`` (1..39), smaller y first."""
        if not 1 <= board <= BOARDS:
            raise ValueError(f"board = {board} must be an integer in [1, {BOARDS}]")
        a = self.board_to_y_m(board - 0.5, handedness)
        b = self.board_to_y_m(board + 0.5, handedness)
        return (a, b) if a <= b else (b, a)

    def mirror_y_m(self, y_m: float) -> float:
        """Mirror image of lane-frame y (m) through the lane's center line: width - y."""
        return self.width_m - y_m

    def ft_to_x_m(self, distance_ft: float) -> float:
        """Lane-frame x (m) of a distance from the foul line given in feet."""
        return distance_ft * FT_M

    def x_m_to_ft(self, x_m: float) -> float:
        """Distance from the foul line (ft) of lane-frame x (m)."""
        return x_m / FT_M

    # --- the physical lane ---------------------------------------------------------------

    def to_physical(self, friction: Friction | None = None) -> Lane:
        """The SI :class:`~bowlrec.spec.Lane` with this geometry and ``friction`` (default: the
        physical lane's default friction map, the paper's typical pattern)."""
        if friction is None:
            return Lane(length_m=self.length_m, width_m=self.width_m)
        return Lane(length_m=self.length_m, width_m=self.width_m, friction=friction)

    @classmethod
    def from_physical(cls, lane: Lane) -> BowlerLane:
        """The geometry of an SI lane (its friction is not part of the geometry)."""
        return cls(length_ft=lane.length_m / FT_M, width_in=lane.width_m / IN_M)

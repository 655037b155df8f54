"""The pocket: where and at what angle a ball should reach the head pin line to strike.

One default is used everywhere (aiming, release scatter, reports): a right-hander's pocket is
between the head pin (board 20) and the 3 pin, entered at board 17.5 at 60 ft with a window of
boards 17-18; a left-hander's is the mirror image, which in bowlrec's boards (counted from the
bowling hand's gutter) has the same numbers. The entry angle window is 4-6 deg.

Sources: United States Bowling Congress, "Pin Carry Study" (USBC Equipment Specifications and
Certifications, 2008-2009; summarized in "USBC research: entry angle and pocket position",
https://bowl.com/): strike percentage peaks for balls entering near board 17.5 at an entry angle
of about 6 deg and falls off below 4 deg; the window used here (17-18 boards, 4-6 deg) is the
band of high carry in that work. Both are parameters: give your own to every command.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from bowlrec.spec._base import SpecModel, fmt, spec_error

__all__ = ["POCKET", "Pocket"]


class Pocket(SpecModel):
    """The target at the head pin line: entry board and angle with their windows (boards are
    the bowler's own count; angles in degrees toward higher boards)."""

    board: float = Field(default=17.5, ge=0.5, le=39.5, description="Entry board to aim at.")
    board_min: float = Field(default=17.0, ge=0.5, le=39.5, description="Window: lowest board.")
    board_max: float = Field(default=18.0, ge=0.5, le=39.5, description="Window: highest board.")
    angle_deg: float = Field(
        default=5.0, gt=0.0, lt=30.0, description="Entry angle to aim at (deg), in (0, 30)."
    )
    angle_min_deg: float = Field(default=4.0, ge=0.0, lt=30.0, description="Window: lowest.")
    angle_max_deg: float = Field(default=6.0, gt=0.0, lt=30.0, description="Window: highest.")

    @model_validator(mode="after")
    def _ordered(self) -> Pocket:
        if not self.board_min <= self.board <= self.board_max:
            raise spec_error(
                f"pocket board = {fmt(self.board)} must lie in its window [{fmt(self.board_min)}"
                f", {fmt(self.board_max)}]"
            )
        if not self.angle_min_deg <= self.angle_deg <= self.angle_max_deg:
            raise spec_error(
                f"pocket angle_deg = {fmt(self.angle_deg)} must lie in its window "
                f"[{fmt(self.angle_min_deg)}, {fmt(self.angle_max_deg)}] deg"
            )
        return self

    def board_ok(self, board: float | None) -> bool:
        """The entry board lies in the window."""
        return board is not None and self.board_min <= board <= self.board_max

    def angle_ok(self, angle_deg: float | None) -> bool:
        """The entry angle lies in the window."""
        return angle_deg is not None and self.angle_min_deg <= angle_deg <= self.angle_max_deg

    def contains(self, board: float | None, angle_deg: float | None) -> bool:
        """Both the entry board and the entry angle lie in their windows."""
        return self.board_ok(board) and self.angle_ok(angle_deg)

    def contains_all(
        self, board: NDArray[np.float64], angle_deg: NDArray[np.float64]
    ) -> NDArray[np.bool_]:
        """:meth:`contains` element-wise (NaN: outside)."""
        with np.errstate(invalid="ignore"):
            return np.asarray(
                (board >= self.board_min) & (board <= self.board_max)
                & (angle_deg >= self.angle_min_deg) & (angle_deg <= self.angle_max_deg)
            )  # fmt: skip

    def describe(self) -> str:
        """One line: 'board 17.5 (17-18), 5 deg (4-6)'."""
        return (
            f"board {fmt(self.board)} ({fmt(self.board_min)}-{fmt(self.board_max)}), "
            f"{fmt(self.angle_deg)} deg ({fmt(self.angle_min_deg)}-{fmt(self.angle_max_deg)})"
        )


#: the default pocket (module docstring)
POCKET = Pocket()

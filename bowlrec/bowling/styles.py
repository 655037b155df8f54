"""Bowler types (styles) as delivery presets: stroker, tweener, cranker, two-handed.

A style is how a bowler releases the ball: speed, rev rate, axis rotation and axis tilt. Each
preset is a typical value with the range bowlers of that type cover; a bowler delivery with
``style`` takes the typical value of every release quantity it does not give itself
(:class:`~bowlrec.bowling.delivery.BowlerDelivery`). Which numbers are sourced and which are
assumed is said per quantity (``docs/calibration.md`` has the sources' own lines):

* **Rev rate.** Informal classes: stroker 250-350 rpm, tweener 300-400, cranker 400 and more
  (a weak source: the BowlerTrax reference notes, GitHub husky2466-codo/BowlerTrax-V1; PBA
  League 2020: men average 436 rpm, women 297, the highest 570 rpm a two-hander (Albany Times
  Union, 29 Sep 2020). The two-handed range (450-600) is the upper end of those figures: an
  assumption bounded by them.
* **Speed** at release: slow < 17, medium 17-19, fast > 19 mph (Shotmakers Pro Shop,
  "Definitions"); PBA League 2020 men average 18.61 mph, women 17.83 (Times Union). The per-type
  values are assumed inside that range.
* **Axis rotation and tilt.** Sample profiles often 30-60 deg of rotation (Blueprint Bowling,
  "Axis rotation and axis tilt explained"); tilt from 0 up to about 25-30 deg is common.
  No source gives them per type: the values are assumptions (more rotation and less tilt
  for the high-rev types) and are said to be.

**Skill** (release repeatability: :data:`~bowlrec.bowling.variance.PRESETS` ``robot | pro |
league``) is an independent axis: a style sets the release a bowler aims for, a scatter preset
how far each repeat strays from it. ``bowlrec variance`` and sessions combine the two: the
scatter is added to the styled release.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Literal, get_args

__all__ = ["STYLES", "STYLE_NAMES", "Style", "StylePreset", "StyleRange"]

#: a bowler type
Style = Literal["stroker", "tweener", "cranker", "two-handed"]
STYLE_NAMES: tuple[str, ...] = get_args(Style)


@dataclass(frozen=True)
class StyleRange:
    """A typical value and the range a type's bowlers cover, with whether it is sourced."""

    low: float
    typical: float
    high: float
    sourced: bool

    def __post_init__(self) -> None:
        if not self.low <= self.typical <= self.high:
            raise ValueError(f"need low <= typical <= high, got {self}")


@dataclass(frozen=True)
class StylePreset:
    """A bowler type's release: speed (mph at release), rev rate (rpm at release), axis
    rotation and axis tilt (deg), each a :class:`StyleRange`."""

    name: str
    speed_mph: StyleRange
    rev_rate_rpm: StyleRange
    axis_rotation_deg: StyleRange
    axis_tilt_deg: StyleRange
    summary: str

    def typical(self) -> dict[str, float]:
        """The typical value of every release quantity, by BowlerDelivery field name."""
        return {
            "speed_mph": self.speed_mph.typical,
            "rev_rate_rpm": self.rev_rate_rpm.typical,
            "axis_rotation_deg": self.axis_rotation_deg.typical,
            "axis_tilt_deg": self.axis_tilt_deg.typical,
        }


#: the presets (module docstring: what is sourced and what is assumed)
STYLES: MappingProxyType[str, StylePreset] = MappingProxyType(
    {
        "stroker": StylePreset(
            name="stroker",
            speed_mph=StyleRange(15.5, 16.5, 17.5, sourced=False),
            rev_rate_rpm=StyleRange(250.0, 300.0, 350.0, sourced=True),
            axis_rotation_deg=StyleRange(20.0, 35.0, 50.0, sourced=False),
            axis_tilt_deg=StyleRange(10.0, 15.0, 20.0, sourced=False),
            summary="smooth, accurate, lower rev rate and speed; plays straighter lines",
        ),
        "tweener": StylePreset(
            name="tweener",
            speed_mph=StyleRange(16.5, 17.5, 18.5, sourced=False),
            rev_rate_rpm=StyleRange(300.0, 350.0, 400.0, sourced=True),
            axis_rotation_deg=StyleRange(30.0, 45.0, 60.0, sourced=False),
            axis_tilt_deg=StyleRange(8.0, 12.0, 18.0, sourced=False),
            summary="between stroker and cranker: medium rev rate, speed and hook",
        ),
        "cranker": StylePreset(
            name="cranker",
            speed_mph=StyleRange(17.0, 18.0, 19.5, sourced=False),
            rev_rate_rpm=StyleRange(400.0, 450.0, 550.0, sourced=True),
            axis_rotation_deg=StyleRange(40.0, 50.0, 70.0, sourced=False),
            axis_tilt_deg=StyleRange(5.0, 10.0, 15.0, sourced=False),
            summary="one-handed power player: high rev rate, big hook, deeper lines",
        ),
        "two-handed": StylePreset(
            name="two-handed",
            speed_mph=StyleRange(17.0, 18.0, 19.5, sourced=False),
            rev_rate_rpm=StyleRange(450.0, 500.0, 600.0, sourced=True),
            axis_rotation_deg=StyleRange(30.0, 45.0, 60.0, sourced=False),
            axis_tilt_deg=StyleRange(3.0, 8.0, 15.0, sourced=False),
            summary="no thumb in the ball: the highest rev rates, low tilt, the deepest lines",
        ),
    }
)

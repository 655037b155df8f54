"""Exact unit conversions between bowlers' units and SI (definitions, not measurements).

inch = 0.0254 m, foot = 0.3048 m, pound = 0.45359237 kg, ounce = pound / 16, mile per hour =
0.44704 m/s, revolution per minute = 2 pi / 60 rad/s. The lane: 39 boards across its width,
board 1 at the right gutter for a right-hander, arrows at 15 ft, head pin on board 20.
"""

from __future__ import annotations

import math

__all__ = [
    "ARROWS_FT",
    "BOARDS",
    "FT_M",
    "HEAD_PIN_BOARD",
    "IN_M",
    "LANE_LENGTH_FT",
    "LANE_WIDTH_IN",
    "LB_KG",
    "MPH_MPS",
    "OZ_KG",
    "RPM_RADPS",
]

IN_M = 0.0254
FT_M = 0.3048
LB_KG = 0.45359237
OZ_KG = LB_KG / 16.0
MPH_MPS = 0.44704
RPM_RADPS = 2.0 * math.pi / 60.0

LANE_LENGTH_FT = 60.0
#: USBC lane width (in); the paper uses 42 in
LANE_WIDTH_IN = 41.5
BOARDS = 39
ARROWS_FT = 15.0
HEAD_PIN_BOARD = 20

"""Units: exact conversions between bowlers' units and SI, and the units of stored quantities.

Conversions (definitions, not measurements): inch = 0.0254 m, foot = 0.3048 m, pound =
0.45359237 kg, ounce = pound / 16, mile per hour = 0.44704 m/s, revolution per minute = 2 pi /
60 rad/s. The lane: 39 boards across its width, board 1 at the right gutter for a right-hander,
arrows at 15 ft, head pin on board 20.

Stored quantities: every dataset an archive or run file writes carries a ``units`` attribute
read off the project's naming convention (``speed_mps`` -> m/s) by :func:`units_for`; a name
with no recognised suffix and not listed as dimensionless is an error, so a new quantity cannot
be written without deciding its units. This module imports nothing of bowlrec.
"""

from __future__ import annotations

import math

__all__ = [
    "ARROWS_FT",
    "BOARDS",
    "DIMENSIONLESS",
    "FT_M",
    "HEAD_PIN_BOARD",
    "IN_M",
    "LANE_LENGTH_FT",
    "LANE_WIDTH_IN",
    "LB_KG",
    "MPH_MPS",
    "OZ_KG",
    "RPM_RADPS",
    "units_for",
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

#: name suffix -> units string (longest suffix wins)
_SUFFIX_UNITS = {
    "_s": "s",
    "_m": "m",
    "_m2": "m^2",
    "_mm": "mm",
    "_kg": "kg",
    "_mps": "m/s",
    "_mps2": "m/s^2",
    "_radps": "rad/s",
    "_radps2": "rad/s^2",
    "_rpm": "rev/min",
    "_deg": "deg",
    "_N": "N",
    "_Nm": "N m",
    "_J": "J",
    "_kg_m3": "kg/m^3",
    "_ft": "ft",
    "_boards": "board",
    "_ul": "uL",
}

#: quantities without units, with what their numbers mean
DIMENSIONLESS = {
    "mu": "friction coefficient",
    "phase": "0 sliding, 1 rolling",
    "quaternion_wxyz": "unit quaternion (w, x, y, z), body -> lane frame",
    "q0": "unit quaternion (w, x, y, z), body -> lane frame at release",
    "friction_mu": "friction coefficient per grid cell",
    "rtol": "relative tolerance",
    "record_mode": "0 summary, 1 steps, 2 rate",
    "record_terms": "per-term torques recorded (bool)",
    "slide_to_roll": "0 exact (slip = 0), 1 threshold (paper's rule)",
    "max_steps": "count",
    "kind": "event kind",
    "torque_term": "equation term",
    "drag_coefficient": "air drag coefficient C_D",
    "lift_model": "Magnus lift model (0 none, 1 Sawicki et al. 2003)",
    "rolling_resistance": "rolling-resistance coefficient C_rr",
    "cross_slope": "lane slope across dz/dy",
}


def units_for(name: str) -> str:
    """The units string for a quantity named by the project's convention ("1" if dimensionless).

    Raises KeyError for a name with neither a known unit suffix nor a dimensionless entry.
    """
    if name in DIMENSIONLESS:
        return "1"
    best = ""
    for suffix in _SUFFIX_UNITS:
        if name.endswith(suffix) and len(suffix) > len(best):
            best = suffix
    if not best:
        raise KeyError(f"no units known for quantity {name!r} (name it with a unit suffix)")
    return _SUFFIX_UNITS[best]

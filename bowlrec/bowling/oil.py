"""Oil patterns as lane machines print them (Kegel pattern sheets), the oil grid they lay down
(board x distance) and the statistics a pattern sheet states.

Lane frame and boards: x is the distance from the foul line (ft here, m in the physics), y runs
from the RIGHT gutter (y = 0) toward the left one. The lane has 39 boards; board b (numbered from
the right gutter, board 1 at the right gutter as a right-hander counts them) spans
y in [(b - 1) w, b w] with w = lane width / 39. Positions across the lane are written here in
*board widths from the right gutter* (d / w, a float in [0, 39]), so board b is [b - 1, b].
(Not the "fractional board" of :mod:`bowlrec.bowling.lane`, whose integer n is the center of
board n, i.e. n - 0.5 board widths here.)

Kegel sheet conventions (domain notes §6.1):

* **Board notation**: ``"2L"`` is board 2 counted from the left gutter, ``"2R"`` board 2 counted
  from the right gutter (= board 38 counted from the left). A step from ``2L`` to ``2R`` covers
  every board between and including both: boards 2..38 counted from the right, 37 boards. The
  L/R notation is absolute (it does not depend on the bowler's hand).
* **Loads**: how many times the oil head crosses the step's boards; each load puts ``mics_ul``
  microlitres on every board it crosses. Zero-load steps only move the machine ("travel to").
* **Crossed** (per step) = boards from start to stop (inclusive) x loads; **crosses** of a pass
  = sum over its steps; e.g. 2L-2R x 3 loads = 37 x 3 = 111.
* **Oil of a step** (µL) = crossed x mics; **volume** (mL) = sum over the steps / 1000.
* **Start / end ft**: where the step begins and ends, from the foul line. The forward pass runs
  toward the pins (start <= end), the reverse pass back toward the foul line (start >= end).
  Model: a step's oil is spread **uniformly** over its distance [min, max) on each crossed board.
* **Buffer**: the sheet's "Buffer"/"Buff" column, the buffer-brush setting of the step (e.g. 3
  or 4); "reverse brush drop" is where the brush drops on the reverse pass. The brush buffs the
  conditioner after the head stops oiling (domain notes, marked unverified). Both are recorded
  as printed and **not modelled**: the oil grid assumes the oil stays where it is laid (no
  buffing, no carrydown, no breakdown). So the laid oil can end before the sheet's pattern
  distance (the zero-load steps up to it lay none): Big Ben's last load ends at 36 ft of 44.
* **Ratio** (Kegel / USBC): the mean oil per board on boards 18..22 (18L-18R) divided by the
  mean oil per board on boards 3..7 of both sides (3..7 and 33..37), each board's oil integrated
  over the whole pattern (foul line to the end of the oil). :func:`ratio` can also give it at
  one distance (the oil density per board in the cell containing ``at_ft``). It reproduces the
  7.33:1 printed on Kegel's "Big Ben" sheet (tested).

A second, non-Kegel form (:class:`RectanglePattern`) paints rectangles of uniform oil in feet
and (possibly fractional) board widths; it expresses the paper's Fig. 4 pattern, whose oil edge
(10 % of the width from each gutter = 3.9 boards) is not on a board boundary.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, TypeAdapter, ValidationInfo, field_validator, model_validator

from bowlrec.spec._base import NonNegativeFloat, PositiveFloat, SpecModel, fmt, spec_error
from bowlrec.units import BOARDS, LANE_LENGTH_FT

__all__ = [
    "unknown_preset",
    "INNER_BOARDS",
    "OUTER_BOARDS",
    "KegelPattern",
    "KegelStep",
    "OilGrid",
    "OilPattern",
    "OilRectangle",
    "OilStatistics",
    "RectanglePattern",
    "board_from_notation",
    "board_volumes_ul",
    "load_pattern",
    "oil_grid",
    "parse_pattern",
    "pattern_statistics",
    "preset",
    "preset_names",
    "ratio",
]

Array = NDArray[np.float64]

#: boards (numbered from the right gutter) of the ratio's numerator: 18L-18R
INNER_BOARDS = (18, 19, 20, 21, 22)
#: boards of the ratio's denominator: 3-7 on each side (3R-7R and 7L-3L)
OUTER_BOARDS = (3, 4, 5, 6, 7, 33, 34, 35, 36, 37)

_BOARD_RE = re.compile(r"^\s*(\d{1,2})\s*([LR])\s*$", re.IGNORECASE)
#: tolerance of a printed total in mL (sheets print 2 decimals: half the last digit)
_ML_TOL = 0.005 + 1e-9
#: tolerance of a printed step total in µL (sheets print whole microlitres)
_UL_TOL = 0.5 + 1e-9
#: tolerance of a printed ratio (2 decimals)
_RATIO_TOL = 0.005 + 1e-9


def board_from_notation(text: str, field: str = "board") -> int:
    """Board number counted from the right gutter (1..39) of Kegel notation: ``"2R"`` -> 2,
    ``"2L"`` -> 38 (board 2 from the left), ``"20L"`` -> ``"20R"`` -> 20 (the centre).

    Raises ValueError naming ``field``, the value and the allowed form and range.
    """
    m = _BOARD_RE.match(text) if isinstance(text, str) else None
    if m is None:
        raise ValueError(
            f"{field} = {text!r} is not in Kegel board notation: a board number 1..{BOARDS} "
            "followed by L (counted from the left gutter) or R (from the right), e.g. '2L'"
        )
    n, side = int(m.group(1)), m.group(2).upper()
    if not 1 <= n <= BOARDS:
        raise ValueError(f"{field} = {text!r}: board number {n} must be in 1..{BOARDS}")
    return n if side == "R" else BOARDS + 1 - n


_FeetOnLane = Annotated[float, Field(ge=0, le=LANE_LENGTH_FT, allow_inf_nan=False)]


class KegelStep(SpecModel):
    """One row of a Kegel load table (a step of the forward or the reverse pass)."""

    start_board: str = Field(description="Start board in L/R notation, e.g. '2L'.")
    stop_board: str = Field(description="Stop board in L/R notation, e.g. '2R'.")
    loads: int = Field(ge=0, description="Crossings of the oil head (0 = travel only).")
    mics_ul: NonNegativeFloat = Field(description="Oil per board per load (µL).")
    start_ft: _FeetOnLane = Field(description="Where the step starts (ft from the foul line).")
    end_ft: _FeetOnLane = Field(description="Where the step ends (ft from the foul line).")
    speed_in_s: PositiveFloat | None = Field(
        default=None, description="Machine speed as printed (in/s); recorded, not modelled."
    )
    buffer: int | None = Field(
        default=None, ge=0, description="Buffer-brush setting as printed; recorded, not modelled."
    )
    tank: str | None = Field(default=None, description="Conditioner tank as printed, e.g. 'A'.")
    crossed: int | None = Field(
        default=None, ge=0, description="Boards crossed as printed; checked if given."
    )
    total_oil_ul: NonNegativeFloat | None = Field(
        default=None, description="Oil of the step as printed (µL); checked if given."
    )

    @field_validator("start_board", "stop_board")
    @classmethod
    def _board_notation(cls, v: str, info: ValidationInfo) -> str:
        """Valid L/R notation."""
        try:
            board_from_notation(v, info.field_name or "board")
        except ValueError as e:
            raise spec_error(str(e)) from None
        return v

    @model_validator(mode="after")
    def _printed_columns_agree(self) -> KegelStep:
        """The printed crossed / total oil equal the derived ones; an oiling step has length."""
        if self.crossed is not None and self.crossed != self.derived_crossed:
            raise spec_error(
                f"crossed = {self.crossed} must equal boards x loads = {self.boards} x "
                f"{self.loads} = {self.derived_crossed} ({self.start_board} to {self.stop_board})"
            )
        oil = self.oil_ul
        if self.total_oil_ul is not None and abs(self.total_oil_ul - oil) > _UL_TOL:
            raise spec_error(
                f"total_oil_ul = {fmt(self.total_oil_ul)} must equal crossed x mics_ul = "
                f"{self.derived_crossed} x {fmt(self.mics_ul)} = {fmt(oil)}"
            )
        if oil > 0 and self.start_ft == self.end_ft:
            raise spec_error(
                f"start_ft = end_ft = {fmt(self.start_ft)}: a step that lays oil "
                f"({fmt(oil)} µL) must cover a positive distance"
            )
        return self

    @property
    def board_range(self) -> tuple[int, int]:
        """(lowest, highest) board covered, numbered from the right gutter, inclusive."""
        a = board_from_notation(self.start_board)
        b = board_from_notation(self.stop_board)
        return min(a, b), max(a, b)

    @property
    def boards(self) -> int:
        """Number of boards from start to stop, inclusive."""
        lo, hi = self.board_range
        return hi - lo + 1

    @property
    def derived_crossed(self) -> int:
        """Boards crossed = boards x loads."""
        return self.boards * self.loads

    @property
    def oil_ul(self) -> float:
        """Oil laid by the step (µL) = crossed x mics."""
        return self.derived_crossed * self.mics_ul


def _check_pass(steps: list[KegelStep], name: str, forward: bool, distance_ft: float) -> None:
    """Direction of travel and extent of every step of a pass."""
    for k, s in enumerate(steps):
        if forward and s.start_ft > s.end_ft:
            raise spec_error(
                f"{name}[{k}]: start_ft = {fmt(s.start_ft)} must be <= end_ft = "
                f"{fmt(s.end_ft)} (the forward pass travels toward the pins)"
            )
        if not forward and s.start_ft < s.end_ft:
            raise spec_error(
                f"{name}[{k}]: start_ft = {fmt(s.start_ft)} must be >= end_ft = "
                f"{fmt(s.end_ft)} (the reverse pass travels toward the foul line)"
            )
        far = max(s.start_ft, s.end_ft)
        if s.oil_ul > 0 and far > distance_ft:
            raise spec_error(
                f"{name}[{k}]: oil up to {fmt(far)} ft must lie within distance_ft = "
                f"{fmt(distance_ft)} (the oil pattern distance)"
            )


def _check_printed(stated: float | None, derived: float, name: str, tol: float) -> None:
    """A printed total must equal the derived one (to the sheet's printed precision)."""
    if stated is not None and abs(stated - derived) > tol:
        raise spec_error(
            f"{name} = {fmt(stated)} must equal the value derived from the steps, "
            f"{derived:.6g} (to +-{tol:.3g})"
        )


class KegelPattern(SpecModel):
    """A Kegel pattern sheet: header and the load tables of the forward and reverse passes.

    Optional printed totals (``*_total_ml``, ``ratio_stated``) are checked against the values
    derived from the steps, so a mistyped row cannot load quietly.
    """

    kind: Literal["kegel"] = "kegel"
    name: str = Field(description="Pattern name as printed.")
    distance_ft: float = Field(
        gt=0, le=LANE_LENGTH_FT, allow_inf_nan=False, description="Oil pattern distance (ft)."
    )
    reverse_brush_drop_ft: _FeetOnLane | None = Field(
        default=None, description="Reverse brush drop (ft) as printed; recorded, not modelled."
    )
    forward: list[KegelStep] = Field(description="Forward pass, foul line toward the pins.")
    reverse: list[KegelStep] = Field(
        default_factory=list, description="Reverse pass, back toward the foul line."
    )
    forward_oil_total_ml: NonNegativeFloat | None = Field(
        default=None, description="Forward oil total as printed (mL); checked if given."
    )
    reverse_oil_total_ml: NonNegativeFloat | None = Field(
        default=None, description="Reverse oil total as printed (mL); checked if given."
    )
    volume_oil_total_ml: NonNegativeFloat | None = Field(
        default=None, description="Volume oil total as printed (mL); checked if given."
    )
    ratio_stated: PositiveFloat | None = Field(
        default=None, description="Ratio as printed (x:1 -> x); checked if given."
    )
    source: str = Field(default="", description="Provenance: where the sheet comes from.")
    approximation: bool = Field(
        default=True, description="False only for a sheet transcribed from a published one."
    )

    @model_validator(mode="after")
    def _consistent(self) -> KegelPattern:
        """Directions, extents and printed totals."""
        _check_pass(self.forward, "forward", True, self.distance_ft)
        _check_pass(self.reverse, "reverse", False, self.distance_ft)
        fwd = sum(s.oil_ul for s in self.forward) / 1000.0
        rev = sum(s.oil_ul for s in self.reverse) / 1000.0
        _check_printed(self.forward_oil_total_ml, fwd, "forward_oil_total_ml", _ML_TOL)
        _check_printed(self.reverse_oil_total_ml, rev, "reverse_oil_total_ml", _ML_TOL)
        _check_printed(self.volume_oil_total_ml, fwd + rev, "volume_oil_total_ml", _ML_TOL)
        if self.ratio_stated is not None:
            derived = ratio(oil_grid(self))
            value = math.inf if derived is None else derived
            _check_printed(self.ratio_stated, value, "ratio_stated", _RATIO_TOL)
        return self


class OilRectangle(SpecModel):
    """Uniform oil over x in [start_ft, end_ft) and y in [y_min_boards, y_max_boards), y in
    board widths from the right gutter (board b is [b - 1, b]; fractions allowed)."""

    start_ft: _FeetOnLane = Field(description="Start of the oil (ft from the foul line).")
    end_ft: _FeetOnLane = Field(description="End of the oil (ft from the foul line), > start.")
    y_min_boards: float = Field(
        ge=0,
        le=BOARDS,
        allow_inf_nan=False,
        description="Right edge: distance from the right gutter in board widths (0..39).",
    )
    y_max_boards: float = Field(
        ge=0,
        le=BOARDS,
        allow_inf_nan=False,
        description="Left edge: distance from the right gutter in board widths (> y_min_boards).",
    )
    ul_per_board_ft: PositiveFloat = Field(description="Oil per board width per foot (µL).")

    @field_validator("end_ft", "y_max_boards")
    @classmethod
    def _positive_extent(cls, v: float, info: ValidationInfo) -> float:
        """end_ft > start_ft and y_max_boards > y_min_boards."""
        lo_name = "start_ft" if info.field_name == "end_ft" else "y_min_boards"
        lo = info.data.get(lo_name)
        if lo is not None and not lo < v:
            raise spec_error(
                f"{info.field_name} = {fmt(v)} must be > {lo_name} = {fmt(lo)} "
                "(a rectangle must have a positive extent)"
            )
        return v


class RectanglePattern(SpecModel):
    """Oil as rectangles of uniform depth (overlapping rectangles add their oil)."""

    kind: Literal["rectangles"] = "rectangles"
    name: str = Field(description="Pattern name.")
    rectangles: list[OilRectangle] = Field(min_length=1, description="The oiled rectangles.")
    source: str = Field(default="", description="Provenance of the pattern.")
    approximation: bool = Field(default=True, description="True unless built from a source.")


#: an oil pattern, discriminated by ``kind``
OilPattern = Annotated[KegelPattern | RectanglePattern, Field(discriminator="kind")]
_PATTERN_ADAPTER: TypeAdapter[KegelPattern | RectanglePattern] = TypeAdapter(OilPattern)


@dataclass(frozen=True)
class OilGrid:
    """Oil laid on the lane: ``volume_ul[i, j]`` µL in x in [x_edges_ft[i], x_edges_ft[i+1])
    (ft from the foul line) and across [board_edges[j], board_edges[j+1]) (board widths from
    the right gutter). No oil outside the grid."""

    x_edges_ft: Array
    board_edges: Array
    volume_ul: Array

    @property
    def oil_end_ft(self) -> float:
        """Distance from the foul line to the end of the laid oil (ft); 0 for a dry lane. It can
        be shorter than a sheet's pattern distance: the brush's buffing beyond the last load is
        not modelled."""
        oiled_rows = np.nonzero(self.volume_ul.sum(axis=1) > 0)[0]
        return float(self.x_edges_ft[oiled_rows[-1] + 1]) if oiled_rows.size else 0.0


def _kegel_grid(p: KegelPattern) -> OilGrid:
    """Each oiling step spreads boards x loads x mics uniformly over its distance."""
    steps = [s for s in (*p.forward, *p.reverse) if s.oil_ul > 0]
    xe = np.unique([v for s in steps for v in (s.start_ft, s.end_ft)]).astype(np.float64)
    if xe.size < 2:
        xe = np.array([0.0, p.distance_ft])
    be = np.arange(BOARDS + 1, dtype=np.float64)
    vol = np.zeros((xe.size - 1, BOARDS))
    lengths = np.diff(xe)
    for s in steps:
        lo_ft, hi_ft = sorted((s.start_ft, s.end_ft))
        rows = (xe[:-1] >= lo_ft) & (xe[1:] <= hi_ft)
        b0, b1 = s.board_range
        per_board = s.loads * s.mics_ul * lengths[rows] / (hi_ft - lo_ft)
        vol[np.ix_(rows, np.arange(b0 - 1, b1))] += per_board[:, None]
    return OilGrid(xe, be, vol)


def _rectangle_grid(p: RectanglePattern) -> OilGrid:
    """Cells cut by every rectangle edge; each rectangle adds its density x cell area."""
    rs = p.rectangles
    xe = np.unique([v for r in rs for v in (r.start_ft, r.end_ft)]).astype(np.float64)
    be = np.unique([v for r in rs for v in (r.y_min_boards, r.y_max_boards)]).astype(np.float64)
    xm, bm = 0.5 * (xe[:-1] + xe[1:]), 0.5 * (be[:-1] + be[1:])
    area = np.outer(np.diff(xe), np.diff(be))  # board-feet
    vol = np.zeros_like(area)
    for r in rs:
        inside = np.outer(
            (xm > r.start_ft) & (xm < r.end_ft), (bm > r.y_min_boards) & (bm < r.y_max_boards)
        )
        vol += np.where(inside, r.ul_per_board_ft * area, 0.0)
    return OilGrid(xe, be, vol)


def oil_grid(pattern: KegelPattern | RectanglePattern) -> OilGrid:
    """The oil a pattern lays (µL per cell; see :class:`OilGrid`)."""
    if isinstance(pattern, KegelPattern):
        return _kegel_grid(pattern)
    return _rectangle_grid(pattern)


def _board_overlap(board_edges: Array) -> Array:
    """(n cells, 39) fraction of each grid column that lies on each board."""
    lo, hi = board_edges[:-1, None], board_edges[1:, None]
    b = np.arange(BOARDS, dtype=np.float64)[None, :]
    overlap = np.clip(np.minimum(hi, b + 1.0) - np.maximum(lo, b), 0.0, None)
    return overlap / (hi - lo)


def board_volumes_ul(grid: OilGrid, at_ft: float | None = None) -> Array:
    """Oil on each board (index b - 1 for board b from the right gutter).

    ``at_ft=None``: µL per board integrated over the whole pattern; otherwise the density in
    the grid row containing x = at_ft, in µL per board per ft (zeros outside the oil).
    """
    if at_ft is None:
        return grid.volume_ul.sum(axis=0) @ _board_overlap(grid.board_edges)
    i = int(np.searchsorted(grid.x_edges_ft, at_ft, side="right")) - 1
    if not 0 <= i < grid.volume_ul.shape[0]:
        return np.zeros(BOARDS)
    density = grid.volume_ul[i] / (grid.x_edges_ft[i + 1] - grid.x_edges_ft[i])
    return density @ _board_overlap(grid.board_edges)


def ratio(grid: OilGrid, at_ft: float | None = None) -> float | None:
    """Mean oil per board on 18..22 / mean on 3..7 and 33..37 (see the module docstring).

    Integrated over the whole pattern (``at_ft=None``, the Kegel sheet's ratio) or at one
    distance (ft). None when boards 3..7 / 33..37 carry no oil (the ratio is undefined).
    """
    per_board = board_volumes_ul(grid, at_ft)
    inner = float(np.mean(per_board[[b - 1 for b in INNER_BOARDS]]))
    outer = float(np.mean(per_board[[b - 1 for b in OUTER_BOARDS]]))
    return inner / outer if outer > 0 else None


@dataclass(frozen=True)
class OilStatistics:
    """What a pattern sheet states, derived from the steps.

    Volumes in mL; crosses in boards crossed (None for non-Kegel patterns); ratio as x in x:1
    (None when undefined); distance_ft: the pattern distance (a Kegel sheet's "Oil Pattern
    Distance"; the end of the oil for rectangles); oil_end_ft: foul line to the end of the laid
    oil (a Kegel pattern's zero-load steps to the distance lay none).
    """

    forward_ml: float
    reverse_ml: float
    total_ml: float
    forward_crosses: int | None
    reverse_crosses: int | None
    total_crosses: int | None
    ratio: float | None
    distance_ft: float
    oil_end_ft: float


def pattern_statistics(pattern: KegelPattern | RectanglePattern) -> OilStatistics:
    """Volumes, crosses, ratio (whole pattern) and oil length of a pattern."""
    grid = oil_grid(pattern)
    if isinstance(pattern, KegelPattern):
        fwd = sum(s.oil_ul for s in pattern.forward) / 1000.0
        rev = sum(s.oil_ul for s in pattern.reverse) / 1000.0
        fc = sum(s.derived_crossed for s in pattern.forward)
        rc = sum(s.derived_crossed for s in pattern.reverse)
        r, end = ratio(grid), grid.oil_end_ft
        return OilStatistics(fwd, rev, fwd + rev, fc, rc, fc + rc, r, pattern.distance_ft, end)
    total = float(grid.volume_ul.sum()) / 1000.0
    end = grid.oil_end_ft
    return OilStatistics(total, 0.0, total, None, None, None, ratio(grid), end, end)


def load_pattern(path: str | Path) -> KegelPattern | RectanglePattern:
    """Load and validate a pattern JSON file (``kind``: "kegel" or "rectangles")."""
    return parse_pattern(json.loads(Path(path).read_text(encoding="utf-8")))


def parse_pattern(data: object) -> KegelPattern | RectanglePattern:
    """Validate a pattern given as a mapping (raises ``pydantic.ValidationError``)."""
    return _PATTERN_ADAPTER.validate_python(data)


def _presets_dir() -> Traversable:
    """The bundled presets' folder."""
    return resources.files("bowlrec.bowling").joinpath("data", "patterns")


def preset_names() -> list[str]:
    """Names of the bundled patterns (file stems under bowlrec/bowling/data/patterns)."""
    names = (p.name for p in _presets_dir().iterdir())
    return sorted(n.removesuffix(".json") for n in names if n.endswith(".json"))


def unknown_preset(field: str, name: str) -> str:
    """The message for a pattern name that is not a preset: the close ones, then every one."""
    from bowlrec.suggest import did_you_mean

    names = preset_names()
    hint = did_you_mean(name, names)
    return f"{field} = {name!r} is not a preset; {hint + ' ' if hint else ''}presets: " + ", ".join(
        names
    )


def preset(name: str) -> KegelPattern | RectanglePattern:
    """A bundled pattern by name (see :func:`preset_names`)."""
    path = _presets_dir().joinpath(f"{name}.json")
    if not path.is_file():
        raise KeyError(f"no oil pattern preset {name!r}; known: {', '.join(preset_names())}")
    return parse_pattern(json.loads(path.read_text(encoding="utf-8")))

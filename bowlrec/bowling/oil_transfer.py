"""Oil transfer by the ball: breakdown (oil lifted from the lane under the ball's track) and
carrydown (oil the ball carries and lays down further along), shot after shot on one lane, with
exact bookkeeping (``docs/oil-transition.md`` states the model, its sources and its calibration).

**The lane** is an :class:`~bowlrec.bowling.oil.OilGrid` (µL per cell; x in ft from the foul
line, y in board widths from the right gutter). :func:`session_oil_grid` lays a pattern on a
regular grid by whole feet and boards, conserving its volume.

**The track** of one delivery is the path of the ball's contact point, which on a flat lane is
directly below the center: the center's (x, y) in m, in the order the ball travelled. Its
footprint is the band ``track_width_m`` wide centred on the path; the fraction c of each cell
it covers is the area it sweeps in the cell over the cell's area, integrated exactly along the
polyline (a path crossing boards inside one cell covers each board only along its own width,
not the whole lateral extent). Samples where x does not advance beyond every earlier sample are
dropped: the ball only lifts oil where it is for the first time (a ball never travels back up
the lane; a path that stops is cut where it stops). The track acts only where it exists: a
gutter ball's ends where it left the lane, and nothing happens behind its first sample.

**One shot** (:func:`apply_track`), row by row in the direction of travel:

* **breakdown**: the ball lifts ``pickup_fraction x c x V`` from every cell (V: the cell's oil
  before the shot; each cell is crossed once);
* **carrydown**: with a load L (µL) on its cover entering a row, the ball lays down
  ``L (1 - (1 - carrydown_fraction) ** d)`` over the d feet of its track in the row, spread over
  the row's cells in proportion to the area it sweeps in each (d = swept area on the lane /
  track width: a track hanging over a gutter lays nothing off the lane), then picks up the
  row's lift. The load after the last row stays on the ball;
* **between shots** (:func:`absorb_between_shots`) the coverstock soaks up
  ``absorption_fraction`` of the load; the rest comes back to the lane on the next shot.

**Conservation** (tested to rounding, for every shot and a session): oil removed from the
lane = lifted - deposited = change of the ball's load, and over the time between shots the
load falls by exactly the oil absorbed. :class:`TransferLedger` carries every term.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from bowlrec.spec._base import NonNegativeFloat, SpecModel, fmt
from bowlrec.units import BOARDS, FT_M, LANE_LENGTH_FT

from .oil import KegelPattern, OilGrid, RectanglePattern, oil_grid

__all__ = [
    "TransferLedger",
    "TransferModel",
    "absorb_between_shots",
    "apply_track",
    "resample_grid",
    "session_oil_grid",
    "track_coverage",
]

Array = NDArray[np.float64]

#: a track narrower than this (boards) is treated as a line of zero width (nothing is lifted)
_MIN_WIDTH_BOARDS = 1e-12


class TransferModel(SpecModel):
    """Parameters of the oil transfer (module docstring). Defaults: the calibrated values of
    ``docs/oil-transition.md`` (pickup_fraction fitted to Kegel's "over 40 percent removed
    from the area of play within about 4-5 games per lane"; the others argued there)."""

    pickup_fraction: NonNegativeFloat = Field(
        default=0.168,
        le=1.0,
        description="Fraction of the oil under the track lifted by one pass, in [0, 1] "
        "(calibrated to Kegel's >40 % removed from the area of play in 4.5 games; Fresh Oil "
        "lifts ~0.035 over an 11 cm band, Bowling-Sim 0.04 of a board's cell).",
    )
    carrydown_fraction: NonNegativeFloat = Field(
        default=0.02,
        le=1.0,
        description="Fraction of the ball's load laid down per foot of travel, in [0, 1] "
        "(assumed; Fresh Oil lays 55 % of what it lifts 1 ft further, Bowling-Sim 1 % 4 ft "
        "further).",
    )
    absorption_fraction: NonNegativeFloat = Field(
        default=0.5,
        le=1.0,
        description="Fraction of the ball's load soaked into the coverstock (or wiped off) "
        "between shots, in [0, 1] (assumed).",
    )
    track_width_m: float = Field(
        default=0.006,
        gt=0.0,
        le=0.25,
        allow_inf_nan=False,
        description="Width of the ball's contact track on the lane (m), in (0, 0.25] "
        "(argued from the Hertz contact of a 7 kg ball: 4-6 mm).",
    )


@dataclass(frozen=True)
class TransferLedger:
    """The oil moved by one shot (all µL). ``lifted``: taken from the lane by breakdown;
    ``deposited``: laid back by carrydown; ``ball_load_before`` / ``ball_load_after``: on the
    ball's cover entering / leaving the lane (after = before + lifted - deposited);
    ``absorbed``: soaked into the cover between this shot and the next (0 until
    :meth:`with_absorption`); ``lane_before`` / ``lane_after``: the lane's total oil."""

    lifted_ul: float
    deposited_ul: float
    ball_load_before_ul: float
    ball_load_after_ul: float
    lane_before_ul: float
    lane_after_ul: float
    absorbed_ul: float = 0.0

    @property
    def removed_from_lane_ul(self) -> float:
        """Net oil taken off the lane by the shot: lifted - deposited (µL)."""
        return self.lifted_ul - self.deposited_ul

    @property
    def ball_load_kept_ul(self) -> float:
        """The ball's load at the next shot: after the shot less the oil absorbed (µL)."""
        return self.ball_load_after_ul - self.absorbed_ul

    @property
    def imbalance_ul(self) -> float:
        """Oil unaccounted for (µL; zero to rounding): lane's loss - ball's gain - absorbed,
        the ball's gain counted to the next shot (kept - before)."""
        lane_loss = self.lane_before_ul - self.lane_after_ul
        return lane_loss - (self.ball_load_kept_ul - self.ball_load_before_ul) - self.absorbed_ul

    def with_absorption(self, model: TransferModel) -> TransferLedger:
        """This ledger with the between-shot absorption of ``model`` applied."""
        _, absorbed = absorb_between_shots(self.ball_load_after_ul, model)
        return replace(self, absorbed_ul=absorbed)


def absorb_between_shots(ball_load_ul: float, model: TransferModel) -> tuple[float, float]:
    """(kept, absorbed) µL: the cover soaks up ``absorption_fraction`` of the load between
    shots; kept + absorbed == ball_load_ul exactly (kept is computed as the difference)."""
    if not (math.isfinite(ball_load_ul) and ball_load_ul >= 0.0):
        raise ValueError(f"ball_load_ul = {fmt(ball_load_ul)} must be a finite load >= 0 (µL)")
    absorbed = ball_load_ul * model.absorption_fraction
    return ball_load_ul - absorbed, absorbed


# ---- the session's grid ----------------------------------------------------------------------


def _regular_edges(length: float, cell: float, name: str) -> Array:
    """0, cell, 2 cell, ..., length (the last cell shorter when cell does not divide length)."""
    if not (math.isfinite(cell) and cell > 0.0):
        raise ValueError(f"{name} = {fmt(cell)} must be > 0")
    n = max(1, math.ceil(length / cell - 1e-9))
    edges = np.minimum(np.arange(n + 1, dtype=np.float64) * cell, length)
    edges[-1] = length
    return edges


def _overlap(src: Array, dst: Array) -> Array:
    """(n src cells, n dst cells): the fraction of each source cell inside each target cell."""
    lo = np.maximum(src[:-1, None], dst[None, :-1])
    hi = np.minimum(src[1:, None], dst[None, 1:])
    return np.clip(hi - lo, 0.0, None) / np.diff(src)[:, None]


def resample_grid(grid: OilGrid, x_edges_ft: ArrayLike, board_edges: ArrayLike) -> OilGrid:
    """``grid``'s oil on other cells, each source cell's oil spread uniformly over it and
    shared by area. Conserves the volume exactly (to rounding) when the new cells cover the
    old oil; ValueError if oil would fall outside them."""
    xe = np.asarray(x_edges_ft, dtype=np.float64)
    be = np.asarray(board_edges, dtype=np.float64)
    ox = _overlap(grid.x_edges_ft, xe)
    ob = _overlap(grid.board_edges, be)
    outside = grid.volume_ul * (1.0 - ox.sum(axis=1))[:, None]
    outside += grid.volume_ul * (1.0 - ob.sum(axis=1))[None, :]
    total = float(np.sum(grid.volume_ul))
    if float(np.sum(np.abs(outside))) > 1e-9 * max(total, 1.0):
        raise ValueError(
            f"the new grid (x {fmt(xe[0])}..{fmt(xe[-1])} ft, boards {fmt(be[0])}.."
            f"{fmt(be[-1])}) does not cover the oil, which reaches {fmt(grid.oil_end_ft)} ft"
        )
    return OilGrid(xe, be, ox.T @ grid.volume_ul @ ob)


def session_oil_grid(
    pattern: KegelPattern | RectanglePattern,
    *,
    cell_ft: float = 1.0,
    cell_boards: float = 1.0,
    length_ft: float = LANE_LENGTH_FT,
) -> OilGrid:
    """The oil of ``pattern`` (µL, :func:`~bowlrec.bowling.oil.oil_grid`) on a regular grid
    from the foul line to ``length_ft`` in cells of ``cell_ft`` x ``cell_boards`` (the last
    row / column shorter where they do not divide 60 ft / 39 boards), volume conserved to
    rounding; dry cells are 0. ValueError for a non-positive cell or a grid shorter than the
    oil."""
    if not (math.isfinite(length_ft) and length_ft > 0.0):
        raise ValueError(f"length_ft = {fmt(length_ft)} must be > 0")
    xe = _regular_edges(length_ft, cell_ft, "cell_ft")
    be = _regular_edges(float(BOARDS), cell_boards, "cell_boards")
    return resample_grid(oil_grid(pattern), xe, be)


# ---- the track's footprint ------------------------------------------------------------------


def _ramp_integral(z: Array, h: float) -> Array:
    """Q(z) = integral from -inf to z of clip(v + h, 0, 2h) dv (piecewise quadratic)."""
    return np.where(z <= -h, 0.0, np.where(z >= h, 2.0 * h * z, 0.5 * (z + h) ** 2))


def _ramp(z: Array, h: float) -> Array:
    """clip(z + h, 0, 2h): the overlap of [y - h, y + h] with [b, inf) at z = y - b."""
    return np.clip(z + h, 0.0, 2.0 * h)


def _advancing(x: Array, y: Array) -> tuple[Array, Array]:
    """The samples where x exceeds every earlier x (the first sample kept)."""
    if x.size == 0:
        return x, y
    running = np.maximum.accumulate(x)
    keep = np.ones(x.size, dtype=bool)
    keep[1:] = x[1:] > running[:-1]
    return x[keep], y[keep]


def track_coverage(
    grid: OilGrid, track_x_m: ArrayLike, track_y_m: ArrayLike, *, lane_width_m: float,
    track_width_m: float,
) -> tuple[Array, Array]:  # fmt: skip
    """(area, length): ``area[i, j]`` the area (ft x board widths) the band ``track_width_m``
    wide around the track sweeps in cell (i, j) of ``grid``, and ``length[i]`` the feet of
    track on the lane's cells in row i (swept area / width). The fraction covered is
    area / cell area (module docstring)."""
    x = np.asarray(track_x_m, dtype=np.float64).reshape(-1) / FT_M
    y = np.asarray(track_y_m, dtype=np.float64).reshape(-1) * (BOARDS / lane_width_m)
    if x.shape != y.shape:
        raise ValueError(f"track_x_m has {x.size} samples but track_y_m has {y.size}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError("the track's coordinates must be finite")
    xe, be = grid.x_edges_ft, grid.board_edges
    nrow, ncol = xe.size - 1, be.size - 1
    area = np.zeros((nrow, ncol))
    h = 0.5 * track_width_m * (BOARDS / lane_width_m)
    x, y = _advancing(x, y)
    if x.size < 2 or h < _MIN_WIDTH_BOARDS:
        return area, np.zeros(nrow)
    inner = xe[(xe > x[0]) & (xe < x[-1])]
    xs = np.union1d(x, inner)
    ys = np.interp(xs, x, y)
    x0, x1, y0, y1 = xs[:-1], xs[1:], ys[:-1], ys[1:]
    row = np.searchsorted(xe, 0.5 * (x0 + x1), side="right") - 1
    on = (row >= 0) & (row < nrow)
    x0, x1, y0, y1, row = x0[on], x1[on], y0[on], y1[on], row[on]
    dx, dy = (x1 - x0)[:, None], (y1 - y0)[:, None]
    lo, hi = be[None, :-1], be[None, 1:]
    flat = np.abs(dy) < 1e-9
    safe = np.where(flat, 1.0, dy)
    sloped = (
        (_ramp_integral(y1[:, None] - lo, h) - _ramp_integral(y1[:, None] - hi, h))
        - (_ramp_integral(y0[:, None] - lo, h) - _ramp_integral(y0[:, None] - hi, h))
    ) * (dx / safe)
    ym = 0.5 * (y0 + y1)[:, None]
    level = (_ramp(ym - lo, h) - _ramp(ym - hi, h)) * dx
    seg = np.clip(np.where(flat, level, sloped), 0.0, None)
    np.add.at(area, row, seg)
    cell = np.outer(np.diff(xe), np.diff(be))
    area = np.minimum(area, cell)
    return area, area.sum(axis=1) / (2.0 * h)


# ---- one shot ---------------------------------------------------------------------------------


def apply_track(
    grid: OilGrid,
    track_x_m: np.ndarray,
    track_y_m: np.ndarray,
    *,
    lane_width_m: float,
    model: TransferModel,
    ball_load_ul: float,
) -> tuple[OilGrid, float, TransferLedger]:
    """One shot's breakdown and carrydown on ``grid`` (module docstring): the new grid, the
    ball's load after the shot (µL, before the between-shot absorption:
    :func:`absorb_between_shots`) and the shot's :class:`TransferLedger`. ``track_x_m``,
    ``track_y_m``: the contact point's path (m, lane frame), in the order travelled;
    ``ball_load_ul``: oil on the cover as the ball is released (µL)."""
    if not (math.isfinite(ball_load_ul) and ball_load_ul >= 0.0):
        raise ValueError(f"ball_load_ul = {fmt(ball_load_ul)} must be a finite load >= 0 (µL)")
    area, length_ft = track_coverage(
        grid, track_x_m, track_y_m, lane_width_m=lane_width_m, track_width_m=model.track_width_m
    )
    vol = grid.volume_ul
    cell = np.outer(np.diff(grid.x_edges_ft), np.diff(grid.board_edges))
    lift = model.pickup_fraction * np.minimum(area / cell, 1.0) * vol
    lift_row = lift.sum(axis=1)
    keep_row = (1.0 - model.carrydown_fraction) ** length_ft
    area_row = area.sum(axis=1)
    deposit = np.zeros_like(vol)
    load = float(ball_load_ul)
    for i in np.nonzero(area_row > 0.0)[0]:
        laid = load - load * float(keep_row[i])
        if laid > 0.0:
            share = area[i] / area_row[i]
            deposit[i] = laid * share
            laid = float(deposit[i].sum())  # what the cells received, to rounding
        # all of a load laid down (carrydown 1 over a foot or more) can leave -1e-23 by rounding
        load = max(load - laid, 0.0) + float(lift_row[i])
    new_vol = vol - lift + deposit
    lifted, deposited = float(lift.sum()), float(deposit.sum())
    ledger = TransferLedger(
        lifted_ul=lifted,
        deposited_ul=deposited,
        ball_load_before_ul=float(ball_load_ul),
        ball_load_after_ul=load,
        lane_before_ul=float(vol.sum()),
        lane_after_ul=float(new_vol.sum()),
    )
    return OilGrid(grid.x_edges_ft, grid.board_edges, new_vol), load, ledger

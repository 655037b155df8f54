"""Friction map -> piecewise-constant grid (the form :class:`~bowlrec.core.plan.Plan` stores).

Grid convention: sorted break points ``x_edges`` (m) and ``y_edges`` (m), and ``mu`` of shape
(len(x_edges) + 1, len(y_edges) + 1); cell (i, j) covers x in [x_edges[i-1], x_edges[i]) and
y in [y_edges[j-1], y_edges[j]) (the first and last cells are unbounded), so
``np.searchsorted(edges, value, side="right")`` is a point's cell index. Break points with the
same mu on both sides are removed, so every grid is minimal (a constant map has no edges).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from .friction import (
    ConstantFriction,
    Friction,
    GridFriction,
    TypicalFriction,
    Zone,
    ZoneFriction,
)

__all__ = ["FrictionGrid", "build_friction_grid", "clip_to_lane", "mu_at", "simplify_grid"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class FrictionGrid:
    """A piecewise-constant friction map (see the module docstring for the cell convention)."""

    x_edges_m: Array
    y_edges_m: Array
    mu: Array


class _PlanLike(Protocol):
    friction_x_edges_m: Array
    friction_y_edges_m: Array
    friction_mu: Array


def simplify_grid(
    x_edges: Sequence[float] | Array, y_edges: Sequence[float] | Array, mu: Array
) -> FrictionGrid:
    """Remove break points where mu is identical on both sides for every row / column."""
    xe = np.asarray(x_edges, dtype=np.float64)
    ye = np.asarray(y_edges, dtype=np.float64)
    m = np.asarray(mu, dtype=np.float64)
    keep_x = [k for k in range(xe.size) if not np.array_equal(m[k, :], m[k + 1, :])]
    m = m[[0, *(k + 1 for k in keep_x)], :]
    keep_y = [k for k in range(ye.size) if not np.array_equal(m[:, k], m[:, k + 1])]
    m = m[:, [0, *(k + 1 for k in keep_y)]]
    return FrictionGrid(xe[keep_x].copy(), ye[keep_y].copy(), np.ascontiguousarray(m))


def _cell_points(edges: Array) -> Array:
    """One point strictly inside every cell defined by ``edges`` (len(edges) + 1 points)."""
    if edges.size == 0:
        return np.zeros(1)
    mids = 0.5 * (edges[:-1] + edges[1:])
    return np.concatenate([[edges[0] - 1.0], mids, [edges[-1] + 1.0]])


def _zone_grid(default_mu: float, zones: Sequence[Zone]) -> FrictionGrid:
    """Paint zones in order over ``default_mu`` (later zones override earlier ones)."""
    xe = np.unique([v for z in zones for v in (z.x_min_m, z.x_max_m)]).astype(np.float64)
    ye = np.unique([v for z in zones for v in (z.y_min_m, z.y_max_m)]).astype(np.float64)
    px, py = _cell_points(xe), _cell_points(ye)
    mu = np.full((px.size, py.size), float(default_mu))
    for z in zones:
        in_x = (px >= z.x_min_m) & (px < z.x_max_m)
        in_y = (py >= z.y_min_m) & (py < z.y_max_m)
        mu[np.ix_(in_x, in_y)] = z.mu
    return simplify_grid(xe, ye, mu)


def _typical_grid(f: TypicalFriction, width_m: float) -> FrictionGrid:
    """Oil for x < oil_length_m over the central band of the width; dry elsewhere."""
    half = 0.5 * f.oil_width_fraction * width_m
    center = 0.5 * width_m
    mu = np.array([[f.mu_dry, f.mu_oil, f.mu_dry], [f.mu_dry, f.mu_dry, f.mu_dry]])
    return simplify_grid([f.oil_length_m], [center - half, center + half], mu)


def build_friction_grid(friction: Friction, width_m: float) -> FrictionGrid:
    """The minimal grid of a friction model on a lane ``width_m`` wide (m)."""
    if isinstance(friction, ConstantFriction):
        return FrictionGrid(np.empty(0), np.empty(0), np.full((1, 1), float(friction.mu)))
    if isinstance(friction, ZoneFriction):
        return _zone_grid(friction.default_mu, friction.zones)
    if isinstance(friction, TypicalFriction):
        return _typical_grid(friction, width_m)
    if isinstance(friction, GridFriction):
        return simplify_grid(friction.x_edges_m, friction.y_edges_m, np.array(friction.mu))
    raise TypeError(f"unknown friction model {type(friction).__name__}")


def _inside_points(edges: Array, hi: float) -> Array:
    """A point inside [0, hi] for every cell of ``edges`` (all strictly inside (0, hi))."""
    bounds = np.concatenate([[0.0], edges, [hi]])
    return 0.5 * (bounds[:-1] + bounds[1:])


def clip_to_lane(grid: FrictionGrid, length_m: float, width_m: float) -> FrictionGrid:
    """The grid without break points on or beyond the lane's edges (x <= 0, x >= length_m,
    y <= 0, y >= width_m); each remaining cell keeps the friction it has on the lane.

    The run ends when the center reaches the pins (x = length_m) or a gutter (y = 0 or
    width_m), so cells beyond those lines are never visited, and a break point exactly on one of
    them would coincide with the end-of-run event (a zone covering the whole lane, e.g.).
    """
    xe = grid.x_edges_m[(grid.x_edges_m > 0.0) & (grid.x_edges_m < length_m)]
    ye = grid.y_edges_m[(grid.y_edges_m > 0.0) & (grid.y_edges_m < width_m)]
    if xe.size == grid.x_edges_m.size and ye.size == grid.y_edges_m.size:
        return grid
    px, py = _inside_points(xe, length_m), _inside_points(ye, width_m)
    mu = np.array([[mu_at(grid, x, y) for y in py] for x in px])
    return simplify_grid(xe, ye, mu)


def mu_at(grid: FrictionGrid | _PlanLike | tuple[Array, Array, Array], x: float, y: float) -> float:
    """Friction at lane point (x, y) (m) of a grid, a Plan, or a tuple (x_edges, y_edges, mu)."""
    if isinstance(grid, FrictionGrid):
        xe, ye, mu = grid.x_edges_m, grid.y_edges_m, grid.mu
    elif isinstance(grid, tuple):
        xe, ye, mu = grid
    else:
        xe, ye, mu = grid.friction_x_edges_m, grid.friction_y_edges_m, grid.friction_mu
    i = int(np.searchsorted(xe, x, side="right"))
    j = int(np.searchsorted(ye, y, side="right"))
    return float(mu[i, j])

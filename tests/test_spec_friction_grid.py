"""Friction maps -> minimal piecewise-constant grids."""

from __future__ import annotations

import numpy as np
import pytest

from bowlrec.spec import ConstantFriction, Lane, Scene, TypicalFriction, Zone, ZoneFriction
from bowlrec.spec.friction_grid import build_friction_grid, mu_at, simplify_grid

W = 1.0668


def _zone(x0: float, x1: float, y0: float, y1: float, mu: float) -> Zone:
    return Zone(x_min_m=x0, x_max_m=x1, y_min_m=y0, y_max_m=y1, mu=mu)


def test_constant() -> None:
    grid = build_friction_grid(ConstantFriction(mu=0.12), W)
    assert grid.x_edges_m.shape == (0,) and grid.y_edges_m.shape == (0,)
    np.testing.assert_array_equal(grid.mu, [[0.12]])
    assert mu_at(grid, 5.0, 0.5) == 0.12 and mu_at(grid, -100.0, 100.0) == 0.12


def test_typical() -> None:
    plan = Scene(lane=Lane(friction=TypicalFriction())).resolve()
    np.testing.assert_array_equal(plan.friction_x_edges_m, [12.192])
    np.testing.assert_allclose(plan.friction_y_edges_m, [0.1 * W, 0.9 * W], rtol=1e-15)
    assert plan.friction_mu.shape == (2, 3)
    assert mu_at(plan, 0.0, W / 2) == 0.04  # oil at the foul line, center
    assert mu_at(plan, 12.19, 0.11) == 0.04
    assert mu_at(plan, 12.192, W / 2) == 0.20  # the oil ends at oil_length (half-open)
    assert mu_at(plan, 5.0, 0.05) == 0.20  # dry near the right gutter
    assert mu_at(plan, 5.0, W - 0.05) == 0.20  # and near the left one
    assert mu_at(plan, 18.0, W / 2) == 0.20


def test_typical_full_width_and_degenerate() -> None:
    grid = build_friction_grid(TypicalFriction(oil_width_fraction=1.0), W)
    np.testing.assert_array_equal(grid.y_edges_m, [0.0, W])
    assert mu_at(grid, 1.0, 0.0) == 0.04 and mu_at(grid, 1.0, W - 1e-9) == 0.04
    # equal oil and dry friction collapse to a constant map
    grid = build_friction_grid(TypicalFriction(mu_oil=0.1, mu_dry=0.1), W)
    assert grid.x_edges_m.size == 0 and grid.y_edges_m.size == 0
    np.testing.assert_array_equal(grid.mu, [[0.1]])


def test_zones_override_in_order() -> None:
    friction = ZoneFriction(
        default_mu=0.2,
        zones=[_zone(0.0, 10.0, 0.0, 1.0, 0.04), _zone(5.0, 20.0, 0.4, 0.6, 0.08)],
    )
    grid = build_friction_grid(friction, W)
    np.testing.assert_array_equal(grid.x_edges_m, [0.0, 5.0, 10.0, 20.0])
    np.testing.assert_array_equal(grid.y_edges_m, [0.0, 0.4, 0.6, 1.0])
    assert mu_at(grid, 2.0, 0.5) == 0.04
    assert mu_at(grid, 7.0, 0.5) == 0.08  # the later zone wins where they overlap
    assert mu_at(grid, 7.0, 0.3) == 0.04
    assert mu_at(grid, 15.0, 0.5) == 0.08
    assert mu_at(grid, 15.0, 0.3) == 0.2
    assert mu_at(grid, -1.0, 0.5) == 0.2 and mu_at(grid, 25.0, 0.5) == 0.2
    assert mu_at(grid, 2.0, 1.0) == 0.2  # zones are half-open
    # reversed order: the big zone now covers the small one entirely
    friction = ZoneFriction(default_mu=0.2, zones=list(reversed(friction.zones)))
    grid = build_friction_grid(friction, W)
    assert mu_at(grid, 7.0, 0.5) == 0.04 and mu_at(grid, 15.0, 0.5) == 0.08


def test_constant_map_as_zones_has_no_edges() -> None:
    friction = ZoneFriction(
        default_mu=0.1, zones=[_zone(0.0, 5.0, 0.0, 1.0, 0.1), _zone(-1e3, 1e3, -1e3, 1e3, 0.1)]
    )
    grid = build_friction_grid(friction, W)
    assert grid.x_edges_m.size == 0 and grid.y_edges_m.size == 0
    np.testing.assert_array_equal(grid.mu, [[0.1]])
    grid = build_friction_grid(ZoneFriction(default_mu=0.3), W)
    np.testing.assert_array_equal(grid.mu, [[0.3]])


def test_zones_may_extend_beyond_the_lane() -> None:
    friction = ZoneFriction(default_mu=0.2, zones=[_zone(-100.0, 12.0, -100.0, 100.0, 0.04)])
    grid = build_friction_grid(friction, W)
    np.testing.assert_array_equal(grid.x_edges_m, [-100.0, 12.0])
    np.testing.assert_array_equal(grid.y_edges_m, [-100.0, 100.0])
    assert mu_at(grid, 11.0, 0.3) == 0.04 and mu_at(grid, 12.0, 0.3) == 0.2
    assert mu_at(grid, 0.0, 0.0) == 0.04 and mu_at(grid, 0.0, W) == 0.04


def test_simplify_grid_removes_only_redundant_edges() -> None:
    mu = np.array([[1.0, 1.0, 2.0], [1.0, 1.0, 2.0], [3.0, 3.0, 3.0]])
    grid = simplify_grid([1.0, 2.0], [10.0, 20.0], mu)
    np.testing.assert_array_equal(grid.x_edges_m, [2.0])
    np.testing.assert_array_equal(grid.y_edges_m, [20.0])
    np.testing.assert_array_equal(grid.mu, [[1.0, 2.0], [3.0, 3.0]])
    for x, y in [(0.0, 0.0), (1.5, 15.0), (1.5, 25.0), (2.0, 0.0), (5.0, 30.0)]:
        assert mu_at(grid, x, y) == mu_at((np.array([1.0, 2.0]), np.array([10.0, 20.0]), mu), x, y)


@pytest.mark.parametrize("seed", range(5))
def test_zone_grid_matches_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    zones = []
    for _ in range(6):
        x0, x1 = np.sort(rng.choice(np.arange(0.0, 20.0, 1.0), 2, replace=False))
        y0, y1 = np.sort(rng.choice(np.arange(0.0, 1.2, 0.1), 2, replace=False))
        zones.append(_zone(x0, x1, y0, y1, float(rng.choice([0.04, 0.1, 0.2]))))
    grid = build_friction_grid(ZoneFriction(default_mu=0.15, zones=zones), W)
    for x, y in rng.uniform([-2.0, -0.2], [22.0, 1.4], size=(500, 2)):
        expected = 0.15
        for z in zones:
            if z.x_min_m <= x < z.x_max_m and z.y_min_m <= y < z.y_max_m:
                expected = z.mu
        assert mu_at(grid, x, y) == expected

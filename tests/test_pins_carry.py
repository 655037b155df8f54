"""Carry maps: the bookkeeping of a cell (counts, probabilities, binomial standard errors, the
leaves by standing set and by name, pinfall, touches, exit boards) on made-up shots and on a
tiny real grid run in process; the same map whatever the number of workers (process tier: a
pool); the heat map's content (the mesh's values, the cells' labels, the window, the axis
words) and that it renders as PNG and SVG.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from matplotlib.collections import QuadMesh
from matplotlib.patches import Rectangle

import bowlrec.pins  # noqa: F401  (MUJOCO_GL=disable before MuJoCo loads)
from bowlrec.figures.carry import USBC_WINDOW, carry_figure, strike_heatmap
from bowlrec.figures.render import figure_bytes
from bowlrec.pins.carry import (
    CarryCell,
    CarryGrid,
    CarryMap,
    Shot,
    carry_map,
    default_plan,
    run_shot,
)
from bowlrec.pins.entry import PinEntry


def _shot(standing: tuple[int, ...], touched: tuple[int, ...], exit_board: float | None) -> Shot:
    return Shot(seed=0, standing=standing, touched=touched, exit_board=exit_board, at_rest=True)


def _cell() -> CarryCell:
    shots = (
        _shot((), (1, 3, 5, 9), 19.0),
        _shot((), (1, 3, 5), 20.0),
        _shot((10,), (1, 3, 5, 9), 14.0),
        _shot((10,), (1, 3), None),
        _shot((7, 10), (1, 3, 5), 18.0),
    )
    return CarryCell(entry=PinEntry(board=17.5, angle_deg=6.0), shots=shots)


def test_a_cells_sums() -> None:
    c = _cell()
    assert c.n == 5 and c.strikes == 2
    assert c.strike_probability == pytest.approx(0.4)
    assert c.strike_se == pytest.approx(math.sqrt(0.4 * 0.6 / 5))
    assert c.leaves == {(): 2, (10,): 2, (7, 10): 1}
    assert list(c.leaves) == [(), (10,), (7, 10)]  # most first, then fewer pins
    assert sum(c.leave_names.values()) == 5
    assert c.leave_names["strike"] == 2
    assert c.mean_pinfall == pytest.approx((10 + 10 + 9 + 9 + 8) / 5)
    t = c.touched_frequency
    assert t[1] == 1.0 and t[3] == 1.0 and t[5] == pytest.approx(0.8) and t[9] == 0.4
    assert t[2] == 0.0 and set(t) == set(range(1, 11))
    assert c.standing_frequency(10) == pytest.approx(0.6)
    assert c.mean_exit_board == pytest.approx((19 + 20 + 14 + 18) / 4)  # None left out
    d = c.to_dict()
    assert d["strikes"] == 2 and d["n"] == 5 and d["leaves"]["strike"] == 2


def test_certain_cells_have_no_standard_error() -> None:
    all_strikes = CarryCell(PinEntry(), tuple(_shot((), (1,), 19.0) for _ in range(3)))
    assert all_strikes.strike_probability == 1.0 and all_strikes.strike_se == 0.0
    nowhere = CarryCell(PinEntry(), (_shot((1,), (), None),))
    assert nowhere.mean_exit_board is None


def test_a_grid_names_its_entries_and_racks() -> None:
    g = CarryGrid(boards=(17.0, 18.0), angles_deg=(4.0, 6.0), speeds_mph=(15.0, 17.0),
                  repeats=3, first_seed=5, base=PinEntry(hand="left"))  # fmt: skip
    entries = g.entries()
    assert len(entries) == 8 and g.size == 24
    assert [(e.board, e.angle_deg, e.speed_mph) for e in entries[:3]] == [
        (17.0, 4.0, 15.0),
        (18.0, 4.0, 15.0),
        (17.0, 6.0, 15.0),
    ]
    assert all(e.hand == "left" and e.axis_tilt_deg == PinEntry.axis_tilt_deg for e in entries)
    assert g.seeds == (5, 6, 7)
    with pytest.raises(ValueError, match="repeats"):
        CarryGrid(boards=(17.0,), angles_deg=(6.0,), repeats=0)
    with pytest.raises(ValueError, match="boards is empty"):
        CarryGrid(boards=(), angles_deg=(6.0,))


def test_a_tiny_map_in_process_adds_up() -> None:
    pytest.importorskip("mujoco")
    grid = CarryGrid(boards=(17.5, 16.0), angles_deg=(6.0,), repeats=2, first_seed=11)
    cmap = carry_map(grid, workers=1)
    assert [(c.entry.board, c.entry.angle_deg) for c in cmap.cells] == [(17.5, 6.0), (16.0, 6.0)]
    for cell in cmap.cells:
        assert cell.n == 2 and [s.seed for s in cell.shots] == [11, 12]
        assert sum(cell.leaves.values()) == 2
        assert cell.strikes == cell.leaves.get((), 0)
        assert 0 <= cell.mean_pinfall <= 10
        assert all(s.touched and s.touched[0] == 1 for s in cell.shots)  # the head pin first
    # a cell's shot is the one run alone
    alone = run_shot(grid.entries()[1], 12, default_plan())
    assert alone == cmap.cell(16.0, 6.0).shots[1]
    grid_pct = cmap.strike_grid()
    assert grid_pct.shape == (1, 2)
    assert grid_pct[0, 0] == cmap.cell(17.5, 6.0).strike_probability
    assert cmap.to_dict()["deliveries"] == 4


@pytest.mark.process
def test_the_map_is_the_same_on_any_number_of_workers() -> None:
    pytest.importorskip("mujoco")
    grid = CarryGrid(boards=(16.5, 17.5, 18.5), angles_deg=(4.0, 6.0), repeats=2)
    one = carry_map(grid, workers=1)
    two = carry_map(grid, workers=2, chunk=1)
    three = carry_map(grid, workers=3, chunk=2)
    assert one.cells == two.cells == three.cells


# -- the heat map ----------------------------------------------------------------------------


def _fake_map() -> CarryMap:
    grid = CarryGrid(boards=(16.0, 17.0, 18.0), angles_deg=(2.0, 4.0, 6.0), repeats=2)
    cells = []
    for e in grid.entries():
        strike = e.board == 17.0 and e.angle_deg >= 4.0
        shots = (_shot((), (1,), 19.0), _shot(() if strike else (10,), (1,), 19.0))
        cells.append(CarryCell(e, shots))
    return CarryMap(grid, tuple(cells), workers=1, wall_time_s=0.0)


def test_the_heat_map_shows_the_strike_percentages() -> None:
    fig = carry_figure(_fake_map(), title="made up")
    ax = fig.axes[0]
    mesh = next(c for c in ax.collections if isinstance(c, QuadMesh))
    values = np.asarray(mesh.get_array()).reshape(3, 3)
    expect = np.array([[50, 50, 50], [50, 100, 50], [50, 100, 50]], dtype=float)
    assert np.array_equal(values, expect)
    assert mesh.get_clim() == (0.0, 100.0)
    labels = sorted(t.get_text() for t in ax.texts)
    assert labels == sorted(["50"] * 7 + ["100"] * 2)
    window = [p for p in ax.patches if isinstance(p, Rectangle)]
    b0, b1, a0, a1 = USBC_WINDOW
    assert any(
        r.get_xy() == (b0, a0) and r.get_width() == b1 - b0 and r.get_height() == a1 - a0
        for r in window
    )
    assert "(right-hander's count, from the right gutter)" in ax.get_xlabel()
    assert ax.xaxis_inverted()
    svg = figure_bytes(fig, "svg", tight=False)
    ET.fromstring(svg)
    assert figure_bytes(fig, "png", tight=False).startswith(b"\x89PNG")


def test_the_heat_map_sorts_its_axes_and_checks_its_shape() -> None:
    fig = strike_heatmap((18.0, 17.0), (6.0, 4.0), [[10, 20], [30, 40]], hand="left")
    ax = fig.axes[0]
    mesh = next(c for c in ax.collections if isinstance(c, QuadMesh))
    assert np.array_equal(np.asarray(mesh.get_array()).reshape(2, 2), [[40, 30], [20, 10]])
    assert "(left-hander's count, from the left gutter)" in ax.get_xlabel()
    with pytest.raises(ValueError, match="shape"):
        strike_heatmap((17.0,), (4.0, 6.0), [[1.0, 2.0]])

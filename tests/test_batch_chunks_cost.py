"""What a summary-only chunk costs besides its kernel: its run IDs, its chunk size and its
index rows. Each piece is checked against the plain implementation it replaces."""

from __future__ import annotations

import sqlite3
from typing import Any

import numpy as np
import pytest

from bowlrec.archive.index import RUN_TABLE_COLUMNS, create_schema
from bowlrec.archive.registry import INSERT_RUN, insert_runs
from bowlrec.archive.run_id import RUN_ID_LENGTH, run_id
from bowlrec.batch.fastprep import FastSweep, float_hex
from bowlrec.batch.spans import FIRST_CHUNK, GROWTH, TARGET_CHUNK_S, Spans
from bowlrec.spec import Scene

BASE: dict[str, Any] = {
    "name": "ids",
    "ball": {"mass_kg": 6.8, "rg_m": [0.069, 0.071, 0.071], "axis_2": None},
    "delivery": {"speed_mps": 8.0, "omega_radps": [-16.0, 23.0, 7.0]},
}
PATHS = [
    "delivery.speed_mps",
    "delivery.takeoff_angle_deg",
    "delivery.omega_radps[0]",
    "delivery.omega_radps[2]",
]


def test_float_hex_is_python_float_hex_for_every_kind_of_double() -> None:
    """Normal doubles over the whole exponent range of both signs, and the ones float.hex
    writes otherwise (zeros, subnormals, infinities, NaN, the extremes)."""
    rng = np.random.default_rng(7)
    normal = rng.normal(size=20_000) * 10.0 ** rng.uniform(-300, 300, 20_000)
    odd = [0.0, -0.0, 5e-324, -1e-310, np.inf, -np.inf, np.nan, 1.0, -1.0, 0.5, 2.0]
    odd += [1.7976931348623157e308, 2.2250738585072014e-308, -2.2250738585072014e-308]
    values = np.concatenate([normal, odd])
    assert float_hex(values).tolist() == [float(v).hex().encode() for v in values]


def test_a_sweeps_run_ids_are_the_run_ids_of_its_plans() -> None:
    """The run IDs prepared for a whole chunk at once are the SHA-256 run IDs of each run's
    own resolved Plan (:func:`bowlrec.archive.run_id.run_id`)."""
    scene = Scene.model_validate(BASE)
    fast = FastSweep(scene, PATHS)
    rng = np.random.default_rng(3)
    n = 40
    columns = {
        "delivery.speed_mps": rng.uniform(6.0, 10.0, n),
        "delivery.takeoff_angle_deg": rng.uniform(-3.0, 3.0, n),
        "delivery.omega_radps[0]": rng.uniform(-30.0, 0.0, n),
        "delivery.omega_radps[2]": np.where(np.arange(n) % 3 == 0, np.nan, rng.normal(size=n)),
    }
    columns["delivery.takeoff_angle_deg"][0] = 0.0  # a zero among the velocities
    chunk = fast.prepare(np.arange(n), columns, scenes=False)
    for i in range(n):
        assert len(chunk.run_ids[i]) == RUN_ID_LENGTH
        assert chunk.run_ids[i] == run_id(chunk.plan(i, fast.plan)), i


def test_chunks_grow_to_the_set_time_and_stop_at_the_cap() -> None:
    spans = Spans(1_000_000, 16_384, target_s=1.0)
    assert spans.pop() == (0, FIRST_CHUNK)
    spans.timed(FIRST_CHUNK, FIRST_CHUNK * 1e-4)  # 0.1 ms a run
    assert spans.pop()[1] - FIRST_CHUNK == FIRST_CHUNK * GROWTH  # at most GROWTH times
    for _ in range(10):
        start, stop = spans.pop()
        spans.timed(stop - start, (stop - start) * 1e-4)
    start, stop = spans.pop()
    assert stop - start == 10_000  # 1 s of 0.1 ms runs, below the cap
    spans.timed(stop - start, (stop - start) * 1e-5)
    start, stop = spans.pop()
    assert stop - start == 16_384  # the cap


def test_chunks_use_the_general_set_time_unless_told() -> None:
    spans = Spans(1_000_000, 100_000)
    spans.size = 1_000
    spans.timed(1_000, 1.0)  # 1 ms a run
    assert spans.size == int(TARGET_CHUNK_S * 1_000)
    fixed = Spans(100, 7, fixed=True, target_s=5.0)
    fixed.timed(7, 100.0)
    assert [fixed.pop() for _ in range(2)] == [(0, 7), (7, 14)]


def _row(k: int, pins: bool, ball: bool) -> tuple[Any, ...]:
    values: dict[str, Any] = {
        "run_id": f"{k:020x}",
        "seg": 1,
        "row": k,
        "name": "n",
        "created_ns": 1_000 + k,
        "ball_name": "Ball" if ball else None,
        "ball_version": 2 if ball else None,
        "ball_key": 1,
        "pattern": "house",
        "outcome": "pins" if k % 2 else "gutter",
        "pocket_deg": None if k % 2 == 0 else 5.5 + k,  # None in some rows only
        "pinfall": 9 if pins else None,
        "leave": "10" if pins else None,
    }
    return tuple(values.get(c, float(k) / 3.0) for c in RUN_TABLE_COLUMNS)


@pytest.mark.parametrize("pins,ball", [(False, False), (True, False), (False, True)])
def test_index_rows_inserted_with_null_columns_equal_rows_bound_one_by_one(
    pins: bool, ball: bool
) -> None:
    """Columns no row has go into the statement as NULL; the table holds the same rows as
    when every value is bound, including columns that are NULL in some rows only."""
    rows = [_row(k, pins, ball) for k in range(50)]
    tables = []
    for bound in (True, False):
        con = sqlite3.connect(":memory:")
        create_schema(con)
        if bound:
            con.executemany(INSERT_RUN, rows)
        else:
            insert_runs(con, rows)
        tables.append(con.execute("SELECT * FROM runs ORDER BY seq").fetchall())
    assert len(tables[1]) == 50
    assert tables[0] == tables[1]


@pytest.mark.parametrize("value", ["", "a", "case16-sweep", "Kugel ü 🎳"])
@pytest.mark.parametrize("n", [0, 1, 7])
def test_a_shared_string_column_is_the_column_of_its_values(value: str, n: int) -> None:
    """A segment's column of one string repeated (the fast path of a batch's segment) has the
    dtype and bytes of the column built value by value."""
    from bowlrec.archive.segment import _repeated, _strings

    fast, plain = _repeated(value, n), _strings([value] * n)
    assert fast.dtype == plain.dtype and fast.tobytes() == plain.tobytes()

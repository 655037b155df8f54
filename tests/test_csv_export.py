"""CSV files of runs: one row per sample with units in the column names, a summary-only run as
its summary row, several runs as one summary row each; floats read back bit for bit; written
whole or not at all; reached from the command line by the ``.csv`` suffix."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

import bowlrec
from bowlrec.archive import Archive
from bowlrec.cli import app
from bowlrec.core.terms import INERTIA_TERMS, TORQUE_TERMS
from bowlrec.core.trajectory import Summary, Trajectory, sample_columns
from bowlrec.sinks import RunData
from bowlrec.sinks.csv_file import RUN_COLUMNS, cell, write_csv, write_csv_many
from bowlrec.sinks.registry import sink_for
from bowlrec.spec import Scene
from bowlrec.units import units_for

runner = CliRunner()

DELIVERY = {"speed_mps": 8.0, "omega_radps": [-16.62, 23.74, 7.765]}

#: the columns of a run recorded without per-term torques, in file order
SAMPLE_HEADER = [
    "t_s",
    "x_m",
    "y_m",
    "z_m",
    "vx_mps",
    "vy_mps",
    "vz_mps",
    "q_w",
    "q_x",
    "q_y",
    "q_z",
    "omega_x_radps",
    "omega_y_radps",
    "omega_z_radps",
    "phase",
    "mu",
    "normal_force_N",
    "friction_x_N",
    "friction_y_N",
    "friction_z_N",
    "slip_x_mps",
    "slip_y_mps",
    "slip_z_mps",
    "energy_J",
    "alpha_x_radps2",
    "alpha_y_radps2",
    "alpha_z_radps2",
]
SUMMARY_HEADER = [
    "outcome",
    "message",
    "slide_m",
    "hook_m",
    "pocket_deg",
    "time_s",
    "x_end_m",
    "y_end_m",
    "speed_end_mps",
    "rev_rate_end_rpm",
    "n_steps",
    "n_rhs",
    "n_events",
]
#: the Trajectory array each column comes from, for its units
SOURCE = {
    "t_s": "t_s",
    "x": "position_m",
    "v": "velocity_mps",
    "omega": "omega_radps",
    "friction": "friction_force_N",
    "slip": "slip_mps",
    "alpha": "alpha_radps2",
}


def _scene(name: str, **options: Any) -> Scene:
    return Scene.model_validate({"name": name, "delivery": DELIVERY, "options": options})


def _run(scene: Scene) -> RunData:
    return RunData(scene, scene.resolve(), bowlrec.simulate(scene))


@pytest.fixture(scope="module")
def sampled() -> RunData:
    return _run(_scene("sampled", record="rate", record_dt_s=0.02))


@pytest.fixture(scope="module")
def with_terms() -> RunData:
    return _run(_scene("terms", record="rate", record_dt_s=0.05, record_terms=True))


@pytest.fixture(scope="module")
def summary_only() -> RunData:
    return _run(_scene("summary only", record="summary"))


def _read(path: Path) -> tuple[list[str], list[list[str]]]:
    with open(path, encoding="utf-8", newline="") as fh:
        header, *rows = list(csv.reader(fh))
    return header, rows


def _column_units(name: str) -> str:
    """The units a column's name states: the suffix after the last ``_`` read by units_for."""
    if name.startswith("q_"):
        return units_for("quaternion_wxyz")
    return units_for(name)


def test_a_recorded_run_is_one_row_per_sample_with_units_in_the_header(
    sampled: RunData, tmp_path: Path
) -> None:
    traj = sampled.trajectory
    path = write_csv(traj, tmp_path / "run.csv")
    header, rows = _read(path)
    assert header == SAMPLE_HEADER == list(sample_columns(traj))
    assert len(rows) == traj.n_samples > 10 and all(len(r) == len(header) for r in rows)
    assert path.read_text(encoding="utf-8").startswith(",".join(SAMPLE_HEADER) + "\n")
    for name in header:  # every name states units the project knows
        assert _column_units(name)
    assert _column_units("x_m") == units_for("position_m") == "m"
    assert _column_units("omega_z_radps") == units_for("omega_radps") == "rad/s"
    assert _column_units("friction_y_N") == units_for("friction_force_N") == "N"
    assert _column_units("alpha_x_radps2") == units_for("alpha_radps2") == "rad/s^2"
    assert _column_units("q_w") == _column_units("phase") == _column_units("mu") == "1"


def test_every_value_reads_back_bit_for_bit(sampled: RunData, tmp_path: Path) -> None:
    traj = sampled.trajectory
    header, rows = _read(write_csv(traj, tmp_path / "run.csv"))
    table = dict(zip(header, zip(*rows, strict=True), strict=True))
    arrays = traj.arrays()
    for j, (name, vector) in enumerate(
        [
            ("position_m", ("x_m", "y_m", "z_m")),
            ("velocity_mps", ("vx_mps", "vy_mps", "vz_mps")),
            ("quaternion_wxyz", ("q_w", "q_x", "q_y", "q_z")),
            ("omega_radps", ("omega_x_radps", "omega_y_radps", "omega_z_radps")),
            ("friction_force_N", ("friction_x_N", "friction_y_N", "friction_z_N")),
            ("slip_mps", ("slip_x_mps", "slip_y_mps", "slip_z_mps")),
            ("alpha_radps2", ("alpha_x_radps2", "alpha_y_radps2", "alpha_z_radps2")),
        ]
    ):
        read = np.array([[float(v) for v in table[c]] for c in vector]).T
        assert np.array_equal(read, arrays[name]), (j, name)
    for name in ("t_s", "mu", "normal_force_N", "energy_J"):
        read_1d = np.array([float(v) for v in table[name]])
        assert np.array_equal(read_1d, np.asarray(arrays[name]).reshape(-1)), name
        assert read_1d.tobytes() == np.asarray(arrays[name], dtype=np.float64).tobytes()
    assert [int(v) for v in table["phase"]] == traj.phase.tolist()
    assert set(table["phase"]) == {"0", "1"}  # the ball slides, then rolls
    assert all(v == float.__repr__(float(v)) for v in table["t_s"])  # repr-exact text


def test_per_term_torques_are_columns_when_recorded(with_terms: RunData, tmp_path: Path) -> None:
    traj = with_terms.trajectory
    header, rows = _read(write_csv(traj, tmp_path / "terms.csv"))
    terms = [f"{t}_{a}_Nm" for t in traj.torques_Nm for a in "xyz"]
    assert set(traj.torques_Nm) == {*INERTIA_TERMS, *TORQUE_TERMS}
    assert header == SAMPLE_HEADER + terms
    assert "tau_dev_x_Nm" in header and "I_o_z_Nm" in header
    assert all(units_for(t) == "N m" for t in terms)
    k = header.index("tau_fric_y_Nm")
    assert np.array_equal([float(r[k]) for r in rows], traj.torques_Nm["tau_fric"][:, 1])


def test_a_summary_only_run_is_its_summary_as_one_row(
    summary_only: RunData, tmp_path: Path
) -> None:
    traj = summary_only.trajectory
    assert traj.n_samples == 0
    header, rows = _read(write_csv(traj, tmp_path / "summary.csv"))
    expected = traj.summary.to_dict()
    assert header == SUMMARY_HEADER == list(expected)
    (row,) = rows
    for name, text in zip(header, row, strict=True):
        value = expected[name]
        if value is None:
            assert text == "", name
        elif isinstance(value, float):
            assert float(text) == value and text == repr(value), name
        else:
            assert text == str(value), name


def test_none_is_an_empty_cell_and_text_is_quoted(tmp_path: Path) -> None:
    summary = Summary(
        outcome="gutter",
        message='left gutter at x = 12.5 m, "early"',
        slide_m=None,
        hook_m=None,
        pocket_deg=None,
        time_s=1.2345678901234567,
        x_end_m=12.5,
        y_end_m=-0.0,
        speed_end_mps=7.1,
        rev_rate_end_rpm=250.0,
        n_steps=12,
        n_rhs=80,
        n_events=2,
    )
    traj = _with_summary(summary)
    header, rows = _read(write_csv(traj, tmp_path / "gutter.csv"))
    row = dict(zip(header, rows[0], strict=True))
    assert row["slide_m"] == row["hook_m"] == row["pocket_deg"] == ""
    assert row["message"] == summary.message
    assert row["time_s"] == "1.2345678901234567" and row["y_end_m"] == "-0.0"
    assert row["n_steps"] == "12"
    assert [cell(v) for v in (None, math.nan, 0.1, np.float64(0.1), np.int8(1), True)] == [
        "",
        "",
        "0.1",
        "0.1",
        "1",
        "1",
    ]


def _with_summary(summary: Summary) -> Trajectory:
    from bowlrec.core.trajectory import summary_trajectory

    return summary_trajectory([], summary)


def test_several_runs_are_one_summary_row_each(
    sampled: RunData, summary_only: RunData, tmp_path: Path
) -> None:
    archived = RunData(sampled.scene, sampled.plan, sampled.trajectory, "a" * 20)
    path = sink_for("t.csv").write_many([archived, summary_only], tmp_path / "t.csv")
    assert path == tmp_path / "t.csv" and [p.name for p in tmp_path.iterdir()] == ["t.csv"]
    header, rows = _read(path)
    assert header == [*RUN_COLUMNS, *SUMMARY_HEADER] == ["run_id", "name", *SUMMARY_HEADER]
    assert [r[:2] for r in rows] == [["a" * 20, "sampled"], ["", "summary only"]]
    assert rows[0][header.index("slide_m")] == repr(sampled.trajectory.summary.slide_m)
    assert _read(write_csv_many([], tmp_path / "none.csv")) == (header, [])
    assert [f.name for f in fields(Summary)] == SUMMARY_HEADER


def test_a_failed_write_leaves_the_old_file_and_no_temporary(
    sampled: RunData, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import bowlrec.sinks.csv_file as csv_file

    path = tmp_path / "run.csv"
    path.write_text("old\n")

    real_writer = csv.writer

    class Failing:
        def __init__(self, fh: Any, **kwargs: Any) -> None:
            self.writer = real_writer(fh, **kwargs)

        def writerow(self, row: Any) -> None:
            self.writer.writerow(row)

        def writerows(self, rows: Any) -> None:
            self.writer.writerows(list(rows)[:3])
            raise OSError("No space left on device")

    monkeypatch.setattr(csv_file.csv, "writer", Failing)
    with pytest.raises(OSError, match="No space"):
        write_csv(sampled.trajectory, path)
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["run.csv"]


def test_simulate_and_runs_export_write_csv(tmp_path: Path) -> None:
    scene = tmp_path / "scene.json"
    scene.write_text(
        json.dumps({"name": "cli", "delivery": DELIVERY, "options": {"record": "summary"}})
    )
    out = tmp_path / "summary.csv"
    result = runner.invoke(app, ["simulate", str(scene), "--no-archive", "-q", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert f"CSV: {out}" in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.json", "summary.csv"]
    assert _read(out)[0] == SUMMARY_HEADER

    arch = str(tmp_path / "a")
    sampled = {
        "name": "cli",
        "delivery": DELIVERY,
        "options": {"record": "rate", "record_dt_s": 0.05},
    }
    scene.write_text(json.dumps(sampled))
    result = runner.invoke(
        app, ["simulate", str(scene), "-a", arch, "-q", "--out", str(tmp_path / "s.csv")]
    )
    assert result.exit_code == 0, result.output
    header, rows = _read(tmp_path / "s.csv")
    assert header == SAMPLE_HEADER and len(rows) > 10
    (rid,) = [row["run_id"] for row in Archive(arch).list_runs()]
    result = runner.invoke(
        app, ["runs", "export", rid, "-a", arch, "--out", str(tmp_path / "e.csv")]
    )
    assert result.exit_code == 0, result.output
    assert (tmp_path / "e.csv").read_bytes() == (tmp_path / "s.csv").read_bytes()
    two = tmp_path / "two.csv"
    result = runner.invoke(app, ["runs", "export", rid, rid, "-a", arch, "--out", str(two)])
    assert result.exit_code == 0, result.output
    assert "CSV: " in result.output and "2 runs" in result.output
    header, rows = _read(two)
    assert header[:2] == ["run_id", "name"] and [r[:2] for r in rows] == [[rid, "cli"]] * 2


def test_simulate_without_archive_keeps_the_scenes_samples(tmp_path: Path) -> None:
    scene = tmp_path / "scene.json"
    sampled = {
        "name": "cli",
        "delivery": DELIVERY,
        "options": {"record": "rate", "record_dt_s": 0.05},
    }
    scene.write_text(json.dumps(sampled))
    out = tmp_path / "run.csv"
    result = runner.invoke(app, ["simulate", str(scene), "--no-archive", "-q", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert _read(out)[0] == SAMPLE_HEADER

"""The Trajectory as a pandas DataFrame (columns of the CSV file, values of the arrays) and its
short one-line repr (with Summary's and RunData's)."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

import bowlrec
from bowlrec.core.trajectory import Trajectory, sample_columns
from bowlrec.errors import MissingExtraError
from bowlrec.sinks import RunData
from bowlrec.spec import Scene

DELIVERY = {"speed_mps": 8.0, "omega_radps": [-16.62, 23.74, 7.765]}


def _simulate(**options: object) -> Trajectory:
    scene = Scene.model_validate({"name": "api", "delivery": DELIVERY, "options": options})
    return bowlrec.simulate(scene)


@pytest.fixture(scope="module")
def sampled() -> Trajectory:
    return _simulate(record="steps", record_terms=True)


@pytest.fixture(scope="module")
def summary_only() -> Trajectory:
    return _simulate(record="summary")


def test_the_dataframe_has_the_csv_columns_and_the_arrays_values(sampled: Trajectory) -> None:
    pytest.importorskip("pandas")
    frame = sampled.to_dataframe()
    columns = sample_columns(sampled)
    assert list(frame.columns) == list(columns)
    assert len(frame) == sampled.n_samples
    assert list(frame.columns[:5]) == ["t_s", "x_m", "y_m", "z_m", "vx_mps"]
    assert {"omega_x_radps", "normal_force_N", "energy_J", "tau_dev_x_Nm", "I_o_z_Nm"} <= set(
        frame.columns
    )
    assert np.array_equal(frame[["x_m", "y_m", "z_m"]].to_numpy(), sampled.position_m)
    assert np.array_equal(frame[["q_w", "q_x", "q_y", "q_z"]].to_numpy(), sampled.quaternion_wxyz)
    assert np.array_equal(frame["t_s"].to_numpy(), sampled.t_s)
    assert np.array_equal(frame["phase"].to_numpy(), sampled.phase)
    assert frame["phase"].dtype == np.int8 and frame["t_s"].dtype == np.float64
    for name, values in columns.items():
        assert np.array_equal(frame[name].to_numpy(), values), name
    torque = frame[["tau_fric_x_Nm", "tau_fric_y_Nm", "tau_fric_z_Nm"]].to_numpy()
    assert np.array_equal(torque, sampled.torques_Nm["tau_fric"])


def test_a_summary_only_trajectory_is_one_row_of_its_summary(summary_only: Trajectory) -> None:
    pytest.importorskip("pandas")
    frame = summary_only.to_dataframe()
    summary = summary_only.summary.to_dict()
    assert list(frame.columns) == list(summary) and len(frame) == 1
    row = frame.iloc[0]
    for name, value in summary.items():
        if value is None:
            assert math.isnan(row[name]), name
        else:
            assert row[name] == value, name
    assert frame["slide_m"].dtype == np.float64 and frame["n_steps"].dtype == np.int64


def test_without_pandas_the_error_names_the_extra(
    sampled: Trajectory, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'bowlrec\[pandas\]'") as caught:
        sampled.to_dataframe()
    assert isinstance(caught.value, ImportError) and caught.value.name == "pandas"


@pytest.mark.process  # a fresh interpreter's modules
def test_import_bowlrec_does_not_import_pandas() -> None:
    code = "import sys, bowlrec, bowlrec.core.trajectory; print('pandas' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"


def test_the_repr_is_one_short_line(sampled: Trajectory, summary_only: Trajectory) -> None:
    s = sampled.summary
    text = repr(sampled)
    assert "\n" not in text and len(text) < 200, text
    assert text.startswith(f"Trajectory(outcome={s.outcome!r}, samples={sampled.n_samples}, t=0..")
    assert f"slide_m={s.slide_m:.4g}" in text and f"events={len(sampled.events)}" in text
    assert f"terms={len(sampled.torques_Nm)}" in text
    short = repr(summary_only)
    assert "samples=0" in short and f"time_s={summary_only.summary.time_s:.4g}" in short
    assert "terms=" not in short and len(short) < 200
    summary = repr(s)
    assert summary.startswith(f"Summary(outcome={s.outcome!r}, slide_m=") and len(summary) < 200
    assert "\n" not in summary


def test_run_data_repr_names_the_run_and_not_its_arrays(sampled: Trajectory) -> None:
    scene = Scene.model_validate({"name": "api", "delivery": DELIVERY})
    text = repr(RunData(scene, scene.resolve(), sampled, "c" * 20))
    assert text == f"RunData(name='api', run_id='{'c' * 20}', trajectory={sampled!r})"
    assert len(text) < 300

"""The command line: JSON output, errors naming the field, the Table III job, schemas."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from bowlrec.cli import app

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def test_simulate_json_has_the_documented_keys() -> None:
    result = runner.invoke(app, ["simulate", str(ROOT / "examples/paper/case16.json"), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    for key in ("outcome", "slide_m", "hook_m", "pocket_deg", "time_s", "x_end_m", "y_end_m"):
        assert key in data
    assert data["outcome"] == "pins"
    assert abs(data["x_end_m"] - 18.288) < 1e-9


def test_simulate_never_rolling_gives_null_slide() -> None:
    result = runner.invoke(app, ["simulate", str(ROOT / "examples/paper/case06.json"), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["slide_m"] is None


def test_simulate_saves_the_trajectory(tmp_path: Path) -> None:
    out = tmp_path / "run.npz"
    result = runner.invoke(
        app, ["simulate", str(ROOT / "examples/paper/case04.json"), "--out", str(out), "-q"]
    )
    assert result.exit_code == 0, result.output
    with np.load(out) as z:
        assert z["position_m"].shape[1] == 3
        assert abs(z["position_m"][-1, 0] - 18.288) < 1e-9
        summary = json.loads(str(z["summary_json"]))
        assert summary["outcome"] == "pins"


def test_invalid_scene_names_field_value_and_range(tmp_path: Path) -> None:
    bad = json.loads((ROOT / "examples/paper/case01.json").read_text())
    bad["ball"]["rg_m"] = [0.067, 0.2, 0.2]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(bad))
    result = runner.invoke(app, ["simulate", str(path)])
    assert result.exit_code == 2
    assert "ball.rg_m" in result.output
    assert "0.2" in result.output and "0.1085" in result.output


def test_unknown_field_is_rejected(tmp_path: Path) -> None:
    bad = json.loads((ROOT / "examples/paper/case01.json").read_text())
    bad["delivery"]["spin"] = 3
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(bad))
    result = runner.invoke(app, ["simulate", str(path)])
    assert result.exit_code == 2
    assert "delivery.spin" in result.output


def test_missing_file_is_a_clear_error() -> None:
    result = runner.invoke(app, ["simulate", "no-such-scene.json"])
    assert result.exit_code == 2
    assert "no such file" in result.output


def test_paper_json_lists_18_cases_beside_the_paper() -> None:
    result = runner.invoke(app, ["paper", "--json", "--quiet"])
    assert result.exit_code == 0, result.output
    rows = json.loads(result.output)
    assert [r["case"] for r in rows] == list(range(1, 19))
    assert rows[0]["paper"]["slide_m"] == 8.10
    assert abs(rows[0]["as_written"]["slide_m"] - 8.1729) < 1e-3


def test_schema_command_writes_the_committed_schemas(tmp_path: Path) -> None:
    result = runner.invoke(app, ["schema", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    for p in tmp_path.iterdir():
        assert p.read_text() == (ROOT / "schemas" / p.name).read_text()


@pytest.mark.process  # a fresh interpreter's modules
def test_import_bowlrec_does_not_load_numba_or_the_cli_stack() -> None:
    code = (
        "import sys, bowlrec, bowlrec.spec; "
        "print('numba' in sys.modules, 'rich' in sys.modules, "
        "'bowlrec.core.integrator' in sys.modules, 'bowlrec.testing' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False", "False", "False"]


def test_docs_table3_block_is_the_computed_one() -> None:
    from bowlrec.paper_table import markdown_table, run_paper_cases
    from tools.readme_blocks import block_path, read_block

    block = read_block(block_path("table3"), "table3")
    assert block == markdown_table(run_paper_cases()), "regenerate: python -m tools.update_table3"

"""Issue 33, items 8-10: one board convention per view, said on the view (a left-hander's
boards from the left gutter; hook and pocket as magnitudes with their side), the Jobs page's
seed that visibly sweeps something, and colour-bar ticks with sensible rounding."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

import bowlrec
from bowlrec.bowling.report import board_count, inferred_handedness, sideways, summary_rows
from bowlrec.cli import app
from bowlrec.figures.lane import mu_labels
from bowlrec.figures.trajectory import runs_figure
from bowlrec.scene_input import parse_scene
from bowlrec.spec import Scene
from bowlrec.spec.run import RunData

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def _left_hander(target: float = 10.0) -> dict[str, Any]:
    """The right-hander's pocket example mirrored: a left-hander aiming at board 10."""
    data = json.loads((ROOT / "examples/bowler/pocket-right.json").read_text())
    data["name"] = "left-hander"
    data["pap"]["handedness"] = data["delivery"]["handedness"] = "left"
    data["delivery"]["target_board_at_arrows"] = target
    data["options"]["record_dt_s"] = 0.01
    return data


@pytest.fixture(scope="module")
def left_run() -> RunData:
    scene = parse_scene(_left_hander()).scene
    return RunData(scene=scene, plan=scene.resolve(), trajectory=bowlrec.simulate(scene))


def _board_axis(fig: Any) -> Any:
    (lane,) = [a for a in fig.axes if a.get_gid() == "lane"]
    (boards,) = [c for c in lane.child_axes if c.get_gid() == "boards"]
    return lane, boards


def test_a_left_handers_plot_counts_boards_from_the_left_gutter(left_run: RunData) -> None:
    """The arrows target, board 10, reads 10 on the plot's board axis (not 30), and the axis
    says whose count it is; the legend names the hook's side instead of a sign."""
    fig = runs_figure([left_run])
    lane, boards = _board_axis(fig)
    assert "bowler's count" in boards.get_ylabel() and "left gutter" in boards.get_ylabel()
    traj = left_run.trajectory
    arrows_x = 15 * 0.3048
    y_arrows = float(np.interp(arrows_x, traj.position_m[:, 0], traj.position_m[:, 1]))
    # the board axis maps lane-frame y to boards: read the board of the path at the arrows
    to_boards = boards._functions[0]
    assert float(to_boards(y_arrows)) + 0.5 == pytest.approx(10.0, abs=0.05)
    legend = fig.legends[0] if fig.legends else lane.get_legend()
    text = " ".join(t.get_text() for t in legend.get_texts())
    assert "to the right" in text and "hook -" not in text and "pocket -" not in text


def test_a_right_handers_plot_says_its_count_too() -> None:
    scene = Scene.model_validate(
        {"name": "r", "delivery": {"speed_mps": 8.0, "omega_radps": [-8.0, 30.0, 0.0]},
         "options": {"record": "rate", "record_dt_s": 0.01}}
    )  # fmt: skip
    run = RunData(scene=scene, plan=scene.resolve(), trajectory=bowlrec.simulate(scene))
    _, boards = _board_axis(runs_figure([run]))
    assert "bowler's count" in boards.get_ylabel() and "right gutter" in boards.get_ylabel()


def test_the_simulate_summary_names_sides_and_json_keeps_the_signs(tmp_path: Path) -> None:
    """The summary table shows hook and pocket as magnitudes with their side and says whose
    count the bowler's table uses; ``--json`` keeps the signed lane-frame values."""
    path = tmp_path / "left.json"
    data = _left_hander()
    data["options"]["record"] = "summary"
    path.write_text(json.dumps(data))
    env = {"COLUMNS": "200"}
    shown = runner.invoke(app, ["simulate", str(path), "--no-archive", "-q"], env=env)
    assert shown.exit_code == 0, shown.output
    hook = next(line for line in shown.output.splitlines() if "│ hook " in line)
    assert "cm to the right" in hook and "-" not in hook.split("│")[2]
    pocket = next(line for line in shown.output.splitlines() if "pocket angle" in line)
    assert "deg to the right" in pocket
    assert "from the left gutter" in shown.output
    raw = runner.invoke(app, ["simulate", str(path), "--no-archive", "--json"], env=env)
    out = json.loads(raw.output)
    assert out["hook_m"] < 0 and out["pocket_deg"] < 0  # lane frame, signed
    assert out["bowler"]["handedness"] == "left" and out["bowler"]["hook_boards"] > 0


def test_the_conventions_helpers() -> None:
    assert board_count("left") == "bowler's count, from the left gutter"
    assert board_count("right") == "bowler's count, from the right gutter"
    assert sideways(-1.08, ".2f", "m") == "1.08 m to the right"
    assert sideways(2.5, ".1f", "°") == "2.5° to the left"
    assert sideways(-0.0001, ".2f", "cm") == "0.00 cm"
    assert summary_rows(None, None) == []
    assert dict(summary_rows(0.5, 3.0)) == {
        "hook": "50.00 cm to the left", "pocket angle": "3.000 deg to the left"
    }  # fmt: skip
    assert inferred_handedness([0.5, 0.3, 0.45]) == "right"
    assert inferred_handedness([0.5, 0.9, 0.6]) == "left"


def test_variance_figures_say_whose_count() -> None:
    from bowlrec.bowling.pocket import POCKET
    from bowlrec.bowling.variance import ScatterResult
    from bowlrec.figures.variance import scatter_figure

    fields = ScatterResult.__dataclass_fields__
    assert "handedness" in fields
    result = ScatterResult(
        n=2, seed=0, scatter=None, pocket=POCKET,  # type: ignore[arg-type]
        entry_board=np.array([17.0, 18.0]), entry_angle_deg=np.array([5.0, 5.5]),
        outcomes=np.array(["pins", "pins"]), seconds=0.0, handedness="left",
    )  # fmt: skip
    fig = scatter_figure(result)
    assert "from the left gutter" in fig.axes[0].get_xlabel()


def test_colour_bar_ticks_are_rounded(left_run: RunData) -> None:
    """The friction colour bar labels read 0.188 and 0.0307, not 0.188465 and 0.0307285."""
    assert mu_labels([0.0307285, 0.188465]) == ["0.0307", "0.188"]
    assert mu_labels([0.04]) == ["0.04"]
    assert mu_labels([0.1234, 0.1235]) == ["0.1234", "0.1235"]  # more digits only to differ
    fig = runs_figure([left_run])
    (lane,) = [a for a in fig.axes if a.get_gid() == "lane"]
    (bar,) = [c for c in lane.child_axes if c.get_gid() != "boards"]
    fig.canvas.draw()
    labels = [t.get_text() for t in bar.get_yticklabels() if t.get_text()]
    assert labels and all(len(t) <= 6 for t in labels), labels


def test_the_seeded_job_changes_the_hook() -> None:
    """The Jobs page's first example sweeps something that moves the result: its 15 runs
    reach the pins with hooks that differ (not 0.00 cm for all)."""
    from bowlrec.batch import JobSpec, run_job
    from bowlrec.web.seeds import SEEDS

    seed = SEEDS[0]
    assert seed.kind == "job"
    result = run_job(JobSpec.model_validate(seed.value), None, workers=0)
    rows = result.rows
    assert len(rows) == 15 and all(r["outcome"] == "pins" for r in rows)
    hooks = [r["hook_m"] for r in rows]
    assert min(abs(h) for h in hooks) > 0.01
    assert max(hooks) - min(hooks) > 0.1  # over 10 cm between the runs


# -- item 9a: jobs run from the command line are the archive's jobs too ---------------------------


def test_a_command_line_batch_is_listed_on_the_jobs_page(tmp_path: Path, app_server: Any) -> None:
    """``bowlrec batch JOB`` records its job in the archive (``jobs/cli/``); the Jobs page
    lists it beside the service's (so does GET /jobs, with its source; the service refuses to
    cancel or resume it), its page shows it done and its results name its runs. A
    record a killed batch left ``running`` reads as interrupted; a damaged one is listed as
    damaged and breaks nothing."""
    pytest.importorskip("fastapi")
    root = tmp_path / "archive"
    job = {
        "format": "bowlrec-job",
        "name": "from-the-shell",
        "base": {"name": "cli", "options": {"record": "summary"}},
        "sweep": {"kind": "grid", "axes": {"delivery.speed_mps": [7.0, 8.0, 9.0]}},
    }
    path = tmp_path / "job.json"
    path.write_text(json.dumps(job))
    out = tmp_path / "t.csv"
    done = runner.invoke(
        app, ["batch", str(path), "-a", str(root), "-j", "0", "-q", "-o", str(out)]
    )
    assert done.exit_code == 0, done.output
    (record,) = [p for p in (root / "jobs" / "cli").glob("*.json") if ".spec." not in p.name]
    job_id = record.stem
    assert json.loads(record.read_text())["status"] == "done"

    jobs_dir = root / "jobs" / "cli"
    killed = json.loads(record.read_text())
    killed.update(job_id="a" * 16, status="running", done=1)
    (jobs_dir / f"{'a' * 16}.json").write_text(json.dumps(killed))
    (jobs_dir / f"{'a' * 16}.spec.json").write_text((jobs_dir / f"{job_id}.spec.json").read_text())
    (jobs_dir / f"{'b' * 16}.json").write_text("{truncated")

    server = app_server(root)
    with server.client() as client:
        html = client.get("/ui/jobs").text
        assert job_id in html and "from-the-shell" in html and "command line" in html
        assert "a" * 16 in html and "interrupted" in html
        assert "b" * 16 in html and "damaged" in html
        page = client.get(f"/ui/jobs/{job_id}")
        assert page.status_code == 200 and "delivery.speed_mps" in page.text
        assert 'id="cancel-job"' not in page.text  # its batch runs in its own process
        rows = client.get(f"/jobs/{job_id}/results").json()
        assert [r["values"]["delivery.speed_mps"] for r in rows] == [7.0, 8.0, 9.0]
        assert all(r["run_id"] and r["outcome"] == "pins" for r in rows)
        events = client.get(f"/jobs/{job_id}/events").text
        assert '"status":"done"' in events and '"done":3' in events
        assert client.get("/jobs/" + "c" * 16 + "/events").status_code == 404
        listed = {j["job_id"]: j for j in client.get("/jobs").json()}
        assert listed[job_id]["source"] == "command line" and listed[job_id]["status"] == "done"
        assert listed["a" * 16]["status"] == "interrupted"
        one = client.get(f"/jobs/{job_id}").json()
        assert one["source"] == "command line" and len(one["run_ids"]) == 3
        for action in ("cancel", "resume"):
            answer = client.post(f"/jobs/{job_id}/{action}")
            assert answer.status_code == 409 and "command line" in answer.text, answer.text
        assert client.post("/jobs/" + "c" * 16 + "/cancel").status_code == 404

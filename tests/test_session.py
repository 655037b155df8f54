"""Sessions: the oil changes shot by shot, every shot lands in the archive with the oil grid
after it, the oil is conserved over the session, and a session resumes exactly."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bowlrec.archive import Archive
from bowlrec.errors import SceneInputError
from bowlrec.session.records import (
    oil_from_records,
    oil_records,
    state_from_records,
)
from bowlrec.session.runner import run_session, shot_run_id
from bowlrec.session.spec import load_session, parse_session

HERE = Path(__file__).parent
EXAMPLE = HERE.parent / "examples" / "session" / "league-night.yaml"


def _spec(**over: Any) -> Any:
    data: dict[str, Any] = {
        "name": "t",
        "games": 1,
        "seed": 3,
        "pins": False,  # the pocket-window rule: these tests are about the oil
        "grid": {"cell_ft": 3.0, "cell_boards": 1.0},
        "record_dt_s": 0.01,
        "bowlers": [
            {"name": "A", "scene": {}, "scatter": "robot", "aim": False},
            {
                "name": "B",
                "scene": {"delivery": {"rev_rate_rpm": 250.0}},
                "scatter": "league",
                "aim": False,
            },
        ],
    }
    data.update(over)
    return parse_session(data)


@pytest.fixture(scope="module")
def played(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Archive]:
    archive = Archive(tmp_path_factory.mktemp("s") / "a")
    return run_session(_spec(), archive, max_shots=8), archive


def test_every_shot_is_archived_with_the_oil_after_it(played: tuple[Any, Archive]) -> None:
    result, archive = played
    assert len(result.rows) == 8 and result.simulated == 8
    oil = result.fresh
    for row in result.rows:
        stored = archive.load(row.run_id)
        assert set(stored.records) == {"oil", "session"}
        state = state_from_records(stored.records)
        assert (state.shot, state.bowler, state.game) == (row.shot, row.bowler, 1)
        after = oil_from_records(stored.records["oil"])
        # the shot's scene is the lane as the shots before left it: its friction came from
        # the previous grid, and the grid after it differs where the ball ran
        assert after.volume_ul.shape == oil.volume_ul.shape
        assert state.ledger.lane_before_ul == pytest.approx(oil.volume_ul.sum(), rel=1e-12)
        assert not np.array_equal(after.volume_ul, oil.volume_ul)
        oil = after
    np.testing.assert_array_equal(oil.volume_ul, result.final.volume_ul)
    # bowlers take turns frame by frame
    assert [r.bowler for r in result.rows if r.ball == 1][:2] == ["A", "B"]


def test_oil_is_conserved_over_the_session(played: tuple[Any, Archive]) -> None:
    """Oil off the lane = oil absorbed by the covers + oil still on the balls (loads start at
    zero), to rounding (1e-9 relative to the lane's oil: a few hundred float sums)."""
    result, archive = played
    lane_loss = result.fresh.volume_ul.sum() - result.final.volume_ul.sum()
    absorbed = sum(r.absorbed_ul for r in result.rows)
    last = state_from_records(archive.load(result.rows[-1].run_id).records)
    on_balls = sum(last.loads_ul.values())
    assert lane_loss > 0.0
    assert lane_loss == pytest.approx(absorbed + on_balls, abs=1e-9 * result.fresh.volume_ul.sum())
    before = float(result.fresh.volume_ul.sum())
    for r in result.rows:  # each shot: the lane loses what the ball lifted and did not lay back
        assert before - r.lane_oil_ul == pytest.approx(r.lifted_ul - r.deposited_ul, abs=1e-9)
        before = r.lane_oil_ul


def test_a_session_resumes_exactly_where_it_stopped(tmp_path: Path) -> None:
    spec = _spec()
    whole = run_session(spec, Archive(tmp_path / "whole"), max_shots=7)
    archive = Archive(tmp_path / "parts")
    first = run_session(spec, archive, max_shots=3)
    rest = run_session(spec, archive, max_shots=7)
    assert first.simulated == 3 and (rest.resumed, rest.simulated) == (3, 4)
    assert [r.run_id for r in rest.rows] == [r.run_id for r in whole.rows]
    for a, b in zip(rest.rows, whole.rows, strict=True):
        assert {**a.to_dict(), "simulated": None} == {**b.to_dict(), "simulated": None}
    np.testing.assert_array_equal(rest.final.volume_ul, whole.final.volume_ul)


def test_shot_ids_belong_to_their_session(played: tuple[Any, Archive]) -> None:
    """The same delivery in another session (other transfer parameters) is another run."""
    result, archive = played
    row = result.rows[0]
    plan = archive.load(row.run_id).scene.resolve()
    assert shot_run_id(plan, result.session_id, 1) == row.run_id
    other = _spec(transfer={"pickup_fraction": 0.1}).session_id()
    assert other != result.session_id
    assert shot_run_id(plan, other, 1) != row.run_id
    assert shot_run_id(plan, result.session_id, 2) != row.run_id


def test_oil_records_round_trip_exactly() -> None:
    from bowlrec.bowling.oil import preset
    from bowlrec.bowling.oil_transfer import session_oil_grid

    grid = session_oil_grid(preset("kegel_chromium_6742"), cell_ft=2.0, cell_boards=3.0)
    back = oil_from_records(oil_records(grid))
    for name in ("x_edges_ft", "board_edges", "volume_ul"):
        np.testing.assert_array_equal(getattr(back, name), getattr(grid, name))


@pytest.mark.parametrize(
    ("over", "message"),
    [
        ({"pattern": "no_such"}, "pattern = 'no_such' is not a preset"),
        ({"games": 0}, "games: Input should be greater than or equal to 1"),
        ({"bowlers": []}, "bowlers: List should have at least 1 item"),
        ({"transfer": {"pickup_fraction": 2}}, "transfer.pickup_fraction"),
        ({"grid": {"cell_ft": -1}}, "grid.cell_ft"),
    ],
)
def test_bad_sessions_are_one_clear_line(over: dict[str, Any], message: str) -> None:
    with pytest.raises(SceneInputError, match=message.replace("(", r"\(")):
        _spec(**over)


def test_bowlers_need_distinct_names() -> None:
    with pytest.raises(SceneInputError, match="names must differ"):
        _spec(bowlers=[{"name": "A", "scene": {}}, {"name": "A", "scene": {}}])


def test_the_example_session_loads_its_bowler_files() -> None:
    spec = load_session(EXAMPLE)
    assert [b.name for b in spec.bowlers] == ["Ann", "Bo", "Cy", "Di"]
    assert spec.bowlers[3].scene.delivery.handedness == "left"


def test_cli_writes_the_table_and_figures(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from bowlrec.cli import app

    session = tmp_path / "s.json"
    data = _spec().model_dump(mode="json")
    session.write_text(json.dumps(data))
    out = tmp_path / "out"
    cmd = ["session", str(session), "-a", str(tmp_path / "a")]
    done = CliRunner().invoke(app, [*cmd, "-o", str(out), "--max-shots", "5", "--quiet"])
    assert done.exit_code == 0, done.stderr
    assert "5 shots (5 simulated, 0 read back" in done.stderr
    lines = (out / "shots.csv").read_text().splitlines()
    assert lines[0].startswith("shot,game,frame,ball,bowler,run_id,outcome,pocket,entry_board")
    assert len(lines) == 6
    for name in ("oil.svg", "drift.svg"):
        assert ET.parse(out / name).getroot().tag.endswith("svg")
    again = CliRunner().invoke(app, [*cmd, "-o", str(out), "--max-shots", "5", "--json"])
    assert json.loads(again.stdout)[0]["resumed"] == 5


def test_cli_bad_session_is_one_line(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from bowlrec.cli import app

    bad = tmp_path / "bad.yaml"
    bad.write_text("format: bowlrec-session\ngames: 3\nbowlers: [{name: A, scene: nope.json}]\n")
    done = CliRunner().invoke(app, ["session", str(bad), "-a", str(tmp_path / "a")])
    assert done.exit_code == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "bowlers[0].scene" in lines[0]


def test_a_sweep_expands_into_named_sessions() -> None:
    from bowlrec.errors import JobError
    from bowlrec.session.spec import expand_sessions

    data = _spec().model_dump(mode="json")
    data["sweep"] = {"kind": "grid", "axes": {"transfer.pickup_fraction": [0.2, 0.4], "seed": [1]}}
    specs = expand_sessions(data)
    assert [s.name for s in specs] == ["t-1", "t-2"]
    assert [s.transfer.pickup_fraction for s in specs] == [0.2, 0.4]
    assert len({s.session_id() for s in specs}) == 2
    data["sweep"] = {"kind": "grid", "axes": {"transfer.no_such": [1]}}
    with pytest.raises(JobError, match="no_such"):
        expand_sessions(data)


@pytest.mark.process  # a process pool
def test_cli_plays_a_sweep_on_parallel_workers(tmp_path: Path) -> None:
    session = tmp_path / "s.json"
    data = _spec().model_dump(mode="json")
    data["sweep"] = {"kind": "zip", "axes": {"seed": [1, 2]}}
    session.write_text(json.dumps(data))
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "bowlrec.cli", "session", str(session), "-a", str(tmp_path / "a")]
        + ["-o", str(out), "--max-shots", "3", "--workers", "2", "--json"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    summaries = json.loads(done.stdout)
    assert [s["name"] for s in summaries] == ["t-1", "t-2"]
    assert all(s["simulated"] == 3 for s in summaries)
    assert (out / "t-1" / "shots.csv").exists() and (out / "t-2" / "drift.svg").exists()
    assert len(Archive(tmp_path / "a", create=False).list_runs()) == 6


@pytest.mark.fault  # SIGKILL
def test_a_session_killed_mid_run_resumes_to_the_same_shots(tmp_path: Path) -> None:
    """SIGKILL once the first shots are sealed; the rerun reads them back and plays the rest,
    and every shot (run ID, result, oil) equals an uninterrupted session's."""
    import os
    import signal
    import time

    session = tmp_path / "s.json"
    session.write_text(json.dumps(_spec().model_dump(mode="json")))
    archive = tmp_path / "a"
    cmd = [sys.executable, "-m", "bowlrec.cli", "session", str(session), "-a", str(archive)]
    cmd += ["-o", str(tmp_path / "out"), "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    segments = archive / "segments"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if segments.is_dir() and any(segments.glob("*.h5")):
            break
        time.sleep(0.02)
    killed = proc.poll() is None
    if killed:
        os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=60)
    done = subprocess.run([*cmd, "--json"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)[0]
    if killed:
        assert summary["resumed"] > 0 and summary["simulated"] > 0
    whole = run_session(_spec(), Archive(tmp_path / "whole"))
    rows = list(csv.DictReader((tmp_path / "out" / "shots.csv").open()))
    assert [r["run_id"] for r in rows] == [r.run_id for r in whole.rows]
    assert [float(r["lane_oil_ul"]) for r in rows] == [r.lane_oil_ul for r in whole.rows]
    assert summary["oil_after_ul"] == float(whole.final.volume_ul.sum())


def test_a_batch_of_a_session_file_names_the_command() -> None:
    from bowlrec.batch.job import load_job
    from bowlrec.errors import JobError

    with pytest.raises(
        JobError, match="this is a session, not a batch job: run it with `bowlrec session`"
    ):
        load_job(EXAMPLE)


def test_bowlers_share_one_lane() -> None:
    with pytest.raises(
        SceneInputError, match=r"bowlers\[1\].scene.lane = .* a session is one lane"
    ):
        _spec(
            bowlers=[{"name": "A", "scene": {}}, {"name": "B", "scene": {"lane": {"width_in": 42}}}]
        )


@pytest.mark.process  # a Dask cluster of processes
def test_sessions_on_a_dask_cluster_equal_local_ones(tmp_path: Path) -> None:
    distributed = pytest.importorskip(
        "distributed", reason="dask.distributed not installed (pip install 'bowlrec[dask]')"
    )
    session = tmp_path / "s.json"
    data = _spec().model_dump(mode="json")
    data["sweep"] = {"kind": "zip", "axes": {"seed": [5, 6]}}
    session.write_text(json.dumps(data))
    base = [sys.executable, "-m", "bowlrec.cli", "session", str(session), "--max-shots", "3"]
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        remote = subprocess.run(
            [*base, "-a", str(tmp_path / "dask"), "-o", str(tmp_path / "o1"), "--json"]
            + ["--scheduler", cluster.scheduler_address],
            capture_output=True,
            text=True,
            timeout=600,
        )
    assert remote.returncode == 0, remote.stderr
    local = subprocess.run(
        [*base, "-a", str(tmp_path / "local"), "-o", str(tmp_path / "o2"), "--json"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert local.returncode == 0, local.stderr
    ids = {r["run_id"] for r in Archive(tmp_path / "dask", create=False).list_runs()}
    assert ids == {r["run_id"] for r in Archive(tmp_path / "local", create=False).list_runs()}
    assert len(ids) == 6


def _adjusting(adjust: Any) -> Any:
    return _spec(
        bowlers=[
            {"name": "A", "scene": {"delivery": {"style": "tweener"}}, "scatter": "league",
             "aim": False, "adjust": adjust},
        ],
    )  # fmt: skip


def test_bowlers_move_feet_and_target_toward_repeated_misses() -> None:
    """The 2-and-1 move: after two first balls in a row on one side of the pocket's boards the
    laydown moves 2 boards and the target 1 toward the miss; a ball in the window, or a miss on
    the other side, starts the count again; adjust null keeps the line."""
    result = run_session(_adjusting({"feet_boards": 2.0, "target_boards": 1.0}), None)
    pocket = result.spec.pocket
    firsts = [r for r in result.rows if r.ball == 1]
    laydown, target = firsts[0].laydown_board, firsts[0].target_board
    streak: list[float] = []
    moves = 0
    for before, after in zip(firsts, firsts[1:], strict=False):
        expected_move = 0.0
        if before.entry_board is not None:
            if pocket.board_min <= before.entry_board <= pocket.board_max:
                streak = []
            else:
                side = 1.0 if before.entry_board > pocket.board_max else -1.0
                streak = [*streak, side] if streak and streak[-1] == side else [side]
                if len(streak) == 2:
                    expected_move, streak = side, []
        # the move shows on the next first ball (a second ball in between throws it already)
        assert after.laydown_board == pytest.approx(laydown + 2.0 * expected_move)
        assert after.target_board == pytest.approx(target + 1.0 * expected_move)  # type: ignore[operator]
        laydown, target = after.laydown_board, after.target_board
        moves += expected_move != 0.0
    assert moves >= 1  # the league scatter on a changing lane makes the bowler move
    kept = run_session(_adjusting(None), None)
    assert {r.laydown_board for r in kept.rows} == {firsts[0].laydown_board}

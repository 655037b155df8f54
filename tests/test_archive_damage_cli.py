"""Damage and recovery as the command line reports them (issue 34): an unreadable segment
whatever the order of ``runs reindex`` and ``runs repair``, a damaged ball row of the index,
and what recovery did, wherever it ran. In-process (typer's CliRunner): the fast tier."""

from __future__ import annotations

import json
import logging
import shutil
import sqlite3
from pathlib import Path

import pytest
from typer.testing import CliRunner

import bowlrec
from bowlrec.archive import Archive
from bowlrec.cli import app
from bowlrec.sinks import RunData
from bowlrec.spec import Scene

runner = CliRunner()


@pytest.fixture(scope="module")
def template() -> RunData:
    """A summary-only run; its copies get run IDs ``f"{i:020x}"``."""
    scene = Scene.model_validate({"options": {"record": "summary"}})
    return RunData(scene, scene.resolve(), bowlrec.simulate(scene))


def _copy(template: RunData, i: int) -> RunData:
    return RunData(template.scene, template.plan, template.trajectory, f"{i:020x}")


def _seal(archive: Archive, template: RunData, ids: range, *, register: bool = True) -> Path:
    builder = archive.builder()
    for i in ids:
        builder.append(archive.record(_copy(template, i), wall_time_s=0.0))
    info = archive.seal(builder)
    if register:
        archive.register([info])
    return info.path


def _three_segments(root: Path, template: RunData) -> list[Path]:
    """12 runs in 3 segments of 4."""
    archive = Archive(root)
    paths = [_seal(archive, template, range(4 * k, 4 * k + 4)) for k in range(3)]
    archive.close()
    return paths


def _invoke(*args: str) -> tuple[int, str]:
    result = runner.invoke(app, list(args))
    # a traceback is an exception other than the SystemExit of a handled error
    assert result.exception is None or isinstance(result.exception, SystemExit), (
        f"unhandled {type(result.exception).__name__}: {result.exception}\n{result.output}"
    )
    return result.exit_code, result.output


def _listed(root: Path) -> list[str]:
    code, out = _invoke("runs", "list", "-a", str(root), "--limit", "0", "--ids")
    assert code == 0, out
    return sorted(out.split())


# -- 1. a truncated segment, whatever the order of the commands --------------------------------


@pytest.mark.parametrize("first", [[], ["runs", "reindex"], ["runs", "list"], ["archive", "info"]])
def test_an_unreadable_segment_is_reported_and_quarantined_in_any_order(
    tmp_path: Path, template: RunData, first: list[str]
) -> None:
    """A segment cut to half its size: ``runs reindex`` (when run) says so and exits 1; then
    ``runs repair`` names the segment, exits 1 and moves it to quarantine/; a second repair
    finds nothing new. The other segments' runs are listed throughout."""
    root = tmp_path / "a"
    paths = _three_segments(root, template)
    bad = paths[1]
    with open(bad, "r+b") as fh:
        fh.truncate(bad.stat().st_size // 2)
    healthy = sorted(f"{i:020x}" for i in [*range(4), *range(8, 12)])

    if first:
        code, out = _invoke(*first, "-a", str(root))
        if first == ["runs", "reindex"]:
            assert code == 1, out
            assert "8 run(s) indexed" in out
            assert bad.stem in out and "runs repair" in out
    code, out = _invoke("runs", "repair", "-a", str(root))
    assert code == 1, out
    assert "1 segment(s) quarantined" in out and bad.stem in out
    assert not bad.exists() and (root / "quarantine" / bad.name).exists()
    report = json.loads((root / "quarantine" / f"{bad.stem}.json").read_text())
    assert report["segment_id"] == bad.stem and report["damaged"]
    assert _listed(root) == healthy
    code, out = _invoke("runs", "list", "--damaged", "-a", str(root), "--json")
    assert code == 0 and {d["segment_id"] for d in json.loads(out)} == {bad.stem}

    code, out = _invoke("runs", "repair", "-a", str(root), "--json")
    assert code == 0, out
    again = json.loads(out)
    assert again["quarantined_segments"] == [] and again["segments_unreadable"] == 0
    code, out = _invoke("runs", "reindex", "-a", str(root))
    assert code == 0 and "8 run(s) indexed" in out, out
    assert _listed(root) == healthy


# -- 2. a damaged ball row of the index ----------------------------------------------------------


def _damage_ball_row(root: Path, name: str) -> None:
    con = sqlite3.connect(root / "index.sqlite")
    with con:
        con.execute("UPDATE balls SET spec_json = ? WHERE name = ?", ('{"mass_kg": 6.', name))
    con.close()


@pytest.mark.parametrize("fix", ["reindex", "repair"])
def test_a_damaged_ball_row_is_one_line_naming_the_ball_and_the_fix(
    tmp_path: Path, template: RunData, fix: str
) -> None:
    root = tmp_path / "a"
    archive = Archive(root)
    archive.balls.add("house", template.scene.ball)
    archive.balls.add("spare", template.scene.ball.model_copy(update={"mass_kg": 6.5}))
    archive.close()
    _damage_ball_row(root, "house")

    for command in (["balls", "list"], ["balls", "list", "--json"], ["balls", "show", "house"]):
        code, out = _invoke(*command, "-a", str(root))
        assert code == 1, out
        lines = out.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error:"), out
        assert "house@1" in lines[0] and "damaged" in lines[0]
        assert "runs reindex" in lines[0] and "runs repair" in lines[0]
    code, out = _invoke("balls", "show", "spare", "-a", str(root))
    assert code == 0 and "6.5" in out, out

    code, out = _invoke("runs", fix, "-a", str(root))
    assert code == 0, out
    code, out = _invoke("balls", "list", "-a", str(root), "--json")
    assert code == 0, out
    assert [b["name"] for b in json.loads(out)] == ["house", "spare"]


# -- 4. what recovery did is reported --------------------------------------------------------


def _copy_in_a_foreign_segment(root: Path, tmp_path: Path, template: RunData) -> None:
    """A sealed segment of 4 new runs copied into segments/ (as a writer killed between
    sealing and registering leaves one)."""
    other = Archive(tmp_path / "other")
    path = _seal(other, template, range(100, 104), register=False)
    other.close()
    shutil.copy(path, root / "segments" / path.name)


def test_repair_reports_the_segment_its_recovery_registered(
    tmp_path: Path, template: RunData
) -> None:
    root = tmp_path / "a"
    _three_segments(root, template)
    _copy_in_a_foreign_segment(root, tmp_path, template)
    assert len(_listed(root)) == 12

    code, out = _invoke("runs", "repair", "-a", str(root))
    assert code == 0, out
    assert "1 unregistered segment(s) indexed" in out
    assert len(_listed(root)) == 16
    code, out = _invoke("runs", "repair", "-a", str(root), "--json")
    assert code == 0 and json.loads(out)["segments_registered"] == 0, out


def test_a_recovery_run_by_the_first_write_is_logged_and_reported(
    tmp_path: Path, template: RunData, caplog: pytest.LogCaptureFixture
) -> None:
    """The first write of a process (here a ball added) registers the copied segment: the
    log says so (info: a sealed segment may be another live writer's), and an explicit
    recover() of the same process reports it too."""
    root = tmp_path / "a"
    _three_segments(root, template)
    _copy_in_a_foreign_segment(root, tmp_path, template)
    archive = Archive(root)
    with caplog.at_level(logging.INFO, logger="bowlrec.archive"):
        archive.balls.add("house", template.scene.ball)
    assert any("1 sealed segment(s)" in r.getMessage() for r in caplog.records), caplog.text
    assert len(archive) == 16
    assert archive.recover()["segments_registered"] == 1
    assert archive.recover()["segments_registered"] == 0

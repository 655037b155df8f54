"""The archive through the CLI: simulate -> runs/balls/replay/plot, default locations."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from bowlrec.archive import Archive, default_archive_path
from bowlrec.cli import app

EXAMPLES = Path(__file__).parents[1] / "examples"
CASE16 = EXAMPLES / "paper" / "case16.json"
runner = CliRunner()


def _ok(*args: str) -> str:
    result = runner.invoke(app, list(args))
    assert result.exit_code == 0, result.output
    return result.output


def _fails(code: int, *args: str) -> str:
    result = runner.invoke(app, list(args))
    assert result.exit_code == code, result.output
    return result.output


def _small_scene(tmp_path: Path, speed: float = 8.0) -> Path:
    doc = json.loads(CASE16.read_text())
    doc["delivery"]["speed_mps"] = speed
    doc["options"] = {"record": "rate", "record_dt_s": 0.02}
    path = tmp_path / f"scene-{speed}.json"
    path.write_text(json.dumps(doc))
    return path


def test_simulate_archives_once_per_content(tmp_path: Path) -> None:
    arch = tmp_path / "arch"
    first = json.loads(_ok("simulate", str(_small_scene(tmp_path)), "-a", str(arch), "--json"))
    again = json.loads(_ok("simulate", str(_small_scene(tmp_path)), "-a", str(arch), "--json"))
    assert first["archived"] is True and again["archived"] is False
    assert first["run_id"] == again["run_id"]
    assert first["hook_m"] == again["hook_m"]
    rows = json.loads(_ok("runs", "list", "-a", str(arch), "--json"))
    assert [r["run_id"] for r in rows] == [first["run_id"]]


def test_simulate_uses_the_default_archive_from_the_environment(tmp_path: Path) -> None:
    out = json.loads(_ok("simulate", str(_small_scene(tmp_path)), "--json"))
    path, source = default_archive_path()
    assert source == "$BOWLREC_ARCHIVE"
    assert out["archive"] == str(path)
    assert Archive(path).has_run(out["run_id"])


def test_no_archive_stores_nothing(tmp_path: Path) -> None:
    out = json.loads(_ok("simulate", str(_small_scene(tmp_path)), "--no-archive", "--json"))
    assert out["run_id"] is None and out["archive"] is None
    path, _ = default_archive_path()
    assert not path.exists() or len(Archive(path)) == 0


def test_config_file_sets_the_default_archive(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("BOWLREC_ARCHIVE")
    config = tmp_path / "config.toml"
    config.write_text(f'archive = "{tmp_path / "from-config"}"\n')
    monkeypatch.setenv("BOWLREC_CONFIG", str(config))
    assert default_archive_path() == (tmp_path / "from-config", f"config {config}")
    monkeypatch.setenv("BOWLREC_CONFIG", str(tmp_path / "missing.toml"))
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    assert default_archive_path() == (tmp_path / "data" / "bowlrec" / "archive", "default")


def test_runs_list_filters_show_export_and_rm(tmp_path: Path) -> None:
    arch = str(tmp_path / "arch")
    ids = {
        v: json.loads(_ok("simulate", str(_small_scene(tmp_path, v)), "-a", arch, "--json"))[
            "run_id"
        ]
        for v in (7.0, 9.0)
    }
    fast = json.loads(_ok("runs", "list", "-a", arch, "-w", "speed_mps>8", "--json"))
    assert [r["run_id"] for r in fast] == [ids[9.0]]
    table = _ok("runs", "list", "-a", arch)
    assert ids[7.0][:10] in table and ids[9.0][:10] in table
    shown = json.loads(_ok("runs", "show", ids[7.0][:8], "-a", arch, "--json"))
    assert shown["index"]["run_id"] == ids[7.0]
    assert shown["scene"]["delivery"]["speed_mps"] == 7.0
    assert [e["kind"] for e in shown["events"]][-1] == "pins"
    assert shown["provenance"]["format_version"] == "3.0"
    assert shown["provenance"]["bowler_layer_version"] == "3" and shown["warnings"] == []
    h5 = tmp_path / "out.h5"
    _ok("runs", "export", ids[7.0], "-a", arch, "--out", str(h5))
    assert h5.stat().st_size > 0
    scene_json = tmp_path / "scene.json"
    _ok("runs", "export", ids[7.0], "-a", arch, "--out", str(scene_json))
    resim = json.loads(_ok("simulate", str(scene_json), "-a", arch, "--json"))
    assert resim["run_id"] == ids[7.0] and resim["archived"] is False
    assert "unknown suffix" in _fails(2, "runs", "export", ids[7.0], "-a", arch, "--out", "x.txt")
    _ok("runs", "rm", ids[7.0][:6], "-a", arch)
    assert "no run" in _fails(1, "runs", "show", ids[7.0], "-a", arch)
    assert "unknown column" in _fails(2, "runs", "list", "-a", arch, "-w", "nope>1")


def test_balls_commands_and_simulating_with_a_library_ball(tmp_path: Path) -> None:
    arch = str(tmp_path / "arch")
    assert "house@1 added" in _ok("balls", "add", "house", str(CASE16), "-a", arch)
    assert "unchanged" in _ok("balls", "add", "house", str(CASE16), "-a", arch)
    heavier = json.loads(CASE16.read_text())["ball"] | {"mass_kg": 7.0}
    (tmp_path / "heavier.json").write_text(json.dumps(heavier))
    assert "house@2 added" in _ok(
        "balls", "add", "house", str(tmp_path / "heavier.json"), "-a", arch
    )
    listed = json.loads(_ok("balls", "list", "--all", "-a", arch, "--json"))
    assert [(b["name"], b["version"]) for b in listed] == [("house", 1), ("house", 2)]
    assert json.loads(_ok("balls", "show", "house@1", "-a", arch))["spec"]["mass_kg"] == 6.8
    out = json.loads(
        _ok("simulate", str(_small_scene(tmp_path)), "--ball", "house", "-a", arch, "--json")
    )
    row = Archive(arch).row(out["run_id"])
    assert (row["ball_name"], row["ball_version"], row["mass_kg"]) == ("house", 2, 7.0)
    exported = tmp_path / "lib.json"
    _ok("balls", "export", str(exported), "-a", arch)
    other = str(tmp_path / "other")
    assert _ok("balls", "import", str(exported), "-a", other).count("added") == 2
    _ok("balls", "rm", "house@1", "-a", arch)
    assert "no ball 'house@1'" in _fails(1, "balls", "show", "house@1", "-a", arch)
    assert "give the version" in _fails(2, "balls", "rm", "house", "-a", arch)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"mass_kg": -1}))
    assert "mass_kg" in _fails(2, "balls", "add", "bad", str(bad), "-a", arch)


def test_archive_commands_refuse_a_missing_archive(tmp_path: Path) -> None:
    out = _fails(2, "runs", "list", "-a", str(tmp_path / "nowhere"))
    assert "not a bowlrec archive" in out
    assert not (tmp_path / "nowhere").exists()


@pytest.mark.skipif(os.name != "posix", reason="flock")
def test_replay_requires_an_output(tmp_path: Path) -> None:
    arch = str(tmp_path / "arch")
    rid = json.loads(_ok("simulate", str(_small_scene(tmp_path)), "-a", arch, "--json"))["run_id"]
    assert "nothing to do" in _fails(2, "replay", rid, "-a", arch)


def test_demo_archives_table3_and_writes_replay_files(tmp_path: Path) -> None:
    arch, out = str(tmp_path / "arch"), tmp_path / "demo"
    first = _ok("demo", "-a", arch, "-o", str(out), "--record-dt-s", "0.02")
    assert "18 Table III runs" in first and "(18 new, 0 already archived)" in first
    for name in ("fig6-cases-9-10-14-16.png", "case16.mcap", "case16.rrd"):
        assert (out / name).stat().st_size > 10_000, name
    assert len(Archive(arch)) == 18
    again = _ok("demo", "-a", arch, "-o", str(out), "--record-dt-s", "0.02")
    assert "(0 new, 18 already archived)" in again


def test_runs_export_several_runs_to_one_mcap(tmp_path: Path) -> None:
    from bowlrec.sinks.mcap_file import read_mcap_positions

    arch = str(tmp_path / "arch")
    ids = [
        json.loads(_ok("simulate", str(_small_scene(tmp_path, v)), "-a", arch, "--json"))["run_id"]
        for v in (7.0, 9.0)
    ]
    out = tmp_path / "batch.mcap"
    assert "(2 runs)" in _ok("runs", "export", *ids, "-a", arch, "--out", str(out))
    for rid in ids:
        _, pos, _ = read_mcap_positions(out, run=rid)
        assert (pos == Archive(arch).load(rid).trajectory.position_m).all()
    assert "several runs go into one .mcap" in _fails(
        2, "runs", "export", *ids, "-a", arch, "--out", str(tmp_path / "x.rrd")
    )


def test_replay_and_simulate_write_every_format(tmp_path: Path) -> None:
    import numpy as np

    from bowlrec.sinks.mcap_file import read_mcap_positions
    from bowlrec.sinks.rerun_recording import read_rrd_positions

    arch = str(tmp_path / "arch")
    rid = json.loads(_ok("simulate", str(_small_scene(tmp_path)), "-a", arch, "--json"))["run_id"]
    files = {k: tmp_path / f"replay.{k}" for k in ("rrd", "mcap", "png")}
    _ok(
        "replay", rid[:8], "-a", arch,
        "--rrd", str(files["rrd"]), "--mcap", str(files["mcap"]), "--plot", str(files["png"]),
    )  # fmt: skip
    traj = Archive(arch).load(rid).trajectory
    _, pos_mcap, _ = read_mcap_positions(files["mcap"])
    assert np.array_equal(pos_mcap, traj.position_m)
    _, pos_rrd = read_rrd_positions(files["rrd"])
    np.testing.assert_allclose(pos_rrd, traj.position_m, atol=1e-5)  # rerun stores float32
    assert files["png"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # a summary-only scene is re-recorded every step when an output needs samples
    summary_only = json.loads(CASE16.read_text()) | {"options": {"record": "summary"}}
    (tmp_path / "summary.json").write_text(json.dumps(summary_only))
    result = runner.invoke(
        app,
        [
            "simulate",
            str(tmp_path / "summary.json"),
            "-a",
            arch,
            "--mcap",
            str(tmp_path / "s.mcap"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "recording every step" in result.output
    assert (tmp_path / "s.mcap").stat().st_size > 0
    # an archived summary-only run is re-recorded from its stored scene to be replayed
    rid2 = json.loads(_ok("simulate", str(tmp_path / "summary.json"), "-a", arch, "--json"))[
        "run_id"
    ]
    out = _ok("replay", rid2, "-a", arch, "--rrd", str(tmp_path / "x.rrd"))
    assert "re-recorded from its stored scene" in out
    assert (tmp_path / "x.rrd").stat().st_size > 1000
    # and plotted from it
    _ok("plot", rid2, "-a", arch, "--out", str(tmp_path / "s.svg"))
    assert (tmp_path / "s.svg").read_text().startswith("<?xml")


def test_config_file_can_name_the_dask_scheduler(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from bowlrec.archive.location import config_value

    config = tmp_path / "config.toml"
    config.write_text('scheduler = "tcp://10.0.0.5:8786"\n')
    monkeypatch.setenv("BOWLREC_CONFIG", str(config))
    assert config_value("scheduler") == "tcp://10.0.0.5:8786"
    assert config_value("missing") is None
    config.write_text("scheduler = [unclosed\n")
    with pytest.raises(ValueError, match="not valid TOML"):
        config_value("scheduler")


def test_repair_names_damage_and_list_damaged_shows_it(tmp_path: Path) -> None:
    import h5py

    arch = str(tmp_path / "arch")
    ids = [
        json.loads(_ok("simulate", str(_small_scene(tmp_path, v)), "-a", arch, "--json"))["run_id"]
        for v in (7.0, 9.0)
    ]
    assert "0 damaged" in _ok("runs", "repair", "-a", arch)
    _, row, path = Archive(arch).locate(ids[0])  # type: ignore[misc]
    with h5py.File(path, "r+") as f:
        values = f["summary/pocket_deg"][()]
        values[row] = -values[row]
        f["summary/pocket_deg"][...] = values
    shown = _fails(1, "runs", "show", ids[0], "-a", arch)
    assert f"run {ids[0]} in segment" in shown and "damaged" in shown
    assert "Traceback" not in shown
    out = _fails(1, "runs", "repair", "-a", arch)
    assert "1 damaged" in out and ids[0] in out
    listed = json.loads(_ok("runs", "list", "--damaged", "-a", arch, "--json"))
    assert [d["run_id"] for d in listed] == [ids[0]]
    assert [r["run_id"] for r in json.loads(_ok("runs", "list", "-a", arch, "--json"))] == [ids[1]]
    info = json.loads(_ok("archive", "info", "-a", arch, "--json"))
    assert (info["runs"], info["damaged_runs"], info["format_version"]) == (1, 1, "2.0")


def test_rm_compact_and_reindex(tmp_path: Path) -> None:
    arch = str(tmp_path / "arch")
    ids = [
        json.loads(_ok("simulate", str(_small_scene(tmp_path, v)), "-a", arch, "--json"))["run_id"]
        for v in (7.0, 8.0, 9.0)
    ]
    _ok("runs", "rm", ids[0], "-a", arch)
    assert "3 segment(s) rewritten into 1" in _ok("runs", "compact", "-a", arch)
    assert "2 run(s) indexed" in _ok("runs", "reindex", "-a", arch)
    listed = {r["run_id"] for r in json.loads(_ok("runs", "list", "-a", arch, "--json"))}
    assert listed == set(ids[1:])


def test_archive_migrate_converts_the_v1_fixture(tmp_path: Path) -> None:
    import shutil

    copy = tmp_path / "old"
    shutil.copytree(Path(__file__).parent / "fixtures" / "archive-v1", copy)
    refused = _fails(2, "runs", "list", "-a", str(copy))
    assert "format 1.0" in refused and "bowlrec archive migrate" in refused
    out = _ok("archive", "migrate", str(copy))
    assert "format 1.0 -> 2.0: 2 run(s)" in out and "v1-archive" in out
    rows = json.loads(_ok("runs", "list", "-a", str(copy), "--json"))
    assert sorted(r["name"] for r in rows) == ["fixture-summary", "fixture-trajectory"]
    assert "is format 2.0 (2 runs): 0 segment(s)" in _ok("archive", "migrate", str(copy))


def test_runs_show_flags_a_run_made_before_the_current_bowler_layer(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A segment whose provenance has no bowler_layer_version (written before it existed)."""
    from bowlrec import provenance

    old = tuple(kv for kv in provenance._environment() if kv[0] != "bowler_layer_version")
    monkeypatch.setattr(provenance, "_environment", lambda: old)
    arch = str(tmp_path / "arch")
    run_id = json.loads(_ok("simulate", str(_small_scene(tmp_path)), "-a", arch, "--json"))[
        "run_id"
    ]
    monkeypatch.undo()
    shown = json.loads(_ok("runs", "show", run_id, "-a", arch, "--json"))
    assert "bowler_layer_version" not in shown["provenance"]
    assert len(shown["warnings"]) == 1 and "other end of the spin axis" in shown["warnings"][0]
    assert "made with bowler layer 1" in " ".join(_ok("runs", "show", run_id, "-a", arch).split())

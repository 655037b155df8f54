"""The sink registry: every file format declared once and found by suffix, each written file
read back by its own reader, and every place that writes runs going through it."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

import bowlrec
from bowlrec.api import simulate_into
from bowlrec.archive import Archive
from bowlrec.cli import app
from bowlrec.errors import InputError, MissingExtraError, UnknownFormatError
from bowlrec.sinks import RunData
from bowlrec.sinks.npz import write_npz
from bowlrec.sinks.registry import SINKS, Sink, known_suffixes, sink_for, sink_named
from bowlrec.spec import Scene

runner = CliRunner()

#: what each sink is found by
SUFFIXES = {
    "hdf5": (".h5", ".hdf5"),
    "mcap": (".mcap",),
    "rrd": (".rrd",),
    "npz": (".npz",),
    "csv": (".csv",),
    "plot": (".png", ".svg"),
    "scene": (".json",),
}
SAMPLED = {
    "name": "sampled",
    "delivery": {"speed_mps": 8.0, "omega_radps": [-16.62, 23.74, 7.765]},
    "options": {"record": "rate", "record_dt_s": 0.02},
}


@pytest.fixture(scope="module")
def run() -> RunData:
    scene = Scene.model_validate(SAMPLED)
    return RunData(scene, scene.resolve(), bowlrec.simulate(scene))


def test_the_plot_sink_writes_what_the_figures_render() -> None:
    """PNG and SVG are written by the figures package (a layer below the writers), which
    renders exactly the plot sink's suffixes."""
    from bowlrec.figures.render import FORMATS

    plot = sink_named("plot")
    assert plot.module == "bowlrec.figures.trajectory"
    assert plot.suffixes == tuple(f".{fmt}" for fmt in FORMATS)
    assert callable(plot.attribute(plot.writer)) and plot.many is not None
    assert callable(plot.attribute(plot.many))


def test_every_suffix_finds_its_sink() -> None:
    assert {s.name: s.suffixes for s in SINKS} == SUFFIXES
    assert known_suffixes() == [x for suffixes in SUFFIXES.values() for x in suffixes]
    for name, suffixes in SUFFIXES.items():
        assert sink_named(name).suffix == suffixes[0]
        for suffix in suffixes:
            assert sink_for(f"dir/run{suffix}").name == name
            assert sink_for(f"RUN{suffix.upper()}").name == name


def test_an_unknown_suffix_is_one_input_error_line_naming_the_known_ones() -> None:
    with pytest.raises(UnknownFormatError) as caught:
        sink_for("out/run.txt")
    message = str(caught.value)
    assert isinstance(caught.value, InputError) and isinstance(caught.value, ValueError)
    assert message.startswith("out/run.txt: unknown suffix '.txt' (known: .h5 .hdf5 .mcap")
    assert all(s in message for s in known_suffixes()) and "\n" not in message
    with pytest.raises(UnknownFormatError, match="^run: no suffix"):
        sink_for("run")
    with pytest.raises(UnknownFormatError, match="unknown output format 'xlsx'"):
        sink_named("xlsx")
    with pytest.raises(UnknownFormatError, match="^x.rrd: a rerun file holds one run; several"):
        sink_named("rrd").write_many([], "x.rrd")


def _read_back(name: str, path: Path, run: RunData) -> None:
    """Open ``path`` with the format's own reader and compare with ``run``."""
    traj = run.trajectory
    if name == "hdf5":
        from bowlrec.sinks.hdf5_run import read_run_file

        stored = read_run_file(path)
        assert np.array_equal(stored.trajectory.position_m, traj.position_m)
        assert stored.attrs["bowlrec_version"] == bowlrec.__version__
    elif name == "mcap":
        from bowlrec.sinks.mcap_file import read_mcap_positions

        assert np.array_equal(read_mcap_positions(path)[1], traj.position_m)
    elif name == "rrd":
        from bowlrec.sinks.rerun_recording import read_rrd_positions

        np.testing.assert_allclose(read_rrd_positions(path)[1], traj.position_m, atol=1e-5)
    elif name == "npz":
        with np.load(path) as z:
            assert np.array_equal(z["position_m"], traj.position_m)
    elif name == "csv":
        with open(path, newline="") as fh:
            header, *rows = list(csv.reader(fh))
        assert header[:4] == ["t_s", "x_m", "y_m", "z_m"] and len(rows) == traj.n_samples
        assert np.array_equal([[float(v) for v in r[1:4]] for r in rows], traj.position_m)
    elif name == "plot":
        head = path.read_bytes()[:8]
        assert head == b"\x89PNG\r\n\x1a\n" if path.suffix == ".png" else b"<?xml" in head
    else:
        assert Scene.model_validate_json(path.read_text()) == run.scene


@pytest.mark.parametrize("suffix", [s for suffixes in SUFFIXES.values() for s in suffixes])
def test_each_sink_writes_a_file_its_reader_opens(
    suffix: str, run: RunData, tmp_path: Path
) -> None:
    sink = sink_for(f"run{suffix}")
    path = tmp_path / "sub" / f"run{suffix}"
    assert sink.write(run, path) == path
    _read_back(sink.name, path, run)
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]  # no temporary left


@pytest.mark.parametrize("name", list(SUFFIXES))
def test_each_sink_writes_exactly_the_path_it_is_given(
    name: str, run: RunData, tmp_path: Path
) -> None:
    """The path returned is the path asked, whatever the case of its suffix (and, but for a
    plot, whose suffix picks PNG or SVG, whatever its suffix), and no other file appears."""
    sink = sink_named(name)
    asked = [tmp_path / f"run{s}" for s in sink.suffixes]
    asked += [tmp_path / f"RUN{s.upper()}" for s in sink.suffixes]
    if name != "plot":
        asked += [tmp_path / "run.data", tmp_path / "run"]
    for path in asked:
        assert sink.write(run, path) == path
        assert path.stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in asked)
    if sink.many is not None:
        many = tmp_path / "many" / f"Two{sink.suffix.upper()}"
        assert sink.write_many([run, run], many) == many
        assert [p.name for p in many.parent.iterdir()] == [many.name]


def test_sinks_of_several_runs(run: RunData, tmp_path: Path) -> None:
    from bowlrec.sinks.mcap_file import read_mcap_positions

    other = RunData(run.scene, run.plan, run.trajectory, "b" * 20)
    mcap = sink_named("mcap").write_many([run, other], tmp_path / "two.mcap")
    assert np.array_equal(read_mcap_positions(mcap, run="b" * 20)[1], run.trajectory.position_m)
    plot = sink_named("plot").write_many([run, other], tmp_path / "two.svg")
    assert b"<svg" in plot.read_bytes()[:2000]


def test_npz_holds_the_samples_events_and_summary(run: RunData, tmp_path: Path) -> None:
    traj = run.trajectory
    path = write_npz(traj, tmp_path / "run.npz")
    with np.load(path) as z:
        assert set(z.files) == {"events_json", "summary_json", *traj.arrays()}
        for name, values in traj.arrays().items():
            assert np.array_equal(z[name], values), name
        assert json.loads(str(z["events_json"])) == [asdict(e) for e in traj.events]
        assert json.loads(str(z["summary_json"])) == json.loads(json.dumps(traj.summary.to_dict()))
    assert write_npz(traj, tmp_path / "run.NPZ") == tmp_path / "run.NPZ"  # no suffix added


def test_rev_rate_series_is_the_norm_of_omega_in_rpm(run: RunData) -> None:
    from bowlrec.sinks.common import series_columns

    omega = run.trajectory.omega_radps
    rpm, units = series_columns(run.trajectory)["rev_rate_rpm"]
    assert units == "rpm"
    assert np.array_equal(rpm, np.linalg.norm(omega, axis=1) * 60.0 / (2.0 * math.pi))


def test_archived_run_files_carry_the_stored_provenance(tmp_path: Path) -> None:
    from bowlrec.sinks.hdf5_run import read_run_file

    archive = Archive(tmp_path / "a")
    rid = simulate_into(archive, Scene.model_validate(SAMPLED)).run_id
    data = archive.run_data(rid)
    assert data.provenance is not None and data.provenance["segment_id"] == archive.locate(rid)[0]
    stored = read_run_file(archive.export(rid, tmp_path / "run.h5"))
    assert stored.run_id == rid and stored.attrs["segment_id"] == data.provenance["segment_id"]
    assert stored.attrs["created_at"] == archive.load(rid).attrs["created_at"]
    scene = sink_named("scene").write(data, tmp_path / "scene.json")
    as_stored = json.loads(archive.load(rid).attrs["scene_json"])
    assert scene.read_text() == json.dumps(as_stored, indent=2) + "\n"


def test_a_missing_library_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    import bowlrec.sinks.registry as registry

    def missing(name: str) -> Any:
        raise ImportError(f"No module named {name!r}", name="foxglove")

    monkeypatch.setattr(registry.importlib, "import_module", missing)
    with pytest.raises(MissingExtraError, match=r"pip install 'bowlrec\[mcap\]'") as caught:
        sink_named("mcap").write(None, "x.mcap")  # type: ignore[arg-type]
    assert caught.value.name == "foxglove" and isinstance(caught.value, ImportError)

    def broken(name: str) -> Any:  # a bug of bowlrec's own is not a missing extra
        raise ImportError("cannot import name 'x'", name="bowlrec.sinks.mcap_file")

    monkeypatch.setattr(registry.importlib, "import_module", broken)
    with pytest.raises(ImportError) as caught_bug:
        sink_named("mcap").write(None, "x.mcap")  # type: ignore[arg-type]
    assert not isinstance(caught_bug.value, MissingExtraError)


@pytest.mark.process  # a fresh interpreter's modules
def test_start_up_loads_no_format_library() -> None:
    """``import bowlrec``, the registry and ``bowlrec --help`` (whose help texts list the
    registry's suffixes) load no format library, not even NumPy."""
    heavy = ("numpy", "h5py", "rerun", "mcap", "foxglove", "matplotlib", "pandas")
    for argv in (["--help"], ["simulate", "--help"], ["runs", "export", "--help"]):
        code = (
            "import atexit, json, sys\n"
            f"loaded = lambda: json.dumps([m for m in {heavy!r} if m in sys.modules])\n"
            "atexit.register(lambda: print(loaded()))\n"
            "import bowlrec, bowlrec.sinks.registry\n"
            "from bowlrec.cli import app\n"
            f"app({argv!r})\n"
        )
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        assert json.loads(done.stdout.strip().splitlines()[-1]) == [], argv


# -- every place that writes runs goes through the registry -------------------------------------


@pytest.fixture
def written(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, str]]:
    """(sink name, file name) of every file written through :meth:`Sink.write`."""
    calls: list[tuple[str, str]] = []
    original = Sink.write

    def spy(self: Sink, run: RunData, path: Any) -> Path:
        calls.append((self.name, Path(path).name))
        return original(self, run, path)

    monkeypatch.setattr(Sink, "write", spy)
    return calls


def test_the_cli_writes_through_the_registry(
    written: list[tuple[str, str]], tmp_path: Path
) -> None:
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps(SAMPLED))
    arch = str(tmp_path / "a")
    args = ["simulate", str(scene), "-a", arch, "-q", "--out", str(tmp_path / "run.npz")]
    result = runner.invoke(app, [*args, "--mcap", str(tmp_path / "run.mcap")])
    assert result.exit_code == 0, result.output
    assert "NumPy: " in result.output and "MCAP: " in result.output
    rid = Archive(arch).list_runs()[0]["run_id"]
    for out in ("run.h5", "run.json", "run.png", "run.csv"):
        result = runner.invoke(
            app, ["runs", "export", rid, "-a", arch, "--out", str(tmp_path / out)]
        )
        assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["replay", rid, "-a", arch, "--rrd", str(tmp_path / "r.rrd")])
    assert result.exit_code == 0, result.output
    assert written == [
        ("npz", "run.npz"),
        ("mcap", "run.mcap"),
        ("hdf5", "run.h5"),
        ("scene", "run.json"),
        ("plot", "run.png"),
        ("csv", "run.csv"),
        ("rrd", "r.rrd"),
    ]


def test_batch_replays_go_through_the_registry(
    written: list[tuple[str, str]], tmp_path: Path
) -> None:
    from bowlrec.batch import JobSpec, run_job

    job = JobSpec.model_validate(
        {
            "name": "replays",
            "sweep": {"kind": "scenes", "scenes": [SAMPLED]},
            "record": "scene",
            "formats": ["rrd", "mcap"],
        }
    )
    archive = Archive(tmp_path / "a")
    result = run_job(job, archive, workers=0, replay_dir=tmp_path / "replays")
    (rid,) = [row["run_id"] for row in archive.list_runs()]
    assert written == [("rrd", f"{rid}.rrd"), ("mcap", f"{rid}.mcap")]
    assert sorted(p.name for p in result.replays) == [f"{rid}.mcap", f"{rid}.rrd"]


def test_the_service_writes_through_the_registry(
    written: list[tuple[str, str]], tmp_path: Path
) -> None:
    pytest.importorskip("fastapi")
    from fastapi.testclient import TestClient

    from bowlrec.service.app import FILE_KINDS, create_app

    assert set(FILE_KINDS) <= {s.name for s in SINKS}
    with TestClient(create_app(tmp_path / "a", warm_up=False), base_url="http://127.0.0.1") as c:
        rid = c.post("/runs", json=SAMPLED).json()["run_id"]
        for kind in FILE_KINDS:
            r = c.get(f"/runs/{rid}/files/{kind}")
            assert r.status_code == 200, r.text
            suffix = sink_named(kind).suffix
            assert r.headers["content-disposition"].endswith(f'"{rid}{suffix}"')
        assert c.get(f"/runs/{rid}/files/mcap").status_code == 200  # cached: not written again
    assert written == [(kind, f"{rid}{sink_named(kind).suffix}") for kind in FILE_KINDS]

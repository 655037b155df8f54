"""HDF5 run files, segments and the archive: round trips, content IDs, queries, the ball
library, tombstones and compaction, and the committed fixtures (format 1.0, migrated; format
2.0 and 2.1, read as is). The contract every archive layer keeps is test_archive_contract.py;
faults: test_archive_fault_points.py and test_archive_damage.py (in-process),
test_archive_processes.py (several processes) and test_archive_faults.py (real kills)."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

from bowlrec.api import simulate_into
from bowlrec.archive import Archive, SegmentFile, run_id
from bowlrec.archive.segment_file import _INCOMPRESSIBLE
from bowlrec.errors import (
    ArchiveError,
    BallNotFoundError,
    IndexQueryError,
    RunDamagedError,
    RunFileError,
    RunNotFoundError,
    SpecError,
)
from bowlrec.paper import paper_scene
from bowlrec.sinks import RunData
from bowlrec.sinks.hdf5_run import (
    FORMAT_VERSION,
    read_run_file,
    read_run_header,
    write_run_file,
)
from bowlrec.spec import Scene

HERE = Path(__file__).parent
FIXTURE = HERE / "fixtures" / "archive-v1"
FIXTURE_V2 = HERE / "fixtures" / "archive-v2"


def _scene(**delivery: float) -> Scene:
    """A non-uniform ball with an offset (so every term and orientation is exercised)."""
    base = paper_scene(16).model_dump(mode="json")
    base["options"] = {"record": "rate", "record_dt_s": 0.02, "record_terms": True}
    base["delivery"].update(delivery)
    return Scene.model_validate(base)


@pytest.fixture(scope="module")
def template_run() -> RunData:
    import bowlrec

    scene = _scene()
    return RunData(scene, scene.resolve(), bowlrec.simulate(scene))


#: the per-sample quantities a 3.0 segment derives on read
_DERIVED = {"alpha_radps2", "energy_J", "friction_force_N", "normal_force_N", "slip_mps"}


def _assert_same_trajectory(a, b, derived_rtol: float = 0.0) -> None:  # type: ignore[no-untyped-def]
    """Bit for bit; ``derived_rtol``: the derived quantities of a run migrated from an older
    format agree to that relative tolerance (docs/archive-format.md, "Samples (3.0)")."""
    arrays_a, arrays_b = a.arrays(), b.arrays()
    assert arrays_a.keys() == arrays_b.keys()
    for key, arr in arrays_a.items():
        other = arrays_b[key]
        assert arr.dtype == other.dtype, key
        assert arr.shape == other.shape, key
        if derived_rtol and key in _DERIVED:
            scale = max(1.0, float(np.abs(other).max())) if other.size else 1.0
            np.testing.assert_allclose(arr, other, rtol=derived_rtol, atol=derived_rtol * scale)
            continue
        assert np.array_equal(arr, other), key  # bit-for-bit, not approximately
    assert a.events == b.events
    assert a.summary == b.summary


# -- run files -----------------------------------------------------------------------------------


def test_run_file_round_trip_is_exact(tmp_path: Path, template_run: RunData) -> None:
    path = write_run_file(tmp_path / "r.h5", template_run, {"wall_time_s": 0.5})
    back = read_run_file(path)
    assert back.scene == template_run.scene
    _assert_same_trajectory(back.trajectory, template_run.trajectory)
    assert set(back.trajectory.torques_Nm) == set(template_run.trajectory.torques_Nm)
    assert back.attrs["format_version"] == FORMAT_VERSION
    assert back.attrs["wall_time_s"] == 0.5


def test_every_dataset_has_units_and_arrays_are_chunked_gzip_shuffle(
    tmp_path: Path, template_run: RunData
) -> None:
    path = write_run_file(tmp_path / "r.h5", template_run, {})
    seen: list[str] = []

    def visit(name: str, obj: object) -> None:
        if isinstance(obj, h5py.Dataset):
            seen.append(name)
            assert "units" in obj.attrs, name
            if obj.ndim >= 1 and obj.size > 0 and obj.dtype.kind == "f":
                assert obj.chunks is not None, name
                assert obj.compression == "gzip" and obj.shuffle, name

    with h5py.File(path, "r") as f:
        f.visititems(visit)
        assert f["trajectory/position_m"].attrs["units"] == "m"
        assert f["trajectory/velocity_mps"].attrs["units"] == "m/s"
        assert f["trajectory/torques/tau_dev"].attrs["units"] == "N m"
        assert f["resolved/inertia_per_mass_m2"].attrs["units"] == "m^2"
        assert f["events/t_s"].attrs["units"] == "s"
        # default libver: the file is readable by HDF5 1.10-era tools (superblock v0)
        assert f.id.get_access_plist().get_libver_bounds()[0] == h5py.h5f.LIBVER_EARLIEST
    assert len(seen) > 30


def test_resolved_parameters_are_the_plan(tmp_path: Path, template_run: RunData) -> None:
    path = write_run_file(tmp_path / "r.h5", template_run, {})
    with h5py.File(path, "r") as f:
        np.testing.assert_array_equal(
            f["resolved/inertia_per_mass_m2"][()], template_run.plan.inertia_per_mass_m2
        )
        np.testing.assert_array_equal(
            f["resolved/r_delta_body_m"][()], template_run.plan.r_delta_body_m
        )
        assert f["resolved/mass_kg"][()] == template_run.plan.mass_kg


def test_summary_only_run_round_trips(tmp_path: Path) -> None:
    import bowlrec

    scene = Scene.model_validate({"options": {"record": "summary"}})
    run = RunData(scene, scene.resolve(), bowlrec.simulate(scene))
    back = read_run_file(write_run_file(tmp_path / "s.h5", run, {}))
    assert back.trajectory.n_samples == 0
    _assert_same_trajectory(back.trajectory, run.trajectory)


def test_unknown_format_versions_are_rejected(tmp_path: Path, template_run: RunData) -> None:
    path = write_run_file(tmp_path / "r.h5", template_run, {})
    with h5py.File(path, "a") as f:
        f.attrs["format_version"] = "2.0"
    with pytest.raises(RunFileError, match="format version 2.0 is not supported"):
        read_run_header(path)
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f.attrs["format"] = "something-else"
    with pytest.raises(RunFileError, match="not a bowlrec run file"):
        read_run_file(tmp_path / "other.h5")


def test_failed_write_leaves_nothing(tmp_path: Path, template_run: RunData) -> None:
    path = tmp_path / "r.h5"
    with pytest.raises(TypeError):
        write_run_file(path, template_run, {"bad": object()})
    assert list(tmp_path.iterdir()) == []


# -- archive -------------------------------------------------------------------------------------


def test_simulating_the_same_scene_twice_stores_one_run(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    first = simulate_into(archive, _scene())
    again = simulate_into(archive, _scene().model_copy(update={"name": "renamed"}))
    assert first.added and not again.added
    assert first.run_id == again.run_id == run_id(_scene().resolve())
    assert len(archive) == 1
    assert len(list((tmp_path / "a" / "segments").glob("*.h5"))) == 1
    assert again.trajectory is not None and first.trajectory is not None
    _assert_same_trajectory(again.trajectory, first.trajectory)


def test_run_ids_change_with_any_parameter_and_the_physics_version() -> None:
    plan = _scene().resolve()
    assert run_id(plan) == run_id(_scene().resolve())
    assert run_id(plan) != run_id(_scene(speed_mps=8.000000000000002).resolve())
    assert run_id(plan) != run_id(plan, physics_version="another")
    rtol = _scene().model_copy(
        update={"options": _scene().options.model_copy(update={"rtol": 1e-8})}
    )
    assert run_id(plan) != run_id(rtol.resolve())


def test_load_returns_what_was_written(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    added = simulate_into(archive, _scene())
    stored = archive.load(added.run_id[:8])
    assert stored.scene == _scene()
    assert added.trajectory is not None
    _assert_same_trajectory(stored.trajectory, added.trajectory)
    assert stored.attrs["physics_version"]
    assert stored.attrs["solver"] == "integrator"
    assert stored.attrs["wall_time_s"] > 0


def test_queries_filter_by_summary_ranges_outcome_pattern_and_ball(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    entry, created = archive.balls.add("case16-ball", _scene().ball)
    assert created and entry.version == 1
    speeds = [7.0, 8.0, 9.0, 10.0]
    ids = {v: simulate_into(archive, _scene(speed_mps=v)).run_id for v in speeds}
    gutter = Scene.model_validate(
        {"delivery": {"takeoff_angle_deg": 5.0}, "options": {"record": "summary"}}
    )
    simulate_into(archive, gutter)
    rows = archive.list_runs()
    assert len(rows) == 5
    hooks = {r["run_id"]: r["hook_m"] for r in rows}
    # slower deliveries hook more on this ball (check the filter against the stored numbers)
    threshold = sorted(hooks[ids[v]] for v in speeds)[1]
    picked = {r["run_id"] for r in archive.list_runs(where=[f"hook_m>={threshold}"])}
    assert picked == {rid for rid, h in hooks.items() if h is not None and h >= threshold}
    assert len(picked) == 3
    assert [r["outcome"] for r in archive.list_runs(outcome="gutter")] == ["gutter"]
    assert len(archive.list_runs(pattern="typical")) == 5
    by_ball = archive.list_runs(ball="case16-ball")
    assert {r["run_id"] for r in by_ball} == set(ids.values())
    assert all(r["ball_name"] == "case16-ball" and r["ball_version"] == 1 for r in by_ball)
    assert len(archive.list_runs(ball="case16-ball@1", where=["speed_mps<8.5"])) == 2
    ordered = archive.list_runs(order_by="-speed_mps", where=["outcome=pins"])
    assert [r["speed_mps"] for r in ordered] == pytest.approx(sorted(speeds, reverse=True))
    with pytest.raises(IndexQueryError, match="unknown column 'hookk_m'"):
        archive.list_runs(where=["hookk_m>1"])
    for bad in ("abc", "NaN", "inf"):
        with pytest.raises(IndexQueryError, match="is not a finite number"):
            archive.list_runs(where=[f"hook_m>{bad}"])
    with pytest.raises(IndexQueryError, match="cannot order by unknown column '--hook_m'"):
        archive.list_runs(order_by="--hook_m")


def test_runs_made_before_the_ball_was_added_are_found_by_spec(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    rid = simulate_into(archive, _scene()).run_id
    archive.balls.add("later", _scene().ball)
    assert [r["run_id"] for r in archive.list_runs(ball="later")] == [rid]


def test_remove_export_and_prefix_lookup(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    rid = simulate_into(archive, _scene()).run_id
    out = archive.export(rid[:6], tmp_path)
    assert read_run_file(out).run_id == rid
    with pytest.raises(RunNotFoundError, match="no run"):
        archive.load("ffffffff")
    with pytest.raises(RunNotFoundError, match="not a run ID"):
        archive.resolve_id("xy")
    assert archive.remove(rid[:6]) == rid
    assert len(archive) == 0 and not archive.has_run(rid)


def test_reindex_rebuilds_the_index_from_the_run_files(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    ids = {simulate_into(archive, _scene(speed_mps=v)).run_id for v in (7.0, 8.0)}
    rows = {r["run_id"]: r for r in archive.list_runs()}
    (tmp_path / "a" / "index.sqlite").unlink()
    for extra in ("index.sqlite-wal", "index.sqlite-shm"):
        (tmp_path / "a" / extra).unlink(missing_ok=True)
    assert Archive(tmp_path / "a").reindex() == 2
    again = {r["run_id"]: r for r in Archive(tmp_path / "a").list_runs()}
    assert again.keys() == ids
    for rid in ids:
        assert again[rid] == rows[rid]


def test_a_non_archive_directory_is_refused(tmp_path: Path) -> None:
    (tmp_path / "stuff.txt").write_text("x")
    with pytest.raises(ArchiveError, match="not empty and is not a bowlrec archive"):
        Archive(tmp_path)
    with pytest.raises(ArchiveError, match="no archive.json"):
        Archive(tmp_path / "new", create=False)


# -- ball library ----------------------------------------------------------------------------------


def test_ball_library_versions_and_keeps_old_versions(tmp_path: Path) -> None:
    lib = Archive(tmp_path / "a").balls
    ball = _scene().ball
    heavier = ball.model_copy(update={"mass_kg": 7.0})
    e1, new1 = lib.add("house", ball)
    e1b, new1b = lib.add("house", ball)
    e2, new2 = lib.add("house", heavier)
    assert (e1.version, new1, e1b.version, new1b, e2.version, new2) == (1, True, 1, False, 2, True)
    assert lib.get("house").ball == heavier
    assert lib.get("house@1").ball == ball
    assert [e.version for e in lib.list(all_versions=True)] == [1, 2]
    assert [e.ref for e in lib.list()] == ["house@2"]
    lib.remove("house", 1)
    with pytest.raises(BallNotFoundError, match="no ball 'house@1'"):
        lib.get("house@1")
    with pytest.raises(BallNotFoundError):
        lib.remove("house", 1)
    with pytest.raises(ValueError, match="ball name"):
        lib.add("bad@name", ball)


def test_ball_library_export_import_round_trip(tmp_path: Path) -> None:
    lib = Archive(tmp_path / "a").balls
    ball = _scene().ball
    lib.add("house", ball)
    lib.add("house", ball.model_copy(update={"mass_kg": 7.0}))
    lib.add("spare", Scene().ball, note="plastic")
    doc = lib.export_json(tmp_path / "balls.json")
    assert json.loads((tmp_path / "balls.json").read_text()) == doc
    other = Archive(tmp_path / "b").balls
    results = other.import_json(tmp_path / "balls.json")
    assert [added for _, added in results] == [True, True, True]
    assert [(e.ref, e.sha, e.note) for e in other.list(all_versions=True)] == [
        (e.ref, e.sha, e.note) for e in lib.list(all_versions=True)
    ]
    assert [added for _, added in other.import_json(doc)] == [False, False, False]


def test_a_ball_import_with_one_bad_entry_adds_nothing_and_names_the_entry(
    tmp_path: Path,
) -> None:
    lib = Archive(tmp_path / "a").balls
    good = {"name": "house", "spec": json.loads(_scene().ball.model_dump_json())}
    head = {"format": "bowlrec-ball-library", "format_version": 1}
    for balls, words in (
        ([good, {**good, "name": "spare", "note": {"a": 1}}], "balls[1].note: must be text"),
        ([good, {"name": "spare"}], "balls[1].spec: missing"),
        ([good, {"name": "spare", "spec": {"mass_kg": -1}}], "balls[1].spec.mass_kg"),
        ([good, 5], "balls[1]: must be an object with name and spec (got int)"),
        ("x", "balls: must be an array of balls (got text)"),
    ):
        with pytest.raises(SpecError, match=re.escape(words)):
            lib.import_json({**head, "balls": balls})
    with pytest.raises(SpecError, match="format_version = 2: this bowlrec reads"):
        lib.import_json({**head, "format_version": 2, "balls": [good]})
    assert lib.list(all_versions=True) == []


def test_runs_reference_the_library_ball_they_used(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    archive.balls.add("house", _scene().ball)
    rid = simulate_into(archive, _scene()).run_id
    assert archive.load(rid).ball_ref == "house@1"
    explicit = simulate_into(archive, _scene(speed_mps=7.0), ball_ref="house@1").run_id
    assert archive.row(explicit)["ball_name"] == "house"


# -- segments, tombstones, compaction ---------------------------------------------------------


def test_segment_layout_units_compression_and_libver(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    builder = archive.builder()
    summary_scene = Scene.model_validate({"options": {"record": "summary"}})
    import bowlrec

    for scene in (_scene(), summary_scene):
        plan = scene.resolve()
        run = RunData(scene, plan, bowlrec.simulate(scene), run_id(plan))
        builder.append(archive.record(run, wall_time_s=0.1, solver="integrator"))
    info = archive.seal(builder)
    seen: list[str] = []

    def visit(name: str, obj: object) -> None:
        if isinstance(obj, h5py.Dataset):
            seen.append(name)
            assert "units" in obj.attrs, name
            if obj.nbytes > 4096 and tuple(name.split("/")) not in _INCOMPRESSIBLE:
                assert obj.compression == "gzip" and obj.shuffle, name

    with h5py.File(info.path, "r") as f:
        f.visititems(visit)
        assert f.attrs["format"] == "bowlrec-segment" and f.attrs["format_version"] == "3.0"
        assert f.attrs["n_runs"] == 2 and f.attrs["physics_version"]
        assert f["trajectory/position_m"].attrs["units"] == "m"
        assert f["summary/hook_m"].attrs["units"] == "m"
        assert f["runs/created_at_ns"].attrs["units"] == "ns"
        assert f["torques/tau_dev"].attrs["units"] == "N m"
        offsets = f["trajectory/offsets"][()]
        assert offsets[0] == 0 and offsets[2] == offsets[1]  # the summary-only run: no samples
        # default libver: readable by HDF5 1.10-era tools (superblock v0)
        assert f.id.get_access_plist().get_libver_bounds()[0] == h5py.h5f.LIBVER_EARLIEST
    assert len(seen) > 30
    added, shadowed = archive.register([info])
    assert (added, shadowed) == (2, 0)
    assert archive.register([info]) == (2, 0)  # registering again changes nothing
    assert len(archive) == 2


def test_a_run_stored_twice_is_listed_once_and_survives_the_removal_of_neither(
    tmp_path: Path, template_run: RunData
) -> None:
    archive = Archive(tmp_path / "a")
    segments = []
    for _ in range(2):  # two writers that simulated the same scene
        builder = archive.builder()
        builder.append(archive.record(template_run_with_id(template_run), wall_time_s=0.0))
        segments.append(archive.seal(builder))
    assert archive.register(segments) == (1, 1)
    assert len(archive) == 1 and archive.info()["duplicate_copies"] == 1
    archive.remove("ab" * 10)
    assert len(archive) == 0
    assert archive.reindex() == 0  # neither copy comes back from the files


def template_run_with_id(run: RunData, rid: str = "ab" * 10) -> RunData:
    return RunData(run.scene, run.plan, run.trajectory, rid)


def test_removed_runs_stay_removed_and_compaction_reclaims_them(
    tmp_path: Path, template_run: RunData
) -> None:
    archive = Archive(tmp_path / "a")
    ids = [f"{i:020x}" for i in range(6)]
    for rid in ids:  # six one-run segments, as interactive use makes them
        archive.add(template_run_with_id(template_run, rid), wall_time_s=0.0)
    archive.remove(ids[0])
    archive.remove(ids[1])
    assert archive.reindex() == 4
    assert {r["run_id"] for r in archive.list_runs()} == set(ids[2:])
    report = archive.compact()
    assert report["segments_rewritten"] == 6 and report["segments_written"] == 1
    assert report["runs_moved"] == 4 and report["tombstone_files_deleted"] == 2
    assert len(list((tmp_path / "a" / "segments").glob("*.h5"))) == 1
    assert not list((tmp_path / "a" / "tombstones").glob("*.json"))
    assert archive.reindex() == 4
    for rid in ids[2:]:
        _assert_same_trajectory(archive.load(rid).trajectory, template_run.trajectory)
    # a removed run simulated again is stored again
    archive.add(template_run_with_id(template_run, ids[0]), wall_time_s=0.0)
    assert archive.reindex() == 5


def test_a_changed_summary_value_is_detected_by_its_digest(
    tmp_path: Path, template_run: RunData
) -> None:
    archive = Archive(tmp_path / "a")
    builder = archive.builder()
    for i in range(3):
        run = template_run_with_id(template_run, f"{i:020x}")
        builder.append(archive.record(run, wall_time_s=0))
    info = archive.seal(builder)
    archive.register([info])
    with h5py.File(info.path, "r+") as f:  # what a bit flip or a careless edit does
        hooks = f["summary/hook_m"][()]
        hooks[1] += 1e-9
        f["summary/hook_m"][...] = hooks
    archive.load(f"{0:020x}")
    with pytest.raises(RunDamagedError, match=f"run {1:020x} in segment {info.segment_id}"):
        archive.load(f"{1:020x}")
    report = archive.repair()
    assert [d["run_id"] for d in report["damaged_runs"]] == [f"{1:020x}"]
    assert report["quarantined_segments"] == [info.segment_id]
    assert [d["run_id"] for d in archive.damaged()] == [f"{1:020x}"]
    for i in (0, 2):  # the healthy runs of the damaged segment were kept
        _assert_same_trajectory(archive.load(f"{i:020x}").trajectory, template_run.trajectory)
    assert (tmp_path / "a" / "quarantine" / f"{info.segment_id}.h5").exists()
    assert archive.reindex() == 2 and len(archive.damaged()) == 1


def test_a_per_run_record_group_is_read_checked_and_carried_by_compaction(
    tmp_path: Path, template_run: RunData
) -> None:
    """The extension rule of docs/archive-format.md: a 2.x segment with a per-run record group
    written by another writer (here an oil grid per run) reads, its rows are checksummed, and
    compaction carries them into the merged segment."""
    archive = Archive(tmp_path / "a")
    builder = archive.builder()
    for i in range(2):
        builder.append(
            archive.record(template_run_with_id(template_run, f"{i:020x}"), wall_time_s=0)
        )
    info = archive.seal(builder)
    with h5py.File(info.path, "r+") as f:  # what a later 2.x writer adds
        f["oil_grid/depth_m"] = np.arange(12.0).reshape(2, 2, 3)  # run i: depth_m[i]
        f["oil_grid/offsets"] = np.array([0, 1, 2])
        before = f["digest/blocks"][()]
    with SegmentFile(info.path) as seg:  # the digests a 2.x writer stores: the group included
        size = seg.block_runs
        digests = [int(seg.computed_digest(i), 16) for i in range(0, seg.n_runs, size)]
    assert digests != list(before)
    with h5py.File(info.path, "r+") as f:
        f["digest/blocks"][...] = np.array(digests, dtype=np.uint32)
    archive.register([info])
    _assert_same_trajectory(archive.load(f"{1:020x}").trajectory, template_run.trajectory)
    assert archive.repair()["damaged_runs"] == []
    stored = archive.load(f"{1:020x}").records["oil_grid"]["depth_m"]
    np.testing.assert_array_equal(stored, np.arange(6.0, 12.0).reshape(1, 2, 3))
    archive.add(template_run_with_id(template_run, f"{9:020x}"), wall_time_s=0)
    assert archive.compact()["segments_left"] == 0 and not info.path.exists()
    merged = archive.locate(f"{1:020x}")
    assert merged is not None
    with SegmentFile(merged[2]) as seg:
        assert seg.provenance["format_version"] == "3.0"  # it holds samples
    assert archive.load(f"{9:020x}").records == {}
    np.testing.assert_array_equal(archive.load(f"{1:020x}").records["oil_grid"]["depth_m"], stored)
    archive.close()  # segments read are kept open; HDF5 opens a file once per process
    with h5py.File(merged[2], "r+") as f:
        f["oil_grid/depth_m"][1, 0, 0] = -1.0  # a changed oil value of run 1
    archive.load(f"{0:020x}")
    with pytest.raises(RunDamagedError, match="digest mismatch"):
        archive.load(f"{1:020x}")


def test_record_groups_are_checked_when_written(tmp_path: Path, template_run: RunData) -> None:
    """Record groups with a reserved name, no datasets, unequal rows, or another layout than
    the segment's other runs are refused with the run named; a segment with samples is 3.0
    either way."""
    archive = Archive(tmp_path / "a")
    run = template_run_with_id(template_run, f"{1:020x}")
    for bad, match in [
        ({"events": {"x": np.zeros(2)}}, "cannot name"),
        ({"oil": {}}, "needs datasets"),
        ({"oil": {"a": np.zeros(2), "b": np.zeros(3)}}, "equal first dimensions"),
    ]:
        with pytest.raises(ValueError, match=match):
            archive.record(run, wall_time_s=0, records=bad)
    builder = archive.builder()
    builder.append(archive.record(run, wall_time_s=0, records={"oil": {"v": np.zeros(2)}}))
    other = template_run_with_id(template_run, f"{2:020x}")
    with pytest.raises(ValueError, match="seal the segment first"):
        builder.append(archive.record(other, wall_time_s=0, records={"oil": {"w": np.zeros(2)}}))
    plain = archive.add(template_run_with_id(template_run, f"{3:020x}"), wall_time_s=0)
    with SegmentFile(plain.path) as seg:
        assert seg.provenance["format_version"] == "3.0"  # it holds samples


def test_committed_v2_1_fixture_archive_reads_flags_and_resumes(tmp_path: Path) -> None:
    """tests/fixtures/archive-v2.1 holds two shots of a session written by format 2.1
    (tests/fixtures/make_fixture_v21.py) with physics frohlich2004-dp54-3: each run's oil grid
    and session state read back and the runs are flagged as an older physics version's; playing
    the session again simulates the same shots under today's physics (new run IDs) beside them,
    and a third play reads those from the archive. See
    test_committed_v2_fixture_archive_still_reads."""
    import json
    import shutil

    from bowlrec.provenance import physics_version_warning
    from bowlrec.session.records import oil_from_records, state_from_records
    from bowlrec.session.runner import run_session
    from bowlrec.session.spec import parse_session
    from bowlrec.testing.shots import assert_same_shots

    expected = json.loads((HERE / "fixtures" / "archive-v2.1.json").read_text())
    copy = shutil.copytree(HERE / "fixtures" / "archive-v2.1", tmp_path / "archive")
    archive = Archive(copy, create=False)
    assert archive.repair()["damaged_runs"] == []
    for shot in expected["shots"]:
        stored = archive.load(shot["run_id"])
        assert stored.attrs["format_version"] == "2.1"
        assert state_from_records(stored.records).shot == shot["shot"]
        assert oil_from_records(stored.records["oil"]).volume_ul.sum() == pytest.approx(
            shot["lane_oil_ul"], rel=1e-12
        )
    # the session was stored by the pocket-window rule: said explicitly, it keeps its ID; its
    # runs were made by an older physics version, so playing it again simulates them anew
    # (new run IDs, the same play) and keeps the stored ones
    session = {**expected["session"], "pins": False}
    result = run_session(parse_session(session), archive, max_shots=2)
    assert (result.resumed, result.simulated) == (0, 2)
    rows = [{**r.to_dict(), "simulated": True} for r in result.rows]
    assert_same_shots(rows, expected["shots"])
    for shot in expected["shots"]:
        assert physics_version_warning(dict(archive.load(shot["run_id"]).attrs)) is not None
    _older_runs_are_marked(copy, [s["run_id"] for s in expected["shots"]])
    again = run_session(parse_session(session), archive, max_shots=2)
    assert (again.resumed, again.simulated) == (2, 0)
    assert all(r["pinfall"] is None and r["score"] is None for r in rows)
    assert float(result.final.volume_ul.sum()) == pytest.approx(expected["final_oil_ul"], rel=1e-9)


def _older_runs_are_marked(root: Path, older: list[str]) -> None:
    """`runs list` marks runs of an older physics version with `*` and says so; `runs show`
    names the version."""
    from typer.testing import CliRunner

    from bowlrec.cli import app

    listed = CliRunner().invoke(app, ["runs", "list", "-a", str(root)], env={"COLUMNS": "200"})
    assert listed.exit_code == 0, listed.stderr
    marked = [line for line in listed.stdout.splitlines() if " * " in line]
    assert {rid[:10] for rid in older} <= {line.split()[1] for line in marked}
    assert "made with an older physics version" in listed.stderr
    shown = CliRunner().invoke(app, ["runs", "show", older[0], "-a", str(root), "--json"])
    assert shown.exit_code == 0, shown.stderr
    warnings = json.loads(shown.stdout)["warnings"]
    assert any("frohlich2004-dp54-3" in w and "current" in w for w in warnings)


def test_bowler_preset_runs_are_indexed_by_their_pattern(tmp_path: Path) -> None:
    from bowlrec.bowling.scene import BowlerScene

    archive = Archive(tmp_path / "a")
    bowler = BowlerScene(pattern="kegel_chromium_6742", options={"record": "summary"})
    scene = bowler.to_scene()
    rid = simulate_into(archive, scene).run_id
    assert run_id(scene.resolve()) == run_id(
        scene.model_copy(
            update={
                "lane": scene.lane.model_copy(
                    update={"friction": scene.lane.friction.model_copy(update={"pattern": None})}
                )
            }
        ).resolve()
    )  # the pattern name is a label: it does not change the run ID
    assert [r["run_id"] for r in archive.list_runs(pattern="kegel_chromium_6742")] == [rid]
    assert archive.list_runs(pattern="grid") == []


# -- committed fixtures --------------------------------------------------------------------------


def test_committed_v1_fixture_archive_migrates_to_v2(tmp_path: Path) -> None:
    """tests/fixtures/archive-v1 was written by format 1.0; ``bowlrec archive migrate``
    converts it: same run IDs, same bytes, the ball library kept, the 1.0 files kept aside."""
    import shutil

    from bowlrec.archive.migrate import migrate
    from bowlrec.sinks.hdf5_run import read_run_file

    copy = shutil.copytree(FIXTURE, tmp_path / "archive")  # migrating must not touch the repo
    with pytest.raises(ArchiveError, match="bowlrec archive migrate"):
        Archive(copy, create=False)
    report = migrate(copy)
    assert (report["runs"], report["balls"], report["unreadable_run_files"]) == (2, 1, [])
    archive = Archive(copy, create=False)
    rows = archive.list_runs(order_by="name")
    assert [r["name"] for r in rows] == ["fixture-summary", "fixture-trajectory"]
    assert [e.ref for e in archive.balls.list(all_versions=True)] == ["fixture-ball@1"]
    for row in rows:
        old = read_run_file(next((copy / "v1-archive" / "runs").glob(f"*/{row['run_id']}.h5")))
        new = archive.load(row["run_id"])
        assert new.scene == old.scene and new.ball_ref == "fixture-ball@1"
        assert new.attrs["physics_version"] == old.attrs["physics_version"]
        assert new.attrs["created_at"] == old.attrs["created_at"]
        _assert_same_trajectory(new.trajectory, old.trajectory, derived_rtol=1e-12)
        # re-running the same scene finds the migrated run: no duplicate
        again = simulate_into(archive, old.scene)
        assert again.run_id == row["run_id"] or again.added  # a new physics version, new ID
    assert migrate(copy)["already"] == "2.0"


def test_committed_v2_fixture_archive_still_reads(tmp_path: Path) -> None:
    """tests/fixtures/archive-v2 was written by format 2.0 (tests/fixtures/make_fixture.py).

    If this fails, the on-disk format changed: bump the segment or archive format version,
    document the change in docs/archive-format.md and keep reading the old version (or decide
    to migrate it), never by accident.
    """
    import shutil

    import bowlrec

    copy = shutil.copytree(FIXTURE_V2, tmp_path / "archive")
    assert not (copy / "index.sqlite").exists()  # the index is derived: built from the files
    archive = Archive(copy, create=False)
    rows = archive.list_runs(order_by="name")
    assert [r["name"] for r in rows] == ["fixture-summary", "fixture-trajectory"]
    assert [e.ref for e in archive.balls.list(all_versions=True)] == ["fixture-ball@1"]
    assert archive.repair()["damaged_runs"] == []
    for row in rows:
        stored = archive.load(row["run_id"])
        assert stored.attrs["format"] == "bowlrec-segment"
        assert stored.attrs["format_version"] == "2.0"
        assert stored.ball_ref == "fixture-ball@1"
        assert stored.trajectory.summary.outcome == row["outcome"] == "pins"
        assert stored.trajectory.summary.hook_m == row["hook_m"]
        # the stored physics still agrees with this tree's kernel (tolerance: 1e-6 m of hook, far
        # above the 1e-9 rtol and far below any physical change)
        again = bowlrec.simulate(stored.scene)
        assert again.summary.hook_m == pytest.approx(row["hook_m"], abs=1e-6)
    traj = archive.load(rows[1]["run_id"]).trajectory
    assert traj.n_samples > 10 and traj.position_m.shape == (traj.n_samples, 3)
    assert set(traj.torques_Nm) >= {"tau_dev", "I_dev"}


@pytest.mark.process
@pytest.mark.skipif(
    __import__("shutil").which("h5dump") is None,
    reason="h5dump (Debian's hdf5-tools, HDF5 1.10) is not installed; .ci/run installs it",
)
def test_segments_and_exports_read_with_hdf5_1_10_tools(tmp_path: Path) -> None:
    """A segment and a one-run export, written by h5py with HDF5 2.0, read by the HDF5 1.10
    command-line tools (another HDF5 implementation's reader, gzip + shuffle decoded)."""
    import shutil

    h5dump = shutil.which("h5dump")
    assert h5dump is not None
    archive = Archive(tmp_path / "a")
    stored = archive.load(simulate_into(archive, _scene()).run_id)
    segment = next((tmp_path / "a" / "segments").glob("*.h5"))
    out = subprocess.run(
        [h5dump, "-d", "/summary/hook_m", "-d", "/trajectory/t_s", "-m", "%.17g", str(segment)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
    hook_text, times_text = out.stdout.split('DATASET "/trajectory/t_s"')

    def values(text: str) -> list[float]:
        data = text.split("DATA {", 1)[1].split("}", 1)[0]
        return [float(v) for v in re.findall(r"\(\d+\): ([^,\s]+)", data)]

    assert values(hook_text) == [stored.trajectory.summary.hook_m]  # exact to the last bit
    assert values(times_text) == stored.trajectory.t_s.tolist()
    exported = archive.export(stored.run_id, tmp_path / "one.h5")
    out = subprocess.run(
        [h5dump, "-d", "/trajectory/position_m", str(exported)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0 and "DATASPACE  SIMPLE" in out.stdout, out.stderr

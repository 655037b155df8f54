"""The archive's contract: checks every archive layer passes, and the helpers the archive tests
share (in the spirit of zarr's ``zarr/testing/store.py``).

:class:`ArchiveContract` is a base class of tests: a subclass says how to open an archive
(:meth:`ArchiveContract.open`) and inherits every check. The object it opens has the
:class:`~bowlrec.archive.Archive` methods the checks call (:class:`ArchiveLike`): the facade
itself, or an adapter that calls the middle modules directly on an
:class:`~bowlrec.archive.directory.ArchiveDir` (tests/test_archive_contract.py runs both).

The checks: add, an idempotent re-add, locate, load with its digest checked, list / count /
filter / page, remove (a tombstone: the run never comes back, not from a rebuilt index, a
recovery or a compaction), a damaged copy set aside, a sealed but unregistered segment
recovered, a rebuilt index equal to the incrementally kept one, compaction keeping every live
run bit for bit, the ball library (add, get, versions, find, remove), and reads that never
write (the index file's bytes and mtime, the lock file and the directory listing unchanged by
every read method, with the index file healthy or missing).
"""

from __future__ import annotations

import contextlib
import random
import subprocess
import sys
import zlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import h5py
import numpy as np
import pytest

import bowlrec
from bowlrec.archive import faults, run_id
from bowlrec.archive.segment_file import SegmentFile
from bowlrec.core.trajectory import Trajectory
from bowlrec.errors import BallNotFoundError, RunDamagedError, RunNotFoundError
from bowlrec.paper import paper_scene
from bowlrec.sinks import RunData
from bowlrec.sinks.hdf5_run import read_run_file, write_run_file
from bowlrec.spec import Scene

# -- runs ----------------------------------------------------------------------------------------


def recorded_scene(speed_mps: float | None = None, *, terms: bool = False) -> Scene:
    """The paper's scene 16, recorded every 50 ms (57 samples: small segments, fast loads)."""
    base = paper_scene(16).model_dump(mode="json")
    base["options"] = {"record": "rate", "record_dt_s": 0.05, "record_terms": terms}
    if speed_mps is not None:
        base["delivery"]["speed_mps"] = speed_mps
    return Scene.model_validate(base)


def simulated(scene: Scene) -> RunData:
    """``scene`` simulated now, with its content ID."""
    plan = scene.resolve()
    return RunData(scene, plan, bowlrec.simulate(scene), run_id(plan))


def copy_of(run: RunData, i: int) -> RunData:
    """Copy ``i`` of ``run``: the same scene and trajectory under run ID ``f"{i:020x}"``."""
    return RunData(run.scene, run.plan, run.trajectory, f"{i:020x}")


def assert_same_trajectory(got: Trajectory, want: Trajectory, what: str = "") -> None:
    """Bit-identical arrays (dtype, shape, bytes), events and summary."""
    a, b = got.arrays(), want.arrays()
    assert a.keys() == b.keys(), what
    for key, arr in a.items():
        assert arr.dtype == b[key].dtype, (what, key)
        assert arr.shape == b[key].shape, (what, key)
        assert arr.tobytes() == b[key].tobytes(), (what, key)
    assert got.events == want.events, what
    assert got.summary == want.summary, what
    assert got.torques_Nm.keys() == want.torques_Nm.keys(), what
    for term, arr in got.torques_Nm.items():
        assert arr.tobytes() == want.torques_Nm[term].tobytes(), (what, term)


def seal(archive: Any, runs: Sequence[RunData], *, register: bool = True) -> Path:
    """Seal ``runs`` as one segment of ``archive`` (registered unless told); its path."""
    builder = archive.builder()
    for run in runs:
        builder.append(archive.record(run, wall_time_s=0.0))
    info = archive.seal(builder)
    if register:
        archive.register([info])
    return Path(info.path)


def listed(archive: Any, **filters: Any) -> list[str]:
    """The run IDs ``archive.list_runs`` lists (in its order)."""
    return [r["run_id"] for r in archive.list_runs(**filters)]


def ids_in_segment_files(root: Path) -> list[str]:
    """Run IDs of every sealed segment file (with repeats when several files hold a run)."""
    ids: list[str] = []
    for path in sorted((root / "segments").glob("*.h5")):
        with SegmentFile(path) as seg:
            ids += seg.run_ids()
    return ids


def temporaries(root: Path) -> list[Path]:
    """Temporaries (``*.part``) under ``root``."""
    return sorted(root.rglob("*.part"))


def library(archive: Any) -> list[tuple[str, int, str, str, str]]:
    """The ball library: (name, version, sha, added_at, note) of every version."""
    return [
        (e.name, e.version, e.sha, e.added_at, e.note)
        for e in archive.balls.list(all_versions=True)
    ]


def indexed_archive(root: Path, run: RunData) -> Any:
    """An archive of 8 live runs (copies 0-8 of ``run`` in two segments, copy 4 removed) and
    three ball versions."""
    from bowlrec.archive import Archive

    archive = Archive(root)
    seal(archive, [copy_of(run, i) for i in range(6)])
    seal(archive, [copy_of(run, i) for i in range(6, 9)])
    ball = run.scene.ball
    archive.balls.add("house", ball, note="first")
    archive.balls.add("house", ball.model_copy(update={"mass_kg": 7.0}), note="second")
    archive.balls.add("spare", ball.model_copy(update={"mass_kg": 6.0}))
    archive.remove(f"{4:020x}")
    return archive


def damage_index(path: Path, damage: str) -> None:
    """``damage`` the index file at ``path``: "deleted", or "garbled" (random bytes in place)."""
    if damage == "deleted":
        path.unlink()
    else:
        size = path.stat().st_size
        with open(path, "r+b") as fh:  # in place: same file, random bytes
            fh.write(random.Random(7).randbytes(size))


# -- crashes replayed in-process -----------------------------------------------------------------


class SimulatedCrash(BaseException):
    """Raised at an armed fault point: the process "dies" there. A BaseException, so that no
    ``except Exception`` of the write path handles it (nothing handles a kill either)."""


@contextlib.contextmanager
def crash_at(name: str, before: Callable[..., None] | None = None) -> Iterator[None]:
    """Within the block, the write path "dies" at fault point ``name`` (raises
    :class:`SimulatedCrash` there), after ``before(**context)`` when given (to leave what a real
    kill leaves, e.g. a temporary)."""

    def crash(**context: Any) -> None:
        if before is not None:
            before(**context)
        raise SimulatedCrash(f"simulated crash at fault point {name!r}")

    with faults.armed(name, crash):
        yield


# -- child processes (tests/archive_fault_child.py) -----------------------------------------------

CHILD = Path(__file__).resolve().parents[1] / "archive_fault_child.py"


@dataclass(frozen=True)
class Template:
    """A run file the writer children copy, and the run as read back from it."""

    path: Path
    run: RunData


def make_template(directory: Path) -> Template:
    """:func:`recorded_scene` simulated, written as a run file in ``directory`` and read
    back."""
    scene = recorded_scene()
    run = RunData(scene, scene.resolve(), bowlrec.simulate(scene))
    path = write_run_file(directory / "template.h5", run, {})
    stored = read_run_file(path)
    return Template(path, RunData(stored.scene, stored.scene.resolve(), stored.trajectory))


def spawn(*args: str, **kwargs: Any) -> subprocess.Popen[str]:
    """tests/archive_fault_child.py started with ``args`` (stdout and stderr piped, text)."""
    return subprocess.Popen(
        [sys.executable, str(CHILD), *args],
        stdin=kwargs.pop("stdin", subprocess.DEVNULL),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,
    )


def collect(child: subprocess.Popen[str]) -> tuple[str, str]:
    """The rest of a child's stdout and its stderr, once it exits. (Not communicate(): after a
    readline() it would miss what the text wrapper had already buffered.)"""
    assert child.stdout is not None and child.stderr is not None
    out = child.stdout.read()
    err = child.stderr.read()
    child.wait(timeout=60)
    return out, err


def wait_ready(child: subprocess.Popen[str]) -> None:
    """Wait for the child's ``ready`` line (kill it and fail otherwise)."""
    assert child.stdout is not None
    line = child.stdout.readline().strip()
    if line != "ready":
        child.kill()
        _, err = collect(child)
        raise AssertionError(f"child did not start: {line!r}\n{err}")


# -- damage --------------------------------------------------------------------------------------


def _chunk_of(ds: h5py.Dataset, index: int) -> tuple[int, int, int]:
    """(file offset, stored size, first element) of the chunk holding element ``index``."""
    assert ds.chunks is not None and ds.ndim == 1
    first = index // ds.chunks[0] * ds.chunks[0]
    info = ds.id.get_chunk_info_by_coord((first,))
    assert info.filter_mask == 0
    return int(info.byte_offset), int(info.size), first


def change_value_in_place(path: Path, dataset: str, index: int) -> float:
    """Change one float64 of ``dataset`` (1-D) by rewriting its bytes in the file, the rest of
    the file untouched (a compressed chunk is re-encoded into its own space). The new value."""
    with h5py.File(path, "r") as f:
        ds = f[dataset]
        assert ds.dtype == np.float64
        old = ds[()]
        if ds.chunks is None:
            offset, size, first, chunk_len = ds.id.get_offset(), old.nbytes, 0, old.size
            encoded = False
        else:
            offset, size, first = _chunk_of(ds, index)
            chunk_len = ds.chunks[0]
            assert ds.compression == "gzip" and ds.shuffle
            encoded = True
    with open(path, "r+b") as fh:
        fh.seek(offset)
        stored = fh.read(size)
        raw = zlib.decompress(stored) if encoded else stored
        planes = np.frombuffer(raw, np.uint8)
        # shuffle stores byte 0 of every element, then byte 1, ...
        values = (planes.reshape(8, chunk_len).T.copy() if encoded else planes.copy()).view(
            np.uint64
        )
        for bit in range(52):  # a mantissa bit whose flip re-encodes into the chunk's space
            changed = values.copy().reshape(-1)
            changed[index - first] ^= np.uint64(1 << bit)
            data = changed.view(np.uint8).reshape(chunk_len, 8).T.tobytes() if encoded else None
            for level in range(9, 0, -1) if encoded else (0,):
                new = zlib.compress(data, level) if data is not None else changed.tobytes()
                if len(new) <= size:
                    fh.seek(offset)
                    fh.write(new)  # any old bytes after the new stream are never read
                    break
            else:
                continue
            break
        else:
            raise AssertionError(f"{path}:{dataset}: no one-bit change fits the chunk's space")
    with h5py.File(path, "r") as f:
        now = f[dataset][()]
    assert now[index] != old[index]
    assert np.delete(now, index).tobytes() == np.delete(old, index).tobytes()
    return float(now[index])


def flip_raw_bytes(path: Path, dataset: str, chunk: int = 0, n: int = 16) -> None:
    """Invert ``n`` bytes in the middle of a stored (compressed) chunk of ``dataset``."""
    with h5py.File(path, "r") as f:
        info = f[dataset].id.get_chunk_info(chunk)
        offset, size = int(info.byte_offset), int(info.size)
    assert size > n + 8
    with open(path, "r+b") as fh:
        fh.seek(offset + size // 2)
        data = fh.read(n)
        fh.seek(offset + size // 2)
        fh.write(bytes(b ^ 0xFF for b in data))


def snapshot(root: Path) -> dict[str, tuple[int, int, int]]:
    """Every file and directory under ``root``: (size, mtime ns, CRC-32 of a file's bytes)."""
    out = {}
    for p in sorted(root.rglob("*")):
        st = p.stat()
        crc = zlib.crc32(p.read_bytes()) if p.is_file() else 0
        out[str(p.relative_to(root))] = (st.st_size, st.st_mtime_ns, crc)
    return out


# -- the contract --------------------------------------------------------------------------------


class ArchiveLike(Protocol):
    """The methods of :class:`~bowlrec.archive.Archive` the contract calls."""

    root: Path
    balls: Any

    def builder(self) -> Any: ...
    def record(self, run: RunData, *, wall_time_s: float) -> Any: ...
    def seal(self, builder: Any) -> Any: ...
    def register(self, segments: Any) -> tuple[int, int]: ...
    def add(self, run: RunData, *, wall_time_s: float) -> Any: ...
    def locate(self, run_id: str) -> tuple[str, int, Path] | None: ...
    def has_run(self, run_id: str) -> bool: ...
    def resolve_id(self, run_id: str) -> str: ...
    def load(self, run_id: str) -> Any: ...
    def run_data(self, run_id: str) -> RunData: ...
    def export(self, run_id: str, dest: Path) -> Path: ...
    def list_runs(self, **filters: Any) -> list[dict[str, Any]]: ...
    def count_runs(self, **filters: Any) -> int: ...
    def row(self, run_id: str) -> dict[str, Any]: ...
    def rows(self, run_ids: Any) -> dict[str, dict[str, Any]]: ...
    def damaged(self) -> list[dict[str, Any]]: ...
    def info(self) -> dict[str, Any]: ...
    def __len__(self) -> int: ...
    def remove(self, run_id: str) -> str: ...
    def set_aside(self, run_id: str, segment_id: str, reason: str) -> None: ...
    def recover(self) -> dict[str, int]: ...
    def reindex(self) -> int: ...
    def compact(self) -> dict[str, int]: ...
    def repair(self) -> dict[str, Any]: ...
    def close(self) -> None: ...


@pytest.fixture(scope="module")
def contract_runs() -> dict[str, RunData]:
    """Runs the contract stores: ``recorded`` (samples and per-term torques), four
    summary-only deliveries at 7.0-9.5 m/s (``summary-7.0`` ...) and ``gutter``."""
    runs = {"recorded": simulated(recorded_scene(terms=True))}
    for v in (7.0, 7.5, 8.5, 9.5):
        scene = recorded_scene(v).model_copy(
            update={"options": recorded_scene(v).options.model_copy(update={"record": "summary"})}
        )
        runs[f"summary-{v}"] = simulated(scene)
    gutter = Scene.model_validate(
        {"delivery": {"takeoff_angle_deg": 5.0}, "options": {"record": "summary"}}
    )
    runs["gutter"] = simulated(gutter)
    return runs


class ArchiveContract:
    """Checks every archive layer passes. Subclass it (named ``Test...``) and implement
    :meth:`open`; a class attribute ``reopen_is_new_process = True`` says :meth:`open` on the
    same root gives an object that shares no state with the earlier one (a new process, as
    far as the archive can tell)."""

    def open(self, root: Path) -> ArchiveLike:
        """An archive at ``root`` (created when missing)."""
        raise NotImplementedError

    @pytest.fixture
    def archive(self, tmp_path: Path) -> ArchiveLike:
        return self.open(tmp_path / "a")

    @pytest.fixture
    def filled(self, archive: ArchiveLike, contract_runs: dict[str, RunData]) -> ArchiveLike:
        """Every contract run added (one segment each), a duplicate copy of ``recorded``
        sealed in a segment of two, two ball versions and one removed run."""
        for run in contract_runs.values():
            assert archive.add(run, wall_time_s=0.25).added
        seal(archive, [contract_runs["recorded"], copy_of(contract_runs["recorded"], 7)])
        ball = contract_runs["recorded"].scene.ball
        archive.balls.add("house", ball, note="first")
        archive.balls.add("house", ball.model_copy(update={"mass_kg": 7.0}))
        gone = contract_runs["summary-9.5"].run_id
        assert gone is not None
        archive.remove(gone)
        return archive

    # -- add, locate, load ---------------------------------------------------------------------

    def test_add_locate_and_load_bit_for_bit(
        self, archive: ArchiveLike, contract_runs: dict[str, RunData]
    ) -> None:
        run = contract_runs["recorded"]
        assert run.run_id is not None
        res = archive.add(run, wall_time_s=0.5)
        assert res.added and res.run_id == run.run_id and res.path.exists()
        found = archive.locate(run.run_id)
        assert found is not None and found[2] == res.path and found[1] == 0
        assert archive.has_run(run.run_id) and len(archive) == 1
        assert archive.resolve_id(run.run_id[:6]) == run.run_id
        stored = archive.load(run.run_id[:8])
        assert stored.run_id == run.run_id and stored.scene == run.scene
        assert_same_trajectory(stored.trajectory, run.trajectory)
        assert stored.attrs["wall_time_s"] == 0.5 and stored.attrs["physics_version"]
        data = archive.run_data(run.run_id)
        assert data.provenance is not None and data.provenance["segment_id"] == found[0]
        with pytest.raises(RunNotFoundError):
            archive.load("ffffffffff")

    def test_adding_again_writes_nothing(
        self, archive: ArchiveLike, contract_runs: dict[str, RunData]
    ) -> None:
        run = contract_runs["summary-7.5"]
        first = archive.add(run, wall_time_s=0.0)
        before = sorted(p.name for p in (archive.root / "segments").iterdir())
        again = archive.add(run, wall_time_s=0.0)
        assert first.added and not again.added and again.path == first.path
        assert sorted(p.name for p in (archive.root / "segments").iterdir()) == before
        assert len(archive) == 1

    def test_a_changed_byte_is_named_never_returned(
        self, archive: ArchiveLike, contract_runs: dict[str, RunData]
    ) -> None:
        runs = [copy_of(contract_runs["recorded"], i) for i in range(3)]
        path = seal(archive, runs)
        change_value_in_place(path, "summary/hook_m", 1)
        archive.close()
        with pytest.raises(RunDamagedError) as info:
            archive.load(f"{1:020x}")
        assert info.value.run_id == f"{1:020x}" and info.value.segment == path.stem
        for i in (0, 2):
            assert_same_trajectory(archive.load(f"{i:020x}").trajectory, runs[i].trajectory)

    # -- queries -------------------------------------------------------------------------------

    def test_list_count_filter_and_page(
        self, filled: ArchiveLike, contract_runs: dict[str, RunData]
    ) -> None:
        a = filled
        everything = a.list_runs()
        assert len(everything) == len(a) == a.count_runs() == 6  # 7 stored, 1 removed
        assert len({r["run_id"] for r in everything}) == 6
        hooks = {r["run_id"]: r["hook_m"] for r in everything}
        cut = sorted(h for h in hooks.values() if h is not None)[2]
        picked = set(listed(a, where=[f"hook_m>={cut}"]))
        assert picked == {rid for rid, h in hooks.items() if h is not None and h >= cut}
        assert a.count_runs(where=[f"hook_m>={cut}"]) == len(picked)
        assert listed(a, outcome="gutter") == [contract_runs["gutter"].run_id]
        assert a.count_runs(outcome="pins", cap=2) == 2
        by_speed = a.list_runs(order_by="-speed_mps", where=["record=summary"])
        speeds = [r["speed_mps"] for r in by_speed]
        assert speeds == sorted(speeds, reverse=True) and len(speeds) == 4
        pages = [listed(a, order_by="created_at", limit=2, offset=k) for k in (0, 2, 4)]
        assert sum(pages, []) == listed(a, order_by="created_at")
        rid = contract_runs["recorded"].run_id
        assert rid is not None
        assert a.row(rid[:6]) == a.rows([rid, "0" * 20])[rid]
        assert a.row(rid)["n_samples"] == contract_runs["recorded"].trajectory.n_samples
        house1 = a.balls.get("house@1").sha  # runs made before the ball was added: by spec
        assert set(listed(a, ball="house@1")) == {
            r["run_id"] for r in everything if r["ball_sha"] == house1
        }
        assert listed(a, ball="house@2") == []
        info = a.info()
        assert (info["runs"], info["balls"], info["duplicate_copies"]) == (6, 2, 1)

    # -- removal and damage ----------------------------------------------------------------------

    def test_a_removed_run_never_comes_back(
        self, filled: ArchiveLike, contract_runs: dict[str, RunData]
    ) -> None:
        a = filled
        gone = contract_runs["summary-9.5"].run_id
        dup = contract_runs["recorded"].run_id
        assert gone is not None and dup is not None
        a.remove(dup)  # its live copy and its duplicate copy
        for step in (a.recover, a.reindex, a.compact, a.reindex, a.repair):
            step()
            assert gone not in listed(a) and dup not in listed(a), step.__name__
            assert not a.has_run(gone) and not a.has_run(dup)
        reopened = self.open(a.root)
        assert gone not in listed(reopened) and dup not in listed(reopened)
        assert reopened.add(contract_runs["summary-9.5"], wall_time_s=0.0).added  # stored anew
        assert gone in listed(reopened)

    def test_a_damaged_copy_is_set_aside_and_listed(
        self, filled: ArchiveLike, contract_runs: dict[str, RunData]
    ) -> None:
        a = filled
        rid = contract_runs["summary-7.0"].run_id
        assert rid is not None
        found = a.locate(rid)
        assert found is not None
        a.set_aside(rid, found[0], "damaged: a test says so")
        assert rid not in listed(a)
        assert [(d["run_id"], d["segment_id"]) for d in a.damaged()] == [(rid, found[0])]
        a.reindex()
        assert rid not in listed(a) and [d["run_id"] for d in a.damaged()] == [rid]
        assert a.add(contract_runs["summary-7.0"], wall_time_s=0.0).added  # a fresh copy
        assert rid in listed(a)

    # -- recovery and the derived index ----------------------------------------------------------

    def test_a_sealed_unregistered_segment_is_recovered(
        self, archive: ArchiveLike, contract_runs: dict[str, RunData]
    ) -> None:
        archive.add(contract_runs["gutter"], wall_time_s=0.0)
        runs = [copy_of(contract_runs["recorded"], i) for i in (1, 2)]
        seal(archive, runs, register=False)  # a writer killed before it registered
        reader = self.open(archive.root)
        assert sorted(listed(reader)) == [contract_runs["gutter"].run_id]  # reads recover nothing
        report = reader.recover()
        assert report["segments_registered"] == 1
        assert sorted(listed(reader)) == sorted([contract_runs["gutter"].run_id, *_ids(runs)])
        for run in runs:
            assert run.run_id is not None
            assert_same_trajectory(reader.load(run.run_id).trajectory, run.trajectory)
        assert reader.recover()["segments_registered"] == 0

    def test_a_rebuilt_index_equals_the_incremental_one(self, filled: ArchiveLike) -> None:
        a = filled
        before = (a.list_runs(), a.damaged(), _library(a), a.info())
        assert a.reindex() == 6
        after = (a.list_runs(), a.damaged(), _library(a), a.info())
        assert _without_sizes(after) == _without_sizes(before)

    def test_compaction_keeps_every_live_run_bit_for_bit(
        self, filled: ArchiveLike, contract_runs: dict[str, RunData]
    ) -> None:
        a = filled
        before = {r["run_id"]: r for r in a.list_runs()}
        stored = {rid: a.load(rid) for rid in before}
        report = a.compact()
        assert report["segments_left"] == 0 and report["segments_written"] == 1
        assert len(list((a.root / "segments").glob("*.h5"))) == 1
        after = {r["run_id"]: r for r in a.list_runs()}
        moved = ("segment_id", "row", "path")
        assert {k: {c: v for c, v in r.items() if c not in moved} for k, r in after.items()} == {
            k: {c: v for c, v in r.items() if c not in moved} for k, r in before.items()
        }
        for rid, old in stored.items():
            new = a.load(rid)
            assert new.scene == old.scene and new.attrs["created_at"] == old.attrs["created_at"]
            assert new.attrs["scene_json"] == old.attrs["scene_json"]
            assert_same_trajectory(new.trajectory, old.trajectory, rid)
        assert a.info()["duplicate_copies"] == 0 and a.reindex() == 6

    # -- the ball library --------------------------------------------------------------------------

    def test_ball_library_versions(
        self, archive: ArchiveLike, contract_runs: dict[str, RunData]
    ) -> None:
        lib = archive.balls
        ball = contract_runs["recorded"].scene.ball
        heavier = ball.model_copy(update={"mass_kg": 7.0})
        e1, new1 = lib.add("house", ball, note="v1")
        e1b, new1b = lib.add("house", ball)
        e2, new2 = lib.add("house", heavier)
        assert (e1.ref, new1, e1b.ref, new1b, e2.ref, new2) == (
            "house@1",
            True,
            "house@1",
            False,
            "house@2",
            True,
        )
        assert lib.get("house").ball == heavier and lib.get("house@1").note == "v1"
        assert [e.ref for e in lib.list(all_versions=True)] == ["house@1", "house@2"]
        assert [e.ref for e in lib.list()] == ["house@2"]
        found = lib.find(ball)
        assert found is not None and found.ref == "house@1"
        lib.remove("house", 1)
        with pytest.raises(BallNotFoundError):
            lib.get("house@1")
        assert [e.ref for e in self.open(archive.root).balls.list(all_versions=True)] == ["house@2"]
        assert archive.reindex() == 0 and [e.ref for e in lib.list(all_versions=True)] == [
            "house@2"
        ]

    # -- reads never write -------------------------------------------------------------------------

    @pytest.mark.parametrize("index", ["healthy", "missing", "garbled"])
    def test_reads_never_write(
        self,
        filled: ArchiveLike,
        contract_runs: dict[str, RunData],
        tmp_path: Path,
        index: str,
    ) -> None:
        """Every read method, on this object and a reopened one, leaves the directory as it
        was: the index file's bytes and mtime, the lock file (absent stays absent), every
        other file and the listing."""
        root = filled.root
        filled.close()
        (root / ".writer.lock").unlink()
        path = root / "index.sqlite"
        if index == "missing":
            path.unlink()
        elif index == "garbled":
            path.write_bytes(b"not a database " * 64)
        before = snapshot(root)
        rid = contract_runs["recorded"].run_id
        assert rid is not None
        for a in (filled, self.open(root)):
            for name, read in _reads(a, rid, tmp_path / "out"):
                read()
                assert snapshot(root) == before, f"{name} wrote to the archive ({index} index)"
            a.close()


def _ids(runs: Sequence[RunData]) -> list[str]:
    return [r.run_id for r in runs if r.run_id is not None]


def _library(a: ArchiveLike) -> list[tuple[str, int, str, str, str]]:
    return [(e.name, e.version, e.sha, e.added_at, e.note) for e in a.balls.list(all_versions=True)]


def _without_sizes(state: tuple[Any, ...]) -> tuple[Any, ...]:
    """An index's state without what a rebuild may change: the index file's size and the
    time damage was detected."""
    rows, damaged, library, info = state
    info = {k: v for k, v in info.items() if k != "index_bytes"}
    damaged = [{k: v for k, v in d.items() if k != "detected_at"} for d in damaged]
    return rows, damaged, library, info


def _reads(a: ArchiveLike, rid: str, out: Path) -> Iterator[tuple[str, Callable[[], Any]]]:
    """Every read method of ``a``, named, each called on run ``rid``."""
    out.mkdir(exist_ok=True)
    yield "list_runs", lambda: a.list_runs(where=["hook_m>=0"], ball="house", limit=3)
    yield "count_runs", lambda: a.count_runs(outcome="pins")
    yield "len", lambda: len(a)
    yield "damaged", a.damaged
    yield "info", a.info
    yield "resolve_id", lambda: a.resolve_id(rid[:6])
    yield "locate", lambda: a.locate(rid)
    yield "has_run", lambda: a.has_run(rid)
    yield "row", lambda: a.row(rid)
    yield "rows", lambda: a.rows([rid])
    yield "load", lambda: a.load(rid)
    yield "run_data", lambda: a.run_data(rid)
    yield "export", lambda: a.export(rid, out)
    yield "balls.list", lambda: a.balls.list(all_versions=True)
    yield "balls.get", lambda: a.balls.get("house@1")
    yield "balls.find", lambda: a.balls.find(a.load(rid).scene.ball)
    yield "balls.export_json", a.balls.export_json
    yield "a run not archived", lambda: a.locate("0" * 20)

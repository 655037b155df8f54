"""The samples filter: recorded samples stored uncompressed or with Blosc LZ4 read back the
same, and compaction rewrites them with gzip."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import hdf5plugin
import numpy as np
import pytest

from bowlrec.archive import Archive
from bowlrec.batch import JobSpec, run_job
from bowlrec.core.solver import solve

BLOSC = hdf5plugin.BLOSC_ID


def _job(samples: str) -> JobSpec:
    return JobSpec.model_validate(
        {
            "base": {"options": {"record": "rate", "record_dt_s": 0.005}},
            "sweep": {"kind": "grid", "axes": {"delivery.speed_mps": [6.0, 7.0, 8.0]}},
            "record": "scene",
            "samples": samples,
        }
    )


def _filters(archive: Archive) -> set[str | None]:
    out: set[str | None] = set()
    for path in archive.segments_dir.glob("*.h5"):
        with h5py.File(path, "r") as f:
            ds = f["trajectory/position_m"]
            out.add("lz4" if str(BLOSC) in ds._filters else ds.compression)
    return out


@pytest.mark.parametrize("samples", ["gzip", "lz4", "none"])
def test_samples_stored_by_filter_read_back_equal(tmp_path: Path, samples: str) -> None:
    archive = Archive(tmp_path / "a")
    result = run_job(_job(samples), archive, workers=0)
    assert result.counts["ok"] == 3
    assert _filters(archive) == {None if samples == "none" else samples}
    for row in result.rows:
        stored = archive.load(row["run_id"])
        fresh = solve(stored.scene.resolve())
        assert np.array_equal(stored.trajectory.position_m, fresh.position_m)
        assert np.array_equal(stored.trajectory.energy_J, fresh.energy_J)
    assert archive.repair()["damaged_runs"] == []


def test_compaction_recompresses_uncompressed_samples(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    result = run_job(_job("none"), archive, workers=0, chunk_size=1)  # one segment per run
    before = {r["run_id"]: archive.load(r["run_id"]).trajectory.t_s for r in result.rows}
    report = archive.compact()
    assert report["segments_written"] == 1 and report["runs_moved"] == 3
    assert _filters(archive) == {"gzip"}
    for rid, t in before.items():
        assert np.array_equal(archive.load(rid).trajectory.t_s, t)


def test_an_unknown_filter_is_refused() -> None:
    with pytest.raises(ValueError, match="samples"):
        JobSpec.model_validate({"samples": "brotli"})


#: loads every run of the archive at argv[1] in a fresh interpreter, then prints whether the
#: Blosc plugin package was imported
LOAD_ALL = """
import sys
from bowlrec.archive import Archive
archive = Archive(sys.argv[1])
for row in archive.list_runs():
    assert archive.load(row["run_id"]).trajectory.n_samples > 0
print("hdf5plugin" in sys.modules)
"""


@pytest.mark.process  # a fresh interpreter's modules
@pytest.mark.parametrize(("samples", "imported"), [("gzip", "False"), ("lz4", "True")])
def test_the_blosc_plugin_is_imported_only_for_samples_stored_with_it(
    tmp_path: Path, samples: str, imported: str
) -> None:
    archive = Archive(tmp_path / "a")
    assert run_job(_job(samples), archive, workers=0).counts["ok"] == 3
    out = subprocess.run(
        [sys.executable, "-c", LOAD_ALL, str(archive.root)],
        capture_output=True,
        text=True,
        check=True,
    )
    assert out.stdout.strip().splitlines()[-1] == imported

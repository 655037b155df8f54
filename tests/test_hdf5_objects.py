"""Segment files written through the low-level HDF5 calls of ``bowlrec.archive.hdf5_objects``
and built in memory (HDF5's core driver) are the files h5py's high-level API writes through the
default driver, byte for byte."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from bowlrec.archive import Archive, run_id, segment_file
from bowlrec.archive import hdf5_objects as fast
from bowlrec.archive.segment import SegmentBuilder
from bowlrec.core.solver import run_plan
from bowlrec.provenance import environment
from bowlrec.sinks.common import RunData
from bowlrec.spec.scene import Scene


def _high_level_dataset(
    group: h5py.Group, name: str, data: Any, options: dict[str, Any]
) -> h5py.Dataset:
    return group.create_dataset(name, data=data, **options)


def _high_level_attr(obj: Any, name: str, value: Any) -> None:
    obj.attrs[name] = value


def _columns(tmp_path: Path, samples: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """Every dataset of a segment with a summary-only, a sampled and a bowler-language run."""
    archive = Archive(tmp_path / "a")
    scenes = [
        Scene.model_validate({"name": "summary", "delivery": {"speed_mps": 7.5}}),
        Scene.model_validate(
            {"name": "sampled", "options": {"record": "rate", "record_dt_s": 0.01}}
        ),
        Scene.model_validate({"name": "steps", "options": {"record": "steps"}}),
    ]
    builder = SegmentBuilder(environment(), samples=samples)
    for k, scene in enumerate(scenes):
        plan = scene.resolve()
        run = RunData(scene, plan, run_plan(plan, "auto"), run_id(plan))
        builder.append(archive.record(run, wall_time_s=1e-3 * (k + 1), solver="integrator"))
    return builder.columns(), builder.provenance


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("samples", ["gzip", "lz4", "none"])
def test_segment_file_bytes_equal_the_high_level_api_and_default_driver(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, samples: str
) -> None:
    columns, provenance = _columns(tmp_path, samples)
    fast_path, slow_path = tmp_path / "fast.h5", tmp_path / "slow.h5"
    segment_file.write_segment(fast_path, "seg", columns, provenance, samples=samples)
    monkeypatch.setattr(segment_file, "new_dataset", _high_level_dataset)
    monkeypatch.setattr(segment_file, "set_attr", _high_level_attr)
    monkeypatch.setattr(segment_file, "IN_MEMORY_BYTES", -1)  # the default driver
    segment_file.write_segment(slow_path, "seg", columns, provenance, samples=samples)
    assert _digest(fast_path) == _digest(slow_path)
    with segment_file.SegmentFile(fast_path) as seg:
        assert seg.verify() == ([0, 1, 2], {})


def test_attributes_read_back_as_written(tmp_path: Path) -> None:
    values: dict[str, Any] = {
        "text": "m/s",
        "unicode": "µm ° ±",
        "empty": "",
        "int": 7,
        "negative": -(2**62),
        "float": 0.1,
        "nan": float("nan"),
        "bool": True,
        "array": np.arange(3.0),
    }
    with h5py.File(tmp_path / "f.h5", "w") as f:
        for name, value in values.items():
            fast.set_attr(f, name, value)
        fast.set_attr(f, "text", "replaced")
        with pytest.raises(TypeError):  # beyond int64: refused, as h5py refuses it
            fast.set_attr(f, "huge", 2**70)
    with h5py.File(tmp_path / "f.h5", "r") as f:
        got = dict(f.attrs.items())
    assert got["text"] == "replaced" and got["unicode"] == values["unicode"]
    assert got["empty"] == "" and got["float"] == 0.1 and np.isnan(got["nan"])
    assert got["int"] == 7 and got["int"].dtype == np.int64 and got["negative"] == -(2**62)
    assert "huge" not in got
    assert bool(got["bool"]) is True and np.array_equal(got["array"], values["array"])


def test_datasets_read_back_as_written(tmp_path: Path) -> None:
    arrays = {
        "f8": np.linspace(0.0, 1.0, 5),
        "i8": np.arange(-3, 3, dtype=np.int64),
        "u1": np.arange(4, dtype=np.uint8),
        "bytes": np.array([b"ab", b"c"], dtype="S2"),
        "matrix": np.arange(12.0).reshape(3, 4),
        "empty": np.zeros((0, 3)),
        "strided": np.arange(10.0)[::2],
        "chunked": np.arange(100.0),
    }
    with h5py.File(tmp_path / "f.h5", "w") as f:
        for name, data in arrays.items():
            options = {"chunks": (10,), "compression": "gzip"} if name == "chunked" else {}
            fast.new_dataset(f, name, data, options)
    with h5py.File(tmp_path / "f.h5", "r") as f:
        for name, data in arrays.items():
            assert f[name].dtype == data.dtype and np.array_equal(f[name][()], data)
        assert f["chunked"].compression == "gzip" and f["f8"].chunks is None


def test_read_whole_reads_what_the_high_level_api_reads(tmp_path: Path) -> None:
    """read_whole gives the dtype, shape and bytes of ``group[name][()]`` for every kind of
    dataset a segment holds (and falls back for the others)."""
    datasets: dict[str, Any] = {
        "f8": np.linspace(0.0, 1.0, 7),
        "i8_2d": np.arange(12, dtype=np.int64).reshape(4, 3),
        "u1": np.arange(5, dtype=np.uint8),
        "bytes": np.array([b"pins", b"gutter", b""], dtype="S6"),
        "bool": np.array([True, False, True]),
        "empty": np.zeros((0, 3)),
        "scalar": np.float64(2.5),
        "big_endian": np.arange(3, dtype=">f8"),
    }
    path = tmp_path / "r.h5"
    with h5py.File(path, "w") as f:
        g = f.create_group("g")
        for name, data in datasets.items():
            g.create_dataset(name, data=data)
        g.create_dataset("gzip", data=np.arange(5000.0), chunks=(1000,), compression="gzip")
        g.create_dataset("vlen", data=["a", "bc"], dtype=h5py.string_dtype())
    with h5py.File(path, "r") as f:
        for name in [*datasets, "gzip", "vlen"]:
            fast_read, plain = fast.read_whole(f["g"], name), f["g"][name][()]
            assert isinstance(fast_read, np.ndarray) == isinstance(plain, np.ndarray), name
            a, b = np.asarray(fast_read), np.asarray(plain)
            assert a.dtype == b.dtype and a.shape == b.shape, name
            if a.dtype != object:
                assert a.tobytes() == b.tobytes(), name
            else:
                assert a.tolist() == b.tolist()
        assert fast.read_whole(f, "g/f8").tolist() == datasets["f8"].tolist()  # a path

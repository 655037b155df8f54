"""Segment format 2.3: scenes as a base and overrides, digests per block of runs."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pydantic_core
import pytest

from bowlrec.archive import Archive, SegmentFile
from bowlrec.archive.scene_store import apply, scene_text
from bowlrec.batch import JobSpec, run_job
from bowlrec.errors import RunDamagedError

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

BASE: dict[str, Any] = {
    "name": "base",
    "ball": {"mass_kg": 6.8, "rg_m": [0.069, 0.071, 0.071], "axis_2": None},
    "lane": {"friction": {"kind": "grid", "mu": [0.04] * 12}},
    "delivery": {"speed_mps": 8.0, "omega_radps": [-16.0, 23.0, 7.0]},
}


def test_a_scene_is_its_base_with_its_columns_or_stored_whole() -> None:
    """Column values replace the base's at their paths (NaN: the base's), in the base's key
    order and number texts; a scene stored whole reads back as its bytes."""
    base_json = pydantic_core.to_json(BASE)
    text = scene_text(
        base_json,
        [["delivery", "speed_mps"], ["delivery", "omega_radps", 2]],
        [7.25, float("nan")],
        b"",
    )
    doc = json.loads(text)
    assert (doc["delivery"]["speed_mps"], doc["delivery"]["omega_radps"][2]) == (7.25, 7.0)
    assert list(doc) == list(BASE) and text == pydantic_core.to_json(doc).decode()
    whole = '{"name":"other \u2713","delivery":{"speed_mps":8}}'.encode()
    assert scene_text(base_json, [["delivery", "speed_mps"]], [float("nan")], whole) == (
        whole.decode()
    )
    with pytest.raises(KeyError):
        apply(copy.deepcopy(BASE), ["delivery", "nothing", 1], 1.0)


def test_a_builders_segment_stores_only_scenes_that_differ() -> None:
    """The first run's scene is the base; a run with the same scene stores nothing of it, any
    other its scene whole; every scene reads back as the text it was stored from."""
    from bowlrec.archive.segment import scene_columns

    texts = [pydantic_core.to_json(BASE)]
    other = copy.deepcopy(BASE)
    other["delivery"]["speed_mps"] = 8  # an int where the base has a float: another text
    texts += [texts[0], pydantic_core.to_json(other)]
    cols = scene_columns(texts)
    offsets = cols["override_offsets"].tolist()
    assert offsets[:3] == [0, 0, 0] and offsets[3] == len(texts[2])
    for i, raw in enumerate(texts):
        whole = cols["override_json"][offsets[i] : offsets[i + 1]].tobytes()
        assert scene_text(cols["base_json"].tobytes(), [], [], whole) == raw.decode()


def _sweep_job(n: int) -> JobSpec:
    return JobSpec.model_validate(
        {
            "base": json.loads((EXAMPLES / "paper" / "case16.json").read_text())
            | {"options": {"record": "summary", "rtol": 2e-4}},
            "sweep": {
                "kind": "random",
                "n": n,
                "seed": 5,
                "axes": {"delivery.speed_mps": {"low": 7.0, "high": 9.0}},
            },
            "record": "summary",
        }
    )


def test_damage_is_found_per_block_and_other_blocks_read(tmp_path: Path) -> None:
    """A summary job's segment: 600 runs in 3 digest blocks of 256. A changed value in run 300
    damages its block (runs 256-511), named on load and by repair; the other blocks read."""
    archive = Archive(tmp_path / "a")
    assert run_job(_sweep_job(600), archive, workers=0, chunk_size=600).error is None
    (path,) = archive.segments_dir.glob("*.h5")
    with SegmentFile(path) as seg:
        assert (seg.format_version, seg.block_runs, seg.n_runs) == ("2.3", 256, 600)
        ids = seg.run_ids()
        assert seg.verify() == (list(range(600)), {})
        scene = json.loads(seg.read_run(300).scene_json)
    with h5py.File(path, "r") as f:
        assert f["digest/blocks"].shape == (3,)
        assert f["scene/override_values"].shape == (600, 1)
        assert f["scene/override_json"].shape == (0,)
        speed = float(f["scene/override_values"][300, 0])
    assert scene["delivery"]["speed_mps"] == speed
    archive.close()
    with h5py.File(path, "r+") as f:
        f["summary/hook_m"][300] += 1e-9
    archive = Archive(tmp_path / "a")
    archive.load(ids[10])
    archive.load(ids[599])
    for row in (256, 300, 511):
        with pytest.raises(RunDamagedError, match="digest mismatch"):
            archive.load(ids[row])
    with SegmentFile(path) as seg:
        healthy, damaged = seg.verify()
    assert healthy == [*range(256), *range(512, 600)]
    assert sorted(damaged) == list(range(256, 512))
    report = archive.repair()
    assert len(report["damaged_runs"]) == 256
    assert len(archive) == 600 - 256
    archive.load(ids[10])


def test_a_scene_changed_in_place_fails_the_digest(tmp_path: Path) -> None:
    """The base scene and the overrides are in every block's digest."""
    archive = Archive(tmp_path / "a")
    assert run_job(_sweep_job(20), archive, workers=0, chunk_size=20).error is None
    (path,) = archive.segments_dir.glob("*.h5")
    with SegmentFile(path) as seg:
        first = seg.run_ids()[0]
    archive.close()
    for dataset, index in (("scene/base_json", 10), ("scene/override_values", (3, 0))):
        with h5py.File(path, "r+") as f:
            original = f[dataset][index]
            f[dataset][index] = original + 1
        with SegmentFile(path) as seg:
            _, damaged = seg.verify()
            assert sorted(damaged) == list(range(20)), dataset
            with pytest.raises(RunDamagedError):
                seg.read_run(0)
        with h5py.File(path, "r+") as f:
            f[dataset][index] = original
    assert Archive(tmp_path / "a").load(first).run_id == first
    assert np.isfinite(Archive(tmp_path / "a").load(first).trajectory.summary.hook_m or 0.0)

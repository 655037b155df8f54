"""Scene files: JSON and YAML load into validated scenes (through the one way in,
:mod:`bowlrec.scene_input`, over the spec's file reader) and round-trip."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from bowlrec.errors import SceneInputError
from bowlrec.scene_input import parse_scene_file
from bowlrec.spec import (
    Ball,
    Delivery,
    Lane,
    Options,
    Scene,
    Zone,
    ZoneFriction,
    dump_scene_json,
)
from bowlrec.spec.loading import read_mapping


def load_scene(path: Path | str) -> Scene:
    """The physical scene of a scene file, as bowlrec.simulate and the CLI read it."""
    return parse_scene_file(path).scene


def _rich_scene() -> Scene:
    return Scene(
        name="rich",
        description="zones, quaternion, offset",
        ball=Ball(
            mass_kg=7.0,
            rg_m=(0.06, 0.063, 0.066),
            orientation_wxyz=(0.9, 0.1, -0.2, 0.3),
            com_offset_m=(0.0005, -0.0002, 0.0001),
        ),
        lane=Lane(
            friction=ZoneFriction(
                default_mu=0.2,
                zones=[Zone(x_min_m=0.0, x_max_m=12.0, y_min_m=0.1, y_max_m=0.9, mu=0.04)],
            )
        ),
        delivery=Delivery(position_m=(0.1, 0.3), takeoff_angle_deg=2.5, omega_radps=(-20, 15, 3)),
        options=Options(record="rate", record_dt_s=0.005, rtol=1e-8),
    )


def test_json_round_trip(tmp_path: Path) -> None:
    scene = _rich_scene()
    path = tmp_path / "scene.json"
    path.write_text(dump_scene_json(scene))
    assert load_scene(path) == scene
    assert load_scene(str(path)) == scene


@pytest.mark.parametrize("suffix", [".yaml", ".yml", ".YAML"])
def test_yaml_round_trip(tmp_path: Path, suffix: str) -> None:
    scene = _rich_scene()
    path = tmp_path / f"scene{suffix}"
    path.write_text(yaml.safe_dump(scene.model_dump(mode="json")))
    assert load_scene(path) == scene


def test_hand_written_yaml(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(
        "name: hand\n"
        "ball: {rg_m: [0.062, 0.064, 0.064], axis_1: [-0.57, 0.82, 0]}\n"
        "lane:\n  friction: {kind: constant, mu: 0.12}\n"
        "options: {rtol: 1e-10}\n"  # YAML 1.1 reads 1e-10 as a string; it is coerced
    )
    scene = load_scene(path)
    assert scene.options.rtol == 1e-10
    assert scene.lane.friction.kind == "constant"
    assert scene.resolve().constant_friction


def test_invalid_file_names_the_file_and_the_field(tmp_path: Path) -> None:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"ball": {"mass_kg": -1}}))
    with pytest.raises(SceneInputError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: ball.mass_kg: Input should be greater than 0 (got -1)"


def test_the_reader_parses_without_validating(tmp_path: Path) -> None:
    path = tmp_path / "any.yaml"
    path.write_text("ball: {mass_kg: -1}\nnot_a_field: 1\n")
    assert read_mapping(path) == {"ball": {"mass_kg": -1}, "not_a_field": 1}


def test_unsupported_suffix(tmp_path: Path) -> None:
    path = tmp_path / "scene.toml"
    path.write_text("")
    with pytest.raises(ValueError, match="unsupported scene file type"):
        load_scene(path)
    with pytest.raises(SceneInputError, match=r"scene\.toml: unsupported scene file type"):
        load_scene(path)


def test_dict_validation_equals_constructor() -> None:
    scene = _rich_scene()
    assert Scene.model_validate(scene.model_dump()) == scene
    assert Scene.model_validate(json.loads(scene.model_dump_json())) == scene


def test_dump_is_canonical() -> None:
    text = dump_scene_json(Scene())
    assert text.endswith("}\n") and not text.endswith("\n\n")
    assert list(json.loads(text)) == sorted(json.loads(text))


@pytest.mark.process  # a fresh interpreter's modules
def test_spec_does_not_import_numba() -> None:
    """The scene stack's bottom loads neither numba nor the layers above it, and PyYAML only
    for a YAML file."""
    code = (
        "import sys, bowlrec.spec, bowlrec.paper\n"
        "bowlrec.spec.Scene().resolve()\n"
        "assert 'numba' not in sys.modules, 'numba imported'\n"
        "above = ('yaml', 'bowlrec.bowling', 'bowlrec.scene_input')\n"
        "assert not [m for m in above if m in sys.modules], sorted(sys.modules)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)

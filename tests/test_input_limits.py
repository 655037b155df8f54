"""Bounded work and finite answers: the physical limits of a scene, the samples per run, the runs
per job, and user errors as one line naming the file, the line or the field (exit 2).

The inputs: a tiny ``record_dt_s``, spins and speeds of 1e300, a grid of 1e8 points, an LHS too
big for memory, YAML syntax errors, aliases, tags and deep nesting, a bowler scene with no spin,
and sweep sizes that would otherwise give a screen of union errors.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, get_args

import numpy as np
import pytest
from helpers.scene_builders import recorded_speed_job
from pydantic import ValidationError
from typer.testing import CliRunner

import bowlrec
from bowlrec.batch.job import MAX_HYPERCUBE_VALUES, MAX_JOB_RUNS, JobSpec, load_job
from bowlrec.bowling.ball import MAX_DIAMETER_IN, MAX_WEIGHT_LB
from bowlrec.bowling.delivery import MAX_REV_RATE_RPM, MAX_SPEED_MPH
from bowlrec.bowling.lane import MAX_LANE_FT
from bowlrec.cli import app
from bowlrec.core.plan import Plan
from bowlrec.errors import JobError, SceneInputError, SpecFileError
from bowlrec.paper import TABLE_III, Variant, paper_scene
from bowlrec.scene_input import parse_scene
from bowlrec.session.spec import load_session
from bowlrec.spec import Scene, format_validation_error
from bowlrec.spec import limits as L
from bowlrec.spec.loading import MAX_NESTING, read_mapping
from bowlrec.units import FT_M, IN_M, LB_KG, MPH_MPS, RPM_RADPS

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def _error(data: dict[str, Any]) -> str:
    with pytest.raises(SceneInputError) as info:
        parse_scene(data)
    return str(info.value)


# -- physical limits ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("data", "field", "bound"),
    [
        ({"delivery": {"omega_radps": [0, 1e300, 0]}}, "delivery.omega_radps[1]", "1000"),
        ({"delivery": {"omega_radps": [-1001, 0, 0]}}, "delivery.omega_radps[0]", "-1000"),
        ({"delivery": {"speed_mps": 1e300}}, "delivery.speed_mps", "100"),
        ({"ball": {"mass_kg": 101}}, "ball.mass_kg", "100"),
        ({"ball": {"radius_m": 1.5}}, "ball.radius_m", "1"),
        ({"lane": {"length_m": 1e5}}, "lane.length_m", "10000"),
        ({"lane": {"width_m": 1e5}}, "lane.width_m", "10000"),
        ({"lane": {"friction": {"kind": "constant", "mu": 11}}}, "lane.friction.constant.mu", "10"),
        ({"lane": {"friction": {"kind": "typical", "mu_dry": 1e9}}}, "mu_dry", "10"),
        ({"options": {"g_mps2": 1e4}}, "options.g_mps2", "100"),
        ({"options": {"max_time_s": 1e6}}, "options.max_time_s", "10000"),
        ({"options": {"slip_threshold_mps": 1e3}}, "options.slip_threshold_mps", "100"),
    ],
)
def test_values_beyond_a_physical_limit_are_refused_by_name(
    data: dict[str, Any], field: str, bound: str
) -> None:
    message = _error(data)
    assert field in message and bound in message, message
    assert len(message.splitlines()) == 1, message


def test_too_many_friction_zones_are_refused() -> None:
    zone = {"x_min_m": 0, "x_max_m": 1, "y_min_m": 0, "y_max_m": 1, "mu": 0.1}
    friction = {"kind": "zones", "default_mu": 0.2, "zones": [zone] * (L.MAX_ZONES + 1)}
    message = _error({"lane": {"friction": friction}})
    assert "zones" in message and str(L.MAX_ZONES) in message


def test_limits_are_in_the_json_schemas() -> None:
    scene = json.loads((ROOT / "schemas" / "scene.schema.json").read_text())
    delivery = scene["$defs"]["Delivery"]["properties"]
    assert delivery["speed_mps"]["maximum"] == L.MAX_SPEED_MPS
    assert all(
        item["maximum"] == L.MAX_OMEGA_RADPS for item in delivery["omega_radps"]["prefixItems"]
    )
    ball = scene["$defs"]["Ball"]["properties"]
    assert ball["mass_kg"]["maximum"] == L.MAX_MASS_KG
    assert ball["radius_m"]["maximum"] == L.MAX_RADIUS_M
    options = scene["$defs"]["Options"]["properties"]
    assert options["max_time_s"]["maximum"] == L.MAX_TIME_S
    assert options["g_mps2"]["maximum"] == L.MAX_G_MPS2
    assert f"{L.MAX_SAMPLES_PER_RUN:,} samples per run" in options["record_dt_s"]["description"]
    defs = scene["$defs"]
    assert defs["ZoneFriction"]["properties"]["zones"]["maxItems"] == L.MAX_ZONES
    for axis in ("x_edges_m", "y_edges_m"):
        assert defs["GridFriction"]["properties"][axis]["maxItems"] == L.MAX_GRID_EDGES
    for lane in ("length_m", "width_m"):
        assert defs["Lane"]["properties"][lane]["maximum"] == L.MAX_LANE_M
    assert defs["ConstantFriction"]["properties"]["mu"]["maximum"] == L.MAX_MU
    for mu in ("mu_oil", "mu_dry"):
        assert defs["TypicalFriction"]["properties"][mu]["maximum"] == L.MAX_MU
    assert defs["Zone"]["properties"]["mu"]["maximum"] == L.MAX_MU
    job = json.loads((ROOT / "schemas" / "job.schema.json").read_text())
    assert job["$defs"]["RandomSweep"]["properties"]["n"]["maximum"] == MAX_JOB_RUNS


def test_bowler_limits_stay_inside_the_physical_ones() -> None:
    """The bowlers' limits are round numbers that convert to values within the physical
    limits, so a bowler scene within its own limits never fails on a physical one."""
    assert MAX_SPEED_MPH * MPH_MPS <= L.MAX_SPEED_MPS
    assert MAX_REV_RATE_RPM * RPM_RADPS <= L.MAX_OMEGA_RADPS  # |omega| bounds every component
    assert MAX_WEIGHT_LB * LB_KG <= L.MAX_MASS_KG
    assert MAX_DIAMETER_IN * IN_M / 2 <= L.MAX_RADIUS_M
    assert MAX_LANE_FT * FT_M <= L.MAX_LANE_M


def test_the_step_limit_equals_the_samples_limit() -> None:
    """``record: steps`` keeps one sample per step, so the integrator's step limit bounds it by
    the same number as ``record: rate``."""
    assert Plan.__dataclass_fields__["max_steps"].default == L.MAX_SAMPLES_PER_RUN


def test_every_example_scene_and_table_iii_case_stays_valid() -> None:
    files = sorted((ROOT / "examples").rglob("*.json")) + sorted(
        (ROOT / "examples").rglob("*.yaml")
    )
    scenes = [p for p in files if "jobs" not in p.parts]
    assert len(scenes) >= 18
    for path in scenes:
        data = read_mapping(path)
        if isinstance(data, dict) and data.get("format") == "bowlrec-session":
            load_session(path)
        elif isinstance(data, dict) and data.get("format") == "bowlrec-carry":
            from bowlrec.pins.carry_job import load_carry_job

            load_carry_job(path)
        elif isinstance(data, dict) and data.get("format") != "bowlrec-job":
            parse_scene(data)
    for case in range(1, len(TABLE_III) + 1):
        for variant in get_args(Variant):
            Scene.model_validate(paper_scene(case, variant).model_dump())
    for path in sorted((ROOT / "examples" / "jobs").glob("*")) + sorted(
        (ROOT / "benchmarks" / "jobs").glob("*.json")
    ):
        load_job(path)


@pytest.mark.parametrize("record", ["summary", "steps", "rate"])
def test_a_delivery_at_the_limits_gives_finite_values(record: str) -> None:
    """The fastest, hardest-spinning delivery the limits allow: every summary value and
    every sample finite (NaN only where a metric does not apply: it is null in JSON)."""
    tr = bowlrec.simulate(
        Scene.model_validate(
            {
                "delivery": {
                    "speed_mps": L.MAX_SPEED_MPS,
                    "omega_radps": [-L.MAX_OMEGA_RADPS, L.MAX_OMEGA_RADPS, L.MAX_OMEGA_RADPS],
                    "takeoff_angle_deg": 0.5,
                },
                "options": {"record": record, "record_dt_s": 1e-4},
            }
        )
    )
    summary = tr.summary
    for name in ("time_s", "x_end_m", "y_end_m", "speed_end_mps", "rev_rate_end_rpm"):
        assert math.isfinite(getattr(summary, name)), name
    if record != "summary":
        for name in ("position_m", "velocity_mps", "omega_radps", "quaternion_wxyz"):
            assert np.isfinite(getattr(tr, name)).all(), name
    text = json.dumps(summary.to_dict() if hasattr(summary, "to_dict") else vars(summary))
    json.loads(text, parse_constant=lambda c: pytest.fail(f"non-finite {c} in {text}"))


# -- samples per run ------------------------------------------------------------------------


@pytest.mark.parametrize("dt", [1e-300, 1e-8, 1e-6])
def test_a_tiny_record_interval_is_refused_before_any_work(dt: float) -> None:
    message = _error({"options": {"record": "rate", "record_dt_s": dt}})
    assert "record_dt_s" in message and "2,000,000 samples per run" in message, message
    assert "3e-05" in message  # the smallest interval allowed at max_time_s = 60 s


def test_the_largest_allowed_recording_is_accepted() -> None:
    parse_scene({"options": {"record": "rate", "record_dt_s": 3e-5, "max_time_s": 60}})
    parse_scene({"options": {"record": "summary", "record_dt_s": 1e-300}})  # not recorded


# -- runs per job ---------------------------------------------------------------------------


def _job_error(doc: dict[str, Any]) -> str:
    with pytest.raises(ValidationError) as info:
        JobSpec.model_validate(doc)
    return format_validation_error(info.value)


def test_a_grid_beyond_the_runs_per_job_is_refused_without_expanding_it() -> None:
    axis = {"start": 0.0, "stop": 1.0, "num": 100_000}
    doc = {
        "sweep": {
            "kind": "grid",
            "axes": {"delivery.speed_mps": axis, "delivery.takeoff_angle_deg": axis},
        }
    }
    message = _job_error(doc)
    assert message == (
        "sweep: 10,000,000,000 runs (grid 100,000 x 100,000); at most 10,000,000 runs per job: "
        "use fewer points, or split the sweep into several jobs"
    )


def test_blocks_add_up_to_the_runs_per_job() -> None:
    block = {"kind": "random", "n": MAX_JOB_RUNS, "seed": 0, "axes": {"a": {"low": 0, "high": 1}}}
    JobSpec.model_validate({"sweep": [block]})
    message = _job_error({"sweep": [block, {**block, "n": 1}]})
    assert message.startswith("sweep: 10,000,001 runs (random 10,000,000, random 1)")


def test_a_random_sweep_over_the_limit_gives_one_line() -> None:
    doc = {"sweep": {"kind": "random", "n": 10**8, "seed": 1, "axes": {"a": {"low": 0, "high": 1}}}}
    assert _job_error(doc) == (
        "sweep.random.n: Input should be less than or equal to 10000000 (got 100000000)"
    )


def test_a_latin_hypercube_is_bounded_by_its_values_in_memory() -> None:
    axes = {f"delivery.omega_radps[{i}]": {"low": 0, "high": 1} for i in range(3)}
    n = MAX_HYPERCUBE_VALUES // 3 + 1
    message = _job_error({"sweep": {"kind": "lhs", "n": n, "seed": 0, "axes": axes}})
    assert "sweep.lhs" in message and "20,000,000 values" in message and "6,666,666" in message


@pytest.mark.parametrize(
    ("doc", "expected"),
    [
        ({"base": 5}, "base: Input should be a valid string, or a valid dictionary (got 5)"),
        ({"sweep": {"kind": "nope"}}, "sweep: Input tag 'nope' found using 'kind'"),
        (
            {"sweep": {"kind": "grid", "axes": {"a": {"start": 0, "stop": 1, "num": 0}}}},
            "sweep.grid.axes.a.num: Input should be greater than or equal to 1 (got 0)",
        ),
    ],
)
def test_union_errors_are_one_line_for_the_member_that_fits(
    doc: dict[str, Any], expected: str
) -> None:
    message = _job_error(doc)
    assert message.startswith(expected) and "\n" not in message, message
    assert "tagged-union" not in message and "list[" not in message


# -- files: one line naming the file and where ----------------------------------------------

_BAD_FILES = {
    "syntax.yaml": ("delivery:\n  speed_mps: [1,\n", "line 3, column 1"),
    "alias.yaml": (
        "a: &a [1, 2, 3]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]\nc: [*b, *b, *b, *b]\n",
        "YAML aliases (*a) are not supported",
    ),
    "tag.yaml": ("!!python/object/apply:os.system ['echo pwned']\n", "could not determine"),
    "deep.json": ("[" * 5000 + "]" * 5000, f"nested deeper than {MAX_NESTING} levels"),
    "deep.yaml": ("[" * 5000 + "]" * 5000, f"nested deeper than {MAX_NESTING} levels"),
    "syntax.json": ('{"delivery": {"speed_mps": 8,}}', "not valid JSON: line 1, column 30"),
    "latin1.json": (b'{"name": "caf\xe9"}', "not UTF-8 text"),
}


@pytest.mark.parametrize("name", sorted(_BAD_FILES))
def test_read_mapping_names_what_and_where(tmp_path: Path, name: str) -> None:
    text, expected = _BAD_FILES[name]
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(SpecFileError, match=None) as info:
        read_mapping(path)
    assert expected in str(info.value), str(info.value)


@pytest.mark.parametrize("name", sorted(_BAD_FILES))
@pytest.mark.parametrize(
    "command",
    [["validate"], ["simulate", "--no-archive"], ["plot"], ["batch", "--no-archive"]],
    ids=["validate", "simulate", "plot", "batch"],
)
def test_every_command_reports_a_bad_file_in_one_line(
    tmp_path: Path, name: str, command: list[str]
) -> None:
    text, expected = _BAD_FILES[name]
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    args = [command[0], str(path), *command[1:]]
    if command[0] == "plot":
        args += ["--out", str(tmp_path / "p.png")]
    if command[0] == "batch":
        args += ["--out", str(tmp_path / "t.csv")]
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert "Traceback" not in result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {path}: "), result.output
    assert expected in lines[0]


def test_balls_add_reads_files_with_the_same_reader(tmp_path: Path) -> None:
    path = tmp_path / "ball.yaml"
    path.write_text(_BAD_FILES["alias.yaml"][0])
    result = runner.invoke(app, ["balls", "add", "x", str(path), "-a", str(tmp_path / "a")])
    assert result.exit_code == 2
    assert result.output.strip() == (
        f"error: {path}: not valid YAML: line 2, column 8: YAML aliases (*a) are not "
        "supported; write the value out"
    )


def test_a_job_file_error_is_one_line_per_field(tmp_path: Path) -> None:
    path = tmp_path / "job.json"
    path.write_text(
        json.dumps(
            {
                "sweep": {
                    "kind": "random",
                    "n": 10**8,
                    "seed": -1,
                    "axes": {"a": {"low": 0, "high": 1}},
                }
            }
        )
    )
    with pytest.raises(JobError) as info:
        load_job(path)
    lines = str(info.value).splitlines()
    assert lines == [
        f"{path}: sweep.random.n: Input should be less than or equal to 10000000 (got 100000000)",
        f"{path}: sweep.random.seed: Input should be greater than or equal to 0 (got -1)",
    ]


# -- the bowlers' layer ---------------------------------------------------------------------


def test_a_bowler_scene_without_spin_names_the_field(tmp_path: Path) -> None:
    path = tmp_path / "b.yaml"
    path.write_text("format: bowler\ndelivery: {rev_rate_rpm: 0}\n")
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 2
    assert result.output.startswith(f"error: {path}: delivery: rev_rate_rpm = 0.0: a bowler scene")
    assert "undefined" not in result.output


@pytest.mark.parametrize(
    ("delivery", "field"),
    [
        ({"speed_mph": 1e300}, "delivery.speed_mph"),
        ({"rev_rate_rpm": 1e300}, "delivery.rev_rate_rpm"),
    ],
)
def test_bowler_values_beyond_the_limits_name_the_bowler_field(
    delivery: dict[str, Any], field: str
) -> None:
    message = _error({"format": "bowler", "delivery": delivery, "allow_illegal": True})
    assert message.startswith(field), message


def test_a_bowler_scene_whose_physical_scene_is_invalid_says_so() -> None:
    """Valid bowler fields can still give an invalid physical value (here a coverstock factor
    pushes the dry friction past 10): the message says it comes from the conversion."""
    ball = {"name": "x", "weight_lb": 15, "rg_in": 2.5, "differential_in": 0.03}
    data = {
        "format": "bowler",
        "ball": {**ball, "coverstock": "urethane", "surface": 1000},
        "oil_friction": {"mu_dry": 10, "dry_factor": {"urethane": 5}},
    }
    message = _error(data)
    assert message.startswith("scene: the physical scene of this bowler scene: mu["), message
    assert "less than or equal to 10 (got 50.0)" in message


def test_a_stopped_ten_million_run_job_ends_its_table_at_the_last_run_reached() -> None:
    """Cancelled after its first chunk, a 10,000,000-run job returns with a table that ends
    at the last run reached; the runs after it are counted, not written as rows."""
    import threading

    from bowlrec.batch import run_job

    job = JobSpec.model_validate(
        {
            "base": {"options": {"record": "summary", "rtol": 2e-4}},
            "sweep": {
                "kind": "random",
                "n": MAX_JOB_RUNS,
                "seed": 3,
                "axes": {"delivery.speed_mps": {"low": 7, "high": 9}},
            },
        }
    )
    cancel = threading.Event()

    def progress(p: Any) -> None:
        if p.done > 0:
            cancel.set()

    result = run_job(job, None, workers=0, progress=progress, cancel=cancel, chunk_size=512)
    assert result.cancelled
    assert 0 < result.n_rows < 10_000
    assert result.n_rows + result.not_reached == MAX_JOB_RUNS
    assert result.counts["ok"] == result.n_rows - result.counts["cancelled"]


# -- messages that stay readable ------------------------------------------------------------


def test_long_values_are_cut_and_control_characters_escaped() -> None:
    message = _error({"ball": {"mass_kg": "x" * 100_000}})
    assert len(message) < 300 and "(100,000 characters)" in message, message
    message = _error({"lane": {"friction": {"kind": "a\nb\x00c \u202eevil"}}})
    assert "\n" not in message and "\\x00" in message and "\\u202e" in message, message


def test_a_wrong_or_missing_format_is_one_line() -> None:
    bowler = json.loads((ROOT / "examples/bowler/house-shot-right.json").read_text())
    message = _error({**bowler, "format": 0})
    assert message == (
        "format: Input should be 'bowler' (a bowler-language scene), or left out (a physical "
        "scene) (got 0)"
    )
    del bowler["format"]
    message = _error(bowler)
    assert message.startswith("format: missing; ") and message.endswith('add "format": "bowler"')
    assert "\n" not in message


def test_several_unknown_fields_of_one_mapping_are_one_line() -> None:
    message = _error({"ball": {"weight_lb": 15, "rg_in": 2.5}, "delivery": {"speed_mph": 17}})
    assert message.splitlines() == [
        "ball: Extra inputs are not permitted: weight_lb, rg_in (did you mean 'rg_m'?)",
        "delivery.speed_mph: Extra inputs are not permitted (got 17); did you mean 'speed_mps'?",
    ]


def test_a_huge_axis_component_is_a_direction_like_any_other() -> None:
    """Directions are normalized without squaring components near the float64 range, so
    (1e300, 0, 1e300) is the same axis as (1, 0, 1); a 1e-300 axis is too short to have one."""
    big = parse_scene({"ball": {"axis_1": [1e300, 0, 1e300]}}).scene.resolve()
    unit = parse_scene({"ball": {"axis_1": [1, 0, 1]}}).scene.resolve()
    np.testing.assert_allclose(big.q0, unit.q0, rtol=0, atol=1e-15)
    assert "has length 1e-300" in _error({"ball": {"axis_1": [1e-300, 0, 0]}})


def test_a_chunk_of_recorded_runs_seals_as_its_samples_add_up(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A worker seals what it holds every SEAL_SAMPLES samples, so a chunk of recorded runs
    (each up to 2,000,000 samples) never holds more than that plus one run: here a chunk of 8
    runs of ~500 samples with a 1,200-sample budget becomes several segments, and every run is
    archived and reads back whole."""
    from bowlrec.archive import Archive
    from bowlrec.batch import chunks, run_job

    monkeypatch.setattr(chunks, "SEAL_SAMPLES", 1200)
    job = JobSpec.model_validate(recorded_speed_job(8, 0.005))
    archive = Archive(tmp_path / "a")
    result = run_job(job, archive, workers=0, chunk_size=8)
    assert result.counts["ok"] == 8
    ids = [rid for t in result.tables for rid in t.run_id]
    assert {r["run_id"] for r in archive.list_runs()} == set(ids)
    assert len(list(archive.segments_dir.glob("*.h5"))) >= 3
    for rid in ids:
        traj = archive.load(rid).trajectory
        assert traj.t_s.size > 400 and np.isfinite(traj.position_m).all()


def test_keys_the_user_wrote_stay_in_the_location() -> None:
    """Only Pydantic's own union-member names leave the location: a sweep axis that looks like
    an indexed path, or an unknown field with a capital letter, is kept, and no error is lost."""
    axes = {"delivery.speed_mps": {"start": 1, "stop": 2, "num": 0}, "delivery.omega_radps[1]": "x"}
    message = _job_error({"sweep": {"kind": "grid", "axes": axes}})
    assert message.splitlines() == [
        "sweep.grid.axes.delivery.speed_mps.num: Input should be greater than or equal to 1 "
        "(got 0)",
        "sweep.grid.axes.delivery.omega_radps[1]: Input should be a valid list, or a valid "
        "dictionary or instance of Linspace (got 'x')",
    ]
    assert _error({"ball": {"Mass": 1}}) == (
        "ball.Mass: Extra inputs are not permitted (got 1); did you mean 'mass_kg'?"
    )
    assert _error({"ball": {"Mass": 1, "Radius": 2}}) == (
        "ball: Extra inputs are not permitted: Mass (did you mean 'mass_kg'?), Radius (did you "
        "mean 'radius_m'?)"
    )

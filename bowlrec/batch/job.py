"""A job's scenes read, checked as a whole and prepared run by run.

:func:`job_context` checks a job (:class:`~bowlrec.batch.job_spec.JobSpec`) as a whole before
anything runs: its base scene, read and validated through the one way in for a scene
(:mod:`bowlrec.scene_input`, whose field-named lines a :class:`~bowlrec.errors.JobError`
carries, prefixed with ``base:`` and the file's path for a file), every swept path, every
value on its own, and the library balls it names. :func:`prepare_point` turns one point of the
job into a validated, resolved and hashed run (the general path;
:class:`~bowlrec.batch.fastprep.FastSweep` is the fast one): a listed scene (a ``scenes``
block) is read and validated there, so an invalid one is a failed run whose error carries the
same lines (``invalid scene: delivery.speed_mps: ...``), not a job error.

The job's models (sweep blocks, :class:`~bowlrec.batch.job_spec.JobSpec`, :func:`load_job`)
live in :mod:`bowlrec.batch.job_spec` and are importable from here too.
"""

from __future__ import annotations

import copy
import json
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ValidationError

from bowlrec.archive import run_id
from bowlrec.batch.context import JobContext
from bowlrec.batch.fastprep import FastSweep
from bowlrec.batch.job_spec import (
    JOB_FORMAT,
    MAX_HYPERCUBE_VALUES,
    MAX_JOB_RUNS,
    GridSweep,
    JobSpec,
    LatinHypercubeSweep,
    Linspace,
    Point,
    PointsSweep,
    RandomSweep,
    Range,
    ScenesSweep,
    Sweep,
    ZipSweep,
    axis_values,
    job_schema_text,
    latin_hypercube,
    load_job,
)
from bowlrec.batch.paths import apply_override, parse_path
from bowlrec.bowling.scene import BowlerScene
from bowlrec.errors import JobError, SceneInputError
from bowlrec.scene_input import (
    check_scene_input,
    is_bowler,
    parse_scene,
    prefix_lines,
    read_scene_mapping,
    with_library_ball,
)
from bowlrec.scene_input import library_lookup as scene_lookup
from bowlrec.spec import Scene

if TYPE_CHECKING:
    from bowlrec.archive import BallLibrary
    from bowlrec.core.plan import Plan
    from bowlrec.scene_input import BallLookup


__all__ = [
    "JOB_FORMAT",
    "MAX_HYPERCUBE_VALUES",
    "MAX_JOB_RUNS",
    "GridSweep",
    "JobError",
    "JobSpec",
    "LatinHypercubeSweep",
    "Linspace",
    "Point",
    "PointsSweep",
    "PreparedRun",
    "RandomSweep",
    "Range",
    "ScenesSweep",
    "Sweep",
    "ZipSweep",
    "freeze_balls",
    "job_context",
    "job_schema_text",
    "job_unit_warnings",
    "latin_hypercube",
    "library_lookup",
    "load_job",
    "point_data",
    "prepare_one",
    "prepare_point",
    "prepare_runs",
]


def library_lookup(balls: BallLibrary | None) -> BallLookup:
    """A :data:`~bowlrec.scene_input.BallLookup` over an archive's ball library that raises
    JobError (a job naming a ball that does not exist is wrong as a whole)."""

    inner = scene_lookup(balls)

    def lookup(ref: str) -> tuple[dict[str, Any], str]:
        try:
            return inner(ref)
        except SceneInputError as err:
            raise JobError(str(err).removeprefix("ball: ")) from err

    return lookup


@dataclass(frozen=True)
class PreparedRun:
    """One run ready to simulate, or its failure before simulation.

    params: the table's parameter columns (the overrides; ``scene`` for a ``scenes`` block);
    scene/plan/run_id: the validated physical scene, its resolved Plan and content ID (None when
    ``error`` says why the combination is invalid); ball_ref: the library ball used, if any.
    """

    index: int
    params: dict[str, Any]
    scene: Scene | None = None
    plan: Plan | None = None
    run_id: str | None = None
    ball_ref: str | None = None
    error: str | None = None


@dataclass(frozen=True)
class _Base:
    bowler: bool
    data: dict[str, Any]
    ball_ref: str | None


def _model(bowler: bool) -> type[BaseModel]:
    if bowler:
        return BowlerScene

    return Scene


def _read_scene_mapping(entry: str | dict[str, Any], base_dir: Path, what: str) -> dict[str, Any]:
    """A listed scene as a mapping of its own (an inline one copied, a file read through the
    intake); JobError naming ``what`` and the file when the file cannot be read."""
    if isinstance(entry, dict):
        return copy.deepcopy(entry)
    try:
        return read_scene_mapping(base_dir / entry)
    except SceneInputError as err:
        raise JobError(prefix_lines(what, str(err))) from None


def _no_library_ball(ref: str) -> tuple[dict[str, Any], str]:
    """The base scene's lookup: a job names its library ball in its own ``ball`` field."""
    raise SceneInputError(
        f"ball: {ref!r}: a job names its library ball in its own 'ball' field, not in the base "
        "scene"
    )


def _base(job: JobSpec, base_dir: Path, lookup: BallLookup) -> _Base:
    """The base scene read and validated through the intake (default: ``Scene()``), as every
    field's JSON value; JobError with the intake's lines prefixed ``base:``."""
    try:
        checked = check_scene_input(
            {} if job.base is None else job.base, _no_library_ball, base_dir=base_dir
        )
    except SceneInputError as err:
        raise JobError(prefix_lines("base", str(err))) from None
    data = checked.model.model_dump(mode="json")
    ref = None
    if job.ball is not None:
        data, ref = _library_ball({**data, "ball": job.ball}, lookup)
    return _Base(checked.is_bowler, data, ref)


def _own_errors(err: ValidationError, path: str) -> list[str]:
    """The lines of the message that concern ``path`` itself (or a field below it)."""
    from bowlrec.spec.errors import format_errors

    keys = parse_path(path)
    own = [e for e in err.errors(include_url=False) if _within(tuple(e["loc"]), keys)]
    return format_errors(own).splitlines() if own else []


def _within(loc: tuple[Any, ...], keys: tuple[Any, ...]) -> bool:
    """Whether an error at ``loc`` concerns the field at ``keys`` or one below it. Pydantic puts
    a tagged union's tag into the location (``lane.friction.typical.mu_oil`` for the path
    ``lane.friction.mu_oil``), so one element between two of the path's is passed over."""
    i = 0
    for k, key in enumerate(keys):
        skipped = 0
        while i < len(loc) and loc[i] != key:
            i, skipped = i + 1, skipped + 1
        if i == len(loc) or (skipped and k == 0) or skipped > 1:
            return False
        i += 1
    return True


def _check_values(job: JobSpec, base: _Base, lookup: BallLookup) -> None:
    """Each axis value applied alone to the base: bad paths, and values invalid by themselves
    (not merely in combination with other fields) raise JobError naming the path."""
    model = _model(base.bowler)
    for b, block in enumerate(job.blocks()):
        if isinstance(block, ScenesSweep):
            continue
        if isinstance(block, PointsSweep):
            checks = _point_checks(b, block)
        else:
            checks = []
            for path, axis in block.axes.items():
                values = [axis.low, axis.high] if isinstance(axis, Range) else axis_values(axis)
                checks += [(f"sweep[{b}].axes[{path!r}]", path, value) for value in values]
        scratches: dict[str, dict[str, Any]] = {}
        for where, path, value in checks:
            # one copy of the base per path: each value overwrites the one path it sets
            if path not in scratches:
                scratches[path] = copy.deepcopy(base.data)
            scratch = scratches[path]
            try:
                apply_override(scratch, path, value)
                data, _ = _library_ball(scratch, lookup)
            except JobError as err:
                raise JobError(f"{where}: {err}") from err
            try:
                model.model_validate(data)
            except ValidationError as err:
                own = _own_errors(err, path)
                if own:
                    raise JobError(
                        f"{where}: value {value!r} is invalid\n" + "\n".join(own)
                    ) from err


def _point_checks(b: int, block: PointsSweep) -> list[tuple[str, str, Any]]:
    """(where, path, value) of a points sweep's values to check on their own: per path, the
    smallest and largest number (as a range's ends: they cover the numbers between them) and
    every distinct other value, each named by the first point that holds it."""
    numbers: dict[str, list[tuple[float, int]]] = {}
    others: dict[tuple[str, str], tuple[int, Any]] = {}
    for i, point in enumerate(block.points_):
        for path, value in point.items():
            if isinstance(value, int | float) and not isinstance(value, bool):
                numbers.setdefault(path, []).append((value, i))
            else:
                key = (path, json.dumps(value, sort_keys=True, default=str))
                others.setdefault(key, (i, value))
    checks = [
        (f"sweep[{b}].points[{i}][{path!r}]", path, value)
        for path, found in numbers.items()
        for value, i in sorted({min(found), max(found)})
    ]
    checks += [
        (f"sweep[{b}].points[{i}][{path!r}]", path, value)
        for (path, _), (i, value) in others.items()
    ]
    return checks


def _library_ball(data: dict[str, Any], lookup: BallLookup) -> tuple[dict[str, Any], str | None]:
    """The mapping with a library reference at ``ball`` replaced by its spec (a physical ball
    in a physical scene, a spec sheet in a bowler scene) and the reference used."""

    try:
        return with_library_ball(data, lookup)
    except SceneInputError as err:
        raise JobError(str(err)) from err


def _set_record(data: dict[str, Any], record: str) -> None:
    options = data.setdefault("options", {})
    if record == "summary":
        options["record"] = "summary"
    elif record == "trajectory" and options.get("record", "steps") == "summary":
        options["record"] = "rate"


def prepare_one(
    index: int, params: dict[str, Any], bowler: bool, data: dict[str, Any], ref: str | None
) -> PreparedRun:
    """Validate, convert (bowler scenes: :func:`bowlrec.scene_input.parse_scene`), resolve and
    hash one scene mapping (its library ball already substituted)."""

    try:
        scene = parse_scene(data).scene
        plan = scene.resolve()
    except SceneInputError as err:
        return PreparedRun(index, params, error=f"invalid scene: {err}")
    except (ValueError, ArithmeticError) as err:
        return PreparedRun(index, params, error=f"{type(err).__name__}: {err}")
    return PreparedRun(index, params, scene, plan, run_id(plan), ref)


def _named_balls(job: JobSpec, base_dir: Path) -> set[str]:
    """Library references ("name" or "name@version") the job's points name at path ``ball``."""
    refs: set[str] = set()
    for block in job.blocks():
        if isinstance(block, GridSweep | ZipSweep):
            axis = block.axes.get("ball")
            if isinstance(axis, list):
                refs.update(v for v in axis if isinstance(v, str))
        elif isinstance(block, PointsSweep):
            refs.update(p["ball"] for p in block.points_ if isinstance(p.get("ball"), str))
        elif isinstance(block, ScenesSweep):
            for k, entry in enumerate(block.scenes):
                data = (  # an inline scene is only looked at: no copy
                    entry
                    if isinstance(entry, dict)
                    else _read_scene_mapping(entry, base_dir, f"sweep.scenes[{k}]")
                )
                if isinstance(data.get("ball"), str):
                    refs.add(data["ball"])
    return refs


def job_context(
    job: JobSpec,
    *,
    base_dir: str | Path = ".",
    balls: BallLibrary | None = None,
    ball_refs: Mapping[str, str] | None = None,
    replay_dir: str | Path | None = None,
) -> JobContext:
    """Check a job as a whole and package what workers need to prepare any of its runs.

    Raises JobError for a job that is wrong as a whole (base scene, paths, a value invalid on
    its own, an unknown library ball); nothing is expanded. ``balls``: the archive's ball
    library for ``name@version`` references; ``ball_refs``: ball-spec SHA-256 -> library
    reference, for runs whose ball equals a library spec."""

    root = Path(base_dir)
    lookup = library_lookup(balls)
    base = _base(job, root, lookup)
    _check_values(job, base, lookup)
    named = {ref: lookup(ref) for ref in sorted(_named_balls(job, root))}
    blocks = job.blocks()
    paths = [p for b in blocks if not isinstance(b, ScenesSweep | PointsSweep) for p in b.axes]
    has_lists = any(isinstance(b, ScenesSweep | PointsSweep) for b in blocks)
    numeric = all(
        isinstance(v, int | float) and not isinstance(v, bool)
        for b in blocks
        if isinstance(b, GridSweep | ZipSweep)
        for axis in b.axes.values()
        for v in axis_values(axis)
    )
    summary = job.record == "summary"
    pins = bool((base.data.get("options") or {}).get("pins")) or any(
        p == "options.pins" or p.startswith("options.pins.") for p in paths
    )
    fast = (
        tuple(dict.fromkeys(paths))
        if (summary or not job.formats)  # replay files are written from a Scene per run
        and numeric
        and not pins
        and FastSweep.applies(base.bowler, paths, has_lists)
        else None
    )
    data = copy.deepcopy(base.data)
    _set_record(data, job.record)
    return JobContext(
        key=uuid.uuid4().hex,
        job=job,
        base_bowler=base.bowler,
        base_data=data,
        base_ref=base.ball_ref,
        base_dir=str(root),
        balls=named,
        ball_refs=dict(ball_refs or {}),
        fast_paths=fast,
        replay_dir=None if replay_dir is None else str(replay_dir),
        formats=tuple(job.formats),
    )


def job_unit_warnings(job: JobSpec, *, base_dir: str | Path = ".") -> list[str]:
    """The base scene's values that look typed in another unit, and every listed or range-end
    value of a swept field that does (:mod:`bowlrec.spec.unit_sense`), each once, before the
    first run; none when the base scene silences them (``options.unit_warnings: false``) or
    cannot be read (the job's own check then says why)."""
    from bowlrec.spec.unit_sense import RULES, unit_warnings

    try:
        base = _base(job, Path(base_dir), _no_library_ball)
        model = _model(base.bowler).model_validate(base.data)
    except (JobError, ValidationError):
        return []
    options = getattr(model, "options", None)
    if options is None or not options.unit_warnings:
        return []
    out = [f"base: {line}" for line in unit_warnings(model)]
    rules = {r.path: r for r in RULES}
    for b, block in enumerate(job.blocks()):
        if isinstance(block, ScenesSweep | PointsSweep):
            continue
        for path, axis in block.axes.items():
            rule = rules.get(path.split("[")[0])
            if rule is None or rule.norm != path.endswith("]"):
                continue
            values = [axis.low, axis.high] if isinstance(axis, Range) else axis_values(axis)
            for value in values:
                if isinstance(value, int | float) and not isinstance(value, bool):
                    line = rule.check(abs(float(value)))
                    if line is not None:
                        out.append(
                            f"sweep[{b}].axes[{path!r}]: {line} (options.unit_warnings: false "
                            "in the base scene silences this)"
                        )
    return list(dict.fromkeys(out))


def freeze_balls(job: JobSpec, ctx: JobContext) -> JobSpec:
    """The job with every library reference it names pinned to the ``name@version`` its
    context resolved (a later version added to the library does not change the job)."""

    def pin(value: Any) -> Any:
        return ctx.balls[value][1] if isinstance(value, str) and value in ctx.balls else value

    if not ctx.balls and job.ball is None:  # nothing to pin
        return job
    data = job.model_dump(mode="json", by_alias=True)
    if job.ball is not None:
        data["ball"] = ctx.base_ref
    blocks = data["sweep"] if isinstance(data["sweep"], list) else [data["sweep"]]
    for block in blocks:
        if block is None:
            continue
        if block["kind"] in ("grid", "zip") and isinstance(block["axes"].get("ball"), list):
            block["axes"]["ball"] = [pin(v) for v in block["axes"]["ball"]]
        elif block["kind"] == "points":
            for point in block["points"]:
                if "ball" in point:
                    point["ball"] = pin(point["ball"])
        elif block["kind"] == "scenes":
            for entry in block["scenes"]:
                if isinstance(entry, dict) and "ball" in entry:
                    entry["ball"] = pin(entry["ball"])
    return JobSpec.model_validate(data)


def point_data(
    ctx: JobContext, point: Point
) -> tuple[dict[str, Any], bool, dict[str, Any], str | None]:
    """(table parameters, bowler?, full scene mapping, library ball used) of one run."""

    def lookup(ref: str) -> tuple[dict[str, Any], str]:
        try:
            spec, used = ctx.balls[ref]
        except KeyError:
            raise JobError(f"library ball {ref!r} is not named by the job") from None
        return copy.deepcopy(spec), used

    blocks = ctx.job.blocks()
    block = blocks[point.block] if blocks else None
    if isinstance(block, ScenesSweep) and point.scene is not None:
        entry = block.scenes[point.scene]
        label = entry if isinstance(entry, str) else str(entry.get("name", point.scene))
        params: dict[str, Any] = {"scene": label}
        what = f"sweep[{point.block}].scenes[{point.scene}]"
        data = _read_scene_mapping(entry, Path(ctx.base_dir), what)
        bowler, ref = is_bowler(data), None
    else:
        params = dict(point.overrides)
        data, bowler, ref = copy.deepcopy(ctx.base_data), ctx.base_bowler, ctx.base_ref
        for path, value in point.overrides.items():
            try:
                apply_override(data, path, value)
            except JobError as err:
                raise JobError(f"sweep[{point.block}] point {point.index}: {err}") from err
    data, used = _library_ball(data, lookup)
    ref = used or ref
    _set_record(data, ctx.job.record)
    return params, bowler, data, ref


def prepare_point(ctx: JobContext, point: Point) -> PreparedRun:
    """Validate, convert (bowler scenes), resolve and hash one run of the job (the general
    path; :class:`~bowlrec.batch.fastprep.FastSweep` is the fast one)."""
    try:
        params, bowler, data, ref = point_data(ctx, point)
    except ValueError as err:  # JobError: an entry that cannot be read
        return PreparedRun(point.index, dict(point.overrides), error=str(err))
    return prepare_one(point.index, params, bowler, data, ref)


def prepare_runs(
    job: JobSpec,
    *,
    base_dir: str | Path = ".",
    balls: BallLibrary | None = None,
) -> list[PreparedRun]:
    """Expand the whole job and prepare every run in this process (validate, resolve, run ID;
    per-run costs: benchmarks/results/pipeline.md). Batches prepare in their workers, chunk by
    chunk (:func:`bowlrec.batch.run_job`); this is for inspecting a job's runs.

    Raises JobError for a job that is wrong as a whole; an invalid combination becomes a
    PreparedRun with ``error`` set. ``base_dir``: where relative scene paths are resolved (the
    job file's directory); ``balls``: the archive's ball library for ``name@version``
    references.
    """

    ctx = job_context(job, base_dir=base_dir, balls=balls)
    return [prepare_point(ctx, point) for point in job.points()]

"""Job specs: a base scene plus sweep axes, expanded into one set of field overrides per run.

A job file (JSON or YAML, format ``bowlrec-job``) names a base scene (physical
:class:`~bowlrec.spec.Scene` or bowler-language :class:`~bowlrec.bowling.scene.BowlerScene`,
inline or as a path relative to the job file) and one sweep block, or a list of blocks whose
points are concatenated. Kinds of block:

* ``grid``: the cartesian product of its axes (first axis varies slowest); an axis is a list of
  values or ``{"start", "stop", "num"}`` (evenly spaced, both ends included);
* ``zip``: explicit lists of equal length, taken in parallel (point i takes value i of each);
* ``points``: an explicit list of override sets, ``{"path": value, ...}`` each;
* ``random``: ``n`` points drawn uniformly in ``{"low", "high"}`` per axis (NumPy PCG64, ``seed``);
* ``lhs``: a Latin hypercube of ``n`` points in the same ranges (seeded): each axis range is cut
  into ``n`` equal strata and every stratum holds exactly one point;
* ``scenes``: an explicit list of whole scenes (paths or inline), the base is not used.

A path addresses any scene field: dots between fields and ``[i]`` for an element of a vector,
e.g. ``delivery.speed_mps``, ``delivery.omega_radps[1]``, ``ball.rg_m[0]``, ``pattern`` (bowler
scenes take oil-pattern preset names). This is the notation of the validation messages. A value
may be any JSON value (an object replaces a whole sub-model); on a physical base, a string at
path ``ball`` names a library ball (``"name"`` or ``"name@version"``).
"""

from __future__ import annotations

import copy
import functools
import json
import math
import uuid
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from bowlrec.archive import run_id
from bowlrec.batch.context import JobContext
from bowlrec.batch.fastprep import FastSweep
from bowlrec.batch.paths import apply_override, parse_path, path_label
from bowlrec.bowling.scene import BowlerScene
from bowlrec.errors import JobError, SceneInputError
from bowlrec.scene_input import is_bowler, parse_scene, prefix_lines, with_library_ball
from bowlrec.scene_input import library_lookup as scene_lookup
from bowlrec.sinks.registry import sink_named
from bowlrec.spec import Scene, format_validation_error
from bowlrec.spec._base import spec_error
from bowlrec.spec.loading import read_mapping

if TYPE_CHECKING:
    from bowlrec.archive import BallLibrary
    from bowlrec.core.plan import Plan
    from bowlrec.scene_input import BallLookup
    from bowlrec.spec import Scene


__all__ = [
    "JOB_FORMAT",
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
    "job_schema_text",
    "latin_hypercube",
    "load_job",
    "library_lookup",
    "prepare_point",
    "job_context",
    "point_data",
    "prepare_one",
    "prepare_runs",
]

JOB_FORMAT = "bowlrec-job"
#: most runs one job may have (its sweeps are expanded lazily, chunk by chunk, so this bounds
#: the job's run time and table, not memory)
MAX_JOB_RUNS = 10_000_000
#: most values (points x axes) of one Latin hypercube: its strata are permutations of all n
#: points, so the (n, axes) unit array is held whole in every process (8 bytes per value)
MAX_HYPERCUBE_VALUES = 20_000_000


class _JobModel(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Linspace(_JobModel):
    """``num`` evenly spaced values from ``start`` to ``stop`` (both included; field units)."""

    start: float = Field(allow_inf_nan=False)
    stop: float = Field(allow_inf_nan=False)
    num: int = Field(ge=1, le=100_000)

    def values(self) -> list[float]:
        return [float(v) for v in np.linspace(self.start, self.stop, self.num)]


class Range(_JobModel):
    """A closed interval [low, high] of a float field (field units)."""

    low: float = Field(allow_inf_nan=False)
    high: float = Field(allow_inf_nan=False)

    @model_validator(mode="after")
    def _ordered(self) -> Range:
        if not self.low <= self.high:
            raise ValueError(f"low = {self.low!r} must be <= high = {self.high!r}")
        return self


NonEmptyList = Annotated[list[Any], Field(min_length=1)]


class GridSweep(_JobModel):
    """Cartesian product of the axes (path -> values or linspace); the first axis is slowest."""

    kind: Literal["grid"]
    axes: dict[str, NonEmptyList | Linspace] = Field(min_length=1)

    def count(self) -> int:
        return math.prod(a.num if isinstance(a, Linspace) else len(a) for a in self.axes.values())

    def columns(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Points ``start`` to ``stop`` as float64 columns by path (numeric axes only)."""
        lists = [np.asarray(_axis_values(a), dtype=np.float64) for a in self.axes.values()]
        k = np.arange(start, stop, dtype=np.int64)
        out = {}
        for path, values in reversed(list(zip(self.axes, lists, strict=True))):
            k, digit = np.divmod(k, values.size)
            out[path] = values[digit]
        return {p: out[p] for p in self.axes}

    def points(self, start: int = 0, stop: int | None = None) -> list[dict[str, Any]]:
        """Points ``start`` to ``stop`` (job order) without expanding the others."""
        paths = list(self.axes)
        lists = [_axis_values(self.axes[p]) for p in paths]
        stop = self.count() if stop is None else stop
        out = []
        for k in range(start, stop):
            values = []
            for axis in reversed(lists):  # mixed radix, the last axis varies fastest
                k, digit = divmod(k, len(axis))
                values.append(axis[digit])
            out.append(dict(zip(paths, reversed(values), strict=True)))
        return out


class ZipSweep(_JobModel):
    """Explicit value lists of equal length, taken in parallel."""

    kind: Literal["zip"]
    axes: dict[str, NonEmptyList] = Field(min_length=1)

    @model_validator(mode="after")
    def _same_length(self) -> ZipSweep:
        lengths = {p: len(v) for p, v in self.axes.items()}
        if len(set(lengths.values())) > 1:
            raise ValueError(f"zip axes must have equal lengths, got {lengths}")
        return self

    def count(self) -> int:
        return len(next(iter(self.axes.values())))

    def columns(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Points ``start`` to ``stop`` as float64 columns by path (numeric axes only)."""
        return {p: np.asarray(v[start:stop], dtype=np.float64) for p, v in self.axes.items()}

    def points(self, start: int = 0, stop: int | None = None) -> list[dict[str, Any]]:
        paths = list(self.axes)
        columns = zip(*(v[start:stop] for v in self.axes.values()), strict=True)
        return [dict(zip(paths, vals, strict=True)) for vals in columns]


class PointsSweep(_JobModel):
    """An explicit list of override sets (path -> value)."""

    kind: Literal["points"]
    points_: list[dict[str, Any]] = Field(alias="points", min_length=1)

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    def count(self) -> int:
        return len(self.points_)

    def points(self, start: int = 0, stop: int | None = None) -> list[dict[str, Any]]:
        return [dict(p) for p in self.points_[start:stop]]


class RandomSweep(_JobModel):
    """``n`` points, each axis uniform in [low, high], from ``numpy.random.default_rng(seed)``."""

    kind: Literal["random"]
    n: int = Field(ge=1, le=MAX_JOB_RUNS)
    seed: int = Field(ge=0)
    axes: dict[str, Range] = Field(min_length=1)

    def count(self) -> int:
        return self.n

    def points(self, start: int = 0, stop: int | None = None) -> list[dict[str, Any]]:
        """Points ``start`` to ``stop``: rows of ``default_rng(seed).random((n, d))``, drawn
        without the rows before ``start`` (the generator is advanced past them)."""
        return _rows(self.columns(start, self.n if stop is None else stop))

    def columns(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Points ``start`` to ``stop`` as float64 columns by path."""
        stop = min(stop, self.n)
        d = len(self.axes)
        bits = np.random.PCG64(self.seed)
        bits.advance(start * d)  # one 64-bit draw per double
        u = np.random.Generator(bits).random((max(0, stop - start), d))
        return _scale(u, self.axes)


class LatinHypercubeSweep(_JobModel):
    """``n`` points of a seeded Latin hypercube in the axes' ranges (one point per stratum);
    n x (number of axes) at most 20,000,000 (the hypercube is held whole in memory)."""

    kind: Literal["lhs"]
    n: int = Field(ge=1, le=MAX_JOB_RUNS)
    seed: int = Field(ge=0)
    axes: dict[str, Range] = Field(min_length=1)

    @model_validator(mode="after")
    def _fits_in_memory(self) -> LatinHypercubeSweep:
        values = self.n * len(self.axes)
        if values > MAX_HYPERCUBE_VALUES:
            raise spec_error(
                f"n = {self.n:,} points x {len(self.axes)} axes = {values:,} values; a Latin "
                f"hypercube is held whole in memory, at most {MAX_HYPERCUBE_VALUES:,} values "
                f"(n <= {MAX_HYPERCUBE_VALUES // len(self.axes):,} for {len(self.axes)} axes): "
                "use fewer points or axes, or a random sweep"
            )
        return self

    def count(self) -> int:
        return self.n

    def points(self, start: int = 0, stop: int | None = None) -> list[dict[str, Any]]:
        """Points ``start`` to ``stop``; the hypercube's strata are permutations of all ``n``, so
        the (n, d) unit array is drawn whole once per process (8 bytes per value) and cached."""
        return _rows(self.columns(start, self.n if stop is None else stop))

    def columns(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Points ``start`` to ``stop`` as float64 columns by path."""
        u = _cached_hypercube(self.n, len(self.axes), self.seed)
        return _scale(u[start:stop], self.axes)


class ScenesSweep(_JobModel):
    """Whole scenes: paths (relative to the job file) or inline mappings; the base is unused."""

    kind: Literal["scenes"]
    scenes: list[str | dict[str, Any]] = Field(min_length=1)

    def count(self) -> int:
        return len(self.scenes)

    def points(self, start: int = 0, stop: int | None = None) -> list[dict[str, Any]]:
        return [{} for _ in self.scenes[start:stop]]


AnySweep = GridSweep | ZipSweep | PointsSweep | RandomSweep | LatinHypercubeSweep | ScenesSweep
Sweep = Annotated[AnySweep, Field(discriminator="kind")]


class JobSpec(_JobModel):
    """A batch job: a base scene, sweeps over its fields, and what to record."""

    format: Literal["bowlrec-job"] = Field(
        default="bowlrec-job", description="Marks a job file; always 'bowlrec-job'."
    )
    name: str = Field(default="job", description="Short identifier of the job.")
    description: str = Field(default="", description="Free text.")
    base: str | dict[str, Any] | None = Field(
        default=None,
        description="Base scene: a path (relative to the job file) or an inline scene, physical "
        "or bowler-language ('format': 'bowler'); null: the default physical Scene().",
    )
    ball: str | None = Field(
        default=None,
        description="Library ball 'name' or 'name@version' replacing the base scene's ball "
        "(physical base scenes only).",
    )
    sweep: Sweep | list[Sweep] | None = Field(
        default=None,
        description="One sweep block or a list of blocks (their points are concatenated); "
        f"null: the base scene alone. At most {MAX_JOB_RUNS:,} runs per job in all.",
    )
    record: Literal["summary", "trajectory", "scene"] = Field(
        default="summary",
        description="summary: options.record = 'summary' (fast, no samples); trajectory: "
        "samples (options.record 'rate' unless the scene records 'steps' or 'rate'); scene: "
        "keep each scene's options.",
    )
    samples: Literal["gzip", "none"] = Field(
        default="gzip",
        description="How recorded samples are stored: gzip (compact) or none (faster to write, "
        "larger; benchmarks/results/pipeline.md compares them; `bowlrec runs compact` "
        "recompresses later).",
    )
    formats: list[Literal["mcap", "rrd"]] = Field(
        default_factory=list,
        description="Replay files written per new run into the replay directory (needs "
        "record != 'summary' and the mcap / rerun extras).",
    )

    @model_validator(mode="after")
    def _formats_need_samples(self) -> JobSpec:

        if self.record == "summary" and any(sink_named(f).needs_samples for f in self.formats):
            raise ValueError(
                f"formats = {self.formats} need samples: set record to 'trajectory' or 'scene'"
            )
        return self

    @field_validator("sweep")
    @classmethod
    def _runs_bounded(cls, sweep: AnySweep | list[AnySweep] | None) -> Any:
        """At most MAX_JOB_RUNS runs, counted without expanding anything."""
        blocks = [] if sweep is None else sweep if isinstance(sweep, list) else [sweep]
        total = sum(b.count() for b in blocks)
        if total > MAX_JOB_RUNS:
            parts = ", ".join(_describe_count(b) for b in blocks)
            raise spec_error(
                f"{total:,} runs ({parts}); at most {MAX_JOB_RUNS:,} runs per job: use fewer "
                "points, or split the sweep into several jobs"
            )
        return sweep

    def blocks(self) -> list[AnySweep]:
        """The sweep blocks as a list (empty when there is no sweep)."""
        if self.sweep is None:
            return []
        return list(self.sweep) if isinstance(self.sweep, list) else [self.sweep]

    def count(self) -> int:
        """Runs in the job (computed without expanding the sweeps)."""
        blocks = self.blocks()
        return sum(b.count() for b in blocks) if blocks else 1

    def columns(self, start: int, stop: int, paths: Sequence[str]) -> dict[str, np.ndarray]:
        """Runs ``start`` to ``stop`` of a job whose blocks all sweep numeric axes, as float64
        columns for ``paths`` (NaN where a block does not sweep a path)."""
        stop = min(stop, self.count())
        out = {p: np.full(max(0, stop - start), np.nan) for p in paths}
        first = 0
        for block in self.blocks():
            n = block.count()
            lo, hi = max(start, first), min(stop, first + n)
            if lo < hi:
                assert isinstance(block, GridSweep | ZipSweep | RandomSweep | LatinHypercubeSweep)
                for p, values in block.columns(lo - first, hi - first).items():
                    out[p][lo - start : hi - start] = values
            first += n
        return out

    def points(self, start: int = 0, stop: int | None = None) -> list[Point]:
        """Runs ``start`` to ``stop`` of the job (all by default), in order: the block, its
        scene entry (``scenes``) and the overrides (path -> value) to apply to the base. Only
        the runs asked for are expanded."""
        blocks = self.blocks()
        total = self.count()
        stop = total if stop is None else min(stop, total)
        if not blocks:
            return [Point(0, 0, None, {})] if start < stop else []
        out: list[Point] = []
        first = 0  # job index of the block's first point
        for b, block in enumerate(blocks):
            n = block.count()
            lo, hi = max(start, first), min(stop, first + n)
            if lo < hi:
                for i, overrides in enumerate(block.points(lo - first, hi - first), lo - first):
                    scene = i if isinstance(block, ScenesSweep) else None
                    out.append(Point(first + i, b, scene, overrides))
            first += n
        return out


@dataclass(frozen=True)
class Point:
    """One run of a job before validation: ``overrides`` maps dotted paths to values;
    ``scene`` is the entry of a ``scenes`` block (None: the base scene)."""

    index: int
    block: int
    scene: int | None
    overrides: dict[str, Any]


def _describe_count(block: AnySweep) -> str:
    """``grid 10,000 x 10,000``, ``random 5``: a block's kind and how its count arises."""
    if isinstance(block, GridSweep):
        sizes = [a.num if isinstance(a, Linspace) else len(a) for a in block.axes.values()]
        return f"grid {' x '.join(f'{s:,}' for s in sizes)}"
    return f"{block.kind} {block.count():,}"


def _axis_values(axis: list[Any] | Linspace) -> list[Any]:
    return axis.values() if isinstance(axis, Linspace) else list(axis)


def _scale(u: np.ndarray, axes: Mapping[str, Range]) -> dict[str, np.ndarray]:
    """Map unit-cube samples (n, d) to the axes' ranges: a float64 column per path."""
    lows = np.array([r.low for r in axes.values()])
    highs = np.array([r.high for r in axes.values()])
    x = lows + u * (highs - lows)
    return {p: x[:, j].copy() for j, p in enumerate(axes)}


def _rows(columns: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    """Columns by path -> one override mapping per point (Python floats)."""
    paths = list(columns)
    lists = [columns[p].tolist() for p in paths]
    return [dict(zip(paths, vals, strict=True)) for vals in zip(*lists, strict=True)]


@functools.lru_cache(maxsize=2)
def _cached_hypercube(n: int, d: int, seed: int) -> np.ndarray:
    u = latin_hypercube(n, d, seed)
    u.flags.writeable = False
    return u


def latin_hypercube(n: int, d: int, seed: int) -> np.ndarray:
    """(n, d) samples in [0, 1): column j holds one point in each stratum [k/n, (k+1)/n).

    Each column is an independent random permutation of the strata plus a uniform jitter
    within the stratum (``numpy.random.default_rng(seed)``).
    """
    rng = np.random.default_rng(seed)
    strata = np.stack([rng.permutation(n) for _ in range(d)], axis=1)
    return np.asarray((strata + rng.random((n, d))) / n)


def load_job(path: str | Path) -> JobSpec:
    """Read and validate a job file (.json, .yaml, .yml); JobError with field-named messages."""

    p = Path(path)
    try:
        data = read_mapping(p)
    except (OSError, ValueError) as err:
        raise JobError(f"{p}: {err}") from err
    if isinstance(data, dict) and data.get("format") == "bowlrec-session":
        raise JobError(
            f"{p}: a session file (format bowlrec-session): play it with `bowlrec session {p}`"
        )
    try:
        return JobSpec.model_validate(data)
    except ValidationError as err:
        text = format_validation_error(err).replace("scene", "job", 1)
        raise JobError(prefix_lines(p, text)) from err


def job_schema_text() -> str:
    """Canonical text of the job's JSON Schema (the committed ``schemas/job.schema.json``)."""
    schema = JobSpec.model_json_schema(by_alias=True)
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"


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

    if isinstance(entry, dict):
        return copy.deepcopy(entry)
    path = base_dir / entry
    try:
        data = read_mapping(path)
    except (OSError, ValueError) as err:
        raise JobError(f"{what}: {err}") from err
    if not isinstance(data, dict):
        raise JobError(f"{what}: {path} does not hold a scene mapping")
    return data


def _full_mapping(raw: dict[str, Any], what: str) -> tuple[bool, dict[str, Any]]:
    """Validate a scene mapping and return (bowler?, every field as JSON values)."""

    bowler = is_bowler(raw)
    try:
        model = _model(bowler).model_validate(raw)
    except ValidationError as err:
        raise JobError(prefix_lines(what, format_validation_error(err))) from err
    return bowler, model.model_dump(mode="json")


def _base(job: JobSpec, base_dir: Path, lookup: BallLookup) -> _Base:
    raw = {} if job.base is None else _read_scene_mapping(job.base, base_dir, "base")
    bowler, data = _full_mapping(raw, "base")
    ref = None
    if job.ball is not None:
        data, ref = _library_ball({**data, "ball": job.ball}, lookup)
    return _Base(bowler, data, ref)


def _own_errors(err: ValidationError, path: str) -> list[str]:
    """The lines of the message that concern ``path`` itself (or a field below it)."""

    label = path_label(parse_path(path))
    return [
        line
        for line in format_validation_error(err).splitlines()
        if line.startswith((label + ":", label + ".", label + "["))
    ]


def _check_values(job: JobSpec, base: _Base, lookup: BallLookup) -> None:
    """Each axis value applied alone to the base: bad paths, and values invalid by themselves
    (not merely in combination with other fields) raise JobError naming the path."""
    model = _model(base.bowler)
    for b, block in enumerate(job.blocks()):
        if isinstance(block, ScenesSweep | PointsSweep):
            continue
        for path, axis in block.axes.items():
            if isinstance(axis, Range):
                values: list[Any] = [axis.low, axis.high]
            else:
                values = _axis_values(axis)
            where = f"sweep[{b}].axes[{path!r}]"
            scratch = copy.deepcopy(base.data)  # each value overwrites the one path it sets
            for value in values:
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
        for v in _axis_values(axis)
    )
    summary = job.record == "summary"
    fast = (
        tuple(dict.fromkeys(paths))
        if summary and numeric and FastSweep.applies(base.bowler, paths, has_lists)
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

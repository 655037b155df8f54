"""The batch job file: a base scene plus sweep axes, expanded into one set of field overrides
per run (format ``bowlrec-job``, JSON or YAML).

A job names a base scene (physical :class:`~bowlrec.spec.Scene` or bowler-language
:class:`~bowlrec.bowling.scene.BowlerScene`, inline or as a path relative to the job file) and
one sweep block, or a list of blocks whose points are concatenated. Kinds of block:

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

This module holds the job's models and their lazy expansion into points; the scenes are read
and validated when the job is prepared (:mod:`bowlrec.batch.job`).
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import ConfigDict, Field, ValidationError, field_validator, model_validator

from bowlrec.errors import JobError
from bowlrec.file_kinds import wrong_kind
from bowlrec.scene_input import prefix_lines
from bowlrec.sinks.registry import sink_named
from bowlrec.spec import format_validation_error
from bowlrec.spec._base import NumbersModel, spec_error
from bowlrec.spec.loading import read_mapping

__all__ = [
    "JOB_FORMAT",
    "job_from_mapping",
    "MAX_HYPERCUBE_VALUES",
    "MAX_JOB_RUNS",
    "AnySweep",
    "GridSweep",
    "JobSpec",
    "LatinHypercubeSweep",
    "Linspace",
    "Point",
    "PointsSweep",
    "RandomSweep",
    "Range",
    "ScenesSweep",
    "Sweep",
    "ZipSweep",
    "axis_values",
    "job_schema_text",
    "latin_hypercube",
    "load_job",
]

JOB_FORMAT = "bowlrec-job"
#: most runs one job may have (its sweeps are expanded lazily, chunk by chunk, so this bounds
#: the job's run time and table, not memory)
MAX_JOB_RUNS = 10_000_000
#: most values (points x axes) of one Latin hypercube: its strata are permutations of all n
#: points, so the (n, axes) unit array is held whole in every process (8 bytes per value)
MAX_HYPERCUBE_VALUES = 20_000_000


class _JobModel(NumbersModel):
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
        lists = [np.asarray(axis_values(a), dtype=np.float64) for a in self.axes.values()]
        k = np.arange(start, stop, dtype=np.int64)
        out = {}
        for path, values in reversed(list(zip(self.axes, lists, strict=True))):
            k, digit = np.divmod(k, values.size)
            out[path] = values[digit]
        return {p: out[p] for p in self.axes}

    def points(self, start: int = 0, stop: int | None = None) -> list[dict[str, Any]]:
        """Points ``start`` to ``stop`` (job order) without expanding the others."""
        paths = list(self.axes)
        lists = [axis_values(self.axes[p]) for p in paths]
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
    samples: Literal["gzip", "lz4", "none"] = Field(
        default="gzip",
        description="How recorded samples are stored: gzip (compact, readable wherever HDF5 "
        "is), lz4 (Blosc LZ4: faster to write, a little larger; needs the hdf5plugin package "
        "to read) or none (fastest, largest); benchmarks/results/pipeline.md compares them; "
        "`bowlrec runs compact` recompresses later with gzip.",
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


def axis_values(axis: list[Any] | Linspace) -> list[Any]:
    """An axis's values: the list, or the linspace expanded."""
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
    other = wrong_kind(data, "bowlrec-job")
    if other is not None:
        raise JobError(f"{p}: {other}")
    try:
        return job_from_mapping(data)
    except JobError as err:
        raise JobError(prefix_lines(p, str(err))) from err


def job_from_mapping(data: Any) -> JobSpec:
    """``data`` (a job file's mapping) as a job; JobError with one field-named line per
    problem (the job as a whole named ``job``)."""
    try:
        return JobSpec.model_validate(data)
    except ValidationError as err:
        raise JobError(format_validation_error(err).replace("scene", "job", 1)) from None


def job_schema_text() -> str:
    """Canonical text of the job's JSON Schema (the committed ``schemas/job.schema.json``)."""
    schema = JobSpec.model_json_schema(by_alias=True)
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"

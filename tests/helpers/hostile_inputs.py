"""Hostile inputs: deterministic mutations of every example scene and job.

Every example file under ``examples/`` (``*.json``, ``*.yaml``, ``*.yml``) is read and classified
by its content: a job (``"format": "bowlrec-job"``, a ``sweep`` or the ``scenes`` shorthand), a
bowler-language scene (``"format": "bowler"``) or a physical scene. For every node of its tree
(every leaf and every container, the root included) the generator produces mutations:

* replacement values (``VALUE_KINDS``): 0, -1, -0.0, 1e300, -1e300, 1e-300, 1e-8, 10**30,
  10**400, NaN, +-Infinity (``NaN``/``Infinity`` tokens in JSON text, ``.nan``/``.inf`` in
  YAML), a string, true, null, a list, an object, an empty string, a 100 kB string, a string
  with a newline / NUL / unicode, and a 10,000-deep list;
* structure: the key removed, an unknown extra key, an extra vector element;
* YAML-only values in YAML examples (a timestamp, ``!!set``);
* per document: truncated text, a UTF-8 BOM, invalid UTF-8, and as a YAML file: a syntax
  error, tab indentation, two documents, a ``!!python/object/apply:os.system`` tag and an alias
  bomb (billion laughs; for jobs as the value of a ``points`` override);
* per scene: ``options.record = "rate"`` with ``record_dt_s`` 1e-8 and 1e-300;
* per job: every sweep's ``n`` set to 10**7 and 10**8, every linspace ``num`` to 100,000, the
  sweep replaced by grids of 1e7 and 1e8 points over the job's own axes (``huge``: these may
  legitimately run for hours; the channels interrupt them and check that they stop).

Each mutation has a stable id ``<file>:<json path>:<kind>`` (e.g.
``examples/paper/case01.json:$.ball.mass_kg:nan``). Files of identical shape (the 18 generated
Table III scenes) are one family: each (path, kind) pair is applied to one member of the family,
chosen by a hash of the pair, so every structural path gets every kind once and every member gets
mutations (``BOWLREC_HOSTILE_ALL_TWINS=1``: every pair on every member).

The HTTP channel gets the same mutations of the same documents rendered as JSON, except that a
job's ``base`` path (a file next to the job) is inlined first (the service rejects paths); the
inlined base is mutated as a whole (its leaves are those of the scene example it names). Text
that is not JSON (YAML tags, YAML syntax) is CLI-only.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import os
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
SUFFIXES = (".json", ".yaml", ".yml")

#: a key no model knows
EXTRA_KEY = "hostile_extra_key"
LONG_STRING = "x" * 100_000
CONTROL_STRING = "line1\nline2\x00nul \u2603 \u202eevil \U0001f3b3 \ud7ff"
DEEP = 10_000


@dataclass(frozen=True)
class Raw:
    """Text inserted verbatim into the rendered document (deep nesting, YAML tags, anchors)."""

    json: str | None  # None: not expressible in JSON (a YAML-only construct)
    yaml: str


DEEP_LIST = Raw("[" * DEEP + "]" * DEEP, "[" * DEEP + "]" * DEEP)

VALUE_KINDS: dict[str, Any] = {
    "zero": 0,
    "neg_one": -1,
    "neg_zero": -0.0,
    "big": 1e300,
    "neg_big": -1e300,
    "tiny": 1e-300,
    "small": 1e-8,
    "int_1e30": 10**30,
    "int_huge": 10**400,
    "nan": math.nan,
    "inf": math.inf,
    "neg_inf": -math.inf,
    "str": "hostile",
    "true": True,
    "null": None,
    "list": [1.0, 2.0],
    "dict": {"x": 1.0},
    "empty_str": "",
    "long_str": LONG_STRING,
    "ctrl_str": CONTROL_STRING,
    "deep_list": DEEP_LIST,
}

#: replacement values only YAML can write (applied to the leaves of YAML examples)
YAML_VALUE_KINDS: dict[str, Any] = {
    "yaml_timestamp": Raw(None, "2001-12-14t21:59:43.10-05:00"),
    "yaml_set": Raw(None, "!!set {a: null, b: null}"),
}

STRUCTURE_KINDS = ("remove", "extra_key", "append")
DOC_KINDS = ("truncated", "bom", "invalid_utf8")
YAML_DOC_KINDS = (
    "yaml_syntax",
    "yaml_tab_indent",
    "yaml_two_docs",
    "yaml_python_tag",
    "yaml_python_name",
    "yaml_alias_bomb",
)
SCENE_KINDS = ("rate_dt_1e-8", "rate_dt_1e-300")
SWEEP_KINDS = ("n_1e7", "n_1e8", "num_1e5", "grid_1e7", "grid_1e8")
HUGE_KINDS = frozenset({"n_1e7", "num_1e5", "grid_1e7", "grid_1e8"})

ALL_KINDS = (
    *VALUE_KINDS,
    *YAML_VALUE_KINDS,
    *STRUCTURE_KINDS,
    *DOC_KINDS,
    *YAML_DOC_KINDS,
    *SCENE_KINDS,
    *SWEEP_KINDS,
)


# -- examples -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Example:
    """One example file: ``rel`` relative to the repository, ``kind`` scene | bowler | job."""

    rel: str
    path: Path
    kind: str
    suffix: str
    data: Any = field(compare=False, hash=False, repr=False)


def classify(data: Any) -> str | None:
    """scene | bowler | job for a parsed example, None for anything else."""
    if not isinstance(data, dict):
        return None
    if data.get("format") == "bowlrec-job" or "sweep" in data:
        return "job"
    if "scenes" in data and "format" not in data:
        return "job"
    if data.get("format") == "bowler":
        return "bowler"
    scene_keys = {"ball", "lane", "delivery", "options", "name", "description"}
    if data.keys() <= scene_keys:
        return "scene"
    return None


def _read(path: Path) -> Any:
    text = path.read_text(encoding="utf-8")
    if path.suffix == ".json":
        return json.loads(text)
    import yaml

    return yaml.safe_load(text)


@cache
def examples() -> tuple[Example, ...]:
    """Every example scene and job, sorted by path."""
    out = []
    for path in sorted(EXAMPLES.rglob("*")):
        if path.suffix.lower() not in SUFFIXES or not path.is_file():
            continue
        data = _read(path)
        kind = classify(data)
        if kind is not None:
            rel = path.relative_to(ROOT).as_posix()
            out.append(Example(rel, path, kind, path.suffix.lower(), data))
    return tuple(out)


# -- rendering ----------------------------------------------------------------------------------


class NotJson(Exception):
    """The document holds a YAML-only construct."""


def _float_json(x: float) -> str:
    if math.isnan(x):
        return "NaN"
    if math.isinf(x):
        return "Infinity" if x > 0 else "-Infinity"
    return repr(x)


def _float_yaml(x: float) -> str:
    if math.isnan(x):
        return ".nan"
    if math.isinf(x):
        return ".inf" if x > 0 else "-.inf"
    text = repr(x)
    # YAML 1.1 (PyYAML) reads a float only with a '.' and a signed exponent: 1e-08 is a string
    mant, e, exp = text.partition("e")
    if "." not in mant:
        mant += ".0"
    if e and exp[0] not in "+-":
        exp = "+" + exp
    return mant + (("e" + exp) if e else "")


def to_json(obj: Any) -> str:
    """JSON text as Python's json module reads it (NaN/Infinity tokens, any int, raw text)."""
    if isinstance(obj, Raw):
        if obj.json is None:
            raise NotJson
        return obj.json
    if obj is None:
        return "null"
    if obj is True:
        return "true"
    if obj is False:
        return "false"
    if isinstance(obj, int):
        return str(obj)
    if isinstance(obj, float):
        return _float_json(obj)
    if isinstance(obj, str):
        return json.dumps(obj)
    if isinstance(obj, list):
        return "[" + ", ".join(to_json(v) for v in obj) + "]"
    if isinstance(obj, dict):
        return "{" + ", ".join(f"{json.dumps(k)}: {to_json(v)}" for k, v in obj.items()) + "}"
    raise TypeError(type(obj))


def to_yaml(obj: Any) -> str:
    """YAML flow-style text (``.nan``/``.inf``, floats PyYAML reads as floats, raw text)."""
    if isinstance(obj, Raw):
        return obj.yaml
    if obj is None:
        return "null"
    if obj is True:
        return "true"
    if obj is False:
        return "false"
    if isinstance(obj, int):
        return str(obj)
    if isinstance(obj, float):
        return _float_yaml(obj)
    if isinstance(obj, str):
        return json.dumps(obj, ensure_ascii=False)
    if isinstance(obj, list):
        return "[" + ", ".join(to_yaml(v) for v in obj) + "]"
    if isinstance(obj, dict):
        return (
            "{"
            + ", ".join(
                f"{json.dumps(k, ensure_ascii=False)}: {to_yaml(v)}" for k, v in obj.items()
            )
            + "}"
        )
    raise TypeError(type(obj))


def to_yaml_block(obj: dict[str, Any]) -> str:
    """A mapping as block-style YAML (top level), values in flow style."""
    return "".join(f"{json.dumps(k, ensure_ascii=False)}: {to_yaml(v)}\n" for k, v in obj.items())


# -- mutations ----------------------------------------------------------------------------------


Path_ = tuple[str | int, ...]


def jpath(path: Path_) -> str:
    """``("ball", "rg_m", 0)`` -> ``$.ball.rg_m[0]``."""
    out = "$"
    for k in path:
        out += f"[{k}]" if isinstance(k, int) else f".{k}"
    return out


@dataclass(frozen=True)
class Mutation:
    """One hostile input. ``suffix``/``content()``: the file for the CLI; ``body()``: the HTTP
    request body (None when the input cannot be sent as JSON); ``target``: scene | job (what the
    example is: decides the command and the endpoint); ``huge``: a valid request for very many
    runs (interrupted by the channels, which then check that it stops)."""

    id: str
    example: str
    where: str
    kind: str
    target: str
    suffix: str
    doc: Any = field(repr=False, compare=False)
    text: bytes | None = field(default=None, repr=False, compare=False)
    huge: bool = False

    def content(self) -> bytes:
        """The file's bytes."""
        if self.text is not None:
            return self.text
        if self.suffix == ".json":
            return to_json(self.doc).encode()
        if isinstance(self.doc, dict):
            return to_yaml_block(self.doc).encode()
        return (to_yaml(self.doc) + "\n").encode()

    def body(self) -> bytes | None:
        """The HTTP body (JSON text as Python reads it), None for YAML-only inputs."""
        if self.text is not None:
            return self.text if self.suffix == ".json" else None
        try:
            return to_json(self.doc).encode()
        except NotJson:
            return None

    def body_is_json(self) -> bool:
        """True when the body is JSON as the server reads it (Python's json, NaN allowed)."""
        body = self.body()
        if body is None:
            return False
        try:
            json.loads(body)
        except (ValueError, RecursionError):
            return False
        return True


def _nodes(obj: Any, path: Path_ = ()) -> Iterator[tuple[Path_, Any]]:
    yield path, obj
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _nodes(v, (*path, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _nodes(v, (*path, i))


def _get(doc: Any, path: Path_) -> Any:
    for k in path:
        doc = doc[k]
    return doc


def _set(doc: Any, path: Path_, value: Any) -> Any:
    if not path:
        return value
    _get(doc, path[:-1])[path[-1]] = value
    return doc


def _sweep_blocks(doc: dict[str, Any]) -> list[tuple[Path_, dict[str, Any]]]:
    sweep = doc.get("sweep")
    if isinstance(sweep, dict):
        return [(("sweep",), sweep)]
    if isinstance(sweep, list):
        return [(("sweep", i), b) for i, b in enumerate(sweep) if isinstance(b, dict)]
    return []


def _numeric_axes(doc: dict[str, Any]) -> dict[str, tuple[float, float]]:
    """The job's numeric sweep axes: path -> (low, high)."""
    out: dict[str, tuple[float, float]] = {}
    for _, block in _sweep_blocks(doc):
        for p, axis in (block.get("axes") or {}).items():
            if isinstance(axis, dict) and {"low", "high"} <= axis.keys():
                out[p] = (float(axis["low"]), float(axis["high"]))
            elif isinstance(axis, dict) and {"start", "stop"} <= axis.keys():
                out[p] = (float(axis["start"]), float(axis["stop"]))
            elif (
                isinstance(axis, list)
                and axis
                and all(isinstance(v, int | float) and not isinstance(v, bool) for v in axis)
            ):
                out[p] = (float(min(axis)), float(max(axis)))
    return out


def _huge_grid(doc: dict[str, Any], total: float) -> dict[str, Any] | None:
    axes = _numeric_axes(doc)
    if len(axes) < 2:
        return None
    num = min(100_000, math.ceil(total ** (1 / len(axes))))
    return {
        "kind": "grid",
        "axes": {p: {"start": lo, "stop": hi, "num": num} for p, (lo, hi) in axes.items()},
    }


def _alias_bomb(levels: int = 9, width: int = 9) -> Raw:
    """Billion laughs: ``width**levels`` strings when expanded, a few hundred bytes of YAML."""
    text = "&l0 [" + ", ".join(['"lol"'] * width) + "]"
    for k in range(1, levels):
        text = f"&l{k} [{text}, " + ", ".join([f"*l{k - 1}"] * (width - 1)) + "]"
    return Raw(None, text)


def _first_axis_path(doc: dict[str, Any]) -> str:
    for _, block in _sweep_blocks(doc):
        for p in block.get("axes") or {}:
            return str(p)
    return "delivery.speed_mps" if doc.get("format") != "bowler" else "delivery.speed_mph"


def _inline_base(ex: Example) -> Any:
    """The job with a ``base`` path replaced by the scene it names (for the HTTP channel)."""
    doc = copy.deepcopy(ex.data)
    if isinstance(doc, dict) and isinstance(doc.get("base"), str):
        doc["base"] = _read((ex.path.parent / doc["base"]).resolve())
    return doc


def _tree_mutations(
    doc: Any, yaml_values: bool, opaque: Path_ | None = None
) -> Iterator[tuple[str, str, Any]]:
    """(where, kind, mutated document) for every node of ``doc`` (below ``opaque``: none)."""
    kinds = dict(VALUE_KINDS)
    if yaml_values:
        kinds.update(YAML_VALUE_KINDS)
    for path, node in _nodes(doc):
        if opaque is not None and len(path) > len(opaque) and path[: len(opaque)] == opaque:
            continue
        where = jpath(path)
        leaf = not isinstance(node, dict | list)
        for kind, value in kinds.items():
            if kind.startswith("yaml_") and not leaf:
                continue
            yield where, kind, _set(copy.deepcopy(doc), path, copy.deepcopy(value))
        if path and isinstance(path[-1], str):
            d = copy.deepcopy(doc)
            del _get(d, path[:-1])[path[-1]]
            yield where, "remove", d
        if isinstance(node, dict):
            d = copy.deepcopy(doc)
            _get(d, path)[EXTRA_KEY] = 1.0
            yield where, "extra_key", d
        if isinstance(node, list):
            d = copy.deepcopy(doc)
            _get(d, path).append(0.0)
            yield where, "append", d


def _scene_mutations(doc: dict[str, Any]) -> Iterator[tuple[str, str, Any]]:
    for kind, dt in (("rate_dt_1e-8", 1e-8), ("rate_dt_1e-300", 1e-300)):
        d = copy.deepcopy(doc)
        options = d.setdefault("options", {})
        options["record"] = "rate"
        options["record_dt_s"] = dt
        yield "$.options", kind, d


def _sweep_mutations(doc: dict[str, Any]) -> Iterator[tuple[str, str, Any]]:
    for path, block in _sweep_blocks(doc):
        if "n" in block:
            for kind, n in (("n_1e7", 10**7), ("n_1e8", 10**8)):
                d = copy.deepcopy(doc)
                _get(d, path)["n"] = n
                yield jpath((*path, "n")), kind, d
        for p, axis in (block.get("axes") or {}).items():
            if isinstance(axis, dict) and "num" in axis:
                d = copy.deepcopy(doc)
                _get(d, path)["axes"][p]["num"] = 100_000
                yield jpath((*path, "axes", p, "num")), "num_1e5", d
    for kind, total in (("grid_1e7", 1e7), ("grid_1e8", 1e8)):
        grid = _huge_grid(doc, total)
        if grid is not None:
            d = copy.deepcopy(doc)
            d["sweep"] = grid
            yield "$.sweep", kind, d


def _yaml_doc_mutations(doc: Any, target: str) -> Iterator[tuple[str, str, bytes]]:
    """Documents that exist only as YAML text: (where, kind, file bytes)."""
    if not isinstance(doc, dict):
        return
    block = to_yaml_block(doc)
    yield "$", "yaml_syntax", (block + "oops: [unclosed, {\n  - : :\n").encode()
    yield "$", "yaml_tab_indent", ("ball:\n\tmass_kg: 7.0\n" + block).encode()
    yield "$", "yaml_two_docs", (block + "---\n" + block).encode()
    key = "name" if "name" in doc else next(iter(doc))
    for kind, tag in (
        ("yaml_python_tag", '!!python/object/apply:os.system ["echo hostile >&2"]'),
        ("yaml_python_name", "!!python/name:os.system"),
    ):
        d = dict(doc)
        d[key] = Raw(None, tag)
        yield f"$.{key}", kind, to_yaml_block(d).encode()
    d = copy.deepcopy(doc)
    if target == "job":
        # the bomb as the value of a points override (Any-typed: nothing validates it early)
        d["sweep"] = {"kind": "points", "points": [{_first_axis_path(doc): _alias_bomb()}]}
        yield "$.sweep.points[0]", "yaml_alias_bomb", to_yaml_block(d).encode()
    else:
        d[key] = _alias_bomb()
        yield f"$.{key}", "yaml_alias_bomb", to_yaml_block(d).encode()


def _raw_doc_mutations(content: bytes) -> Iterator[tuple[str, str, bytes]]:
    yield "$", "truncated", content[: len(content) // 2]
    yield "$", "bom", b"\xef\xbb\xbf" + content
    yield "$", "invalid_utf8", b"\xff\xfe\xfa" + content[1:]


def _shape(obj: Any) -> Any:
    if isinstance(obj, dict):
        return tuple((k, _shape(v)) for k, v in obj.items())
    if isinstance(obj, list):
        return ("list", tuple(_shape(v) for v in obj))
    return type(obj).__name__


def _families() -> dict[str, tuple[int, int]]:
    """Example rel -> (its index in its family of identically shaped files, family size)."""
    groups: dict[Any, list[str]] = {}
    for ex in examples():
        groups.setdefault((ex.kind, ex.suffix, _shape(ex.data)), []).append(ex.rel)
    return {rel: (i, len(g)) for g in groups.values() for i, rel in enumerate(g)}


def _owner(where: str, kind: str, size: int) -> int:
    digest = hashlib.sha1(f"{where}:{kind}".encode()).digest()
    return int.from_bytes(digest[:4], "big") % size


def _example_mutations(ex: Example, channel: str) -> Iterator[Mutation]:
    doc = _inline_base(ex) if channel == "http" and ex.kind == "job" else ex.data
    target = "job" if ex.kind == "job" else "scene"
    yaml_file = ex.suffix != ".json"
    suffix = ex.suffix

    def mk(where: str, kind: str, d: Any = None, text: bytes | None = None, sfx: str = suffix):
        return Mutation(
            id=f"{ex.rel}:{where}:{kind}",
            example=ex.rel,
            where=where,
            kind=kind,
            target=target,
            suffix=sfx,
            doc=d,
            text=text,
            huge=kind in HUGE_KINDS,
        )

    # an inlined base file is mutated as a whole only (its leaves are the scene example's)
    inlined = isinstance(ex.data, dict) and isinstance(ex.data.get("base"), str)
    opaque = ("base",) if channel == "http" and inlined else None
    for where, kind, d in _tree_mutations(doc, yaml_values=yaml_file, opaque=opaque):
        yield mk(where, kind, d)
    if target == "scene" and isinstance(doc, dict):
        for where, kind, d in _scene_mutations(doc):
            yield mk(where, kind, d)
    if target == "job" and isinstance(doc, dict):
        for where, kind, d in _sweep_mutations(doc):
            yield mk(where, kind, d)
    original = mk("$", "original", doc)
    for where, kind, text in _raw_doc_mutations(original.content()):
        yield mk(where, kind, text=text)
    if channel == "cli":
        for where, kind, text in _yaml_doc_mutations(doc, target):
            yield mk(where, kind, text=text, sfx=".yaml")


@cache
def mutations(channel: str = "cli") -> tuple[Mutation, ...]:
    """Every mutation for ``channel`` (cli: files; http: JSON bodies), in a stable order.

    Members of a family of identically shaped examples share the (path, kind) pairs (see the
    module docstring); ``BOWLREC_HOSTILE_ALL_TWINS=1`` gives every pair to every member."""
    all_twins = os.environ.get("BOWLREC_HOSTILE_ALL_TWINS") == "1"
    families = _families()
    out: list[Mutation] = []
    for ex in examples():
        index, size = families[ex.rel]
        for m in _example_mutations(ex, channel):
            if channel == "http" and m.body() is None:
                continue
            if all_twins or size == 1 or _owner(m.where, m.kind, size) == index:
                out.append(m)
    ids = [m.id for m in out]
    assert len(ids) == len(set(ids)), "mutation ids must be unique"
    return tuple(out)


@cache
def by_id(channel: str) -> dict[str, Mutation]:
    return {m.id: m for m in mutations(channel)}


def _rank(m: Mutation, salt: str) -> bytes:
    return hashlib.sha1(f"{salt}:{m.id}".encode()).digest()


def stratified_sample(
    items: tuple[Mutation, ...] | list[Mutation],
    n: int,
    *,
    max_jobs: int | None = None,
    salt: str = "hostile",
) -> list[Mutation]:
    """A deterministic sample of about ``n``: every kind and every example at least once (for
    scenes and for jobs), then the rest by a hash of the id. ``max_jobs`` caps the job inputs
    beyond the per-kind / per-example picks (jobs run dozens of simulations each)."""
    ranked = sorted(items, key=lambda m: _rank(m, salt))
    chosen: dict[str, Mutation] = {}
    for key in (
        lambda m: (m.target, m.kind),
        lambda m: m.example,
        lambda m: (m.target, m.where.split("[")[0].split(".")[-1]),
    ):
        seen: set[Any] = set()
        for m in ranked:
            k = key(m)
            if k not in seen:
                seen.add(k)
                chosen.setdefault(m.id, m)
    jobs = sum(1 for m in chosen.values() if m.target == "job")
    for m in ranked:
        if len(chosen) >= n:
            break
        if m.id in chosen:
            continue
        if m.target == "job":
            if max_jobs is not None and jobs >= max_jobs:
                continue
            jobs += 1
        chosen[m.id] = m
    order = {m.id: i for i, m in enumerate(items)}
    return sorted(chosen.values(), key=lambda m: order[m.id])


def safe_name(m: Mutation) -> str:
    """A short file name for the mutation (readable, unique by an id hash)."""
    stem = Path(m.example).stem
    where = re.sub(r"[^A-Za-z0-9_.-]+", "_", m.where.removeprefix("$").strip("."))[:60]
    digest = hashlib.sha1(m.id.encode()).hexdigest()[:8]
    return f"{stem}--{where or 'root'}--{m.kind}--{digest}{m.suffix}"


if __name__ == "__main__":  # a summary of what the generator makes
    import collections

    for ch in ("cli", "http"):
        ms = mutations(ch)
        kinds = collections.Counter(m.kind for m in ms)
        targets = collections.Counter(m.target for m in ms)
        print(ch, len(ms), dict(targets), len(kinds), "kinds")
    for ex in examples():
        print(ex.rel, ex.kind, sum(1 for m in mutations("cli") if m.example == ex.rel))

"""The kernels' numba cache: what an edit of one module costs to recompile, against dropping the
whole cache, against a warm cache and a cold one; a cold compile in one process or two.

    python -m benchmarks.kernel_cache [--rounds 3] [--out DIR]

Everything runs in a scratch copy of the package (``bowlrec/`` copied into a temporary directory
without its caches: this tree's files and caches are never touched). Each measurement is a fresh
process (``PYTHONPATH`` at the copy, ``NUMBA_CACHE_DIR`` unset: the caches are the copy's
``__pycache__`` folders) that warms every kernel up (the variants of :mod:`bowlrec.core.warm`
and the paper's RK4 scheme); this process takes its wall time and CPU seconds (user + system,
its own child processes included). Per round, in this order:

* **cold, 1 process**: the caches deleted, then ``python -m bowlrec.testing.warm``: every kernel
  compiled; then a fresh process (which must compile nothing);
* **cold, --jobs 2**: the caches deleted, then ``python -m bowlrec.testing.warm --jobs 2``: the
  variants split over two processes compiling at once; then a fresh process (which must compile
  nothing: no entry was lost);
* **warm**: nothing changed: every kernel loaded from the cache;
* **edit M**: a comment line appended to ``bowlrec/core/M.py`` (the leaf kernel modules
  ``summary`` and ``observe``, ``dynamics``, the Python-only ``solver``, ``arguments``,
  ``trajectory`` and ``outcome``), then one process (:data:`WARM`): the kernel modules whose
  entries the checks of :mod:`bowlrec.core._kernel_cache` dropped, the signatures compiled, the
  time. The cache is
  then warm for the edited sources; the next round appends another line;
* **check**: the cost of the check when nothing changed, in one fresh process (:data:`CHECK`):
  its check of ``bowlrec/core`` at import (``LAST.seconds``; numba, which every kernel module
  imports, imported before), the median of 200 more calls of
  :func:`~bowlrec.core._kernel_cache.drop_stale_kernels`, and, for comparison, one SHA-256 over
  the sources of ``bowlrec/core`` (what a whole-cache rule hashes).

Under a whole-cache rule (any edit of a ``bowlrec/core`` file drops every kernel of
``bowlrec/core`` and of the RK4 scheme) each of these edits costs the cold compile: the "whole
cache dropped" columns are the cold compile's. Medians over the rounds; the JSON has every run,
with the load average before it. Writes ``kernel_cache.json`` and ``kernel_cache.md``.
``--recheck`` measures the check again (no compile: it loads no kernel) into the existing
results.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]

#: checks the caches and warms every kernel up; prints JSON (what was dropped, the warm-up)
WARM = """
import json
from pathlib import Path
import bowlrec.testing
from bowlrec.core import _kernel_cache as kc
testing = kc.drop_stale_kernels(Path(bowlrec.testing.__file__).parent)  # before rk4 loads
from bowlrec.testing.warm import EXTRA, warm_up_all
assert "rk4" in EXTRA, "the RK4 scheme needs scipy"
print(json.dumps({
    **warm_up_all().as_dict(),
    "package": str(Path(bowlrec.testing.__file__).parent.parent),
    "dropped": kc.LAST.modules + ["testing/" + m for m in testing.modules],
    "files_dropped": kc.LAST.files + testing.files,
}))
"""

#: the check's cost when nothing changed; prints JSON
CHECK = """
import hashlib, json, statistics, time
from pathlib import Path
import numba.core.caching  # imported by every kernel module anyway: not the check's cost
from bowlrec.core import _kernel_cache as kc
core = Path(kc.__file__).parent
assert kc.LAST.checked and not kc.LAST.modules
again, whole = [], []
for _ in range(200):
    t = time.perf_counter()
    done = kc.drop_stale_kernels(core)
    again.append(time.perf_counter() - t)
    assert done.checked and not done.modules
for _ in range(200):
    t = time.perf_counter()
    h = hashlib.sha256()
    for p in sorted(core.glob("*.py")):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    h.hexdigest()
    whole.append(time.perf_counter() - t)
print(json.dumps({
    "import_check_ms": kc.LAST.seconds * 1e3,
    "check_ms": statistics.median(again) * 1e3,
    "whole_hash_ms": statistics.median(whole) * 1e3,
}))
"""

COMMAND = ["-m", "bowlrec.testing.warm", "--json"]
#: the edited modules of bowlrec/core, with what they are
EDITS = {
    "summary": "leaf kernel module",
    "observe": "leaf kernel module, the integrator imports it",
    "dynamics": "kernel module, nearly every kernel imports it",
    "solver": "Python only, no kernel module imports it",
    "arguments": "Python only, batch imports it",
    "trajectory": "Python only, summary freezes its constants",
    "outcome": "Python only, solver imports it",
}


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run(src: Path, *args: str) -> dict[str, Any]:
    """One fresh process: its last output line (JSON), its wall and CPU seconds."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(src)
    load = os.getloadavg()[0]
    start, cpu = time.perf_counter(), _cpu()
    out = subprocess.run(
        [sys.executable, *args], env=env, cwd=src, check=True, capture_output=True, text=True
    ).stdout
    wall, cpu = time.perf_counter() - start, _cpu() - cpu
    result = json.loads(out.strip().splitlines()[-1])
    if "package" in result and Path(result["package"]) != src / "bowlrec":
        raise RuntimeError(f"the child imported {result['package']}, not the copy")
    return {"wall_s": wall, "cpu_s": cpu, "load_before": load, **result}


def _drop_caches(src: Path) -> None:
    for cache in (src / "bowlrec").rglob("__pycache__"):
        shutil.rmtree(cache)


def _copy() -> tuple[Path, Path]:
    tmp = Path(tempfile.mkdtemp(prefix="bowlrec-kernel-cache-"))
    src = tmp / "src"
    shutil.copytree(ROOT / "bowlrec", src / "bowlrec", ignore=shutil.ignore_patterns("__pycache__"))
    return tmp, src


def _check(src: Path) -> dict[str, Any]:
    """The check's cost in a fresh process, after one that brought the stamp up to date."""
    subprocess.run(
        [sys.executable, "-c", "import bowlrec.core.vec"],
        env={**os.environ, "PYTHONPATH": str(src)},
        cwd=src,
        check=True,
    )
    return _run(src, "-c", CHECK)


def _medians(raw: dict[str, list[dict[str, Any]]]) -> dict[str, dict[str, float]]:
    return {
        key: {
            k: statistics.median(run[k] for run in runs)
            for k, v in runs[0].items()
            if isinstance(v, (int, float)) and not isinstance(v, bool)
        }
        for key, runs in raw.items()
    }


def recheck(res: dict[str, Any], rounds: int) -> dict[str, Any]:
    """``res`` with its check runs measured again."""
    tmp, src = _copy()
    try:
        res["raw"]["check"] = [_check(src) for _ in range(rounds)]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    res["median"] = _medians(res["raw"])
    return res


def measure(rounds: int) -> dict[str, Any]:
    tmp, src = _copy()
    raw: dict[str, list[dict[str, Any]]] = {}

    def add(key: str, value: dict[str, Any]) -> None:
        raw.setdefault(key, []).append(value)
        brief = {k: value[k] for k in ("wall_s", "cpu_s", "compiled", "dropped") if k in value}
        print(f"{key}: {brief}", flush=True)

    try:
        for r in range(rounds):
            _drop_caches(src)
            add("cold", _run(src, *COMMAND))
            add("after cold", _run(src, "-c", WARM))
            _drop_caches(src)
            add("cold, --jobs 2", _run(src, *COMMAND, "--jobs", "2"))
            add("after --jobs 2", _run(src, "-c", WARM))
            add("warm", _run(src, "-c", WARM))
            add("check", _check(src))
            for module in EDITS:
                path = src / "bowlrec" / "core" / f"{module}.py"
                path.write_text(path.read_text() + f"# benchmark edit {r + 1}\n")
                add(f"edit {module}", _run(src, "-c", WARM))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    median = _medians(raw)
    return {
        "rounds": rounds,
        "cpus": os.cpu_count(),
        "machine": platform.processor() or platform.machine(),
        "python": platform.python_version(),
        "raw": raw,
        "median": median,
    }


def _markdown(res: dict[str, Any]) -> str:
    med, raw = res["median"], res["raw"]
    cold, warm = med["cold"], med["warm"]
    loads = [run["load_before"] for runs in raw.values() for run in runs]
    rounds = f"{res['rounds']} round" + ("s" if res["rounds"] > 1 else "")
    lines = [
        "# The kernels' numba cache: recompiling after an edit",
        "",
        f"`python -m benchmarks.kernel_cache --rounds {res['rounds']}`: medians of {rounds} "
        f"on {res['cpus']} cores ({res['machine']}, Python {res['python']}), each a fresh "
        "process in a scratch copy of the package warming every kernel up (all variants of "
        "`bowlrec.core.warm` and the RK4 scheme); wall and CPU seconds of the whole process. "
        f"Load average before a run: {min(loads):.2f}-{max(loads):.2f} (CPU seconds are the "
        "steadier measure on a shared machine).",
        "",
        "| after | kernel modules dropped | signatures compiled | wall (s) | CPU (s) "
        "| whole cache dropped: wall (s) | CPU (s) |",
        "|---|---|---|---|---|---|---|",
    ]
    for module, what in EDITS.items():
        m = med[f"edit {module}"]
        dropped = ", ".join(raw[f"edit {module}"][0]["dropped"]) or "none"
        lines.append(
            f"| edit of `{module}.py` ({what}) | {dropped} | {m['compiled']:.0f} "
            f"| {m['wall_s']:.0f} | {m['cpu_s']:.0f} | {cold['wall_s']:.0f} "
            f"| {cold['cpu_s']:.0f} |"
        )
    lines += [
        f"| nothing (warm cache: every kernel loaded) | none | {warm['compiled']:.0f} "
        f"| {warm['wall_s']:.1f} | {warm['cpu_s']:.1f} | {warm['wall_s']:.1f} "
        f"| {warm['cpu_s']:.1f} |",
        f"| cold cache (every kernel compiled) | - | {cold['compiled']:.0f} "
        f"| {cold['wall_s']:.0f} | {cold['cpu_s']:.0f} | {cold['wall_s']:.0f} "
        f"| {cold['cpu_s']:.0f} |",
        "",
        "`testing/rk4` is the paper's RK4 scheme (bowlrec/testing), which imports "
        "`bowlrec.core.arguments` and `dynamics`.",
        "",
        "## A cold compile in one process or two",
        "",
        "`python -m bowlrec.testing.warm` against `python -m bowlrec.testing.warm --jobs 2` "
        "(the variants split over two processes compiling at once), the caches deleted before "
        "each; then a fresh process, which must compile nothing.",
        "",
        "| cold compile | wall (s) | CPU (s) | signatures compiled | wall per round (s) "
        "| compiled by a fresh process afterwards |",
        "|---|---|---|---|---|---|",
    ]
    for key, label, after in (
        ("cold", "1 process", "after cold"),
        ("cold, --jobs 2", "2 processes (`--jobs 2`)", "after --jobs 2"),
    ):
        m = med[key]
        walls = ", ".join(f"{run['wall_s']:.0f}" for run in raw[key])
        again = max(run["compiled"] for run in raw[after])
        lines.append(
            f"| {label} | {m['wall_s']:.0f} | {m['cpu_s']:.0f} | {m['compiled']:.0f} "
            f"| {walls} | {again} |"
        )
    ratio = med["cold, --jobs 2"]["wall_s"] / cold["wall_s"]
    lines += [
        "",
        f"Wall time of `--jobs 2` / 1 process: {ratio:.2f}.",
        "",
        "## The check when nothing changed",
        "",
        "| | ms |",
        "|---|---|",
    ]
    check = med["check"]
    lines += [
        "| first check in a fresh process (at import of `vec`; numba imported before) "
        f"| {check['import_check_ms']:.2f} |",
        f"| each further check, median of 200 | {check['check_ms']:.2f} |",
        f"| one SHA-256 over `bowlrec/core/*.py` (a whole-cache rule's check) "
        f"| {check['whole_hash_ms']:.2f} |",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument(
        "--recheck", action="store_true", help="measure the check again into --out's results"
    )
    args = parser.parse_args()
    if args.recheck:
        res = recheck(json.loads((args.out / "kernel_cache.json").read_text()), args.rounds)
    else:
        res = measure(args.rounds)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "kernel_cache.json").write_text(json.dumps(res, indent=1) + "\n")
    (args.out / "kernel_cache.md").write_text(_markdown(res))
    print(_markdown(res))


if __name__ == "__main__":
    main()

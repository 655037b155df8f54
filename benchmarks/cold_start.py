"""Cold start: ``bowlrec simulate case16.json --no-archive`` in a fresh process, numba's kernel
cache on disk, this tree against an earlier commit.

    python -m benchmarks.cold_start [--before REV] [--runs 15] [--out DIR]

``--before`` (default: ae59866, the first landed version) is extracted (``git archive``) into
a folder under the system's temporary directory that is kept between calls, so its kernels are
compiled once; this tree runs from its own checkout. Both run under this interpreter, each with
``PYTHONPATH`` at its own tree (``NUMBA_CACHE_DIR`` unset: the caches are the trees'
``__pycache__`` folders; ``PYTHONDONTWRITEBYTECODE`` unset: Python's bytecode is cached as in an
install), through the ``bowlrec`` entry point (``bowlrec.cli:main``) on this tree's
``examples/paper/case16.json``. Each tree runs twice first, not counted (its kernels compiled or
loaded, its bytecode written); then ``--runs`` rounds, each a fresh process of each tree, the
order alternating (A B, B A, ...): a drift of the shared machine's speed hits both alike. Per
run: wall seconds and CPU seconds (user + system) of the whole process.

Targets (issue 32, item 5): the median wall time of this tree <= 0.7x the first landed
version's (the median of the rounds' ratios), and <= 1.0 s. Besides the times, one more fresh
process of each tree reports what the command loaded: modules imported (bowlrec's among them),
kernels loaded from numba's cache, whether scipy.linalg was imported. The printed summaries of
the two trees must be the same text. Writes ``cold_start.json`` and ``cold_start.md``.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import platform
import re
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_BEFORE = "ae59866"  # the first landed version
CASE = ROOT / "examples" / "paper" / "case16.json"
ARGS = ["simulate", str(CASE), "--no-archive"]
#: targets: ratio of medians (this tree / before) and this tree's median wall time (s)
TARGET_RATIO = 0.7
TARGET_SECONDS = 1.0

#: the ``bowlrec`` console script (``bowlrec.cli:main``) with the command line after ``-c``
ENTRY = "import sys; sys.argv[0] = 'bowlrec'; from bowlrec.cli import main; sys.exit(main())"

#: the entry point, then what it loaded, as JSON on stderr (stdout is the command's)
PROBE = """
import json, sys
sys.argv[0] = "bowlrec"
from bowlrec.cli import main
try:
    main()
except SystemExit:
    pass
from numba.core.registry import CPUDispatcher
hits = sorted(
    f"{obj.__module__}.{obj.__name__}"
    for name, module in list(sys.modules.items())
    if name.startswith("bowlrec.") and module is not None
    for obj in list(vars(module).values())
    if isinstance(obj, CPUDispatcher) and obj.__module__ == name
    and sum(obj.stats.cache_hits.values())
)
print(json.dumps({
    "package": sys.modules["bowlrec"].__file__,
    "modules": len(sys.modules),
    "bowlrec_modules": sum(1 for m in sys.modules if m == "bowlrec" or m.startswith("bowlrec.")),
    "kernels_loaded": hits,
    "scipy_linalg": "scipy.linalg" in sys.modules,
}), file=sys.stderr)
"""


def _env(tree: Path) -> dict[str, str]:
    drop = {"NUMBA_CACHE_DIR", "PYTHONDONTWRITEBYTECODE", "PYTHONPATH"}
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env["PYTHONPATH"] = str(tree)
    return env


def _extract(rev: str) -> Path:
    """``rev``'s package in a kept folder named by its commit (extracted once)."""
    sha = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--verify", f"{rev}^{{commit}}"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    tree = Path(tempfile.gettempdir()) / f"bowlrec-cold-start-{sha[:12]}"
    if not (tree / "bowlrec" / "__init__.py").is_file():
        archive = subprocess.run(
            ["git", "-C", str(ROOT), "archive", "--format=tar", sha, "bowlrec"],
            check=True,
            capture_output=True,
        ).stdout
        tree.mkdir(parents=True, exist_ok=True)
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            tar.extractall(tree, filter="data")
    return tree


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run(tree: Path) -> dict[str, Any]:
    """One fresh process of the command: wall and CPU seconds, its output."""
    load = os.getloadavg()[0]
    start, cpu = time.perf_counter(), _cpu()
    out = subprocess.run(
        [sys.executable, "-c", ENTRY, *ARGS],
        env=_env(tree),
        cwd=tree,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return {
        "wall_s": time.perf_counter() - start,
        "cpu_s": _cpu() - cpu,
        "load_before": load,
        "output": out,
    }


def _probe(tree: Path) -> dict[str, Any]:
    err = subprocess.run(
        [sys.executable, "-c", PROBE, *ARGS],
        env=_env(tree),
        cwd=tree,
        check=True,
        capture_output=True,
        text=True,
    ).stderr
    result: dict[str, Any] = json.loads(err.strip().splitlines()[-1])
    if Path(result["package"]).parent != tree / "bowlrec":
        raise RuntimeError(f"the child imported {result['package']}, not {tree}")
    return result


def _delivery(output: str) -> list[list[str]]:
    """The numbers of the printed summary, row by row, without the solver's counts and the run
    ID: what stays the same between physics versions (those change the step counts and the ID,
    and move results within the tolerance, far below the printed digits) and between the
    wordings of the table (later versions name the side of the hook and the frame)."""
    return [
        re.findall(r"-?\d+(?:\.\d+)?", line)
        for line in output.splitlines()
        if "solver" not in line and "run ID" not in line
    ]


def _stats(values: list[float]) -> dict[str, float]:
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def measure(before: str, runs: int) -> dict[str, Any]:
    trees = {"after": ROOT, "before": _extract(before)}
    for name, tree in trees.items():
        for _ in range(2):  # warm-up: kernels compiled or loaded, bytecode written
            first = _run(tree)
        print(f"{name} ({tree}): warm-up {first['wall_s']:.2f} s", flush=True)
    raw: dict[str, list[dict[str, Any]]] = {name: [] for name in trees}
    for r in range(runs):
        order = list(trees) if r % 2 == 0 else list(reversed(trees))
        for name in order:
            raw[name].append(_run(trees[name]))
        a, b = raw["after"][-1], raw["before"][-1]
        print(f"round {r + 1}: after {a['wall_s']:.3f} s, before {b['wall_s']:.3f} s", flush=True)
    outputs = {name: {run.pop("output") for run in runs_} for name, runs_ in raw.items()}
    if any(len(out) != 1 for out in outputs.values()):
        raise RuntimeError("a tree printed different summaries in different runs")
    out_after, out_before = outputs["after"].pop(), outputs["before"].pop()
    if _delivery(out_after) != _delivery(out_before):
        raise RuntimeError("the two trees printed different deliveries")
    ratios = {
        key: [a[key] / b[key] for a, b in zip(raw["after"], raw["before"], strict=True)]
        for key in ("wall_s", "cpu_s")
    }
    stats = {
        name: {key: _stats([run[key] for run in runs_]) for key in ("wall_s", "cpu_s")}
        for name, runs_ in raw.items()
    }
    ratio = {key: _stats(values) for key, values in ratios.items()}
    after_wall = stats["after"]["wall_s"]["median"]
    return {
        "before": before,
        "command": "bowlrec " + " ".join(ARGS).replace(str(ROOT) + "/", ""),
        "runs": runs,
        "cpus": os.cpu_count(),
        "machine": platform.processor() or platform.machine(),
        "python": platform.python_version(),
        "loaded": {name: _probe(tree) for name, tree in trees.items()},
        "stats": stats,
        "ratio": ratio,
        "met": {
            "ratio": ratio["wall_s"]["median"] <= TARGET_RATIO,
            "seconds": after_wall <= TARGET_SECONDS,
        },
        "raw": raw,
        "output": out_after,
    }


def _markdown(res: dict[str, Any]) -> str:
    stats, ratio, loaded, met = res["stats"], res["ratio"], res["loaded"], res["met"]
    loads = [run["load_before"] for runs in res["raw"].values() for run in runs]

    def row(label: str, s: dict[str, float]) -> str:
        return f"| {label} | {s['median']:.3f} | {s['min']:.3f} | {s['max']:.3f} |"

    yes = {True: "met", False: "missed"}
    lines = [
        "# Cold start: one delivery in a fresh process",
        "",
        f"`python -m benchmarks.cold_start --before {res['before']} --runs {res['runs']}`: "
        f"`{res['command']}` in a fresh process with numba's kernel cache on disk, this tree "
        f"(after) against {res['before']} (before, the first landed version), {res['runs']} "
        "rounds, each a fresh process of each tree in alternating order, after two uncounted "
        f"runs of each; {res['cpus']} cores ({res['machine']}, Python {res['python']}), "
        f"load average before a run {min(loads):.2f}-{max(loads):.2f} (the machine is shared: "
        "the ratios of the rounds are the steadier measure).",
        "",
        "| seconds, whole process | median | min | max |",
        "|---|---|---|---|",
        row("after, wall", stats["after"]["wall_s"]),
        row("before, wall", stats["before"]["wall_s"]),
        row("after, CPU (user + system)", stats["after"]["cpu_s"]),
        row("before, CPU (user + system)", stats["before"]["cpu_s"]),
        row("after / before, wall (per round)", ratio["wall_s"]),
        row("after / before, CPU (per round)", ratio["cpu_s"]),
        "",
        "| target | measured | |",
        "|---|---|---|",
        f"| wall time <= {TARGET_RATIO}x the first landed version's | "
        f"{ratio['wall_s']['median']:.2f}x (median of the rounds' ratios) | {yes[met['ratio']]} |",
        f"| wall time <= {TARGET_SECONDS:.1f} s | {stats['after']['wall_s']['median']:.2f} s "
        f"(median) | {yes[met['seconds']]} |",
        "",
        "What the command loaded (one more fresh process of each tree):",
        "",
        "| | after | before |",
        "|---|---|---|",
        f"| modules imported | {loaded['after']['modules']} | {loaded['before']['modules']} |",
        f"| of them bowlrec's | {loaded['after']['bowlrec_modules']} "
        f"| {loaded['before']['bowlrec_modules']} |",
        f"| kernels loaded from numba's cache | {len(loaded['after']['kernels_loaded'])} "
        f"| {len(loaded['before']['kernels_loaded'])} |",
        f"| which | {', '.join(loaded['after']['kernels_loaded'])} "
        f"| {', '.join(loaded['before']['kernels_loaded'])} |",
        f"| scipy.linalg imported | {'yes' if loaded['after']['scipy_linalg'] else 'no'} "
        f"| {'yes' if loaded['before']['scipy_linalg'] else 'no'} |",
        "",
        "Both printed the same delivery (outcome, slide, hook, pocket and the rest; the solver's "
        "step counts differ between physics versions). scipy.linalg is imported by numba "
        "itself when a kernel loads (numba.np.arraymath checks for BLAS through scipy's "
        "cython_blas) wherever scipy is installed; scipy is no runtime dependency of bowlrec "
        "(the `pins` and `test` extras bring it).",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=DEFAULT_BEFORE)
    parser.add_argument("--runs", type=int, default=15)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    res = measure(args.before, args.runs)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "cold_start.json").write_text(json.dumps(res, indent=1) + "\n")
    (args.out / "cold_start.md").write_text(_markdown(res))
    print(_markdown(res))


if __name__ == "__main__":
    main()

"""The test tiers from a clean checkout: how many tests each tier holds and how long it takes.

    python benchmarks/test_tiers.py [--workers 2] [--fresh-venv] [--slow] [--keep]
        [--baseline JUNIT.xml [--baseline-note TEXT]] [--out benchmarks/results] [--render]

Clones the current commit (``git clone`` of HEAD: commit first) into a temporary directory,
then, in that clone:

1. **the README's test command** (``python -m pytest -q``: the default tier on ``-n auto``
   workers) with an empty numba cache: its wall time includes the first kernel compile, which
   the conftest's warm-up line reports separately;
2. **the default tier again** with the cache warm, on ``--workers`` workers;
3. **every other tier** as ``.ci/run`` runs it: ``--tier process``, ``--tier fault -n 0``,
   ``--tier browser`` (and ``--tier slow`` with ``--slow``).

Each run writes a JUnit XML file: tests (passed, failed, skipped) and the sum of the test
durations per tier come from it. ``--baseline``: the JUnit XML file of a run of the whole suite
before the tiers; its durations are summed per tier of today's map of old test IDs
(benchmarks/results/test_tiers.ids.tsv) for comparison, beside that run's wall time (pytest's own:
the testsuite's ``time``); ``--baseline-note`` says how it was made.

By default the clone runs with this interpreter (its environment's packages) and
``PYTHONPATH`` set to the clone, so that the clone's ``bowlrec`` (and its empty numba cache) is
the one imported by the tests and by every process they start; ``--fresh-venv`` makes a venv
in the clone with ``pip install -e '.[test]'`` instead (not timed). Writes ``test_tiers.json``
and ``test_tiers.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
IDS = ROOT / "benchmarks" / "results" / "test_tiers.ids.tsv"
WARM_UP = re.compile(r"kernel warm-up: ([\d.]+) s before the first test \((\d+) kernels compiled")


def _git(*args: str, cwd: Path = ROOT) -> str:
    return subprocess.run(
        ["git", *args], cwd=cwd, check=True, capture_output=True, text=True
    ).stdout.strip()


def _clone(dest: Path) -> str:
    head = _git("rev-parse", "HEAD")
    if _git("status", "--porcelain", "--untracked-files=no"):
        print("note: uncommitted changes are not in the clone (it is of HEAD)", file=sys.stderr)
    subprocess.run(["git", "clone", "--quiet", "--no-hardlinks", str(ROOT), str(dest)], check=True)
    subprocess.run(["git", "-C", str(dest), "checkout", "--quiet", head], check=True)
    return head


def _environment(clone: Path, python: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST_", "NUMBA_CACHE"))}
    if python == sys.executable:  # this environment's packages, the clone's bowlrec
        env["PYTHONPATH"] = os.pathsep.join([str(clone), *filter(None, [env.get("PYTHONPATH")])])
    return env


def _junit(path: Path) -> dict[str, Any]:
    """Counts and the sum of test durations (setup + call + teardown) of a JUnit XML file."""
    if not path.exists():
        return {"tests": 0, "passed": 0, "failed": 0, "skipped": 0, "durations_s": 0.0}
    counts: Counter[str] = Counter()
    total = 0.0
    for case in ET.parse(path).getroot().iter("testcase"):
        total += float(case.get("time") or 0.0)
        if case.find("skipped") is not None:
            counts["skipped"] += 1
        elif case.find("failure") is not None or case.find("error") is not None:
            counts["failed"] += 1
        else:
            counts["passed"] += 1
    return {
        "tests": sum(counts.values()),
        "passed": counts["passed"],
        "failed": counts["failed"],
        "skipped": counts["skipped"],
        "durations_s": round(total, 1),
    }


def _run(name: str, args: list[str], clone: Path, python: str, out: Path) -> dict[str, Any]:
    junit = out / f"{name}.xml"
    cmd = [python, "-m", "pytest", "-q", *args, f"--junitxml={junit}", "-p", "no:cacheprovider"]
    print(f"--- {name}: {' '.join(cmd[1:])}", flush=True)
    start = time.perf_counter()
    cpu0 = os.times()
    proc = subprocess.run(
        cmd, cwd=clone, env=_environment(clone, python), capture_output=True, text=True
    )
    wall = time.perf_counter() - start
    cpu1 = os.times()
    (out / f"{name}.log").write_text(proc.stdout + proc.stderr)
    tail = (proc.stdout.strip().splitlines() or [""])[-1]
    print(f"    {wall:.1f} s: {tail}", flush=True)
    warm = WARM_UP.search(proc.stdout)
    return {
        "command": "python -m pytest -q " + " ".join(args),
        "exit_status": proc.returncode,
        "wall_s": round(wall, 1),
        "cpu_s": round(
            (cpu1.children_user - cpu0.children_user)
            + (cpu1.children_system - cpu0.children_system),
            1,
        ),
        "warm_up_s": float(warm.group(1)) if warm else None,
        "kernels_compiled": int(warm.group(2)) if warm else None,
        "summary": tail,
        **_junit(junit),
    }


def _baseline(path: Path) -> dict[str, Any]:
    """The baseline run's test durations summed per tier of today's map of old test IDs."""
    tier_of: dict[str, str] = {}
    if IDS.exists():
        for line in IDS.read_text().splitlines()[1:]:
            old, tier, *_ = line.split("\t")
            tier_of[old] = tier
    sums: dict[str, float] = defaultdict(float)
    counts: Counter[str] = Counter()
    for case in ET.parse(path).getroot().iter("testcase"):
        module = case.get("classname", "").replace(".", "/")
        nodeid = f"{module}.py::{case.get('name')}"
        tier = tier_of.get(nodeid, "not mapped")
        if tier == "-":
            tier = "rewritten since by its owner"
        sums[tier] += float(case.get("time") or 0.0)
        counts[tier] += 1
    tiers = {t: {"tests": counts[t], "durations_s": round(sums[t], 1)} for t in sorted(counts)}
    root = ET.parse(path).getroot()
    suite = root if root.tag == "testsuite" else root.find("testsuite")
    wall = float(suite.get("time") or "nan") if suite is not None else float("nan")
    return {"tiers": tiers, "wall_s": round(wall, 1)}


def _markdown(result: dict[str, Any]) -> str:
    runs = result["runs"]
    lines = [
        "# The test tiers from a fresh clone",
        "",
        f"Measured {result['date']} on {result['machine']}, {result['cores']} cores, "
        f"Python {result['python']}, commit {result['commit'][:10]} "
        f"(`python benchmarks/test_tiers.py{result['options']}`), load average at the start "
        f"{result['load_average']}.",
        "",
        "| run | command | tests (passed / failed / skipped) | wall (s) | sum of test "
        "durations (s) | CPU of the run (s) | kernel warm-up (s) |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, r in runs.items():
        warm = "" if r["warm_up_s"] is None else f"{r['warm_up_s']:.1f}"
        if r["kernels_compiled"]:
            warm += f" ({r['kernels_compiled']} compiled)"
        lines.append(
            f"| {name} | `{r['command'].strip()}` | {r['tests']} ({r['passed']} / {r['failed']} "
            f"/ {r['skipped']}) | {r['wall_s']:.1f} | {r['durations_s']:.1f} | {r['cpu_s']:.1f} "
            f"| {warm} |"
        )
    ci = [runs[n]["wall_s"] for n in ("default (warm)", "process", "fault", "browser") if n in runs]
    lines += [
        "",
        f"The README's command from a fresh clone (first kernel compile included): "
        f"**{runs['README command (cold cache)']['wall_s']:.0f} s** (target: 240 s on a quiet "
        f"2-core machine). The tiers `.ci/run` runs, warm cache: **{sum(ci):.0f} s** "
        "(target: 1,200 s, installs excluded; `.ci/run` also lints and type-checks).",
    ]
    base = result.get("baseline")
    if base:
        note = base.get("note", "")
        lines += [
            "",
            "Baseline: the whole suite in one run before the tiers (what the README's command "
            f"ran then){f', {note}' if note else ''}: **{base['wall_s']:.0f} s** (pytest's "
            "own wall time, first kernel compile included). Its test durations summed per tier "
            "of the same tests today (its first test's setup holds that run's kernel compile; a "
            "test skipped there counts 0 s):",
            "",
            "| tier | tests | sum of durations (s) |",
            "|---|---|---|",
        ]
        for tier, b in base["tiers"].items():
            lines.append(f"| {tier} | {b['tests']} | {b['durations_s']:.1f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", default="2", help="-n of the warm default-tier run")
    parser.add_argument("--fresh-venv", action="store_true", help="a venv of the clone's own")
    parser.add_argument("--slow", action="store_true", help="also run --tier slow")
    parser.add_argument("--keep", action="store_true", help="keep the clone (its logs, XML)")
    parser.add_argument("--baseline", type=Path, help="JUnit XML of a run before the tiers")
    parser.add_argument(
        "--baseline-note", default="", help="how the baseline was run (commit, machine, cache)"
    )
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument(
        "--render", action="store_true", help="only rewrite the .md from the .json (and --baseline)"
    )
    args = parser.parse_args()
    if args.render:
        result = json.loads((args.out / "test_tiers.json").read_text())
        if args.baseline:
            result["baseline"] = {**_baseline(args.baseline), "note": args.baseline_note}
            (args.out / "test_tiers.json").write_text(json.dumps(result, indent=2) + "\n")
        (args.out / "test_tiers.md").write_text(_markdown(result))
        return

    work = Path(tempfile.mkdtemp(prefix="bowlrec-tiers-"))
    clone = work / "bowlrec"
    logs = work / "logs"
    logs.mkdir()
    commit = _clone(clone)
    python = sys.executable
    if args.fresh_venv:
        subprocess.run([sys.executable, "-m", "venv", str(clone / ".venv")], check=True)
        python = str(clone / ".venv" / "bin" / "python")
        subprocess.run(
            [python, "-m", "pip", "install", "-q", "-e", ".[test]"], cwd=clone, check=True
        )
    options = "".join(
        f" {flag}"
        for flag, on in (
            (f"--workers {args.workers}", args.workers != "2"),
            ("--fresh-venv", args.fresh_venv),
            ("--slow", args.slow),
        )
        if on
    )
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    runs: dict[str, Any] = {}
    try:
        runs["README command (cold cache)"] = _run("readme", [], clone, python, logs)
        runs["default (warm)"] = _run("default", ["-n", args.workers], clone, python, logs)
        runs["process"] = _run("process", ["--tier", "process"], clone, python, logs)
        runs["fault"] = _run("fault", ["--tier", "fault", "-n", "0"], clone, python, logs)
        runs["browser"] = _run("browser", ["--tier", "browser"], clone, python, logs)
        if args.slow:
            runs["slow"] = _run("slow", ["--tier", "slow"], clone, python, logs)
    finally:
        if args.keep:
            print(f"the clone, its logs and JUnit files: {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    result = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": platform.machine(),
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "commit": commit,
        "options": options,
        "load_average": " ".join(f"{x:.2f}" for x in load),
        "runs": runs,
        "baseline": (
            {**_baseline(args.baseline), "note": args.baseline_note} if args.baseline else None
        ),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "test_tiers.json").write_text(json.dumps(result, indent=2) + "\n")
    (args.out / "test_tiers.md").write_text(_markdown(result))
    print(_markdown(result))


if __name__ == "__main__":
    main()

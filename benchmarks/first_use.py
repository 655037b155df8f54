"""First use: each command's wait for the compiler in a fresh cache, and after ``bowlrec warm``.

    python -m benchmarks.first_use [--out benchmarks/results] [--only NAME ...]

A snapshot of the package and the examples is copied to a scratch directory (edits of the
working tree during the run change nothing) and every process runs there with an empty HOME
and its own ``NUMBA_CACHE_DIR``:

1. **After ``bowlrec warm``**: ``bowlrec warm`` in an empty cache (it compiles every variant),
   ``bowlrec warm`` again (it loads only), then each command of :data:`COMMANDS` against that
   cache: its wall time, and whether it printed the first-use notice (it must not).
2. **First use**: each command in an empty cache of its own: its wall time, whether it printed
   the first-use notice (it must), the variants it left in the cache (``bowlrec.core.warm.
   missing`` afterwards: what it compiled), and its wall time run again in that cache.

One run each (a cold compile takes minutes); the load average of the machine is recorded before
each. Writes ``first_use.json`` and ``first_use.md`` after every command (a partial run keeps
what it measured).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
NOTICE = "first use: compiling"
#: name -> the command's arguments (run in the snapshot's directory; OUT: a scratch directory)
COMMANDS: dict[str, list[str]] = {
    "batch": ["batch", "examples/jobs/speed-rev-grid.json", "--no-archive", "--out", "OUT/g.csv"],
    "variance": ["variance", "examples/bowler/pocket-right.json", "--n", "2000"],
    "simulate (bowler)": ["simulate", "examples/bowler/house-shot-right.json", "--no-archive"],
    "simulate": ["simulate", "examples/scene.yaml", "--no-archive"],
    "paper": ["paper"],
    "aim": ["aim", "examples/bowler/pocket-right.json", "-v", "speed", "-v", "target"],
    "tolerance": ["tolerance", "examples/bowler/pocket-right.json"],
    "plot": ["plot", "examples/paper/case09.json", "-o", "OUT/fig.png"],
    "pins": ["pins", "examples/bowler/pocket-right.json", "--no-archive"],
    "session": ["session", "examples/session/league-night.yaml", "--out", "OUT/session"],
    "demo": ["demo"],
}
TIMEOUT_S = 1800


def _snapshot(tmp: Path) -> Path:
    snap = tmp / "snap"
    ignore = shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc")
    shutil.copytree(ROOT / "bowlrec", snap / "bowlrec", ignore=ignore)
    shutil.copytree(ROOT / "examples", snap / "examples", ignore=ignore)
    return snap


def _seed(source: Path, cache: Path, snap: Path) -> None:
    """Copy numba's entries and bowlrec's stamp from ``source`` to where numba looks for the
    snapshot's ``bowlrec/core`` under ``NUMBA_CACHE_DIR`` = ``cache`` (numba's index keys hold
    no paths, and its source stamps are content hashes)."""
    core = snap / "bowlrec" / "core"
    target = cache / f"core_{hashlib.sha1(str(core).encode()).hexdigest()}"
    target.mkdir(parents=True)
    for f in source.iterdir():
        if f.suffix in (".nbi", ".nbc") or f.name == "bowlrec-kernel-deps.json":
            shutil.copy2(f, target / f.name)


def _env(tmp: Path, snap: Path, cache: Path) -> dict[str, str]:
    home = tmp / "home"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("BOWLREC_", "NUMBA_"))}
    env.update(HOME=str(home), PYTHONPATH=str(snap), NUMBA_CACHE_DIR=str(cache))
    for var, sub in (("XDG_CACHE_HOME", ".cache"), ("XDG_DATA_HOME", ".local/share")):
        (home / sub).mkdir(parents=True, exist_ok=True)
        env[var] = str(home / sub)
    return env


def _run(args: list[str], env: dict[str, str], snap: Path, out: Path) -> dict[str, Any]:
    out.mkdir(parents=True, exist_ok=True)
    argv = [a.replace("OUT", str(out)) for a in args]
    load = os.getloadavg()[0]
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "bowlrec.cli", *argv],
        env=env,
        cwd=snap,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    wall = time.perf_counter() - start
    notices = [line for line in proc.stderr.splitlines() if line.startswith(NOTICE)]
    return {
        "wall_s": round(wall, 1),
        "returncode": proc.returncode,
        "notice": notices[0] if notices else None,
        "load_before": round(load, 1),
        "stdout_tail": proc.stdout.strip().splitlines()[-1:] if proc.stdout.strip() else [],
        "stderr_tail": proc.stderr.strip().splitlines()[-3:] if proc.returncode else [],
    }


def _left(env: dict[str, str], snap: Path) -> list[str]:
    code = "import json; from bowlrec.core.warm import missing; print(json.dumps(missing()))"
    proc = subprocess.run(
        [sys.executable, "-c", code], env=env, cwd=snap, capture_output=True, text=True
    )
    return list(json.loads(proc.stdout)) if proc.returncode == 0 else ["?"]


def _notice(run: dict[str, Any]) -> str:
    """yes/no; "-" for a run whose notice was not recorded (a run of other sources)."""
    return "-" if "notice" not in run else ("yes" if run["notice"] else "no")


def _markdown(doc: dict[str, Any]) -> str:
    lines = [
        f"Measured {doc['date']} on {doc['machine']} (`python -m benchmarks.first_use`): one "
        "run each, in an empty HOME with its own `NUMBA_CACHE_DIR`, on a shared machine (load "
        "average before each run in the tables; wall times under load are longer than on an "
        "idle machine). The parts may come from separate invocations (`--only`, `--skip-cold`, "
        "`--skip-warm`) of the same sources.",
        "",
    ]
    w = doc.get("warm", {})
    if doc.get("seeded"):
        lines += [
            "The cache of the `bowlrec warm` part was seeded with the entries a full warm-up "
            "of the same sources wrote (`--seed-cache`): its first `bowlrec warm` loads only. "
            "A cold `bowlrec warm` compiles every variant: 154 s on 2 idle cores "
            "([kernel_cache.md](kernel_cache.md), the same variants and the RK4 scheme).",
            "",
        ]
    if w:
        lines += ["## `bowlrec warm`", "", "| run | wall (s) | load | printed |"]
        lines += ["|---|---|---|---|"]
        for key in ("first", "again"):
            if key in w:
                r = w[key]
                printed = " ".join(r["stdout_tail"])
                lines.append(f"| {key} | {r['wall_s']} | {r['load_before']} | {printed} |")
        lines.append("")
    lines += [
        "## Each command",
        "",
        "First use: in an empty cache; again: the same cache, run again; after `bowlrec warm`:"
        " a cache `bowlrec warm` filled. Compiled: the variants the first use built. Notice: "
        "whether the first-use line was printed (-: not recorded, a run of earlier sources of "
        "the command line, the same kernels).",
        "",
        "| command | first use (s) | load | notice | compiled | again (s) | after `bowlrec "
        "warm` (s) | notice after warm |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name in COMMANDS:
        c = doc["cold"].get(name)
        a = doc["after_warm"].get(name)
        if c is None and a is None:
            continue
        cells = [f"`bowlrec {' '.join(COMMANDS[name][:1])}`" + (" (bowler)" if "(" in name else "")]
        if c is not None:
            ok = "" if c["first"]["returncode"] == 0 else f" (exit {c['first']['returncode']})"
            cells += [
                f"{c['first']['wall_s']}{ok}",
                str(c["first"]["load_before"]),
                _notice(c["first"]),
                ", ".join(c["compiled"]) or "none",
                str(c["again"]["wall_s"]),
            ]
        else:
            cells += ["", "", "", "", ""]
        if a is not None:
            cells += [str(a["wall_s"]), _notice(a)]
        else:
            cells += ["", ""]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--only", nargs="*", help="commands of COMMANDS (default: all)")
    parser.add_argument("--skip-warm", action="store_true", help="no 'after bowlrec warm' part")
    parser.add_argument("--skip-cold", action="store_true", help="no 'first use' part")
    parser.add_argument(
        "--seed-cache",
        type=Path,
        help="copy numba's entries of bowlrec/core from this directory into the cache of the "
        "'after bowlrec warm' part first (its first 'bowlrec warm' then loads only)",
    )
    args = parser.parse_args(argv)
    names = args.only or list(COMMANDS)
    doc: dict[str, Any] = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}",
        "warm": {},
        "after_warm": {},
        "cold": {},
        "seeded": args.seed_cache is not None,
    }

    def save() -> None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "first_use.json").write_text(json.dumps(doc, indent=1) + "\n")
        (args.out / "first_use.md").write_text(_markdown(doc))

    with tempfile.TemporaryDirectory(prefix="bowlrec-first-use-") as tmp_name:
        tmp = Path(tmp_name)
        snap = _snapshot(tmp)
        if not args.skip_warm:
            env = _env(tmp, snap, tmp / "cache-warm")
            if args.seed_cache is not None:
                _seed(args.seed_cache, tmp / "cache-warm", snap)
            for key in ("first", "again"):
                doc["warm"][key] = _run(["warm"], env, snap, tmp / "out")
                save()
            for name in names:
                doc["after_warm"][name] = _run(COMMANDS[name], env, snap, tmp / "out" / "w")
                save()
        for i, name in enumerate([] if args.skip_cold else names):
            env = _env(tmp, snap, tmp / f"cache-{i}")
            first = _run(COMMANDS[name], env, snap, tmp / "out" / str(i))
            left = _left(env, snap)
            from_all = ("closed_form", "integrator", "steps", "rate", "observe")
            all_names = (*from_all, "batch_serial", "batch_parallel")
            compiled = [n for n in all_names if n not in left]
            again = _run(COMMANDS[name], env, snap, tmp / "out" / str(i))
            doc["cold"][name] = {"first": first, "compiled": compiled, "again": again}
            save()
            print(name, first["wall_s"], again["wall_s"], compiled, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

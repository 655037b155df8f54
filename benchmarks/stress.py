"""The heavy numerical stress variants (``pytest -m slow``), run and recorded.

    python -m benchmarks.stress [--out benchmarks/results] [--update-docs]

CI runs the light versions of the property-based stress tests (``tests/test_stress_*.py``); their
heavy variants (hundreds of random legal and beyond-legal deliveries at many tolerances: no
NaN/inf, energy and friction work, unit quaternion, mirror and body-frame relabelling
invariance) take minutes and are marked ``slow``. This runs them, and writes every test's
outcome and duration to ``stress.json`` and ``stress.md`` (``--update-docs``: also into the
``stress`` block of docs/validation.md). Exit status: pytest's.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def run(out: Path, update_docs: bool = False) -> int:
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "junit.xml"
        t0 = time.perf_counter()
        proc = subprocess.run(
            [
                *(sys.executable, "-m", "pytest", "-q", "-m", "slow"),
                *("tests/test_stress_properties.py", f"--junitxml={report}"),
            ],
            cwd=ROOT,
            check=False,
        )
        wall = time.perf_counter() - t0
        tests: list[dict[str, Any]] = []
        for case in ET.parse(report).getroot().iter("testcase"):
            outcome = "passed"
            for tag in ("failure", "error", "skipped"):
                if case.find(tag) is not None:
                    outcome = {"failure": "failed", "error": "error", "skipped": "skipped"}[tag]
            tests.append(
                {
                    "test": f"{case.get('classname')}::{case.get('name')}",
                    "outcome": outcome,
                    "seconds": float(case.get("time", 0.0)),
                }
            )
    doc = {
        "python": platform.python_version(),
        "returncode": proc.returncode,
        "wall_s": wall,
        "tests": tests,
    }
    (out / "stress.json").write_text(json.dumps(doc, indent=1))
    lines = ["| heavy stress test (`-m slow`) | outcome | seconds |", "|---|---|---|"]
    lines += [f"| `{t['test']}` | {t['outcome']} | {t['seconds']:.0f} |" for t in tests]
    table = "\n".join(lines) + "\n"
    (out / "stress.md").write_text(table)
    if update_docs:
        from tools.readme_blocks import block_path, replace_block

        replace_block(block_path("stress"), "stress", table)
    print(table)
    return proc.returncode


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument(
        "--update-docs", action="store_true", help="rewrite the table in docs/validation.md"
    )
    args = ap.parse_args(argv)
    return run(args.out, args.update_docs)


if __name__ == "__main__":
    raise SystemExit(main())

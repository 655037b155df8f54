"""Costs of the archive and replay formats, and of starting bowlrec.

    python -m benchmarks.formats [--update-docs] [--out benchmarks/results]

Measures, on this machine:
- start-up in fresh processes: ``import bowlrec``, ``bowlrec --help``, ``bowlrec simulate`` of one
  scene from a cold shell (kernels loaded from the on-disk cache) with and without archiving,
  and which heavy modules each of them loads (none of rerun, mcap, foxglove, matplotlib may);
- writing one run to each format (HDF5 run file through the archive, MCAP, rerun .rrd, PNG
  plot): milliseconds (median of repeats) and bytes, for a 2.5 s delivery sampled every 1 ms,
  with and without per-term torques, and a summary-only run into the archive.

Writes ``formats.json`` and ``formats.md``; ``--update-docs`` puts the table in docs/replay.md
between ``<!-- formats:begin -->`` and ``<!-- formats:end -->``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tools.readme_blocks import block_path, replace_block

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "h5py", "rerun", "mcap", "foxglove", "matplotlib", "scipy", "pydantic")


def _wall(cmd: list[str], env: dict[str, str], repeats: int = 5) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, env=env)
        best = min(best, time.perf_counter() - t0)
    return best


def _loaded(code: str, env: dict[str, str]) -> list[str]:
    probe = f"import sys\n{code}\nprint(','.join(m for m in {HEAVY!r} if m in sys.modules))"
    out = (
        subprocess.run(
            [sys.executable, "-c", probe], check=True, capture_output=True, text=True, env=env
        )
        .stdout.strip()
        .splitlines()
    )
    return [m for m in (out[-1].split(",") if out else []) if m]


def startup(tmp: Path) -> dict[str, Any]:
    """Best-of-5 wall times (s) of fresh processes and the heavy modules they load."""
    env = dict(os.environ, BOWLREC_ARCHIVE=str(tmp / "startup-archive"))
    exe = sys.executable
    scene = str(ROOT / "examples" / "paper" / "case16.json")
    cli = [exe, "-m", "bowlrec.cli"]
    subprocess.run([*cli, "simulate", scene, "--no-archive"], check=True, capture_output=True)
    help_code = (
        "from typer.testing import CliRunner\nfrom bowlrec.cli import app\n"
        "CliRunner().invoke(app, ['--help'])"
    )
    return {
        "python_startup_s": _wall([exe, "-c", "pass"], env),
        "import_bowlrec_s": _wall([exe, "-c", "import bowlrec"], env),
        "cli_help_s": _wall([*cli, "--help"], env),
        "cli_simulate_no_archive_s": _wall([*cli, "simulate", scene, "--no-archive", "-q"], env),
        # the first call archives the run; the repeats find it archived (content ID) and reuse it
        "cli_simulate_archive_s": _wall([*cli, "simulate", scene, "-q"], env),
        "modules_after_import_bowlrec": _loaded("import bowlrec", env),
        "modules_after_cli_help": _loaded(help_code, env),
    }


def _median_ms(fn: Callable[[int], Path | None], repeats: int) -> tuple[float, int]:
    times, size = [], 0
    for i in range(repeats):
        t0 = time.perf_counter()
        path = fn(i)
        times.append(time.perf_counter() - t0)
        if path is not None:
            size = path.stat().st_size
    return 1e3 * statistics.median(times), size


def writers(tmp: Path, repeats: int) -> list[dict[str, Any]]:
    """ms per run (median) and bytes per run for each format."""
    import bowlrec
    from bowlrec.archive import Archive
    from bowlrec.figures.trajectory import plot_runs
    from bowlrec.sinks import RunData
    from bowlrec.sinks.mcap_file import write_mcap
    from bowlrec.sinks.rerun_recording import write_rrd
    from bowlrec.spec import Scene

    rows: list[dict[str, Any]] = []
    for label, options in (
        ("1 ms samples", {"record": "rate", "record_dt_s": 0.001}),
        ("1 ms samples + torques", {"record": "rate", "record_dt_s": 0.001, "record_terms": True}),
        ("summary only", {"record": "summary"}),
    ):
        scene = Scene.model_validate({"name": "bench", "options": options})
        traj = bowlrec.simulate(scene)
        run = RunData(scene, scene.resolve(), traj)

        def archive_add(i: int, run: RunData = run, label: str = label) -> Path:
            archive = Archive(tmp / f"archive-{label}-{i}")
            return archive.add(run, wall_time_s=0.0).path

        row: dict[str, Any] = {"run": label, "samples": traj.n_samples}
        row["hdf5_ms"], row["hdf5_bytes"] = _median_ms(archive_add, repeats)
        if traj.n_samples:
            row["mcap_ms"], row["mcap_bytes"] = _median_ms(
                lambda i, run=run: write_mcap(run, tmp / f"r{i}.mcap"), repeats
            )
            row["rrd_ms"], row["rrd_bytes"] = _median_ms(
                lambda i, run=run: write_rrd(run, tmp / f"r{i}.rrd"), repeats
            )
            row["png_ms"], row["png_bytes"] = _median_ms(
                lambda i, run=run: plot_runs([run], tmp / f"r{i}.png"), max(2, repeats // 2)
            )
        rows.append(row)
    return rows


def listing(tmp: Path, n: int = 10_000) -> dict[str, float]:
    """Time to list and filter ``n`` runs: one real summary-only run stored ``n`` times under
    distinct IDs (one segment), its hook varied; listing reads only the index."""
    import dataclasses

    import bowlrec
    from bowlrec.archive import Archive
    from bowlrec.sinks import RunData
    from bowlrec.spec import Scene

    scene = Scene.model_validate({"options": {"record": "summary"}})
    archive = Archive(tmp / "listing")
    run = RunData(scene, scene.resolve(), bowlrec.simulate(scene), "0" * 20)
    template = archive.record(run, wall_time_s=0.0)
    builder = archive.builder()
    for i in range(n):
        summary = dataclasses.replace(template.summary, hook_m=(i % 100) / 100)
        builder.append(dataclasses.replace(template, run_id=f"{i:020x}", summary=summary))
    archive.register([archive.seal(builder)])
    t0 = time.perf_counter()
    rows = archive.list_runs()
    t_all = time.perf_counter() - t0
    t0 = time.perf_counter()
    picked = archive.list_runs(outcome="pins", where=["hook_m>=0.5"])
    t_filter = time.perf_counter() - t0
    return {
        "runs": float(len(rows)),
        "list_all_s": t_all,
        "matched": float(len(picked)),
        "list_filtered_s": t_filter,
    }


def _markdown(doc: dict[str, Any]) -> str:
    s = doc["startup"]
    lines = [
        f"Measured {doc['date']} on {doc['machine']} (`python -m benchmarks.formats`).",
        "",
        "| start-up (fresh process, best of 5) | s |",
        "|---|---|",
        f"| `python -c pass` | {s['python_startup_s']:.3f} |",
        f"| `import bowlrec` | {s['import_bowlrec_s']:.3f} |",
        f"| `bowlrec --help` | {s['cli_help_s']:.3f} |",
        f"| `bowlrec simulate case16.json --no-archive` (cached kernels) | "
        f"{s['cli_simulate_no_archive_s']:.3f} |",
        f"| `bowlrec simulate case16.json` (archived run reused) | "
        f"{s['cli_simulate_archive_s']:.3f} |",
        "",
        f"Heavy modules loaded by `import bowlrec`: "
        f"{', '.join(s['modules_after_import_bowlrec']) or 'none'}; by `bowlrec --help`: "
        f"{', '.join(s['modules_after_cli_help']) or 'none'} (of {', '.join(HEAVY)}).",
        "",
        "| run (default scene, 2.48 s) | samples | HDF5 archive add | MCAP | rerun .rrd "
        "| PNG plot |",
        "|---|---|---|---|---|---|",
    ]

    def cell(row: dict[str, Any], key: str) -> str:
        if f"{key}_ms" not in row:
            return "-"
        return f"{row[f'{key}_ms']:.0f} ms, {row[f'{key}_bytes'] / 1024:.0f} KiB"

    for row in doc["writers"]:
        lines.append(
            f"| {row['run']} | {row['samples']} | {cell(row, 'hdf5')} | {cell(row, 'mcap')} | "
            f"{cell(row, 'rrd')} | {cell(row, 'png')} |"
        )
    lst = doc["listing"]
    lines += [
        "",
        "HDF5 times are a durable archive add: a one-run segment written and fsynced, and its "
        "index registration. "
        f"Listing {lst['runs']:.0f} runs from the index: {1e3 * lst['list_all_s']:.0f} ms "
        f"(all rows), {1e3 * lst['list_filtered_s']:.0f} ms (outcome and hook filter, "
        f"{lst['matched']:.0f} rows).",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument(
        "--update-docs", action="store_true", help="rewrite the table in docs/replay.md"
    )
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        doc = {
            "date": time.strftime("%Y-%m-%d"),
            "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
            f"Python {platform.python_version()}",
            "startup": startup(tmp),
            "writers": writers(tmp, args.repeats),
            "listing": listing(tmp),
        }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "formats.json").write_text(json.dumps(doc, indent=2) + "\n")
    table = _markdown(doc)
    (args.out / "formats.md").write_text(table)
    if args.update_docs:
        replace_block(block_path("formats"), "formats", table)
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

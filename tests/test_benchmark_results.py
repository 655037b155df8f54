"""The benchmark tables of README.md and docs/ are the committed result files, not hand edits."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from tools.readme_blocks import block_path, read_block

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"


@pytest.mark.parametrize(
    ("block", "table"),
    [("bench", "work_precision.md"), ("formats", "formats.md"), ("stress", "stress.md")],
)
def test_docs_block_is_the_committed_result_table(block: str, table: str) -> None:
    assert read_block(block_path(block), block) == (RESULTS / table).read_text()


def test_committed_heavy_stress_run_passed() -> None:
    doc = json.loads((RESULTS / "stress.json").read_text())
    assert doc["returncode"] == 0 and len(doc["tests"]) >= 3
    assert all(t["outcome"] == "passed" for t in doc["tests"])


def test_committed_targets_match_the_measured_numbers() -> None:
    """The 'met' column of docs/performance.md's target table follows from the JSON's numbers
    (medians throughout; comparisons at equal hook, pocket and slide error)."""
    from benchmarks.work_precision import TARGET_US

    doc = json.loads((RESULTS / "work_precision.json").read_text())
    best = doc["fastest_bowlrec_meeting_targets"]
    targets = doc["targets"]
    assert best["hook_mm"]["max"] <= targets["hook_mm"]
    assert best["pocket_deg"]["max"] <= targets["pocket_deg"]
    assert best["slide_mm"]["max"] <= targets["slide_mm"]
    met = {
        "full model": best["time_median_us"] <= TARGET_US,
        "batch": doc["throughput"]["summary_all_threads_median_per_s"] >= 30000.0,
        "`bowlrec simulate`": doc["startup"]["cli_simulate_cold_shell_s"] <= 1.5,
    }
    for method, speed in doc["speedups"].items():
        assert speed, method
        for s in speed:  # bowlrec's errors are at most the other method's, on all three
            for key in ("hook_mm", "pocket_deg", "slide_mm"):
                assert s["bowlrec"][key] is None or s["bowlrec"][key] <= s[key], (method, key)
    rows = read_block(block_path("bench"), "bench").splitlines()[2:]
    said = {}
    for row in rows:
        if not row.startswith("|"):
            break
        said[row.split("|")[1].strip()] = row.rstrip(" |").rsplit("|", 1)[1].strip() == "yes"
    for start, value in met.items():
        hits = [v for k, v in said.items() if k.startswith(start)]
        assert hits == [value], start


def _targets_table(markdown: str) -> str:
    lines = markdown.splitlines()
    start = lines.index("| target | limit | measured | met |")
    end = start
    while end < len(lines) and lines[end].startswith("|"):
        end += 1
    return "\n".join(lines[start:end]) + "\n"


def test_archive_format_doc_shows_the_committed_archive_targets() -> None:
    """docs/archive-format.md's cost table is the committed benchmark's, and each 'met' cell
    follows from the measured number and its limit in archive.json."""
    table = _targets_table((RESULTS / "archive.md").read_text())
    assert read_block(block_path("archive-targets"), "archive-targets") == table
    doc = json.loads((RESULTS / "archive.json").read_text())
    assert doc["build"]["runs_indexed"] >= 1_000_000  # committed from the full-size run
    assert doc["archive_path"]["runs"] >= 100_000 and doc["archive_path"]["repeats"] >= 3
    for target in doc["targets"]:
        op, limit_text = target["target"].split()[:2]
        limit = float(limit_text)
        at_least = op == ">="
        met = target["measured"] >= limit if at_least else target["measured"] <= limit
        assert target["met"] == met, target["key"]
        row = next(r for r in table.splitlines() if r.startswith(f"| {target['what']} |"))
        assert row.rstrip(" |").endswith("yes") == target["met"], row


def test_pipeline_doc_and_readme_show_the_committed_pipeline_run() -> None:
    """docs/pipeline.md's targets and the README's headline are the committed benchmark's,
    from its full-size run, and each 'met' follows from the measured number and its limit."""
    doc = json.loads((RESULTS / "pipeline.json").read_text())
    assert not doc["quick"] and doc["runs"] >= 200_000
    table = _targets_table((RESULTS / "pipeline.md").read_text())
    assert read_block(block_path("pipeline-targets"), "pipeline-targets") == table
    assert read_block(block_path("pipeline-headline"), "pipeline-headline") == doc["headline"]
    for target in doc["targets"]:
        either = target.get("or", {"measured": 0.0, "limit": math.inf})  # a second limit
        met = target["measured"] >= target["limit"] or either["measured"] >= either["limit"]
        assert target["met"] == met, target["key"]
        row = next(r for r in table.splitlines() if r.startswith(f"| {target['what']} |"))
        assert row.rstrip(" |").endswith("yes") == target["met"], row


@pytest.mark.parametrize("name", ["core_layout", "core_observe"])
def test_core_layout_results_follow_from_their_numbers(name: str) -> None:
    """benchmarks/results/NAME.md is made from NAME.json: each ratio is after / before of the
    medians, each 'met' cell follows from it, and the right-hand-side counts of the two
    revisions are equal (the same arithmetic). core_layout: the core split into modules;
    core_observe: the kernel with observation events against the one without."""
    doc = json.loads((RESULTS / f"{name}.json").read_text())
    med, ratio = doc["median"], doc["ratio"]
    for key, value in ratio.items():
        assert value == pytest.approx(med["after"][key] / med["before"][key], rel=1e-12)
    for key in ("n_rhs_rtol_0.0002", "n_rhs_rtol_2e-06"):
        assert med["after"][key] == med["before"][key]
    rows = [r for r in (RESULTS / f"{name}.md").read_text().splitlines() if r.startswith("| ")]
    met = {r.split("|")[1].strip(): r.rstrip(" |").rsplit("|", 1)[1].strip() for r in rows[1:]}
    limits = {
        "first compile, fresh process (s)": ("first_compile_s", 1.05),
        "cold start, cache on disk (s)": ("cold_start_s", 1.05),
        "kernel, median per delivery, rtol 2e-4 (us)": ("kernel_median_us_rtol_0.0002", 1.03),
        "kernel, median per delivery, rtol 2e-6 (us)": ("kernel_median_us_rtol_2e-06", 1.03),
    }
    for label, (key, limit) in limits.items():
        assert met[label] == ("yes" if ratio[key] <= limit else "no"), label


def test_cold_start_results_follow_from_their_numbers() -> None:
    """benchmarks/results/cold_start.*: the ratios are the rounds', the verdicts the targets'."""
    import statistics

    from benchmarks.cold_start import TARGET_RATIO, TARGET_SECONDS, _markdown

    doc = json.loads((RESULTS / "cold_start.json").read_text())
    raw, ratio = doc["raw"], doc["ratio"]
    walls = [a["wall_s"] / b["wall_s"] for a, b in zip(raw["after"], raw["before"], strict=True)]
    assert len(walls) == doc["runs"]
    assert ratio["wall_s"]["median"] == pytest.approx(statistics.median(walls), rel=1e-12)
    after = statistics.median(run["wall_s"] for run in raw["after"])
    assert doc["met"] == {
        "ratio": ratio["wall_s"]["median"] <= TARGET_RATIO,
        "seconds": after <= TARGET_SECONDS,
    }
    assert (RESULTS / "cold_start.md").read_text() == _markdown(doc)

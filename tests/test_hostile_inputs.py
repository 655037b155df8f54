"""Hostile inputs over the CLI and HTTP: mutations of every leaf of the example scenes and jobs
(:mod:`hostile_inputs`) must give zero tracebacks, zero 5xx, zero non-finite values in JSON
output, bounded memory and time, and errors that name the file or the field.

Channels (:mod:`hostile_child`): the CLI in-process (Typer's CliRunner) and the ASGI app
in-process (TestClient), each in a guarded worker process (address space capped, peak-RSS growth
checked per input, killed and restarted after a per-input deadline); real ``bowlrec``
subprocesses; a real ``bowlrec serve`` on 127.0.0.1.

Default run: a deterministic stratified sample (every mutation kind and every example at least
once; ~400 inputs per in-process channel, ~26 per real-process channel), the four channels run
concurrently. ``-m slow``: every mutation over every channel (~5,600 inputs per channel; a plain
run skips these, as the other heavy variants of the suite do); the in-process channels alone:
``-m slow -k "full_cli or full_http"``.

Every test collects all failures and reports them together, grouped by symptom, one line per
failing input id (``<file>:<json path>:<kind>``); the full results are also written as JSON to
``$BOWLREC_HOSTILE_REPORT_DIR`` (default: the test's temporary directory, path printed), and
each result is appended to ``<basetemp>/hostile-*/<channel>/results.jsonl`` as it comes.

Knobs (environment): BOWLREC_HOSTILE_SAMPLE (in-process sample size, default 400),
BOWLREC_HOSTILE_PROC_SAMPLE (real-process sample size, default 20, plus a few kinds always
included), BOWLREC_HOSTILE_ALL_TWINS=1 (every mutation on each of the 18 identically shaped
Table III files), BOWLREC_HOSTILE_MEM_GB (address-space cap, default 6),
BOWLREC_HOSTILE_SOFT_S (seconds before a huge sweep is interrupted, default 6),
BOWLREC_HOSTILE_ONLY (a regex: only the ids it matches).
"""

from __future__ import annotations

import collections
import json
import math
import os
import re
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest
from helpers import hostile_child as hc
from helpers import hostile_inputs as hi

HERE = Path(__file__).resolve().parent

pytest.importorskip("fastapi")
pytest.importorskip("httpx")

SAMPLE = int(os.environ.get("BOWLREC_HOSTILE_SAMPLE", "400"))
PROC_SAMPLE = int(os.environ.get("BOWLREC_HOSTILE_PROC_SAMPLE", "20"))
ONLY = os.environ.get("BOWLREC_HOSTILE_ONLY")


def _select(items: list[hi.Mutation]) -> list[hi.Mutation]:
    return [m for m in items if re.search(ONLY, m.id)] if ONLY else items


def sample_ids(channel: str) -> list[str]:
    """The default run's in-process sample (deterministic, stratified)."""
    ms = hi.stratified_sample(hi.mutations(channel), SAMPLE, max_jobs=SAMPLE // 12)
    return [m.id for m in _select(ms)]


def proc_sample_ids(channel: str) -> list[str]:
    """The default run's real-process sample: fewer inputs, jobs capped at a quarter."""
    ms = hi.mutations(channel)
    per_kind = hi.stratified_sample(ms, 0, salt="proc")  # the per-kind/example picks alone
    jobs = [m for m in per_kind if m.target == "job"]
    scenes = [m for m in per_kind if m.target == "scene"]
    n_jobs = PROC_SAMPLE // 4
    picked = jobs[:: max(1, len(jobs) // n_jobs)][:n_jobs]
    picked += scenes[:: max(1, len(scenes) // (PROC_SAMPLE - len(picked)))][
        : PROC_SAMPLE - len(picked)
    ]
    # the inputs most likely to hurt a process: always in the sample when they exist
    for kind in ("yaml_alias_bomb", "rate_dt_1e-8", "deep_list", "n_1e7", "int_huge", "nan"):
        m = next((m for m in ms if m.kind == kind), None)
        if m is not None and m not in picked:
            picked.append(m)
    order = {m.id: i for i, m in enumerate(ms)}
    return [m.id for m in sorted(_select(picked), key=lambda m: order[m.id])]


def full_ids(channel: str) -> list[str]:
    return [m.id for m in _select(list(hi.mutations(channel)))]


# -- running the channels ----------------------------------------------------------------------


def _progress_file(workdir: Path) -> Callable[[int, dict[str, Any]], None]:
    """Append each result to WORKDIR/results.jsonl as it comes (to follow a long sweep)."""
    workdir.mkdir(parents=True, exist_ok=True)
    path = workdir / "results.jsonl"

    def write(_i: int, result: dict[str, Any]) -> None:
        with path.open("a") as fh:
            fh.write(json.dumps(result) + "\n")

    return write


def run_in_process(channel: str, ids: list[str], workdir: Path) -> dict[str, Any]:
    t0 = time.monotonic()
    out = hc.run_in_process(channel, ids, workdir, progress=_progress_file(workdir))
    out["elapsed_s"] = time.monotonic() - t0
    return out


def run_subprocesses(ids: list[str], workdir: Path) -> dict[str, Any]:
    t0 = time.monotonic()
    table = hi.by_id("cli")
    progress = _progress_file(workdir)
    results = []
    for mid in ids:
        t1 = time.monotonic()
        probs = hc.subprocess_problems(table[mid], workdir)
        results.append({"id": mid, "problems": probs, "elapsed_s": time.monotonic() - t1})
        progress(len(results), results[-1])
    return {"results": results, "final": [], "restarts": 0, "elapsed_s": time.monotonic() - t0}


def run_server(ids: list[str], workdir: Path) -> dict[str, Any]:
    t0 = time.monotonic()
    table = hi.by_id("http")
    progress = _progress_file(workdir)
    server = hc.RealServer(workdir)
    results = []
    try:
        server.start()
        for mid in ids:
            t1 = time.monotonic()
            probs = hc.server_problems(table[mid], server)
            results.append({"id": mid, "problems": probs, "elapsed_s": time.monotonic() - t1})
            progress(len(results), results[-1])
        final = hc.server_final_problems(server)
    finally:
        server.stop()
    return {
        "results": results,
        "final": final,
        "restarts": server.starts - 1,
        "elapsed_s": time.monotonic() - t0,
    }


RUNNERS: dict[str, Callable[[list[str], Path], dict[str, Any]]] = {
    "cli": lambda ids, wd: run_in_process("cli", ids, wd),
    "http": lambda ids, wd: run_in_process("http", ids, wd),
    "subprocess": run_subprocesses,
    "server": run_server,
}
#: which mutation set each channel draws from
SOURCE = {"cli": "cli", "http": "http", "subprocess": "cli", "server": "http"}


class Channels:
    """Runs the selected channels concurrently (on first use) and hands out their results."""

    def __init__(self, plan: dict[str, list[str]], workdir: Path) -> None:
        self.plan = plan
        self.workdir = workdir
        self.futures: dict[str, Future[dict[str, Any]]] = {}
        self.pool: ThreadPoolExecutor | None = None
        self.lock = threading.Lock()

    def result(self, channel: str) -> dict[str, Any]:
        with self.lock:
            if self.pool is None:
                self.pool = ThreadPoolExecutor(max_workers=max(1, len(self.plan)))
                for ch, ids in self.plan.items():
                    self.futures[ch] = self.pool.submit(RUNNERS[ch], ids, self.workdir / ch)
            if channel not in self.futures:  # not planned (e.g. selected by a keyword later)
                self.futures[channel] = self.pool.submit(
                    RUNNERS[channel], self.plan.get(channel, []), self.workdir / channel
                )
        return self.futures[channel].result()

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True)


def _selected_channels(request: pytest.FixtureRequest, prefix: str) -> list[str]:
    names = {item.name for item in request.session.items if item.module is request.module}
    return [ch for ch in RUNNERS if f"{prefix}[{ch}]" in names]


@pytest.fixture(scope="module")
def sample_runs(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory):
    plan = {}
    for ch in _selected_channels(request, "test_sample"):
        plan[ch] = sample_ids(ch) if ch in ("cli", "http") else proc_sample_ids(SOURCE[ch])
    runs = Channels(plan, tmp_path_factory.mktemp("hostile-sample"))
    yield runs
    runs.close()


@pytest.fixture(scope="module")
def full_runs(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory):
    plan = {ch: full_ids(SOURCE[ch]) for ch in _selected_channels(request, "test_full")}
    runs = Channels(plan, tmp_path_factory.mktemp("hostile-full"))
    yield runs
    runs.close()


# -- reporting ---------------------------------------------------------------------------------


def report(channel: str, out: dict[str, Any], tmp_path: Path) -> str | None:
    """None when every input passed; else one message: failures grouped by symptom, one line
    per failing id. The whole result is written as JSON next to it."""
    results = out["results"]
    failed = [r for r in results if r["problems"]]
    report_dir = Path(os.environ.get("BOWLREC_HOSTILE_REPORT_DIR") or tmp_path)
    report_dir.mkdir(parents=True, exist_ok=True)
    path = report_dir / f"hostile-{channel}.json"
    path.write_text(json.dumps(out, indent=1))
    slowest = sorted(results, key=lambda r: -r.get("elapsed_s", 0))[:3]
    head = (
        f"{channel}: {len(failed)} of {len(results)} inputs failed in {out['elapsed_s']:.0f} s "
        f"(worker/server restarts: {out['restarts']}; slowest: "
        + ", ".join(f"{r['id']} {r.get('elapsed_s', 0):.1f} s" for r in slowest)
        + f"); full results: {path}"
    )
    print(head)
    if not failed and not out["final"]:
        return None
    groups: dict[str, list[str]] = collections.defaultdict(list)
    for r in failed:
        seen = set()
        for p in r["problems"]:
            if p["symptom"] in seen:
                continue
            seen.add(p["symptom"])
            groups[p["symptom"]].append(f"  {r['id']}: {p['detail'][:300]}")
    lines = [head]
    for symptom in sorted(groups, key=lambda s: -len(groups[s])):
        lines.append(f"[{symptom}] {len(groups[symptom])} inputs:")
        lines += groups[symptom]
    for p in out["final"]:
        lines.append(f"[after the sweep: {p['symptom']}] {p['detail']}")
    return "\n".join(lines)


def check(channel: str, runs: Channels, tmp_path: Path) -> None:
    assert runs.plan.get(channel), f"no hostile inputs were planned for {channel}"
    out = runs.result(channel)
    message = report(channel, out, tmp_path)
    if message is not None:
        pytest.fail(message, pytrace=False)


# -- the generator -----------------------------------------------------------------------------


def test_generator_covers_every_example_kind_and_leaf() -> None:
    exs = hi.examples()
    kinds = {e.kind for e in exs}
    assert kinds == {"scene", "bowler", "job"}, kinds
    assert any(e.suffix in (".yaml", ".yml") for e in exs)
    cli, http = hi.mutations("cli"), hi.mutations("http")
    for ms in (cli, http):
        assert len({m.id for m in ms}) == len(ms)
        assert {m.example for m in ms} == {e.rel for e in exs}
    cli_kinds = {m.kind for m in cli}
    missing = set(hi.ALL_KINDS) - cli_kinds
    assert not missing, missing
    # every leaf path of every distinct example shape gets the value kinds
    for ex in exs:
        leaves = {hi.jpath(p) for p, v in hi._nodes(ex.data) if not isinstance(v, dict | list)}
        family = [e.rel for e in exs if hi._families()[e.rel][1] > 1]
        got = {m.where for m in cli if m.kind == "nan" and (m.example == ex.rel or family)}
        assert leaves <= got, (ex.rel, sorted(leaves - got)[:5])
    # deterministic: the same ids in the same order
    hi.mutations.cache_clear()
    assert [m.id for m in hi.mutations("cli")] == [m.id for m in cli]


def test_generator_renders_what_it_means() -> None:
    import yaml

    t = hi.by_id("cli")
    yaml_ex = next(e for e in hi.examples() if e.suffix != ".json" and e.kind == "scene")
    rtol = "$.options.rtol"
    for kind, check_value in (
        ("nan", math.isnan),
        ("inf", lambda v: v == math.inf),
        ("small", lambda v: v == 1e-8),
        ("big", lambda v: v == 1e300),
        ("neg_zero", lambda v: v == 0 and math.copysign(1, v) < 0),
        ("int_huge", lambda v: v == 10**400),
    ):
        m = t[f"{yaml_ex.rel}:{rtol}:{kind}"]
        assert check_value(yaml.safe_load(m.content())["options"]["rtol"]), kind
    # the bowler JSON examples are one family of identically shaped files: one of them owns
    # each (path, kind) pair
    bowlers = {e.rel for e in hi.examples() if e.kind == "bowler" and e.suffix == ".json"}
    assert "examples/bowler/house-shot-right.json" in bowlers

    def owned(where: str, kind: str) -> hi.Mutation:
        return next(t[f"{rel}:{where}:{kind}"] for rel in bowlers if f"{rel}:{where}:{kind}" in t)

    m = owned("$.delivery.speed_mph", "nan")
    assert b"NaN" in m.content() and math.isnan(json.loads(m.body())["delivery"]["speed_mph"])
    m = owned("$.delivery.speed_mph", "deep_list")
    assert m.content().count(b"[") >= hi.DEEP and not m.body_is_json()
    bomb = next(m for m in hi.mutations("cli") if m.kind == "yaml_alias_bomb" and m.target == "job")
    assert len(bomb.content()) < 2000 and bomb.body() is None
    assert all(m.body() is not None for m in hi.mutations("http"))
    huge = [m for m in hi.mutations("cli") if m.huge]
    assert {m.kind for m in huge} == set(hi.HUGE_KINDS)


def test_samples_are_stratified() -> None:
    for ch in ("cli", "http"):
        ms = hi.mutations(ch)
        ids = set(sample_ids(ch)) if not ONLY else {m.id for m in ms}
        got = [m for m in ms if m.id in ids]
        assert {m.kind for m in got} == {m.kind for m in ms}
        assert {m.example for m in got} == {m.example for m in ms}


# -- the default run: samples ------------------------------------------------------------------


@pytest.mark.fault
@pytest.mark.parametrize("channel", ["cli", "http", "subprocess", "server"])
def test_sample(channel: str, sample_runs: Channels, tmp_path: Path) -> None:
    """A small fixed sample through each channel: ``cli`` CliRunner in a guarded worker
    (validate + simulate for scenes, batch -j 0 for jobs); ``http`` the ASGI app in a guarded
    worker (POST /runs, POST /jobs polled, then GET /runs); ``subprocess`` real ``bowlrec``
    processes (address space capped); ``server`` a real ``bowlrec serve`` on 127.0.0.1."""
    check(channel, sample_runs, tmp_path)


# -- the full sweep: -m slow -------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.fault
@pytest.mark.parametrize("channel", ["cli", "http", "subprocess", "server"])
def test_full(channel: str, full_runs: Channels, tmp_path: Path) -> None:
    """Every mutation through each channel (the four of the sample tests above)."""
    check(channel, full_runs, tmp_path)

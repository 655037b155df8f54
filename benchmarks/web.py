"""The web app of ``bowlrec serve`` with a million runs in the index, against its targets
(TARGETS).

    python -m benchmarks.web [--archive DIR] [--quick] [--repeats 7] [--out benchmarks/results]

The archive: ``--runs`` (1,000,000; ``--quick``: 20,000) summary-only runs built exactly as
:mod:`benchmarks.archive` builds them (:func:`benchmarks.archive.simulate` of 2,000 distinct
house-shot deliveries (1,000 with ``--quick``), :class:`~benchmarks.archive.RecordFactory`,
:func:`benchmarks.archive.build`: 1,000-run segments, jittered summaries, ``created_at`` spread
over 30 days). It is built once into ``--archive DIR`` (default
``/tmp/bowlrec-web-bench-<runs>``) and reused while ``DIR.build.json`` (written beside it when
the build finished) matches; so a rerun only measures. The synthetic runs' summaries are
jittered, so they cannot be re-recorded for a figure (a re-recorded summary is checked against
the stored one): 40 real summary-only deliveries (simulated as ``Archive.simulate`` does) are
added in a segment of their own for the run, figure and Compare pages. Each rerun empties
``DIR/cache/figure`` before it starts the server, so "first request" is a first one.

What is measured, against a real ``bowlrec serve --archive DIR --port P`` subprocess on
127.0.0.1 (no token; :func:`benchmarks.service.server`):

- server time per page: one httpx client (keep-alive), GET until the whole HTML is received;
  the runs page ``/`` (newest first, 50 rows), filtered, sorted on an unindexed column, sorted
  and filtered, a deep page (10,000), the last page, 500 rows; a summary-only run's page
  ``/ui/runs/{id}`` (the first request re-records the run for its bowler report; then a
  repeat), its figure ``/runs/{id}/figure.svg`` (first: drawn; then from the cache), Compare of
  5 runs (``/ui/compare`` and its figure). Median and best of ``--repeats`` (first requests:
  one per distinct run, ``--first-runs`` runs);
- the page load in a real browser (Playwright, Debian's Chromium, headless): navigation to
  ``load`` of ``/`` and of a filtered ``/`` in a fresh page (new browser context) each repeat,
  from ``performance.getEntriesByType('navigation')[0]`` (responseEnd, domContentLoadedEventEnd,
  loadEventEnd, s from the navigation's start); and a click on a sort header of ``/`` to the
  next page's ``load`` event (wall clock in the test process, and the new page's own timing);
- where the time goes for the runs page: :meth:`Archive.list_runs` and
  :meth:`Archive.count_runs` in-process (a reused connection, as the server's), separately,
  for every table query above, with ``EXPLAIN QUERY PLAN`` of the SQL
  :func:`~bowlrec.archive.index.select_sql` and :func:`~bowlrec.archive.index.count_sql` make.

The OS page cache is warm (the archive was read or written just before). The machine's load
average before and after is recorded. ``--quick`` writes ``web-quick.json``/``.md``; the
committed ``web.json``/``web.md`` come from the 1,000,000-run benchmark.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import statistics
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SEGMENT_RUNS = 1000
PAGE_FILTERED = "/?outcome=pins&hook_min=30"
#: real (not jittered) summary-only runs added for the run, figure and Compare pages
REAL_RUNS = 40
#: the runs-table pages timed on the server: key -> (label, path); "{last}" is filled in
TABLE_PAGES: dict[str, tuple[str, str]] = {
    "runs_default": ("`/` (newest first, 50 rows)", "/"),
    "runs_filtered": ("`/?outcome=pins&hook_min=30`", PAGE_FILTERED),
    "runs_sort_hook": ("`/?sort=-hook_m` (unindexed column)", "/?sort=-hook_m"),
    "runs_sort_speed_filtered": (
        "`/?sort=speed_mps&speed_min=8&pocket_max=5`",
        "/?sort=speed_mps&speed_min=8&pocket_max=5",
    ),
    "runs_page_10000": ("`/?page=10000`", "/?page=10000"),
    "runs_last_page": ("`/?page={last}` (the last page offered)", "/?page={last}"),
    "runs_per_page_500": ("`/?per_page=500`", "/?per_page=500"),
}

TARGETS: dict[str, tuple[str, float, str]] = {
    # key: (what, limit, unit); judged on the median
    "runs_default": ("runs page `/` (default), server time", 0.5, "s"),
    "runs_filtered": (f"runs page `{PAGE_FILTERED}`, server time", 0.5, "s"),
    "browser_runs_default": ("runs page `/` (default) loaded in Chromium (loadEventEnd)", 1.5, "s"),
    "browser_runs_filtered": (f"runs page `{PAGE_FILTERED}` loaded in Chromium", 1.5, "s"),
    "runs_sort_hook": ("`/?sort=-hook_m`, server time", 2.0, "s"),
    "runs_sort_speed_filtered": (
        "`/?sort=speed_mps&speed_min=8&pocket_max=5`, server time",
        2.0,
        "s",
    ),
    "runs_page_10000": ("deep page `/?page=10000`, server time", 2.0, "s"),
    "runs_last_page": ("the last page, server time", 2.0, "s"),
    "runs_per_page_500": ("`/?per_page=500`, server time", 2.0, "s"),
    "browser_sort_click": ("click on a sort header of `/` to the next page's load", 2.0, "s"),
}


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _stats(values: Sequence[float], scale: float = 1.0, digits: int = 4) -> dict[str, Any]:
    v = sorted(x * scale for x in values)
    return {
        "n": len(v),
        "median": round(statistics.median(v), digits),
        "best": round(v[0], digits),
        "max": round(v[-1], digits),
    }


# -- the archive ---------------------------------------------------------------------------------


def _record_path(archive_dir: Path) -> Path:
    return archive_dir.with_name(archive_dir.name + ".build.json")


def ensure_archive(archive_dir: Path, n_runs: int, n_bases: int) -> dict[str, Any]:
    """The build record of the ``n_runs``-run archive at ``archive_dir``, built now unless a
    finished build of that size is there."""
    from benchmarks.archive import RecordFactory, _solver, build, simulate
    from bowlrec.archive import Archive

    record_path = _record_path(archive_dir)
    if record_path.exists():
        info = json.loads(record_path.read_text())
        if info.get("runs") == n_runs and (archive_dir / "index.sqlite").exists():
            _log(f"reusing the archive {archive_dir} (built {info['built_at']})")
            if not info.get("real_run_ids"):
                info |= add_real_runs(Archive(archive_dir))
                record_path.write_text(json.dumps(info, indent=2) + "\n")
            return info | {"reused": True}
        raise SystemExit(f"{archive_dir} holds another build ({info.get('runs')} runs); remove it")
    if archive_dir.exists():
        raise SystemExit(
            f"{archive_dir} exists without a finished build record ({record_path.name}); "
            "remove it (an interrupted build?) or give another --archive"
        )
    t0 = time.perf_counter()
    archive = Archive(archive_dir)
    _log(f"simulating {n_bases} summary-only deliveries ...")
    t_sim = time.perf_counter()
    bases = simulate(n_bases, 1, "summary")
    records = [archive.record(r, wall_time_s=w, solver=_solver(r)) for r, w in bases]
    simulate_s = time.perf_counter() - t_sim
    _log(f"writing {n_runs:,} runs into {archive_dir} ...")
    b = build(archive, RecordFactory(records, n_runs), n_runs, 1, _log)
    real = add_real_runs(archive)
    info = {
        "runs": n_runs,
        "runs_indexed": len(archive),
        "bases_simulated": n_bases,
        "simulate_s": round(simulate_s, 1),
        "write_s": round(b["wall_s"], 1),
        "build_wall_s": round(time.perf_counter() - t0, 1),
        "built_at": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "index_bytes": archive.index_path.stat().st_size,
        "segment_bytes": sum(p.stat().st_size for p in archive.segments_dir.glob("*.h5")),
        **real,
    }
    record_path.write_text(json.dumps(info, indent=2) + "\n")
    _log(f"built in {info['build_wall_s']:.0f} s")
    return info | {"reused": False}


def add_real_runs(archive: Any, n: int = REAL_RUNS) -> dict[str, Any]:
    """``n`` summary-only house-shot deliveries simulated as :func:`bowlrec.api.simulate_into`
    does (``bowlrec.core.solver.run_plan``), in one segment. The synthetic runs' summaries are
    jittered, so they cannot be re-recorded for a figure (the re-recorded summary is checked
    against the stored one); the run, figure and Compare pages are measured on these."""
    from benchmarks.archive import _scene, _solver
    from bowlrec.archive.run_id import run_id
    from bowlrec.core.solver import run_plan
    from bowlrec.sinks.common import RunData

    _log(f"adding {n} real summary-only runs ...")
    rng = random.Random(11)
    builder = archive.builder()
    ids: list[str] = []
    while len(ids) < n:
        scene = _scene(rng, "summary")
        plan = scene.resolve()
        rid = run_id(plan)
        if rid in ids or archive.locate(rid) is not None:
            continue
        t0 = time.perf_counter()
        traj = run_plan(plan)
        run = RunData(scene, plan, traj, rid)
        builder.append(
            archive.record(run, wall_time_s=time.perf_counter() - t0, solver=_solver(run))
        )
        ids.append(rid)
    archive.register([archive.seal(builder)])
    return {"real_run_ids": ids}


# -- server time ---------------------------------------------------------------------------------


def _get(client: Any, path: str) -> tuple[float, int]:
    """Wall s of one GET with the whole body received, and the body's size."""
    t0 = time.perf_counter()
    r = client.get(path)
    n = len(r.content)
    wall = time.perf_counter() - t0
    if r.status_code != 200:
        raise RuntimeError(f"GET {path}: HTTP {r.status_code}: {r.text[:300]}")
    return wall, n


def _page(client: Any, path: str, repeats: int) -> dict[str, Any]:
    first, size = _get(client, path)
    times = [_get(client, path)[0] for _ in range(repeats)]
    return {"path": path, "bytes": size, "first_s": round(first, 4), "s": _stats(times)}


def server_times(
    url: str, n_runs: int, real_ids: list[str], repeats: int, first_runs: int
) -> dict[str, Any]:
    """Server time of each page; the run, figure and Compare pages on ``real_ids`` (each used
    once: figure cache emptied before the server started, re-recorded runs kept in its memory).
    """
    import httpx

    from bowlrec.web.tables import COUNT_CAP, PAGE_SIZES

    out: dict[str, Any] = {}
    # n_runs: every run of the archive (the synthetic ones and the real ones)
    last_offered = -(-min(n_runs, COUNT_CAP) // PAGE_SIZES[0])
    last_real = -(-n_runs // PAGE_SIZES[0])
    pages = dict(TABLE_PAGES)
    pages["runs_last_page"] = (
        f"`/?page={last_real:,}` (the last page of {n_runs:,} runs)",
        f"/?page={last_real}",
    )
    pages["runs_last_offered"] = (
        f"`/?page={last_offered:,}` (the page of the {COUNT_CAP:,}th run, where the count stops)",
        f"/?page={last_offered}",
    )
    fresh = iter(real_ids)
    with httpx.Client(base_url=url, timeout=600) as c:
        for key, (label, path) in pages.items():
            _log(f"  {path}")
            out[key] = {"label": label} | _page(c, path, repeats)

        _log("  run pages and figures ...")
        firsts, repeats_page, fig_first, fig_cached = [], [], [], []
        for rid in [next(fresh) for _ in range(first_runs)]:
            firsts.append(_get(c, f"/ui/runs/{rid}")[0])
            repeats_page += [_get(c, f"/ui/runs/{rid}")[0] for _ in range(max(1, repeats // 3))]
            fig_first.append(_get(c, f"/runs/{rid}/figure.svg")[0])
            fig_cached += [
                _get(c, f"/runs/{rid}/figure.svg")[0] for _ in range(max(1, repeats // 3))
            ]
        cold_fig = [
            _get(c, f"/runs/{rid}/figure.svg")[0]
            for rid in [next(fresh) for _ in range(max(2, first_runs // 2))]
        ]
        out["run_page_first"] = {
            "label": "`/ui/runs/{id}`, summary-only run, first request (re-records the run)",
            "s": _stats(firsts),
        }
        out["run_page_repeat"] = {"label": "`/ui/runs/{id}`, repeated", "s": _stats(repeats_page)}
        out["figure_first_after_page"] = {
            "label": "`/runs/{id}/figure.svg`, first (after the run page: drawn, run in memory)",
            "s": _stats(fig_first),
        }
        out["figure_first_cold"] = {
            "label": "`/runs/{id}/figure.svg`, first, run not visited (re-record + draw)",
            "s": _stats(cold_fig),
        }
        out["figure_cached"] = {
            "label": "`/runs/{id}/figure.svg`, cached",
            "s": _stats(fig_cached),
        }

        _log("  compare ...")
        five = [next(fresh) for _ in range(5)]
        query = "&".join(f"ids={r}" for r in five)
        out["compare_page"] = {"label": "`/ui/compare` of 5 runs"} | _page(
            c, f"/ui/compare?{query}", repeats
        )
        out["compare_page"]["path"] = "/ui/compare?ids=…(5)"
        first, _ = _get(c, f"/compare/figure.svg?{query}")
        cached = [_get(c, f"/compare/figure.svg?{query}")[0] for _ in range(repeats)]
        out["compare_figure_first"] = {
            "label": "`/compare/figure.svg` of the 5, first (re-records 5 runs + draw)",
            "s": _stats([first]),
        }
        out["compare_figure_cached"] = {
            "label": "`/compare/figure.svg` of the 5, cached",
            "s": _stats(cached),
        }
    return out


# -- the browser ---------------------------------------------------------------------------------

NAV_JS = """() => {
  const n = performance.getEntriesByType('navigation')[0];
  return {responseStart: n.responseStart, responseEnd: n.responseEnd,
          domContentLoadedEventEnd: n.domContentLoadedEventEnd, loadEventEnd: n.loadEventEnd,
          transferSize: n.transferSize};
}"""


def _nav(page: Any) -> dict[str, float]:
    page.wait_for_function("() => performance.getEntriesByType('navigation')[0].loadEventEnd > 0")
    return {
        k: float(v) / (1e3 if k != "transferSize" else 1) for k, v in page.evaluate(NAV_JS).items()
    }


def _nav_stats(navs: list[dict[str, float]], walls: list[float]) -> dict[str, Any]:
    return {
        "response_end_s": _stats([n["responseEnd"] for n in navs]),
        "dom_content_loaded_s": _stats([n["domContentLoadedEventEnd"] for n in navs]),
        "load_event_end_s": _stats([n["loadEventEnd"] for n in navs]),
        "wall_s": _stats(walls),
    }


def browser_times(url: str, repeats: int) -> dict[str, Any]:
    from playwright.sync_api import sync_playwright

    out: dict[str, Any] = {}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", headless=True)
        out["chromium"] = browser.version
        try:
            for key, path in (("runs_default", "/"), ("runs_filtered", PAGE_FILTERED)):
                _log(f"  browser {path}")
                navs, walls = [], []
                for i in range(repeats + 1):
                    context = browser.new_context(viewport={"width": 1280, "height": 900})
                    page = context.new_page()
                    t0 = time.perf_counter()
                    r = page.goto(url + path, wait_until="load")
                    wall = time.perf_counter() - t0
                    if r is None or r.status != 200:
                        raise RuntimeError(f"{path}: {None if r is None else r.status}")
                    nav = _nav(page)
                    context.close()
                    if i == 0:
                        out[f"{key}_first_load_s"] = round(nav["loadEventEnd"], 4)
                        continue  # the first is a warm-up of the browser
                    navs.append(nav)
                    walls.append(wall)
                out[key] = {"path": path} | _nav_stats(navs, walls)

            _log("  browser: sort-header click")
            navs, walls = [], []
            for _ in range(repeats):
                context = browser.new_context(viewport={"width": 1280, "height": 900})
                page = context.new_page()
                page.goto(url + "/", wait_until="load")
                link = page.locator("#runs-table thead a", has_text="hook (cm)")
                t0 = time.perf_counter()
                with page.expect_navigation(wait_until="load"):
                    link.click()
                walls.append(time.perf_counter() - t0)
                if "sort=-hook_m" not in page.url:
                    raise RuntimeError(f"the sort click went to {page.url}")
                navs.append(_nav(page))
                context.close()
            out["sort_click"] = {"from": "/", "to": "/?sort=-hook_m"} | _nav_stats(navs, walls)
        finally:
            browser.close()
    return out


# -- where the time goes -------------------------------------------------------------------------


def breakdown(archive_dir: Path, n_runs: int, repeats: int) -> dict[str, Any]:
    """list_runs and count_runs of each table page in-process, and their query plans."""
    from urllib.parse import parse_qsl, urlsplit

    from bowlrec.archive import Archive
    from bowlrec.archive.index import count_sql, select_sql
    from bowlrec.web.tables import COUNT_CAP, PAGE_SIZES, RunsQuery

    archive = Archive(archive_dir)
    con = archive.index_reader()
    last = -(-len(archive) // PAGE_SIZES[0])
    out: dict[str, Any] = {}
    for key, (_label, path) in TABLE_PAGES.items():
        path = path.replace("{last}", str(last))
        q = RunsQuery.parse(dict(parse_qsl(urlsplit(path).query)))
        kw = q.filters()
        offset = (q.page - 1) * q.per_page

        def lst(kw: dict[str, Any] = kw, q: Any = q, offset: int = offset) -> Any:
            return archive.list_runs(**kw, order_by=q.sort, limit=q.per_page, offset=offset)

        def cnt(kw: dict[str, Any] = kw) -> int:
            return archive.count_runs(**kw, cap=COUNT_CAP)

        lst()
        n = cnt()
        lt, ct = [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            lst()
            lt.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            cnt()
            ct.append(time.perf_counter() - t0)
        filters, clauses = archive._run_filters(
            kw["ball"], kw["pattern"], kw["outcome"], kw["name"], kw["where"]
        )
        sel, sp = select_sql(filters, q.sort, q.per_page, clauses, offset=offset)
        cs, cp = count_sql(filters, clauses, COUNT_CAP)

        def plan(sql: str, params: list[Any]) -> list[str]:
            return [r[3] for r in con.execute("EXPLAIN QUERY PLAN " + sql, params)]

        out[key] = {
            "path": path,
            "count": n,
            "list_s": _stats(lt),
            "count_s": _stats(ct),
            "select_plan": plan(sel, sp),
            "count_plan": plan(cs, cp),
            "select_sql_tail": sel[sel.index(" FROM ") :],
        }
        _log(
            f"  {path}: list {out[key]['list_s']['median']} s, "
            f"count {out[key]['count_s']['median']} s"
        )
    return out


# -- the whole benchmark -------------------------------------------------------------------------


def measure(
    archive_dir: Path, n_runs: int, n_bases: int, repeats: int, first_runs: int
) -> dict[str, Any]:
    from benchmarks.archive import machine, server
    from bowlrec.archive import Archive

    t_start = time.perf_counter()
    data: dict[str, Any] = {"machine": machine()}
    data["machine"]["playwright"] = _version("playwright")
    data["machine"]["jinja2"] = _version("jinja2")
    data["archive"] = ensure_archive(archive_dir, n_runs, n_bases)
    data["setup"] = {"runs": n_runs, "repeats": repeats, "first_runs": first_runs}
    data["loadavg_before"] = os.getloadavg()
    _log("where the time goes (in-process) ...")
    data["breakdown"] = breakdown(archive_dir, n_runs, repeats)
    _log("server ...")
    # every rerun draws the figures again: the first requests are first ones
    shutil.rmtree(archive_dir / "cache" / "figure", ignore_errors=True)
    with server(archive_dir) as (url, startup):
        data["server_startup_s"] = round(startup, 3)
        data["server"] = server_times(
            url, len(Archive(archive_dir)), data["archive"]["real_run_ids"], repeats, first_runs
        )
        data["browser"] = browser_times(url, repeats)
    data["loadavg_after"] = os.getloadavg()
    data["benchmark_wall_s"] = round(time.perf_counter() - t_start, 1)
    data["targets"] = _targets(data)
    return data


def _version(dist: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return "not installed"


def _targets(d: dict[str, Any]) -> list[dict[str, Any]]:
    measured: dict[str, float] = {}
    for key in TARGETS:
        if key.startswith("browser_"):
            sub = key.removeprefix("browser_")
            if sub == "sort_click":
                measured[key] = d["browser"]["sort_click"]["wall_s"]["median"]
            else:
                measured[key] = d["browser"][sub]["load_event_end_s"]["median"]
        else:
            measured[key] = d["server"][key]["s"]["median"]
    return [
        {
            "key": key,
            "what": what,
            "target": f"< {limit:g} {unit}",
            "measured": measured[key],
            "unit": unit,
            "met": measured[key] < limit,
        }
        for key, (what, limit, unit) in TARGETS.items()
    ]


# -- report --------------------------------------------------------------------------------------


def _ms(st: dict[str, Any]) -> str:
    return f"{st['median'] * 1e3:,.1f} | {st['best'] * 1e3:,.1f}"


def markdown(d: dict[str, Any], name: str) -> str:
    m, a, s, b = d["machine"], d["archive"], d["setup"], d["browser"]
    quick = " --quick" if name.endswith("quick") else ""
    lines = [
        "# The web app with a million runs" if not quick else "# The web app (quick run)",
        "",
        f"`bowlrec serve` (a subprocess on 127.0.0.1, no token) over an archive of "
        f"{s['runs']:,} summary-only runs (the synthetic runs of `benchmarks/archive.py`: "
        f"{a['bases_simulated']:,} simulated house-shot deliveries, jittered; index "
        f"{a['index_bytes'] / 2**20:,.0f} MiB). {m['nproc']} cores ({m['cpu']}), load average "
        f"{d['loadavg_before'][0]:.2f} before / {d['loadavg_after'][0]:.2f} after; Python "
        f"{m['python']}, SQLite {m['sqlite']}, FastAPI {m['fastapi']}, uvicorn {m['uvicorn']}, "
        f"Chromium {b['chromium']} (headless, Playwright {m['playwright']}). Server time: "
        f"httpx GET to the last byte, one keep-alive client, {s['repeats']} repeats after one "
        f"first request; browser: a new context per repeat, {s['repeats']} repeats after one "
        "warm-up. Median and best; page cache warm.",
        "",
        "| target | limit | median | best | met |",
        "|---|---:|---:|---:|:---:|",
    ]
    for t in d["targets"]:
        key = t["key"]
        if key.startswith("browser_"):
            sub = key.removeprefix("browser_")
            st = b[sub]["wall_s" if sub == "sort_click" else "load_event_end_s"]
        else:
            st = d["server"][key]["s"]
        lines.append(
            f"| {t['what']} | {t['target']} | {st['median']:.3f} s | {st['best']:.3f} s | "
            f"{'yes' if t['met'] else '**no**'} |"
        )
    lines += [
        "",
        "## Server time per page",
        "",
        "| page | HTML bytes | first (ms) | median (ms) | best (ms) |",
        "|---|---:|---:|---:|---:|",
    ]
    for _key, r in d["server"].items():
        size = f"{r['bytes']:,}" if "bytes" in r else ""
        first = f"{r['first_s'] * 1e3:,.1f}" if "first_s" in r else ""
        lines.append(f"| {r['label']} | {size} | {first} | {_ms(r['s'])} |")
    lines += [
        "",
        f"Run and figure rows: {s['first_runs']} distinct runs never drawn before (first "
        "requests), each then repeated. Server start-up (to `/health`): "
        f"{d['server_startup_s']:.2f} s.",
        "",
        "## In the browser",
        "",
        "Seconds from the navigation's start (`performance.getEntriesByType('navigation')[0]`); "
        "the click row times the wall clock from the click to the next page's `load`.",
        "",
        "| page | responseEnd | DOMContentLoaded | load (median) | load (best) | wall |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for key, label in (
        ("runs_default", "`/`"),
        ("runs_filtered", f"`{PAGE_FILTERED}`"),
        ("sort_click", "click on the hook header of `/` (to `/?sort=-hook_m`)"),
    ):
        r = b[key]
        lines.append(
            f"| {label} | {r['response_end_s']['median']:.3f} | "
            f"{r['dom_content_loaded_s']['median']:.3f} | {r['load_event_end_s']['median']:.3f} | "
            f"{r['load_event_end_s']['best']:.3f} | {r['wall_s']['median']:.3f} |"
        )
    lines += [
        "",
        "## Where the time goes",
        "",
        "The runs table's two queries in-process (`Archive.list_runs`, then `Archive.count_runs` "
        "capped at 100,000; a reused connection, as the server's), and SQLite's plan of each.",
        "",
        "| page | list (ms) | count (ms) | matching (capped) | plan of the SELECT "
        "| plan of the COUNT |",
        "|---|---:|---:|---:|---|---|",
    ]
    for _key, r in d["breakdown"].items():
        lines.append(
            f"| `{r['path']}` | {r['list_s']['median'] * 1e3:,.1f} | "
            f"{r['count_s']['median'] * 1e3:,.1f} | {r['count']:,} | "
            f"{'; '.join(r['select_plan'])} | {'; '.join(r['count_plan'])} |"
        )
    lines += [
        "",
        "## Rerun",
        "",
        "```",
        f"python -m benchmarks.web [--archive DIR]{quick}",
        "```",
        "",
        "builds the archive into `DIR` (default `/tmp/bowlrec-web-bench-<runs>`) the first "
        f"time (here {a['build_wall_s']:.0f} s: {a['simulate_s']:.0f} s simulating, "
        f"{a['write_s']:.0f} s writing) and reuses it afterwards (`DIR.build.json` marks a "
        "finished build); `--quick` measures 20,000 runs into `web-quick.json`/`.md`. "
        f"This run: {d['benchmark_wall_s']:.0f} s"
        + (" (archive reused)." if a.get("reused") else " (archive built)."),
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--archive", type=Path, default=None, help="the archive (built once)")
    parser.add_argument("--quick", action="store_true", help="20,000 runs (web-quick.*)")
    parser.add_argument("--runs", type=int, default=None, help="runs (1,000,000)")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--first-runs", type=int, default=5, help="runs for first requests")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--build-only", action="store_true", help="build the archive, stop")
    args = parser.parse_args()
    n_runs = args.runs or (20_000 if args.quick else 1_000_000)
    n_bases = 1_000 if args.quick else 2_000
    archive_dir = args.archive or Path(f"/tmp/bowlrec-web-bench-{n_runs}")
    os.chdir(ROOT)
    if args.build_only:
        ensure_archive(archive_dir, n_runs, n_bases)
        return
    name = "web-quick" if args.quick else "web"
    data = measure(archive_dir, n_runs, n_bases, args.repeats, args.first_runs)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"{name}.json").write_text(json.dumps(data, indent=2) + "\n")
    (args.out / f"{name}.md").write_text(markdown(data, name))
    print(markdown(data, name))


if __name__ == "__main__":
    main()

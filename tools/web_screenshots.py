"""Screenshots of the web app for the docs (a developer script; not shipped).

    .venv/bin/python -m tools.web_screenshots [--out docs/images] [--keep]

Makes a small archive in a temporary directory (two library balls from the curated catalog,
summary-only physical runs, recorded bowler runs, one finished job), starts a real
``bowlrec serve`` on it (loopback, no token), opens each page in Debian's Chromium (Playwright,
headless, 1280 x 900) and saves:

    web-runs.png      /                     the runs table
    web-run.png       /ui/runs/{id}         a recorded bowler run: figure and the rerun viewer
    web-compare.png   /ui/compare?ids=...   four runs overlaid
    web-balls.png     /ui/balls             the ball library
    web-patterns.png  /ui/patterns          the oil patterns
    web-jobs.png      /ui/jobs              jobs and the submit editor
    web-job.png       /ui/jobs/{id}         a finished job: results and its plot

Each PNG is the visible viewport (``full_page=False``), quantized with Pillow when it is larger
than ``MAX_BYTES``. The run page waits for the viewer's canvas (up to 4 minutes: the viewer
compiles ~43 MB of wasm with software rendering). Set ``BOWLREC_CHROMIUM`` to use another
Chromium than ``/usr/bin/chromium``.
"""

from __future__ import annotations

import argparse
import io
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

from benchmarks.service import server

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = os.environ.get("BOWLREC_CHROMIUM", "/usr/bin/chromium")
VIEWPORT = {"width": 1280, "height": 900}
VIEWER_TIMEOUT_MS = 240_000
MAX_BYTES = 400_000
#: library balls added (ids of the curated catalog, bowlrec/bowling/layout.py)
LIBRARY_BALLS = ("storm-the-road-15lb", "hammer-red-legend-15lb")


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


# -- the archive ---------------------------------------------------------------------------------


def physical(name: str, speed_mps: float, **delivery: Any) -> dict[str, Any]:
    """A summary-only physical scene."""
    return {
        "name": name,
        "delivery": {"speed_mps": speed_mps, **delivery},
        "options": {"record": "summary"},
    }


def bowler(
    name: str,
    speed_mph: float,
    rev_rate_rpm: float,
    target: float,
    *,
    ball: str | None = None,
    pattern: str | None = None,
    record: str = "rate",
) -> dict[str, Any]:
    """A bowler scene (recorded every 5 ms unless ``record`` says otherwise)."""
    doc: dict[str, Any] = {
        "format": "bowler",
        "name": name,
        "delivery": {
            "speed_mph": speed_mph,
            "rev_rate_rpm": rev_rate_rpm,
            "laydown_board": 15,
            "target_board_at_arrows": target,
        },
        "options": {"record": record} | ({"record_dt_s": 0.005} if record == "rate" else {}),
    }
    if ball is not None:
        doc["ball"] = ball
    if pattern is not None:
        doc["pattern"] = pattern
    return doc


SCENES: list[dict[str, Any]] = [
    bowler("house-shot-17mph", 17.0, 300.0, 10.0, pattern="house_shot_approx"),
    bowler("the-road-16mph", 16.0, 350.0, 11.0, ball=LIBRARY_BALLS[0], pattern="house_shot_approx"),
    bowler("red-legend-18mph", 18.0, 280.0, 9.0, ball=LIBRARY_BALLS[1]),
    bowler("sport-short", 17.0, 400.0, 8.0, pattern="sport_short_36ft_approx", record="summary"),
    bowler("stroker-15mph", 15.0, 220.0, 12.0, record="summary"),
    physical("speed-6.5", 6.5),
    physical("speed-7.0", 7.0),
    physical("speed-7.5", 7.5),
    physical("speed-8.0", 8.0),
    physical("speed-8.5", 8.5),
    physical("gutter", 7.0, takeoff_angle_deg=-4.0),
    physical("fast-9.0", 9.0),
]

JOB: dict[str, Any] = {
    "format": "bowlrec-job",
    "name": "rev-rate-sweep",
    "description": "A bowler's 17 mph delivery on the house shot at 6 rev rates (summary only).",
    "base": bowler("rev-sweep", 17.0, 300.0, 10.0, pattern="house_shot_approx", record="summary"),
    "sweep": {
        "kind": "grid",
        "axes": {"delivery.rev_rate_rpm": {"start": 200.0, "stop": 450.0, "num": 6}},
    },
    "record": "summary",
}


def add_library_balls(archive_dir: Path) -> None:
    """Two balls of the curated catalog, as ``bowlrec balls add-examples`` adds them."""
    from bowlrec.archive import Archive
    from bowlrec.bowling.catalog import citation
    from bowlrec.bowling.layout import load_example_library

    archive = Archive(archive_dir)
    for item in load_example_library().balls:
        if item.id in LIBRARY_BALLS:
            archive.balls.add(item.id, item.ball, note=citation(item.sources[0]))


def populate(url: str) -> dict[str, Any]:
    """The runs (``POST /runs``) and the job (``POST /jobs``, waited for); their IDs."""
    ids: list[str] = []
    names: dict[str, str] = {}
    with httpx.Client(base_url=url, timeout=600) as c:
        for scene in SCENES:
            r = c.post("/runs", json=scene)
            if r.status_code not in (200, 201):
                raise RuntimeError(f"POST /runs {scene['name']}: {r.status_code} {r.text[:300]}")
            ids.append(r.json()["run_id"])
            names[scene["name"]] = r.json()["run_id"]
            _log(f"  run {scene['name']}: {ids[-1][:12]}")
        r = c.post("/jobs", json=JOB)
        if r.status_code not in (200, 201, 202):
            raise RuntimeError(f"POST /jobs: {r.status_code} {r.text[:300]}")
        job_id = r.json()["job_id"]
        deadline = time.monotonic() + 600
        while True:
            status = c.get(f"/jobs/{job_id}").json()
            if status["status"] not in ("queued", "running"):
                break
            if time.monotonic() > deadline:
                raise RuntimeError(f"job {job_id} did not finish: {status}")
            time.sleep(0.5)
        if status["status"] != "done":
            raise RuntimeError(f"job {job_id} ended {status['status']}: {status}")
        _log(f"  job {job_id}: {status['done']} runs")
    return {"ids": ids, "names": names, "job_id": job_id}


# -- screenshots ---------------------------------------------------------------------------------


def save_png(data: bytes, path: Path) -> None:
    """``data`` written to ``path``; quantized to 256 colours when above MAX_BYTES."""
    if len(data) > MAX_BYTES:
        try:
            from PIL import Image
        except ImportError:
            _log(f"  {path.name}: {len(data):,} bytes (Pillow not installed: not reduced)")
        else:
            img = Image.open(io.BytesIO(data)).convert("RGB")
            buf = io.BytesIO()
            img.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(
                buf, "PNG", optimize=True
            )
            data = buf.getvalue()
    path.write_bytes(data)
    _log(f"  {path}: {len(data):,} bytes")


def _wait_images(page: Any) -> None:
    page.wait_for_load_state("networkidle")
    page.wait_for_function(
        "() => [...document.images].every(i => i.complete && i.naturalWidth > 0)",
        timeout=120_000,
    )


def shoot(url: str, made: dict[str, Any], out: Path) -> list[str]:
    """Every page's screenshot into ``out``; the problems met (pages that errored)."""
    from playwright.sync_api import sync_playwright

    problems: list[str] = []
    names = made["names"]
    compare = [names[n] for n in ("house-shot-17mph", "the-road-16mph", "red-legend-18mph")]
    compare.append(names["sport-short"])
    shots: list[tuple[str, str]] = [
        ("web-runs.png", "/"),
        ("web-compare.png", "/ui/compare?" + "&".join(f"ids={i}" for i in compare)),
        ("web-balls.png", "/ui/balls"),
        ("web-patterns.png", "/ui/patterns"),
        ("web-jobs.png", "/ui/jobs"),
        ("web-job.png", f"/ui/jobs/{made['job_id']}"),
        ("web-run.png", f"/ui/runs/{names['house-shot-17mph']}"),
    ]
    with sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=CHROMIUM,
            headless=True,
            args=["--enable-unsafe-swiftshader", "--use-angle=swiftshader"],
        )
        try:
            for file, path in shots:
                context = browser.new_context(viewport=VIEWPORT)
                page = context.new_page()
                errors: list[str] = []
                page.on("pageerror", lambda e, errs=errors: errs.append(str(e)))
                page.on("console", lambda m, errs=errors: _console(m, errs))
                page.on(
                    "requestfailed",
                    lambda r, errs=errors: errs.append(
                        f"request failed: {r.url[:120]} {r.failure}"
                    ),
                )
                _log(f"{path}")
                response = page.goto(url + path, wait_until="load")
                status = None if response is None else response.status
                if status != 200:
                    problems.append(f"{path}: HTTP {status}")
                try:
                    if file == "web-run.png":
                        _run_page(page)
                    else:
                        _wait_images(page)
                        if file == "web-job.png":
                            page.wait_for_timeout(1500)  # the live plot's first draw
                except Exception as err:  # noqa: BLE001 - reported, the others still shot
                    problems.append(f"{path}: {type(err).__name__}: {str(err)[:300]}")
                if errors:
                    problems.append(f"{path}: console/page errors: {errors[:3]}")
                save_png(page.screenshot(full_page=False), out / file)
                context.close()
        finally:
            browser.close()
    return problems


def _console(message: Any, errors: list[str]) -> None:
    """Console errors, and the viewer's warning that it could not open the recording; not the
    viewer's version check and analytics, which the offline viewer refuses on purpose."""
    text = message.text
    if (
        message.type == "error"
        and "not contacted (offline viewer)" not in text
        or "Failed to open URL" in text
    ):
        errors.append(text[:300])


def _run_page(page: Any) -> None:
    """Scroll so the figure and the viewer show; wait for the viewer's canvas."""
    _wait_images(page)
    page.locator("#run-figure").scroll_into_view_if_needed()
    t0 = time.monotonic()
    frame = page.frame_locator("#viewer")
    frame.locator("canvas").first.wait_for(state="visible", timeout=VIEWER_TIMEOUT_MS)
    _log(f"  viewer canvas after {time.monotonic() - t0:.0f} s")
    page.wait_for_timeout(8000)  # the recording loads and draws
    # the figure's lower part and the viewer: the viewer's bottom at the viewport's bottom
    page.evaluate(
        """() => {
          const v = document.getElementById('viewer').getBoundingClientRect();
          const f = document.getElementById('run-figure').getBoundingClientRect();
          const y = Math.min(window.scrollY + f.top, window.scrollY + v.bottom - innerHeight + 16);
          window.scrollTo(0, Math.max(0, y));
        }"""
    )
    page.wait_for_timeout(1500)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images")
    parser.add_argument("--keep", action="store_true", help="keep the temporary archive")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix="bowlrec-web-shots-"))
    archive_dir = tmp / "archive"
    try:
        add_library_balls(archive_dir)
        with server(archive_dir) as url:  # benchmarks.service.server: bowlrec serve
            _log(f"populating {archive_dir} ...")
            made = populate(url)
            problems = shoot(url, made, args.out)
    finally:
        if args.keep:
            _log(f"kept {archive_dir}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    for problem in problems:
        _log(f"PROBLEM {problem}")
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()

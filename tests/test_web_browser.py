"""The web pages in a real browser: Debian's Chromium driven by Playwright, against a real
``bowlrec serve`` on loopback.

Every test runs with the network cut off: any request to a host other than the server's is
aborted and recorded, and the test fails if there was one (the pages must work offline).
Console errors and answers >= 400 that a test did not ask for fail it too.

Skips (with the reason) only when no Chromium can be found: ``.ci/run`` installs Debian's
``chromium`` when it is missing; set ``BOWLREC_CHROMIUM`` to use another executable.
"""

from __future__ import annotations

import http.server
import json
import os
import re
import shutil
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("jinja2")
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")

from helpers.servers import Server  # noqa: E402

from bowlrec.api import simulate_into  # noqa: E402
from bowlrec.archive import Archive  # noqa: E402
from bowlrec.spec import Scene  # noqa: E402


def _chromium() -> str | None:
    given = os.environ.get("BOWLREC_CHROMIUM")
    if given:
        return given
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


CHROMIUM = _chromium()
pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(
        CHROMIUM is None,
        reason="no Chromium found (apt-get install chromium, or set BOWLREC_CHROMIUM)",
    ),
]

#: the rerun viewer compiles 43 MB of wasm with software rendering: allow it this long
VIEWER_TIMEOUT_MS = 240_000
TOKEN = "t" * 40
ROOT = Path(__file__).resolve().parents[1]


def _populate(archive_dir: Path) -> list[str]:
    """Six summary-only runs: five speeds and a gutter ball; three library balls."""
    archive = Archive(archive_dir)
    ids = []
    for speed in (6.5, 7.0, 7.5, 8.0, 8.5):
        scene = Scene.model_validate(
            {
                "name": f"speed-{speed:g}",
                "delivery": {"speed_mps": speed},
                "options": {"record": "summary"},
            }
        )
        ids.append(simulate_into(archive, scene).run_id)
    gutter = Scene.model_validate(
        {
            "name": "gutter",
            "delivery": {"speed_mps": 7.0, "takeoff_angle_deg": -4.0},
            "options": {"record": "summary"},
        }
    )
    ids.append(simulate_into(archive, gutter).run_id)
    from bowlrec.bowling.catalog import citation
    from bowlrec.bowling.layout import load_example_library

    for item in load_example_library().balls[:3]:
        archive.balls.add(item.id, item.ball, note=citation(item.sources[0]))
    archive.close()
    return ids


@dataclass
class Watch:
    """What a page did that a test did not ask for: requests off the server, console errors,
    failed answers."""

    origin: str
    offsite: list[str] = field(default_factory=list)
    console: list[str] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)
    allowed_status: set[int] = field(default_factory=set)

    def attach(self, context: Any) -> None:
        def route(r: Any) -> None:
            if not r.request.url.startswith(self.origin) and not r.request.url.startswith(
                ("data:", "blob:")
            ):
                self.offsite.append(r.request.url)
                r.abort()
            else:
                r.continue_()

        context.route("**/*", route)

    def page(self, context: Any) -> Any:
        page = context.new_page()
        page.on(
            "console",
            lambda m: self.console.append(m.text) if m.type == "error" else None,
        )
        page.on("pageerror", lambda e: self.console.append(f"page error: {e}"))
        page.on(
            "response",
            lambda r: (
                self.failed.append(f"{r.status} {r.url}")
                if r.status >= 400 and r.status not in self.allowed_status
                else None
            ),
        )
        return page

    def check(self) -> None:
        assert not self.offsite, f"requests off the server: {self.offsite}"
        asked = tuple(f"the server responded with a status of {s} " for s in self.allowed_status)
        console = [m for m in self.console if not (asked and any(a in m for a in asked))]
        assert not console, f"console errors: {console}"
        assert not self.failed, f"failed requests: {self.failed}"


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory, module_serve: Any) -> tuple[Server, list[str]]:
    archive = tmp_path_factory.mktemp("web") / "archive"
    ids = _populate(archive)
    return module_serve(archive), ids


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(
            executable_path=CHROMIUM,
            headless=True,
            args=["--enable-unsafe-swiftshader", "--use-angle=swiftshader"],
        )
        yield b
        b.close()


@pytest.fixture
def web(browser: Any, site: tuple[Server, list[str]]) -> Iterator[tuple[Any, Watch, Server]]:
    srv, _ = site
    context = browser.new_context(base_url=srv.url, viewport={"width": 1400, "height": 1000})
    watch = Watch(srv.url)
    watch.attach(context)
    page = watch.page(context)
    yield page, watch, srv
    context.close()
    watch.check()


def _loaded(page: Any, selector: str, timeout_s: float = 60.0) -> None:
    """Wait until every image matching ``selector`` has loaded (polled from here: the pages'
    Content-Security-Policy forbids the string evaluation ``wait_for_function`` uses)."""
    deadline = time.monotonic() + timeout_s
    script = "els => els.length > 0 && els.every(i => i.complete && i.naturalWidth > 0)"
    while not page.eval_on_selector_all(selector, script):
        assert time.monotonic() < deadline, f"images {selector} did not load"
        page.wait_for_timeout(100)


def _rows(page: Any) -> int:
    return int(page.locator("#runs-table tbody tr").count())


def test_the_runs_table_filters_sorts_and_pages(web: tuple[Any, Watch, Server]) -> None:
    page, _, _ = web
    page.goto("/")
    assert page.title() == "Runs · bowlrec"
    assert _rows(page) == 6
    assert page.locator("#run-count").inner_text() == "1–6 of 6 runs"
    page.select_option("select[name=outcome]", "gutter")
    page.click("#filters button[type=submit]")
    page.wait_for_url(re.compile(r"outcome=gutter"))
    assert _rows(page) == 1
    assert "gutter" in page.locator("#runs-table tbody").inner_text()
    # a range: release speeds from 7.2 m/s
    page.goto("/")
    page.fill("input[name=speed_min]", "7.2")
    page.click("#filters button[type=submit]")
    page.wait_for_url(re.compile(r"speed_min=7.2"))
    assert _rows(page) == 3
    # sorting by a column: descending, then ascending
    page.click("#runs-table thead a:has-text('speed (m/s)')")
    page.wait_for_url(re.compile(r"sort=-speed_mps"))
    speeds = [float(t) for t in page.locator("#runs-table tbody td:nth-child(9)").all_inner_texts()]
    assert speeds == sorted(speeds, reverse=True) == [8.5, 8.0, 7.5]
    page.click("#runs-table thead a:has-text('speed (m/s)')")
    page.wait_for_url(re.compile(r"sort=speed_mps"))
    speeds = [float(t) for t in page.locator("#runs-table tbody td:nth-child(9)").all_inner_texts()]
    assert speeds == [7.5, 8.0, 8.5]


def test_a_bad_filter_is_one_line_on_the_page(web: tuple[Any, Watch, Server]) -> None:
    page, watch, _ = web
    watch.allowed_status.add(422)
    page.goto("/?where=nope>1")
    assert "unknown column 'nope'" in page.locator(".error").inner_text()
    page.goto("/?speed_min=fast")
    assert page.locator(".error").inner_text() == "speed (m/s) from: 'fast' is not a number"


def test_a_run_page_shows_summary_report_figure_and_downloads(
    web: tuple[Any, Watch, Server], site: tuple[Server, list[str]]
) -> None:
    page, _, srv = web
    page.goto("/?sort=speed_mps")
    page.locator("#runs-table tbody tr").first.locator("a.mono").click()
    page.wait_for_url(re.compile(r"/ui/runs/[0-9a-f]+"))
    assert "speed-6.5" in page.locator("h1").inner_text()
    summary = page.locator("#summary").inner_text()
    assert "hook" in summary and "pins" in summary
    assert "entry angle (deg)" in page.locator("#report").inner_text()
    page.locator("#run-figure").scroll_into_view_if_needed()
    _loaded(page, "#run-figure")
    hrefs = page.locator(".downloads a[download]").evaluate_all(
        "links => links.map(a => a.getAttribute('href'))"
    )  # read at once: the requests below may take long on a loaded machine
    assert len(hrefs) == 7, hrefs
    for href in hrefs:
        answer = page.request.get(href)
        assert answer.status == 200, (href, answer.status, answer.text()[:200])
        assert len(answer.body()) > 100
    assert '"speed_mps": 6.5' in (page.locator("#scene").text_content() or "")


def test_the_rerun_viewer_plays_the_run(web: tuple[Any, Watch, Server]) -> None:
    page, _, _ = web
    recordings: list[Any] = []
    page.on("response", lambda r: recordings.append(r) if r.url.endswith(".rrd") else None)
    wasm: list[Any] = []
    page.on("response", lambda r: wasm.append(r) if r.url.endswith(".wasm") else None)
    messages: list[str] = []
    page.on("console", lambda m: messages.append(m.text))
    page.goto("/?sort=speed_mps")
    page.locator("#runs-table tbody tr").first.locator("a.mono").click()
    page.wait_for_url(re.compile(r"/ui/runs/"))
    frame = page.frame_locator("#viewer")
    frame.locator("canvas").first.wait_for(state="visible", timeout=VIEWER_TIMEOUT_MS)
    # the viewer fetched the run's recording (re-recorded from the summary-only run's scene)
    deadline = time.monotonic() + 60
    while not recordings:
        assert time.monotonic() < deadline, "the viewer did not fetch the recording"
        page.wait_for_timeout(200)
    assert recordings[0].status == 200
    assert "/recording.rrd" in recordings[0].url
    # the viewer's wasm came from this server, as WebAssembly (every other request of the
    # page and the viewer answered below 400: the fixture's check)
    assert [(w.status, w.headers["content-type"]) for w in wasm] == [(200, "application/wasm")]
    assert wasm[0].url.endswith("/viewer/re_viewer_bg.wasm")
    # the viewer decoded the whole recording (its own log says so) and opened no other URL
    while not any("has finished" in m and "recording.rrd" in m for m in messages):
        assert time.monotonic() < deadline, f"the viewer did not load the recording: {messages}"
        page.wait_for_timeout(200)
    assert not [m for m in messages if "Failed to open" in m]


def test_compare_two_runs(web: tuple[Any, Watch, Server]) -> None:
    page, _, _ = web
    page.goto("/?sort=speed_mps")
    button = page.locator("#compare-button")
    assert button.is_disabled()
    rows = page.locator("#runs-table tbody tr")
    rows.filter(has_text="speed-6.5").locator("input[type=checkbox]").check()
    rows.filter(has_text="speed-7.5").locator("input[type=checkbox]").check()
    assert button.inner_text() == "Compare selected (2)"
    button.click()
    page.wait_for_url(re.compile(r"/ui/compare\?ids="))
    header = page.locator("#compare-table thead").inner_text()
    assert "speed-6.5" in header and "speed-7.5" in header
    row = page.locator("#compare-table tr:has(th:text-is('speed at release (m/s)'))")
    assert row.locator("td").all_inner_texts() == ["6.500", "7.500"]
    _loaded(page, "#compare-figure")


def test_balls_and_patterns_pages(web: tuple[Any, Watch, Server]) -> None:
    page, _, _ = web
    page.goto("/ui/patterns")
    cards = page.locator("article.pattern")
    assert cards.count() >= 3
    for img in cards.locator("img").all():
        img.scroll_into_view_if_needed()
    _loaded(page, "article.pattern img")
    page.goto("/ui/balls")
    assert page.locator("h1").inner_text() == "Ball library"
    balls = page.locator("article.ball")
    assert balls.count() == 3
    assert balls.first.locator(".badge").inner_text() in ("USBC legal", "not legal")
    assert "Weight" in balls.first.locator("pre.sheet").inner_text()
    for img in balls.locator("img.layout").all():
        img.scroll_into_view_if_needed()
    _loaded(page, "article.ball img.layout")
    before = balls.first.locator("img.layout").get_attribute("src")
    page.select_option("#layout-form select[name=layout]", index=1)
    assert balls.first.locator("img.layout").get_attribute("src") != before
    _loaded(page, "article.ball img.layout")


def test_submit_a_job_and_see_it_finish(web: tuple[Any, Watch, Server]) -> None:
    page, _, _ = web
    page.goto("/ui/jobs")
    page.select_option("#seed", index=0)
    text = page.locator("#editor").input_value()
    assert '"bowlrec-job"' in text
    page.click("#submit-form button[type=submit]")
    page.wait_for_url(re.compile(r"/ui/jobs/[0-9a-f]{16}"))
    page.wait_for_selector("#job-status.done", timeout=120_000)
    assert page.locator("#job-counts").inner_text() == "15 done, 0 failed of 15 runs"
    page.wait_for_selector("#results-table tbody tr")
    assert page.locator("#results-table tbody tr").count() == 15
    _loaded(page, "#job-figure")
    # every run of the job is in the archive, with its own page
    links = page.locator("#results-table tbody a.mono")
    assert links.count() == 15
    links.nth(14).click()
    page.wait_for_url(re.compile(r"/ui/runs/[0-9a-f]+"))
    assert page.locator("#summary").count() == 1


def test_an_invalid_job_shows_the_error(web: tuple[Any, Watch, Server]) -> None:
    page, watch, _ = web
    watch.allowed_status.add(422)
    page.goto("/ui/jobs")
    page.fill("#editor", '{"format": "bowlrec-job", "base": {"delivery": {"speed_mps": -3}}}')
    page.click("#submit-form button[type=submit]")
    error = page.locator("#submit-error")
    error.wait_for(state="visible")
    assert "speed_mps" in error.inner_text()
    page.fill("#editor", "{not json")
    page.click("#submit-form button[type=submit]")
    page.wait_for_selector("#submit-error:has-text('not valid JSON')")


class _EvilSite(http.server.BaseHTTPRequestHandler):
    """Another site's page: a form that posts a job to the bowlrec server on load."""

    target = ""

    def do_GET(self) -> None:  # noqa: N802 - the handler's API
        body = (
            "<!doctype html><html><body><form id=f method=post enctype=text/plain "
            f'action="{self.target}/jobs"><input name=\'{{"name": "evil", "x": "\' '
            "value='\"}'></form><script>document.getElementById('f').submit()</script>"
            "</body></html>"
        ).encode()
        self.send_response(200)
        self.send_header("Content-Type", "text/html")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args: Any) -> None:
        pass


def test_a_cross_site_form_post_is_refused(browser: Any, site: tuple[Server, list[str]]) -> None:
    srv, _ = site
    _EvilSite.target = srv.url
    evil = http.server.ThreadingHTTPServer(("127.0.0.2", 0), _EvilSite)
    thread = threading.Thread(target=evil.serve_forever, daemon=True)
    thread.start()
    try:
        with srv.client() as c:
            before = len(c.get("/jobs").json())
        context = browser.new_context()
        page = context.new_page()
        answers: list[Any] = []
        page.on("response", lambda r: answers.append(r) if r.url.endswith("/jobs") else None)
        host, port = evil.server_address[:2]
        page.goto(f"http://{host}:{port}/")
        page.wait_for_url(f"{srv.url}/jobs")
        assert answers and answers[-1].status == 403
        assert "cross-site request refused" in page.content()
        context.close()
        with srv.client() as c:
            assert len(c.get("/jobs").json()) == before
    finally:
        evil.shutdown()


def test_a_token_server_asks_to_sign_in(browser: Any, serve: Any) -> None:
    srv = serve(None, TOKEN)
    try:
        context = browser.new_context(base_url=srv.url)
        watch = Watch(srv.url, allowed_status={401})
        watch.attach(context)
        page = watch.page(context)
        page.goto("/")
        assert page.title() == "Sign in · bowlrec"
        assert page.locator("#runs-table").count() == 0
        page.fill("input[name=token]", "wrong")
        page.click("#signin button")
        page.locator("#signin .error").wait_for(state="visible")
        assert "wrong token" in page.locator("#signin .error").inner_text()
        page.fill("input[name=token]", TOKEN)
        page.click("#signin button")
        page.wait_for_selector("#run-count")
        assert page.title() == "Runs · bowlrec"
        page.goto("/ui/patterns")
        _loaded(page, "article.pattern img")
        watch.console = [m for m in watch.console if "401" not in m]
        context.close()
        watch.check()
    finally:
        srv.stop()


def test_the_api_docs_work_offline(web: tuple[Any, Watch, Server]) -> None:
    page, _, _ = web
    page.goto("/docs")
    page.wait_for_selector(".swagger-ui .opblock", timeout=60_000)
    assert page.locator(".swagger-ui .opblock").count() > 10


def test_pages_are_served_without_external_urls(site: tuple[Server, list[str]]) -> None:
    srv, ids = site
    with srv.client() as c:
        for path in ("/", f"/ui/runs/{ids[0]}", "/ui/patterns", "/ui/balls", "/ui/jobs"):
            html = c.get(path).text
            for url in re.findall(r'(?:src|href|action)="([^"]+)"', html):
                assert urlsplit(url).netloc in ("", urlsplit(srv.url).netloc), (path, url)


def test_the_runs_table_fits_a_1280_px_window(
    browser: Any, tmp_path: Path, module_serve: Any
) -> None:
    """At 1280x800 the runs table shows every column, hook, pocket and record included,
    without a horizontal scroll, also with long names, a library ball and a pattern (a
    bowler's run)."""
    root = tmp_path / "archive"
    _populate(root)
    archive = Archive(root)
    bowler = json.loads((ROOT / "examples/bowler/pocket-right.json").read_text())
    bowler["name"] = "a right-hander's pocket shot from board twenty, long name"
    bowler["options"]["record"] = "summary"
    from bowlrec.scene_input import parse_scene

    simulate_into(archive, parse_scene(bowler, archive.balls).scene)
    archive.close()
    srv = module_serve(root)
    context = browser.new_context(base_url=srv.url, viewport={"width": 1280, "height": 800})
    watch = Watch(srv.url)
    watch.attach(context)
    page = watch.page(context)
    try:
        page.goto("/")
        table = page.locator("#runs-table")
        box = table.bounding_box()
        scroller = table.locator("xpath=..")
        scroll_width = scroller.evaluate("e => e.scrollWidth")
        client_width = scroller.evaluate("e => e.clientWidth")
        assert box is not None and box["x"] + box["width"] <= 1280, box
        assert scroll_width <= client_width, (scroll_width, client_width)
        for header in ("hook", "pocket", "record"):
            b = table.locator("thead th", has_text=header).first.bounding_box()
            assert b is not None and b["x"] + b["width"] <= 1280, (header, b)
        name = table.locator("td.clip.name", has_text="long name").first
        assert name.get_attribute("title") == bowler["name"]  # the whole name on hover
    finally:
        context.close()
    watch.check()

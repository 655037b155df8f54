"""The web app's pages and their API over HTTP, against the app in process, and ``bowlrec ui``
as a real process (the browser tests in ``test_web_browser.py`` drive the same pages in
Chromium)."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

httpx = pytest.importorskip("httpx")
pytest.importorskip("fastapi")
pytest.importorskip("jinja2")

from helpers.servers import AppServer  # noqa: E402

from bowlrec.api import simulate_into  # noqa: E402
from bowlrec.archive import Archive  # noqa: E402
from bowlrec.errors import InputError  # noqa: E402
from bowlrec.spec import Scene  # noqa: E402
from bowlrec.web.tables import COUNT_CAP, RunsQuery, runs_page  # noqa: E402

TOKEN = "k" * 40


def _scene(name: str, speed: float, record: str = "summary") -> Scene:
    options: dict[str, Any] = {"record": record}
    if record == "rate":
        options["record_dt_s"] = 0.01
    return Scene.model_validate(
        {"name": name, "delivery": {"speed_mps": speed}, "options": options}
    )


@pytest.fixture(scope="module")
def populated(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[str]]:
    """An archive of 12 summary-only runs (speeds 6.0..8.75 m/s) and one recorded run."""
    root = tmp_path_factory.mktemp("pages") / "archive"
    archive = Archive(root)
    ids = [simulate_into(archive, _scene(f"s{i:02d}", 6.0 + 0.25 * i)).run_id for i in range(12)]
    ids.append(simulate_into(archive, _scene("recorded", 7.25, "rate")).run_id)
    archive.close()
    return root, ids


@pytest.fixture(scope="module")
def server(populated: tuple[Path, list[str]], module_app_server: Any) -> AppServer:
    return module_app_server(populated[0])


@pytest.fixture(scope="module")
def client(server: AppServer) -> Iterator[httpx.Client]:
    with server.client() as c:
        yield c


# -- the runs table in process -------------------------------------------------------------------


def test_the_query_string_round_trips() -> None:
    params = {
        "outcome": "pins",
        "where": "n_rhs>10; rtol<1",
        "speed_min": "7.25",
        "hook_max": "30",
        "sort": "speed_mps",
        "page": "3",
        "per_page": "100",
    }
    q = RunsQuery.parse(params)
    assert q.conditions() == ["n_rhs>10", "rtol<1", "speed_mps>=7.25", "hook_m<=0.3"]
    again = RunsQuery.parse(q.params())
    assert again == q
    assert q.url(page=4).count("page=4") == 1
    assert "&page=" not in q.sort_url("hook_m")  # a new order starts at page 1
    assert "sort=-hook_m" in q.sort_url("hook_m")
    assert "sort=-speed_mps" in q.sort_url("speed_mps")  # ascending -> descending
    assert RunsQuery.parse({}).url() == "/"


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"speed_min": "fast"}, "speed (m/s) from: 'fast' is not a number"),
        ({"hook_max": "nan"}, "hook (cm) to: 'nan' is not a finite number"),
        ({"sort": "bogus"}, "sort: cannot sort by 'bogus'; sort by an index column"),
        ({"per_page": "7"}, "per_page: 7 is not offered; one of 50, 100, 200, 500"),
        ({"page": "0"}, "page: 0 is not a page number (1, 2, ...)"),
        ({"page": "1.5"}, "page: 1.5 is not a page number (1, 2, ...)"),
    ],
)
def test_bad_query_values_are_named(params: dict[str, str], message: str) -> None:
    with pytest.raises(InputError) as err:
        RunsQuery.parse(params)
    assert str(err.value) == message


def test_pages_filters_and_the_count(populated: tuple[Path, list[str]]) -> None:
    archive = Archive(populated[0], create=False)
    everything = archive.list_runs(order_by="speed_mps")
    assert len(everything) == 13
    page = runs_page(archive, RunsQuery(sort="speed_mps", per_page=50))
    assert [r["run_id"] for r in page.rows] == [r["run_id"] for r in everything]
    assert (page.total, page.pages, page.capped) == (13, 1, False)
    # offset pages of 5 cover the ordered list exactly once
    seen = []
    for n in (1, 2, 3):
        rows = archive.list_runs(order_by="speed_mps", limit=5, offset=(n - 1) * 5)
        seen += [r["run_id"] for r in rows]
    assert seen == [r["run_id"] for r in everything]
    assert archive.list_runs(order_by="speed_mps", offset=12) == everything[12:]
    fast = runs_page(archive, RunsQuery.parse({"speed_min": "8", "sort": "-speed_mps"}))
    assert [r["speed_mps"] for r in fast.rows] == [8.75, 8.5, 8.25, 8.0]
    assert fast.total == 4
    assert archive.count_runs(where=["speed_mps>=8"], cap=2) == 2
    assert archive.count_runs(outcome="pins") == len(archive.list_runs(outcome="pins"))
    assert COUNT_CAP >= 10_000
    archive.close()


# -- pages over HTTP -----------------------------------------------------------------------------


def _page(client: httpx.Client, path: str, status: int = 200) -> str:
    r = client.get(path)
    assert r.status_code == status, (path, r.status_code, r.text[:300])
    assert r.headers["content-type"].startswith("text/html")
    csp = r.headers["content-security-policy"]
    assert "default-src 'self'" in csp and "frame-ancestors 'self'" in csp
    return r.text


def test_every_page_answers_and_links_only_here(
    client: httpx.Client, populated: tuple[Path, list[str]]
) -> None:
    _, ids = populated
    for path in (
        "/",
        f"/ui/runs/{ids[0]}",
        f"/ui/runs/{ids[-1]}",
        f"/ui/compare?ids={ids[0]}&ids={ids[1]}",
        "/ui/compare",
        "/ui/balls",
        "/ui/patterns",
        "/ui/jobs",
    ):
        html = _page(client, path)
        for url in re.findall(r'(?:src|href|action)="([^"]+)"', html):
            assert not url.startswith(("http:", "https:", "//")) or url.startswith(
                str(client.base_url)
            ), (path, url)
        for url in re.findall(r'(?:src|href)="(/static/[^"?]+)"', html):
            assert client.get(url).status_code == 200, url


def test_the_runs_page_lists_filters_and_pages(client: httpx.Client) -> None:
    html = _page(client, "/?per_page=50&sort=speed_mps")
    assert "1–13 of 13 runs" in html
    html = _page(client, "/?speed_min=8&sort=-speed_mps")
    assert "1–4 of 4 runs" in html
    assert html.index(">8.75<") < html.index(">8.00<")
    html = _page(client, "/?where=nope>1", status=422)
    assert "unknown column &#39;nope&#39;" in html
    html = _page(client, "/?outcome=bogus", status=422)
    assert "is not an outcome" in html


def test_a_run_page_of_a_summary_only_run(
    client: httpx.Client, populated: tuple[Path, list[str]]
) -> None:
    rid = populated[1][3]
    html = _page(client, f"/ui/runs/{rid[:8]}")
    assert f'src="/runs/{rid}/figure.svg"' in html
    assert "re-recorded from the stored scene" in html
    assert f"/viewer/index.html?url={client.base_url}/runs/{rid}/recording.rrd" in html
    _page(client, "/ui/runs/ffffffffffff", status=404)
    hostile = _page(client, "/ui/runs/%3Cimg%20src=x%20onerror=alert(1)%3E", status=404)
    assert "<img src=x" not in hostile and "&lt;img src=x onerror=alert(1)&gt;" in hostile


def test_figures_of_runs_and_compare(
    client: httpx.Client, populated: tuple[Path, list[str]]
) -> None:
    ids = populated[1]
    svg = client.get(f"/runs/{ids[0]}/figure.svg")
    assert svg.status_code == 200 and svg.headers["content-type"] == "image/svg+xml"
    ET.fromstring(svg.content)
    again = client.get(f"/runs/{ids[0]}/figure.svg")
    assert again.content == svg.content
    png = client.get(f"/runs/{ids[-1]}/figure.png")
    assert png.status_code == 200 and png.content.startswith(b"\x89PNG")
    both = client.get("/compare/figure.svg", params={"ids": [ids[0], ids[-1]]})
    assert both.status_code == 200
    ET.fromstring(both.content)
    none = client.get("/compare/figure.svg")
    assert none.status_code == 422


def test_replay_files_of_a_summary_only_run_are_re_recorded(
    client: httpx.Client, populated: tuple[Path, list[str]]
) -> None:
    rid = populated[1][5]
    for kind in ("rrd", "mcap"):
        r = client.get(f"/runs/{rid}/files/{kind}")
        assert r.status_code == 200, (kind, r.text[:200])
        assert len(r.content) > 1000
    assert (
        client.get(f"/runs/{rid}/recording.rrd").content
        == client.get(f"/runs/{rid}/files/rrd").content
    )
    csv = client.get(f"/runs/{rid}/files/csv")
    assert csv.status_code == 200 and csv.headers["content-type"].startswith("text/csv")
    assert len(csv.text.splitlines()) == 2  # the summary row of a summary-only run
    report = client.get(f"/runs/{rid}/report").json()
    assert report is None or "entry_board" in report


def test_patterns_and_their_kegel_graphs(client: httpx.Client) -> None:
    patterns = client.get("/patterns").json()
    names = [p["name"] for p in patterns]
    assert "house_shot_approx" in names
    assert all(p["stats"]["total_ml"] > 0 for p in patterns)
    r = client.get(f"/patterns/{names[0]}/figure.svg")
    assert r.status_code == 200
    ET.fromstring(r.content)
    missing = client.get("/patterns/nope/figure.svg")
    assert missing.status_code == 404 and "house_shot_approx" in missing.json()["detail"]


def test_a_ball_drawn_with_catalog_layouts(client: httpx.Client) -> None:
    from bowlrec.bowling.layout import load_example_library

    library = load_example_library()
    item = library.balls[0]
    body = {"name": "sheet", "spec": item.ball.model_dump(mode="json")}
    assert client.post("/balls", json=body).status_code in (200, 201)
    html = _page(client, "/ui/balls")
    assert "sheet@1" in html and ("USBC legal" in html or "not legal" in html)
    first = client.get("/balls/sheet@1/figure.svg")
    assert first.status_code == 200
    other = client.get(
        "/balls/sheet@1/figure.svg",
        params={"layout": library.layouts[1].id, "pap": library.paps[1].id},
    )
    assert other.status_code == 200 and other.content != first.content
    bad = client.get("/balls/sheet@1/figure.svg", params={"layout": "nope"})
    assert bad.status_code == 422 and library.layouts[0].id in bad.json()["detail"]


def test_a_job_streams_its_progress_and_plots_a_sweep(client: httpx.Client) -> None:
    job = {
        "format": "bowlrec-job",
        "name": "web-sweep",
        "base": {"name": "w"},
        "sweep": {
            "kind": "grid",
            "axes": {"delivery.speed_mps": {"start": 6, "stop": 9, "num": 4}},
        },
    }
    r = client.post("/jobs", json=job)
    assert r.status_code == 202, r.text
    jid = r.json()["job_id"]
    events = []
    with client.stream("GET", f"/jobs/{jid}/events") as stream:
        assert stream.headers["content-type"].startswith("text/event-stream")
        for line in stream.iter_lines():
            if line.startswith("data: "):
                events.append(json.loads(line[6:]))
    assert events[-1]["status"] == "done" and events[-1]["done"] == 4
    assert all(a != b for a, b in zip(events, events[1:], strict=False))
    rows = client.get(f"/jobs/{jid}/results").json()
    assert [row["values"]["delivery.speed_mps"] for row in rows] == [6.0, 7.0, 8.0, 9.0]
    assert all(row["run_id"] and row["outcome"] for row in rows)
    html = _page(client, f"/ui/jobs/{jid}")
    assert "delivery.speed_mps" in html
    fig = client.get(f"/jobs/{jid}/figure.svg", params={"x": "delivery.speed_mps", "y": "slide_m"})
    assert fig.status_code == 200
    ET.fromstring(fig.content)
    bad = client.get(f"/jobs/{jid}/figure.svg", params={"x": "delivery.nope"})
    assert bad.status_code == 422 and "delivery.speed_mps" in bad.json()["detail"]
    assert client.get("/jobs/0000000000000000/events").status_code == 404


def test_the_api_docs_are_served_from_here(client: httpx.Client) -> None:
    html = client.get("/docs").text
    assert "/static/apidocs/swagger-ui-bundle.js" in html
    redoc = client.get("/redoc").text
    assert "/static/apidocs/redoc.standalone.js" in redoc
    for page in (html, redoc):
        assert "cdn" not in page.lower() and "googleapis" not in page
        for url in re.findall(r"""(?:src|href|url)\s*[=:]\s*['"]([^'"]+)['"]""", page):
            assert url.startswith("/"), url
            assert client.get(url).status_code == 200, url


def test_a_token_server_shows_a_sign_in_page(app_server: Any) -> None:
    srv = app_server(token=TOKEN)
    try:
        with srv.client(auth=False) as c:
            for path in ("/", "/ui/jobs", "/ui/balls"):
                r = c.get(path)
                assert r.status_code == 401 and 'id="signin"' in r.text, path
            assert c.get("/patterns").status_code == 401
            assert c.get("/static/app.js").status_code == 200
            opened = c.post("/session", json={"token": TOKEN})
            assert opened.status_code == 200
            r = c.get("/")
            assert r.status_code == 200 and 'id="signin"' not in r.text
    finally:
        srv.stop()


# -- bowlrec ui ----------------------------------------------------------------------------------


@pytest.mark.process
def test_bowlrec_ui_serves_on_loopback_and_stops_on_ctrl_c(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "ui")
    simulate_into(archive, _scene("one", 7.0))
    archive.close()
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["BOWLREC_TOKEN"] = TOKEN  # ignored by ui: loopback, no token
    bowlrec = Path(sys.executable).parent / "bowlrec"
    proc = subprocess.Popen(
        [str(bowlrec), "ui", str(tmp_path / "ui"), "--port", "0"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()
        match = re.search(r"on (http://127\.0\.0\.1:\d+/) \(loopback only, no token\)", line)
        assert match, line
        url = match.group(1)
        deadline = time.monotonic() + 60
        while True:
            try:
                r = httpx.get(url, timeout=5)
                break
            except httpx.TransportError:
                assert time.monotonic() < deadline
                time.sleep(0.1)
        assert r.status_code == 200 and "runs-table" in r.text
    finally:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip().endswith("bowlrec: stopped") and "Traceback" not in err


@pytest.mark.process
def test_bowlrec_ui_does_not_make_an_archive_of_a_wrong_path(tmp_path: Path) -> None:
    bowlrec = Path(sys.executable).parent / "bowlrec"
    out = subprocess.run(
        [str(bowlrec), "ui", str(tmp_path / "typo"), "--port", "0", "--no-browser"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode != 0
    assert out.stderr.count("\n") == 1 and out.stderr.startswith("error:"), out.stderr
    assert not (tmp_path / "typo").exists()

"""The service's defences ("nothing let in"): the request body limit, the Host allow-list, the
cross-site check, cookie sessions, the strong-token rule of ``serve``, ball names matched whole
and error details without server paths. Real servers on 127.0.0.1 (``bowlrec serve`` in a
subprocess, or uvicorn in a thread of this process) where the transport matters; TestClient
for the rest."""

from __future__ import annotations

import http.client
import json
import re
import select
import socket
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

httpx = pytest.importorskip("httpx")
pytest.importorskip("fastapi")
uvicorn = pytest.importorskip("uvicorn")

from fastapi import HTTPException  # noqa: E402
from fastapi.testclient import TestClient  # noqa: E402
from helpers.processes import child_command, child_env  # noqa: E402
from helpers.servers import ThreadServer, start_server  # noqa: E402

from bowlrec.archive import Archive  # noqa: E402
from bowlrec.errors import ArchiveWriteError, RunDamagedError  # noqa: E402
from bowlrec.service.app import create_app  # noqa: E402
from bowlrec.service.redact import Redactor  # noqa: E402

TOKEN = "t0ken-" + "x" * 40
BALL = {"mass_kg": 7.0, "radius_m": 0.1085, "rg_m": [0.068, 0.07, 0.07]}


# -- servers -------------------------------------------------------------------------------------


def start_cli_server(archive: Path, *extra: str) -> tuple[subprocess.Popen[bytes], str]:
    """``bowlrec serve`` in a subprocess (no token); (process, url) once /health answers."""
    server = start_server(archive, None, *extra)
    return server.proc, server.url


def stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


@pytest.fixture
def open_app(tmp_path: Path) -> Iterator[TestClient]:
    """A token-less app (no warm-up) and a client that says ``Host: 127.0.0.1``."""
    app = create_app(tmp_path / "archive", warm_up=False)
    with TestClient(app, base_url="http://127.0.0.1", raise_server_exceptions=False) as client:
        yield client


@pytest.fixture
def token_app(tmp_path: Path) -> Iterator[TestClient]:
    app = create_app(tmp_path / "archive", TOKEN, warm_up=False)
    with TestClient(app, base_url="http://127.0.0.1", raise_server_exceptions=False) as client:
        yield client


def _job_body(n: int) -> dict[str, Any]:
    return {"name": "big", "scenes": [{"delivery": {"speed_mps": 7.5}}] * n}


# -- the body limit ------------------------------------------------------------------------------


@pytest.mark.process
def test_a_chunked_body_over_the_limit_gets_413_without_being_read(tmp_path: Path) -> None:
    """``serve --max-body-mb 0.25``: a chunked POST (no Content-Length) of whitespace that would
    go on for 64 MiB is answered 413 once 256 KiB have arrived; the client sees the answer
    before it has sent its body. A Content-Length over the limit is refused up front."""
    proc, url = start_cli_server(tmp_path / "archive", "--max-body-mb", "0.25")
    detail = "request body exceeds the limit of 262144 bytes (serve --max-body-mb)"
    try:
        port = int(url.rsplit(":", 1)[1])
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        conn.putrequest("POST", "/runs")
        conn.putheader("Content-Type", "application/json")
        conn.putheader("Transfer-Encoding", "chunked")
        conn.endheaders()
        total, sent, chunk = 64 * 2**20, 0, b" " * 65536
        assert conn.sock is not None
        while sent < total and not select.select([conn.sock], [], [], 0)[0]:
            try:
                conn.send(b"%x\r\n%s\r\n" % (len(chunk), chunk))
            except OSError:  # the server closed the connection after answering
                break
            sent += len(chunk)
        response = conn.getresponse()
        assert response.status == 413
        assert json.loads(response.read()) == {"detail": detail}
        assert sent < total  # answered while the body was still coming
        conn.close()

        def body() -> Iterator[bytes]:  # httpx streams a generator chunked
            for _ in range(1000):
                yield b" " * 65536

        r = httpx.post(f"{url}/jobs", content=body(), headers={"content-type": "application/json"})
        assert r.status_code == 413 and r.json() == {"detail": detail}
        declared = httpx.post(
            f"{url}/balls", content=b" " * 300_000, headers={"content-type": "application/json"}
        )
        assert declared.status_code == 413 and declared.json() == {"detail": detail}
        # under the limit, all as usual
        ok = httpx.post(f"{url}/balls", json={"name": "small", "spec": BALL})
        assert ok.status_code == 201, ok.text
    finally:
        stop(proc)


@pytest.mark.process
def test_a_100000_run_job_fits_the_default_limit_and_cross_site_cancel_is_refused(
    tmp_path: Path,
) -> None:
    """The default limit (32 MiB) takes a 100,000-run job of explicit minimal scenes (3.4 MB).
    On this token-less server, a cross-site ``POST /jobs/ID/cancel`` (a page of another site
    posting to 127.0.0.1) gets 403; the same request from a script (no Origin) gets 202."""
    app = create_app(tmp_path / "archive", warm_up=False)
    with ThreadServer(app) as srv, httpx.Client(base_url=srv.url, timeout=120) as client:
        body = json.dumps(_job_body(100_000)).encode()
        assert 3_000_000 < len(body) < 32 * 2**20
        r = client.post("/jobs", content=body, headers={"content-type": "application/json"})
        assert r.status_code == 202, r.text
        job_id = r.json()["job_id"]
        assert r.json()["total"] == 100_000

        attacker = client.post(
            f"/jobs/{job_id}/cancel",
            headers={"Origin": "https://attacker.example", "Sec-Fetch-Site": "cross-site"},
        )
        assert attacker.status_code == 403
        assert "cross-site request refused" in attacker.json()["detail"]
        origin_only = client.post(
            f"/jobs/{job_id}/cancel", headers={"Origin": "https://attacker.example"}
        )
        assert origin_only.status_code == 403 and "\n" not in origin_only.json()["detail"]
        assert client.get(f"/jobs/{job_id}").json()["status"] in ("queued", "running")

        own = client.post(f"/jobs/{job_id}/cancel", headers={"Origin": srv.url})
        assert own.status_code == 202, own.text


def test_create_app_max_body_bytes(tmp_path: Path) -> None:
    app = create_app(tmp_path / "archive", warm_up=False, max_body_bytes=100)
    with TestClient(app, base_url="http://127.0.0.1") as client:
        r = client.post("/balls", json={"name": "x" * 200, "spec": BALL})
        assert r.status_code == 413
        assert r.json()["detail"] == (
            "request body exceeds the limit of 100 bytes (serve --max-body-mb)"
        )
        assert client.post("/jobs/nope/cancel").status_code == 404  # an empty body is fine
    unlimited = create_app(tmp_path / "other", warm_up=False, max_body_bytes=None)
    with TestClient(unlimited, base_url="http://127.0.0.1") as client:
        assert client.post("/balls", json={"name": "y", "spec": BALL}).status_code == 201


# -- the Host allow-list -------------------------------------------------------------------------


@pytest.mark.parametrize(
    "host",
    ["127.0.0.1", "127.0.0.1:8000", "localhost", "LOCALHOST:1", "localhost.", "127.3.4.5:80"]
    + ["[::1]", "[::1]:8000"],
)
def test_loopback_hosts_are_allowed(open_app: TestClient, host: str) -> None:
    assert open_app.get("/health", headers={"Host": host}).status_code == 200


@pytest.mark.parametrize(
    "host", ["evil.example", "evil.example:8000", "192.168.1.4", "[::2]:80", "localhost.evil.io"]
)
def test_other_hosts_are_refused_with_a_hint(open_app: TestClient, host: str) -> None:
    """DNS rebinding: a page of evil.example whose name now resolves to 127.0.0.1 reaches the
    server with ``Host: evil.example``; nothing answers it, not even /health."""
    for method, path in (("GET", "/health"), ("GET", "/runs"), ("POST", "/balls")):
        r = open_app.request(method, path, headers={"Host": host}, json={})
        assert r.status_code == 400, (method, path, r.text)
        detail = r.json()["detail"]
        assert "is not allowed" in detail and "--allowed-host" in detail and "\n" not in detail


def test_allowed_hosts_and_the_bound_address(tmp_path: Path) -> None:
    app = create_app(tmp_path / "a", warm_up=False, allowed_hosts=["box.lan", "10.0.0.7"])
    with TestClient(app, base_url="http://127.0.0.1") as client:
        for host in ("box.lan", "BOX.LAN:8000", "10.0.0.7:8000", "localhost"):
            assert client.get("/balls", headers={"Host": host}).status_code == 200, host
        assert client.get("/balls", headers={"Host": "other.lan"}).status_code == 400
    with pytest.raises(ValueError, match="not a host name"):
        create_app(tmp_path / "b", warm_up=False, allowed_hosts=["http://x/y"])


def test_bearer_requests_skip_the_host_and_origin_checks(token_app: TestClient) -> None:
    bearer = {"Authorization": f"Bearer {TOKEN}"}
    hostile = {"Host": "evil.example", "Origin": "https://attacker.example"}
    assert token_app.get("/balls", headers={**bearer, **hostile}).status_code == 200
    r = token_app.post(
        "/balls", headers={**bearer, **hostile, "Sec-Fetch-Site": "cross-site"},
        json={"name": "scripted", "spec": BALL},
    )  # fmt: skip
    assert r.status_code == 201, r.text
    # a wrong token is no exemption
    wrong = {"Authorization": "Bearer nope", **hostile}
    assert token_app.get("/balls", headers=wrong).status_code == 400


# -- the cross-site check ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("headers", "allowed"),
    [
        ({}, True),  # curl, scripts
        ({"Sec-Fetch-Site": "same-origin"}, True),
        ({"Sec-Fetch-Site": "none"}, True),  # typed into the address bar
        ({"Origin": "http://127.0.0.1"}, True),
        ({"Origin": "http://127.0.0.1:80", "Sec-Fetch-Site": "same-origin"}, True),
        ({"Sec-Fetch-Site": "cross-site"}, False),
        ({"Sec-Fetch-Site": "same-site"}, False),
        ({"Origin": "https://attacker.example"}, False),
        ({"Origin": "null"}, False),
        ({"Origin": "https://127.0.0.1"}, False),  # another scheme: another origin
        ({"Origin": "http://127.0.0.1:8001"}, False),  # another port
        ({"Origin": "http://localhost"}, False),  # another name for the same server
    ],
)
def test_state_changing_requests_must_be_same_origin(
    open_app: TestClient, headers: dict[str, str], allowed: bool
) -> None:
    r = open_app.delete("/balls/nothing@1", headers=headers)
    if allowed:
        assert r.status_code == 404, r.text  # reached the endpoint
    else:
        assert r.status_code == 403, r.text
        assert r.json()["detail"].startswith("cross-site request refused")
    # reading is not state-changing: no Origin check
    assert open_app.get("/balls", headers=headers).status_code == 200


# -- cookie sessions -----------------------------------------------------------------------------


def test_cookie_session_opens_authenticates_and_closes(token_app: TestClient) -> None:
    assert token_app.get("/balls").status_code == 401
    wrong = token_app.post("/session", json={"token": "wrong"})
    assert wrong.status_code == 401 and "set-cookie" not in wrong.headers

    r = token_app.post("/session", json={"token": TOKEN})
    assert r.status_code == 200 and r.json()["auth"] is True and r.json()["expires_at"]
    cookie = r.headers["set-cookie"]
    attrs = {a.strip().split("=")[0].lower() for a in cookie.split(";")}
    assert cookie.startswith("bowlrec_session=")
    assert {"httponly", "path", "samesite", "max-age"} <= attrs and "secure" not in attrs
    assert "samesite=strict" in cookie.lower() and "path=/" in cookie.lower()
    session_id = token_app.cookies["bowlrec_session"]
    assert len(session_id) >= 40

    # the cookie authenticates like the bearer header (what an <img> or EventSource sends)
    assert token_app.get("/balls").status_code == 200
    made = token_app.post("/balls", json={"name": "cookie ball", "spec": BALL})
    assert made.status_code == 201, made.text
    # ... but a cookie-authenticated request from another site is refused
    cross = token_app.post(
        "/balls",
        json={"name": "csrf", "spec": BALL},
        headers={"Origin": "https://attacker.example", "Sec-Fetch-Site": "cross-site"},
    )
    assert cross.status_code == 403
    assert token_app.get("/balls", headers={"Host": "evil.example"}).status_code == 400

    closed = token_app.delete("/session")
    assert closed.status_code == 200 and closed.json() == {"closed": True}
    assert "bowlrec_session" not in token_app.cookies
    token_app.cookies.set("bowlrec_session", session_id)  # replaying the closed session
    assert token_app.get("/balls").status_code == 401
    token_app.cookies.set("bowlrec_session", "forged")
    assert token_app.get("/balls").status_code == 401


def test_session_from_the_bearer_header_over_https_is_secure(tmp_path: Path) -> None:
    app = create_app(tmp_path / "archive", TOKEN, warm_up=False)
    with TestClient(app, base_url="https://localhost") as client:
        r = client.post("/session", headers={"Authorization": f"Bearer {TOKEN}"})
        assert r.status_code == 200
        assert "secure" in {a.strip().lower() for a in r.headers["set-cookie"].split(";")}
        assert client.get("/balls").status_code == 200  # the cookie alone


def test_sessions_expire_and_are_not_needed_without_a_token(tmp_path: Path) -> None:
    app = create_app(tmp_path / "archive", TOKEN, warm_up=False, session_ttl_s=60.0)
    now = [1.8e9]  # the sessions' clock (UNIX s), moved by hand
    app.state.bowlrec.sessions.clock = lambda: now[0]
    with TestClient(app, base_url="http://127.0.0.1") as client:
        assert client.post("/session", json={"token": TOKEN}).status_code == 200
        now[0] += 59.5
        assert client.get("/balls").status_code == 200
        now[0] += 0.5  # the expiry itself
        assert client.get("/balls").status_code == 401
        assert client.post("/session", json={"token": TOKEN}).status_code == 200  # a new one
        assert client.get("/balls").status_code == 200
    app = create_app(tmp_path / "open", warm_up=False)
    with TestClient(app, base_url="http://127.0.0.1") as client:
        r = client.post("/session")
        assert r.json() == {"auth": False, "expires_at": None} and "set-cookie" not in r.headers


#: every route of the app with a token, and what a request that carries neither the bearer
#: token nor a session cookie gets: "open" (docs/service.md "The token": /health, the API
#: docs, the static and viewer files), "token in body" (POST /session: it takes the token as
#: its body instead, and is 401 without it) or "401" (everything else, the pages included:
#: their sign-in form is a 401); a route missing here fails the test
ROUTE_AUTH: dict[tuple[str, str], str] = {
    ("GET", "/health"): "open",
    ("GET", "/openapi.json"): "open",
    ("GET", "/docs"): "open",
    ("GET", "/redoc"): "open",
    ("GET", "/static"): "open",
    ("GET", "/static/apidocs"): "open",
    ("GET", "/viewer/{name:path}"): "open",
    ("POST", "/session"): "token in body",
    ("DELETE", "/session"): "401",
    ("GET", "/"): "401",
    ("GET", "/ui/runs/{run_id}"): "401",
    ("GET", "/ui/compare"): "401",
    ("GET", "/ui/balls"): "401",
    ("GET", "/ui/patterns"): "401",
    ("GET", "/ui/jobs"): "401",
    ("GET", "/ui/jobs/{job_id}"): "401",
    ("POST", "/runs"): "401",
    ("GET", "/runs"): "401",
    ("GET", "/runs/{run_id}"): "401",
    ("GET", "/runs/{run_id}/spec"): "401",
    ("GET", "/runs/{run_id}/files/{kind}"): "401",
    ("GET", "/runs/{run_id}/recording.rrd"): "401",
    ("GET", "/runs/{run_id}/pins"): "401",
    ("GET", "/runs/{run_id}/figure.{fmt}"): "401",
    ("GET", "/runs/{run_id}/report"): "401",
    ("GET", "/compare/figure.{fmt}"): "401",
    ("GET", "/balls"): "401",
    ("GET", "/balls/export"): "401",
    ("POST", "/balls/import"): "401",
    ("GET", "/balls/{ref}"): "401",
    ("POST", "/balls"): "401",
    ("DELETE", "/balls/{ref}"): "401",
    ("GET", "/balls/{ref}/figure.{fmt}"): "401",
    ("GET", "/patterns"): "401",
    ("GET", "/patterns/{name}/figure.{fmt}"): "401",
    ("POST", "/jobs"): "401",
    ("GET", "/jobs"): "401",
    ("GET", "/jobs/{job_id}"): "401",
    ("POST", "/jobs/{job_id}/cancel"): "401",
    ("POST", "/jobs/{job_id}/resume"): "401",
    ("GET", "/jobs/{job_id}/results"): "401",
    ("GET", "/jobs/{job_id}/figure.{fmt}"): "401",
    ("GET", "/jobs/{job_id}/events"): "401",
}
#: a value for each path parameter of the routes above
_PATH_VALUES = {"fmt": "svg", "kind": "csv", "name:path": "nope", "name": "house_shot"}


def _routes(app: Any) -> list[tuple[str, str]]:
    """(method, path) of every route of ``app``; a mounted directory as GET of its path. An
    included router is a route of its own in newer FastAPI versions: its routes are listed."""
    from starlette.routing import Mount

    found = []
    for route in app.routes:
        if isinstance(route, Mount):
            found.append(("GET", route.path))
        elif hasattr(route, "effective_route_contexts"):
            for context in route.effective_route_contexts():
                methods = context.original_route.methods - {"HEAD"}
                found += [(m, context.path) for m in sorted(methods)]
        else:
            found += [(m, route.path) for m in sorted(route.methods - {"HEAD"})]
    return found


def test_every_route_needs_the_token_unless_the_docs_exempt_it(tmp_path: Path) -> None:
    """A request with neither the token nor a session cookie, to every route of a server with a
    token: 401 exactly where :data:`ROUTE_AUTH` says so, and nothing but its "open" routes
    answers without one (the static and viewer files are asked for a file that is not there)."""
    app = create_app(tmp_path / "archive", TOKEN, warm_up=False)

    def no_viewer_file(name: str) -> Path:  # the viewer's files are unpacked by a child process
        raise HTTPException(404, f"no viewer file {name}")

    app.state.bowlrec.viewer.path = no_viewer_file
    routes = _routes(app)
    assert len(routes) == len(set(routes))
    assert sorted(routes) == sorted(ROUTE_AUTH), "a route was added or removed: say in ROUTE_AUTH"
    wrong: list[str] = []
    with TestClient(app, base_url="http://127.0.0.1", raise_server_exceptions=False) as client:
        for (method, path), expected in ROUTE_AUTH.items():
            url = re.sub(r"\{([^}]+)\}", lambda m: _PATH_VALUES.get(m[1], "x0123"), path)
            if url in ("/static", "/static/apidocs"):
                url += "/nope.css"
            answer = client.request(method, url)
            got = "401" if answer.status_code == 401 else "open"
            if expected == "token in body" and got == "401":
                answer = client.request(method, url, json={"token": TOKEN})
                got = "token in body" if answer.status_code == 200 else "401"
                client.cookies.clear()
            if got != expected:
                wrong.append(f"{method} {path}: {answer.status_code} (expected {expected})")
            page = path == "/" or path.startswith("/ui/")
            if got == "401" and page:  # the sign-in form
                assert 'name="token"' in answer.text, f"{method} {path}"
            elif got == "401":
                assert answer.headers.get("www-authenticate") == "Bearer", f"{method} {path}"
    assert not wrong, "\n".join(wrong)


def test_closing_a_session_needs_the_session_or_the_token(token_app: TestClient) -> None:
    """``DELETE /session`` without the token or a valid session cookie is 401 and clears nothing;
    with the bearer header it answers (and there is no session to close)."""
    anonymous = token_app.delete("/session")
    assert anonymous.status_code == 401 and "set-cookie" not in anonymous.headers
    token_app.cookies.set("bowlrec_session", "forged")
    assert token_app.delete("/session").status_code == 401
    token_app.cookies.clear()
    bearer = token_app.delete("/session", headers={"Authorization": f"Bearer {TOKEN}"})
    assert bearer.status_code == 200 and bearer.json() == {"closed": False}


# -- serve: the strong token, flags ----------------------------------------------------------------


def _serve(args: list[str], token: str | None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        child_command("service_child", *args),
        capture_output=True,
        text=True,
        env=child_env(BOWLREC_TOKEN=token),
        timeout=60,
    )


@pytest.mark.process
def test_serve_refuses_a_short_token_on_a_non_loopback_host(tmp_path: Path) -> None:
    archive = tmp_path / "a"
    out = _serve(["--archive", str(archive), "--host", "0.0.0.0"], token="short-token")
    assert out.returncode == 2
    [line] = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert "$BOWLREC_TOKEN must be at least 32 characters" in line
    assert "secrets.token_urlsafe(32)" in line
    assert not archive.exists()  # refused before touching anything


@pytest.mark.process
def test_serve_flags_reach_the_app(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--allowed-host`` (repeatable), ``--max-body-mb`` and the bound IP, as ``serve`` passes
    them to the app (uvicorn's run replaced; the sockets were bound before "serving on")."""
    from typer.testing import CliRunner

    from bowlrec.cli import app as cli
    from bowlrec.cli import serve as _serve_module  # noqa: F401  (registers the command)

    served: dict[str, Any] = {}

    def fake_run(self: Any, sockets: list[socket.socket] | None = None) -> None:
        served["app"], served["sockets"] = self.config.app, sockets

    monkeypatch.setattr(uvicorn.Server, "run", fake_run)
    monkeypatch.setenv("BOWLREC_TOKEN", TOKEN)
    args = ["serve", "--archive", str(tmp_path / "a"), "--host", "127.0.0.9", "--port", "0"]
    args += ["--allowed-host", "box.lan", "--allowed-host", "[fd00::1]", "--max-body-mb", "0.001"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert "serving" in result.output
    for sock in served["sockets"]:
        assert sock.getsockname()[0] == "127.0.0.9"
        sock.close()
    with TestClient(served["app"], base_url="http://127.0.0.1") as client:
        session = client.post("/session", json={"token": TOKEN})
        assert session.status_code == 200
        for host in ("box.lan", "[fd00::1]:8000", "127.0.0.9:8000"):
            assert client.get("/balls", headers={"Host": host}).status_code == 200, host
        assert client.get("/balls", headers={"Host": "other"}).status_code == 400
        big = client.post("/balls", json={"name": "n" * 2000, "spec": BALL})
        assert big.status_code == 413 and "1048 bytes" in big.json()["detail"]

    bad = CliRunner().invoke(
        cli, ["serve", "--archive", str(tmp_path / "b"), "--allowed-host", "a/b"]
    )
    assert bad.exit_code == 2 and "not a host name" in bad.output


@pytest.mark.process
def test_serve_reports_a_port_in_use_in_one_line(tmp_path: Path) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        out = _serve(["--archive", str(tmp_path / "a"), "--port", str(port)], token=None)
    assert out.returncode == 2
    assert "address already in use" in out.stderr.lower() and "serving" not in out.stderr


# -- ball names ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["house\n", "house\r\n", "\nhouse", "house\x00", "a" * 101])
def test_ball_names_are_matched_whole(open_app: TestClient, tmp_path: Path, name: str) -> None:
    r = open_app.post("/balls", json={"name": name, "spec": BALL})
    assert r.status_code == 422 and "ball name" in r.json()["detail"]
    assert open_app.get("/balls", params={"all_versions": True}).json() == []
    library = Archive(tmp_path / "lib").balls
    with pytest.raises(ValueError, match="ball name"):
        library.add(name, library_ball())
    assert library.list() == []


def library_ball() -> Any:
    from bowlrec.archive.balls import parse_ball

    return parse_ball(BALL)


def test_ball_refs_with_odd_versions_or_names_are_client_errors(open_app: TestClient) -> None:
    assert open_app.post("/balls", json={"name": "house", "spec": BALL}).status_code == 201
    for ref in ("house@\uff11", "house@1%0A", "house@99999999999999999999", "house@0"):
        assert open_app.get(f"/balls/{ref}").status_code == 422, ref
        assert open_app.delete(f"/balls/{ref}").status_code == 422, ref
    for ref in ("..@1", ".@1", "house%00@1", "house%0A@1"):
        assert open_app.delete(f"/balls/{ref}").status_code == 404, ref
        assert open_app.get(f"/balls/{ref}").status_code == 404, ref
    assert open_app.get("/balls/house@1").status_code == 200


# -- no server paths in error details ------------------------------------------------------------


def test_404_and_other_error_details_name_no_server_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    root = tmp_path / "archive"
    app = create_app(root, warm_up=False)
    state = app.state.bowlrec
    with TestClient(app, base_url="http://127.0.0.1", raise_server_exceptions=False) as client:
        details = []
        for path in ("/runs/0123456789abcdef0123", "/runs/0123456789abcdef0123/spec",
                     "/runs/0123/files/hdf5", "/balls/none", "/jobs/none", "/nowhere"):  # fmt: skip
            r = client.get(path)
            assert r.status_code == 404, path
            details.append(r.json()["detail"])
        assert "no run '0123456789abcdef0123'" in details[0]

        def unwritable(*args: Any, **kw: Any) -> Any:
            raise ArchiveWriteError(
                f"{root}/segments: could not write a segment of 1 run(s) (disk full); nothing "
                "already archived was lost"
            )

        monkeypatch.setattr(state.commits, "add", unwritable)  # sealing the summary-only run
        r = client.post("/runs", json={"options": {"record": "summary"}})
        assert r.status_code == 507 and "ARCHIVE/segments: could not write" in r.json()["detail"]
        details.append(r.json()["detail"])

        def damaged(*args: Any, **kw: Any) -> Any:
            raise RunDamagedError(
                "0123456789abcdef0123",
                "seg1",
                f"unreadable: Unable to open file (name = '{root}/segments/a/b.h5'); "
                "see /usr/lib/python3/h5py/_hl/files.py",
            )

        monkeypatch.setattr(state.archive, "resolve_id", lambda rid: rid)
        monkeypatch.setattr(state.archive, "load", damaged)
        r = client.get("/runs/0123456789abcdef0123/spec")
        assert r.status_code == 409 and "run 0123456789abcdef0123" in r.json()["detail"]
        details.append(r.json()["detail"])

        def no_foxglove(name: str) -> Any:  # the MCAP writer's library is not installed
            raise ImportError(f"No module named 'foxglove' ({root}/lib/foxglove)", name="foxglove")

        with monkeypatch.context() as m:
            m.setattr(state.replays, "run", lambda rid: object())
            m.setattr("bowlrec.sinks.registry.importlib.import_module", no_foxglove)
            r = client.get("/runs/0123456789abcdef0123/files/mcap")
        assert r.status_code == 501 and "pip install 'bowlrec[mcap]'" in r.json()["detail"]
        details.append(r.json()["detail"])

        # a job that failed with a path in its error, and a failure row naming a file
        job_id = client.post("/jobs", json={"scenes": [{}]}).json()["job_id"]
        client.post(f"/jobs/{job_id}/cancel")
        deadline = time.monotonic() + 60  # settled: the job thread no longer writes its record
        while client.get(f"/jobs/{job_id}").json()["status"] in ("queued", "running"):
            assert time.monotonic() < deadline
            time.sleep(0.05)
        with state.jobs._mutex:
            rec = state.jobs._records[job_id]
            rec.status, rec.error = "failed", f"FileNotFoundError: '{root}/jobs/{job_id}.spec.json'"
            rec.failures = [{"index": 0, "run_id": None, "error": "OSError: /home/u/x.h5 gone"}]
        job = client.get(f"/jobs/{job_id}").json()
        listed = client.get("/jobs").json()[0]
        details += [job["error"], job["failures"][0]["error"], listed["error"]]
    for detail in details:
        assert str(root) not in detail and str(tmp_path) not in detail, detail
        assert "/usr/lib" not in detail and "/home/u" not in detail, detail
    assert "ARCHIVE/jobs/" in job["error"] and "<path>" in job["failures"][0]["error"]


def test_redactor() -> None:
    redact = Redactor("/srv/data/archive")
    assert redact("no run 'ab12' in archive /srv/data/archive") == "no run 'ab12'"
    assert redact("/srv/data/archive/segments/x.h5: gone") == "ARCHIVE/segments/x.h5: gone"
    assert redact("open '/etc/passwd' failed") == "open '<path>' failed"
    assert redact("see /a/b/c/d") == "see <path>"
    kept = "POST /jobs/{id}/resume; ratio 3/4; http://host/a/b; name@2"
    assert redact(kept) == kept


def test_a_relative_archive_root_is_redacted_only_as_a_path() -> None:
    """``serve --archive data``: "data" is replaced where it is a path, not as a word."""
    redact = Redactor("data")
    assert redact("unable to parse raw data") == "unable to parse raw data"
    assert redact("data/segments/x.h5: gone") == "ARCHIVE/segments/x.h5: gone"
    assert redact("line one\nline\x00two") == "line one\nline\\x00two"


# -- no 5xx for bad input ------------------------------------------------------------------------


def test_bad_input_gets_4xx_never_5xx(open_app: TestClient) -> None:
    requests: list[tuple[str, str, Any]] = [
        ("POST", "/balls/import", {"format": "bowlrec-ball-library", "balls": {"a": 1}}),
        ("POST", "/balls/import", {"format": "bowlrec-ball-library", "balls": [1, "x"]}),
        ("POST", "/balls/import", {"format": "bowlrec-ball-library", "balls": [{"name": 1}]}),
        (
            "POST",
            "/balls/import",
            {"format": "bowlrec-ball-library", "balls": [{"name": "a\n", "spec": BALL}]},
        ),  # fmt: skip
        ("POST", "/balls/import", []),
        (
            "POST",
            "/balls/import",
            {"format": "bowlrec-ball-library", "balls": [{"name": "n", "spec": BALL, "note": 7}]},
        ),  # fmt: skip
        ("POST", "/runs", {"options": {"pins": {"standing": []}}}),
        ("POST", "/balls", {"name": "x", "spec": [1]}),
        ("POST", "/balls", {"name": None, "spec": BALL}),
        ("POST", "/balls", {"name": "x", "spec": BALL, "notes": "typo"}),
        ("POST", "/jobs", []),
        ("POST", "/jobs", {"scenes": None}),
        ("POST", "/jobs", {"scenes": "x"}),
        (
            "POST",
            "/jobs",
            {
                "sweep": {
                    "kind": "grid",
                    "axes": {
                        "delivery.speed_mps": {"start": 7, "stop": 9, "num": 100000},
                        "delivery.omega_radps[1]": {"start": 1, "stop": 9, "num": 100000},
                    },
                }
            },
        ),  # fmt: skip
        ("POST", "/session", {"token": 5}),
        ("POST", "/session", [1]),
        ("GET", "/runs?where=hook_m>=abc", None),
        ("GET", "/runs?where=hook_m", None),
        ("GET", "/runs?limit=-1", None),
        ("GET", "/runs/%00", None),
        ("GET", "/balls/%00", None),
        ("GET", "/jobs/%00", None),
        ("POST", "/jobs/..%2F..%2Fx/resume", None),
        ("DELETE", "/balls/a@1@2", None),
    ]
    for method, path, body in requests:
        r = open_app.request(method, path, json=body)
        assert 400 <= r.status_code < 500, (method, path, r.status_code, r.text)


def test_recorded_runs_wait_for_a_slot_and_too_many_waiting_get_503() -> None:
    """Recorded POST /runs simulate at most one per slot (a core) at once; at most 4 per slot
    wait, and one more is refused at once (503), so waiting never takes every worker thread."""
    import time

    from bowlrec.errors import ServerBusyError
    from bowlrec.service.slots import RecordingSlots

    slots = RecordingSlots(1)
    entered = threading.Event()
    release = threading.Event()
    done: list[int] = []

    def hold() -> None:
        with slots.slot():
            entered.set()
            release.wait(30)

    def wait_for_slot(i: int) -> None:
        with slots.slot():
            done.append(i)

    holder = threading.Thread(target=hold)
    holder.start()
    assert entered.wait(30)
    waiters = [threading.Thread(target=wait_for_slot, args=(i,)) for i in range(4)]
    for t in waiters:
        t.start()
    deadline = time.monotonic() + 30
    while slots._waiting < 4 and time.monotonic() < deadline:
        time.sleep(0.01)
    with pytest.raises(ServerBusyError, match="the server is busy"), slots.slot():
        pass
    release.set()
    for t in [holder, *waiters]:
        t.join(30)
    assert sorted(done) == [0, 1, 2, 3]
    with slots.slot():  # free again
        pass

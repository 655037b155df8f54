"""What a new user meets first: malformed requests answered with one ``where: message`` line
(never FastAPI's list; the app in process), and, against real ``bowlrec serve`` processes on
127.0.0.1, an address ``serve`` cannot listen on reported in one ``error:`` line before anything
is served or created, and Ctrl-C (once or twice) stopping the server without a traceback."""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

httpx = pytest.importorskip("httpx")
pytest.importorskip("fastapi")
pytest.importorskip("uvicorn")

from helpers.processes import child_command, child_env  # noqa: E402
from helpers.scene_builders import summary_scene  # noqa: E402
from helpers.servers import AppServer, start_server  # noqa: E402

JSON = {"content-type": "application/json"}


@pytest.fixture(scope="module")
def server(module_app_server: Any) -> AppServer:
    """The service in process: the answers do not depend on the transport."""
    return module_app_server()


# -- malformed requests --------------------------------------------------------------------------

BODY_ROUTES = ["/runs", "/jobs", "/balls", "/balls/import", "/session"]

#: (body, headers, the detail) for every route that takes a JSON body
MALFORMED_BODIES: list[tuple[bytes, dict[str, str], str]] = [
    (b"not json", JSON, "request body: not valid JSON at line 1 column 1: Expecting value"),
    (
        b'{"name": "x" "a": 1}',
        JSON,
        "request body: not valid JSON at line 1 column 14: Expecting ',' delimiter",
    ),
    (
        b'{"name": "x",',
        JSON,
        "request body: not valid JSON at line 1 column 14: Expecting property name enclosed "
        "in double quotes",
    ),
    (
        b'{"a": 1,\n "b": }',
        JSON,
        "request body: not valid JSON at line 2 column 7: Expecting value",
    ),
    (b'{"a": 1}\n{"b": 2}', JSON, "request body: not valid JSON at line 2 column 1: Extra data"),
    (b"\xff\xfe", JSON, "request body: not valid JSON at line 1 column 1: Expecting value"),
    (b"[1, 2]", JSON, "request body: must be a JSON object (got an array)"),
    (b"5", JSON, "request body: must be a JSON object (got the number 5)"),
    (b"-2.5", JSON, "request body: must be a JSON object (got the number -2.5)"),
    (b'"scene"', JSON, "request body: must be a JSON object (got a string)"),
    (b"true", JSON, "request body: must be a JSON object (got true)"),
    (b"null", JSON, "request body: must be a JSON object (got null)"),
    (b"NaN", JSON, "request body: must be a JSON object (got NaN)"),
    (b"-Infinity", JSON, "request body: must be a JSON object (got -Infinity)"),
    (b"1" + b"0" * 400, JSON, "request body: must be a JSON object (got a number of 401 digits)"),
    (
        b'{"name": "x"}',
        {"content-type": "text/plain"},
        "request body: Content-Type 'text/plain' is not JSON (send Content-Type: application/json)",
    ),
    (
        b"name=x",
        {"content-type": "application/x-www-form-urlencoded"},
        "request body: Content-Type 'application/x-www-form-urlencoded' is not JSON (send "
        "Content-Type: application/json)",
    ),
]
#: what an empty body gets, on the routes where the body is required
EMPTY = "request body: empty (send a JSON object with the header Content-Type: application/json)"


def _detail(r: Any) -> str:
    """The answer's detail, checked to be the documented form: ``{"detail": "<one string>"}``."""
    body = r.json()
    assert set(body) == {"detail"}, body
    detail = body["detail"]
    assert isinstance(detail, str), f"not a string: {detail!r}"
    return str(detail)


@pytest.mark.parametrize("path", BODY_ROUTES)
def test_malformed_bodies_get_one_line_naming_the_body(server: AppServer, path: str) -> None:
    with server.client() as client:
        for body, headers, expected in MALFORMED_BODIES:
            if path == "/session" and body == b"null":
                continue  # the session's body is optional: null is no body
            r = client.post(path, content=body, headers=headers)
            assert r.status_code == 422, (path, body, r.status_code, r.text)
            assert _detail(r) == expected, (path, body)
        # no Content-Type at all: the body is not read as JSON
        r = client.post(path, content=b'{"name": "x"}')
        assert r.status_code == 422, (path, r.text)
        assert _detail(r) == (
            "request body: sent without a Content-Type header (send Content-Type: application/json)"
        )
        # a body too deep or with too long a number to parse: 400, still one line
        r = client.post(path, content=b"[" * 100_000, headers=JSON)
        assert r.status_code == 400, (path, r.text)
        assert _detail(r) == "request body: cannot be parsed: nested too deeply"
        r = client.post(path, content=b'{"a": ' + b"1" * 5000 + b"}", headers=JSON)
        assert r.status_code == 400, (path, r.text)
        assert _detail(r) == (
            f"request body: cannot be parsed: an integer has more than "
            f"{sys.get_int_max_str_digits()} digits"
        )
        r = client.post(path, content=b'{"a": "\xff"}', headers=JSON)
        assert r.status_code == 400, (path, r.text)
        assert _detail(r) == "request body: cannot be parsed: not UTF-8 (byte 7)"


@pytest.mark.parametrize("path", ["/runs", "/jobs", "/balls", "/balls/import"])
def test_an_empty_body_is_named(server: AppServer, path: str) -> None:
    with server.client() as client:
        for headers in (JSON, {}):
            r = client.post(path, content=b"", headers=headers)
            assert r.status_code == 422 and _detail(r) == EMPTY, (path, headers, r.text)


def test_the_session_body_is_optional_but_checked(server: AppServer) -> None:
    with server.client() as client:
        assert client.post("/session", content=b"", headers=JSON).status_code == 200
        r = client.post("/session", json={"token": 5})
        assert r.status_code == 422
        assert _detail(r) == "token: Input should be a valid string (got 5)"


def test_a_field_of_the_body_is_named_by_its_path(server: AppServer) -> None:
    with server.client() as client:
        r = client.post("/balls", json={"name": 5, "spec": {}})
        assert r.status_code == 422
        assert _detail(r) == "name: Input should be a valid string (got 5)"
        r = client.post("/balls", json={"name": "x", "spec": {}, "note": ["a"]})
        assert _detail(r) == "note: Input should be a valid string"
        # one line per problem, as for an invalid spec
        r = client.post("/balls", json={})
        assert _detail(r).splitlines() == ["name: Field required", "spec: Field required"]


#: (path and query, the detail) of parameters FastAPI rejects: 422
BAD_PARAMETERS = [
    (
        "/runs?limit=abc",
        "query parameter limit: Input should be a valid integer, unable to parse string as an "
        "integer (got 'abc')",
    ),
    (
        "/runs?limit=-1",
        "query parameter limit: Input should be greater than or equal to 0 (got '-1')",
    ),
    (
        "/runs?limit=1.5",
        "query parameter limit: Input should be a valid integer, unable to parse string as an "
        "integer (got '1.5')",
    ),
    (
        "/runs?limit=",
        "query parameter limit: Input should be a valid integer, unable to parse string as an "
        "integer (got '')",
    ),
    (
        "/runs?limit=99999999999999999999999",
        "query parameter limit: Input should be less than or equal to 9223372036854775807 "
        "(got '99999999999999999999999')",
    ),
    (
        "/runs?name=x&limit=%00",
        "query parameter limit: Input should be a valid integer, unable to parse string as an "
        "integer (got '\\x00')",
    ),
    (
        "/balls?all_versions=maybe",
        "query parameter all_versions: Input should be a valid boolean, unable to interpret "
        "input (got 'maybe')",
    ),
    (
        "/runs/abcd/files/pdf",
        "path parameter kind: Input should be 'hdf5', 'mcap', 'rrd' or 'csv' (got 'pdf')",
    ),
]


def test_bad_parameters_get_one_line_naming_the_parameter(server: AppServer) -> None:
    with server.client() as client:
        for path, expected in BAD_PARAMETERS:
            r = client.get(path)
            assert r.status_code == 422, (path, r.status_code, r.text)
            assert _detail(r) == expected, path
        # the filters bowlrec checks itself answer the same way
        for query, start in [
            ("where=hook_m", "cannot parse filter 'hook_m'"),
            ("where=nope>1", "unknown column 'nope'"),
            ("order_by=nope", "cannot order by unknown column 'nope'"),
        ]:
            r = client.get(f"/runs?{query}")
            assert r.status_code == 422 and start in _detail(r), (query, r.text)
            assert "\n" not in _detail(r)
        # the largest limit is accepted
        assert client.get("/runs?limit=9223372036854775807").status_code == 200


def test_unknown_paths_and_methods_are_named(server: AppServer) -> None:
    with server.client() as client:
        r = client.get("/run")
        assert r.status_code == 404
        assert _detail(r) == "no such path: /run (the API is described at /docs)"
        r = client.put("/runs", json={})
        assert r.status_code == 405
        assert _detail(r) == "method PUT is not allowed on /runs (see /docs)"
        # the client's own path is named whole, however many parts it has
        r = client.get("/runs/abcd/nothing")
        assert _detail(r) == "no such path: /runs/abcd/nothing (the API is described at /docs)"
        r = client.delete("/runs/abcd/files/csv")
        assert r.status_code == 405
        assert _detail(r) == "method DELETE is not allowed on /runs/abcd/files/csv (see /docs)"


def test_the_openapi_document_describes_no_error_list(server: AppServer) -> None:
    with server.client() as client:
        doc = client.get("/openapi.json").json()
    assert "HTTPValidationError" not in json.dumps(doc)
    post_runs = doc["paths"]["/runs"]["post"]["responses"]["422"]
    assert post_runs["content"]["application/json"]["schema"]["$ref"].endswith("/ErrorResponse")


def test_request_error_text_without_a_server() -> None:
    """The formatter on what FastAPI raises, including a position it cannot place."""
    from fastapi.exceptions import RequestValidationError

    from bowlrec.service.app import request_error_text

    invalid = {"type": "json_invalid", "loc": ("body", 3), "msg": "JSON decode error"}
    err = RequestValidationError([{**invalid, "ctx": {"error": "Expecting value"}}], body="a\nb")
    assert request_error_text(err) == (
        "request body: not valid JSON at line 2 column 2: Expecting value"
    )
    err = RequestValidationError([invalid])  # no text, no reason
    assert request_error_text(err) == "request body: not valid JSON: cannot be parsed"
    err = RequestValidationError(
        [{"type": "dict_type", "loc": ("body",), "msg": "x", "input": b"a=1"}]
    )
    assert request_error_text(err, "text/plain\n") == (
        "request body: Content-Type 'text/plain\\n' is not JSON (send Content-Type: "
        "application/json)"
    )


# -- serve: an address it cannot listen on -------------------------------------------------------


def _serve(tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    cmd = child_command("service_child", "--archive", str(tmp_path / "archive"), *args)
    return subprocess.run(cmd, capture_output=True, text=True, env=child_env(), timeout=120)


def _one_error_line(out: subprocess.CompletedProcess[str], tmp_path: Path) -> str:
    """The single ``error:`` line of a serve that could not listen; checks that it served
    nothing, printed no traceback, exited 2 and created nothing (no archive: no worker or
    job thread was started)."""
    lines = [line for line in out.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, out.stderr
    assert out.returncode == 2, (out.returncode, out.stderr)
    assert "serving" not in out.stderr and "Traceback" not in out.stderr
    assert not (tmp_path / "archive").exists()
    assert lines[0].startswith("error: cannot listen on "), lines[0]
    return lines[0]


@pytest.mark.process
def test_a_port_in_use_is_one_line(tmp_path: Path) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        out = _serve(tmp_path, "--port", str(port), "--job-workers", "2")
    assert _one_error_line(out, tmp_path) == (
        f"error: cannot listen on 127.0.0.1:{port}: address already in use (is another "
        "bowlrec serve running? use --port)"
    )


@pytest.mark.process
def test_an_address_not_of_this_machine_is_one_line(tmp_path: Path) -> None:
    out = _serve(tmp_path, "--host", "192.0.2.1", "--insecure", "--port", "8000")
    assert _one_error_line(out, tmp_path) == (
        "error: cannot listen on 192.0.2.1:8000: 192.0.2.1 is not an address of this machine "
        "(use 127.0.0.1, 0.0.0.0 for every interface, or one of its own addresses)"
    )


@pytest.mark.process
def test_an_ipv6_address_is_shown_in_brackets(tmp_path: Path) -> None:
    out = _serve(tmp_path, "--host", "2001:db8::1", "--insecure", "--port", "8000")
    assert _one_error_line(out, tmp_path).startswith("error: cannot listen on [2001:db8::1]:8000: ")


@pytest.mark.process
def test_an_unresolvable_host_name_is_one_line(tmp_path: Path) -> None:
    out = _serve(tmp_path, "--host", "no-such-host.invalid", "--insecure", "--port", "8000")
    line = _one_error_line(out, tmp_path)
    assert line.startswith(
        "error: cannot listen on no-such-host.invalid:8000: cannot resolve the host name ("
    )
    assert line.endswith("give an IP address or a name of this machine, e.g. --host 127.0.0.1")


def _unprivileged_port_start() -> int:
    try:
        return int(Path("/proc/sys/net/ipv4/ip_unprivileged_port_start").read_text())
    except (OSError, ValueError):
        return 1024


@pytest.mark.process
@pytest.mark.skipif(_unprivileged_port_start() <= 80, reason="this kernel lets anyone bind 80")
def test_a_privileged_port_is_one_line(tmp_path: Path) -> None:
    """Port 80 without the right to bind it: as a user, or as root without the capability
    (``setpriv`` drops it; skipped as root without setpriv)."""
    prefix: list[str] = []
    if os.geteuid() == 0:
        setpriv = shutil.which("setpriv")
        if setpriv is None:
            pytest.skip("root may bind port 80, and setpriv is not installed to prevent it")
        drop = "-net_bind_service"
        prefix = [setpriv, f"--bounding-set={drop}", f"--inh-caps={drop}"]
    cmd = [*prefix, *child_command("service_child", "--archive", str(tmp_path / "archive"))]
    out = subprocess.run(
        [*cmd, "--port", "80"], capture_output=True, text=True, env=child_env(), timeout=120
    )
    if prefix and out.stderr.startswith("setpriv:"):
        pytest.skip(f"setpriv cannot drop the capability here: {out.stderr.strip()}")
    assert _one_error_line(out, tmp_path) == (
        "error: cannot listen on 127.0.0.1:80: permission denied: ports below 1024 need root "
        "(use --port 1024 or higher, e.g. 8000)"
    )


def test_listen_error_reasons() -> None:
    from bowlrec.cli.serve import host_port, listen_error

    denied = OSError(errno.EACCES, "Permission denied")
    assert listen_error(denied, "127.0.0.1", 80) == (
        "permission denied: ports below 1024 need root (use --port 1024 or higher, e.g. 8000)"
    )
    assert listen_error(denied, "127.0.0.1", 8080) == "permission denied"
    assert host_port("::1", 8000) == "[::1]:8000"
    assert host_port("[::1]", 8000) == "[::1]:8000"
    assert host_port("bad\nhost", 1) == "bad\\nhost:1"


# -- serve: Ctrl-C -------------------------------------------------------------------------------


def _serve_in_a_session(archive: Path, *extra: str) -> tuple[subprocess.Popen[bytes], str]:
    """``bowlrec serve`` (log level info) in a process group of its own, as a terminal runs
    it: Ctrl-C is SIGINT to the whole group (job worker processes included)."""
    server = start_server(
        archive,
        None,
        *extra,
        log_level=None,
        capture_stderr=True,
        start_new_session=True,
        start_timeout_s=300,  # the first start may compile the kernels
    )
    return server.proc, server.url


def _start_long_job(url: str) -> str:
    """A job of 20,000 summary runs (many seconds), once it is running."""
    scenes = [summary_scene(i, "ctrl-c") for i in range(20_000)]
    job_id = str(httpx.post(f"{url}/jobs", json={"scenes": scenes}, timeout=60).json()["job_id"])
    deadline = time.monotonic() + 300  # job workers may compile the kernels first
    while httpx.get(f"{url}/jobs/{job_id}", timeout=10).json()["done"] < 5:
        assert time.monotonic() < deadline, "the job did not start"
        time.sleep(0.05)
    return job_id


def _ctrl_c(proc: subprocess.Popen[bytes], times: int, gap_s: float) -> tuple[int, str]:
    for i in range(times):
        if i:
            time.sleep(gap_s)
        os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=90)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        _, err = proc.communicate(timeout=10)
        raise AssertionError(f"serve did not stop:\n{err.decode(errors='replace')}") from None
    return proc.returncode, err.decode(errors="replace")


def _stopped_cleanly(code: int, stderr: str, last: str = "bowlrec: stopped") -> None:
    assert code == 130, (code, stderr)
    assert "Traceback" not in stderr and "ERROR" not in stderr, stderr
    assert stderr.splitlines()[-1] == last, stderr
    assert stderr.count("bowlrec: stopped") == 1, stderr


def _job_record(archive: Path, job_id: str) -> dict[str, Any]:
    record: dict[str, Any] = json.loads((archive / "jobs" / f"{job_id}.json").read_text())
    return record


@pytest.mark.process
@pytest.mark.parametrize(
    ("times", "gap_s", "workers"),
    [(1, 0.0, "0"), (2, 0.05, "0"), (2, 0.5, "0"), (3, 0.2, "2")],
    ids=["once", "twice-at-once", "twice-during-shutdown", "three-times-with-workers"],
)
def test_ctrl_c_during_a_job_stops_cleanly(
    tmp_path: Path, times: int, gap_s: float, workers: str
) -> None:
    archive = tmp_path / "archive"
    proc, url = _serve_in_a_session(archive, "--job-workers", workers)
    job_id = _start_long_job(url)
    code, stderr = _ctrl_c(proc, times, gap_s)
    _stopped_cleanly(code, stderr)
    # the application was shut down even when a second Ctrl-C hurried the server: the job was
    # stopped after its runs in flight and recorded as interrupted (resumable)
    record = _job_record(archive, job_id)
    assert record["status"] == "interrupted" and 5 <= record["done"] < 20_000, record


@pytest.mark.process
def test_a_second_ctrl_c_cuts_off_a_request_in_progress_without_a_traceback(
    tmp_path: Path,
) -> None:
    proc, url = _serve_in_a_session(tmp_path / "archive")
    port = int(url.rsplit(":", 1)[1])
    with socket.create_connection(("127.0.0.1", port)) as stalled:  # half a body, then nothing
        stalled.sendall(
            b"POST /runs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
            b'Content-Length: 100\r\n\r\n{"name":'
        )
        time.sleep(0.3)
        code, stderr = _ctrl_c(proc, 2, 0.5)
    _stopped_cleanly(code, stderr, "bowlrec: stopped (1 request(s) in progress cut off)")
    assert re.search(r"Waiting for connections to close", stderr), stderr

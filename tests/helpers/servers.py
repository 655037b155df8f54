"""The one way the tests start a bowlrec HTTP service, three transports with one interface.

* :func:`start_server`: ``bowlrec serve`` in a child process (``python -m
  helpers.service_child``, or another child of this package) on a free port of 127.0.0.1, with
  a HOME of its own next to its archive, returned once ``/health`` answers. The ``serve`` and
  ``module_serve`` fixtures of tests/conftest.py start them and stop them after the test (the
  module); a test using either is in the ``process`` tier by construction.
* :class:`ThreadServer`: uvicorn serving an app in a thread of the test process on a free port
  (a real socket: ``process`` tier too).
* :class:`AppServer`: the ASGI app in process (``create_app(..., warm_up=False)`` behind
  Starlette's TestClient transport; no socket, no process): the default tier. The
  ``app_server`` and ``module_app_server`` fixtures start and stop them.

Each has ``url``, ``archive``, ``headers`` and ``client(**kw)`` (an ``httpx.Client`` with the
token's header unless ``auth=False``, httpx's defaults otherwise), and ``stop()`` (once or
more); :class:`Server` adds ``proc``,
``port``, ``kill()`` and ``log()``.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx

from helpers.processes import child_command, child_env, home_env

LOOPBACK = "127.0.0.1"


def free_port() -> int:
    """A port of 127.0.0.1 that nothing listens on now (the caller retries if it gets taken)."""
    with socket.socket() as s:
        s.bind((LOOPBACK, 0))
        return int(s.getsockname()[1])


def _auth(token: str | None) -> dict[str, str]:
    return {} if token is None else {"Authorization": f"Bearer {token}"}


@dataclass
class Server:
    """A ``bowlrec serve`` child process."""

    proc: subprocess.Popen[bytes]
    url: str
    archive: Path
    headers: dict[str, str]
    log_path: Path | None = None

    @property
    def port(self) -> int:
        return int(self.url.rsplit(":", 1)[1])

    def client(self, *, auth: bool = True, **kw: Any) -> httpx.Client:
        headers = {**(self.headers if auth else {}), **kw.pop("headers", {})}
        kw.setdefault("timeout", 60.0)
        return httpx.Client(base_url=self.url, headers=headers, **kw)

    def log(self) -> str:
        """What the server wrote on stderr so far (when it went to a file)."""
        if self.log_path is None or not self.log_path.exists():
            return ""
        return self.log_path.read_text(errors="replace")

    def kill(self) -> None:
        """SIGKILL (``kill -9``), then reap."""
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait(10)

    def stop(self) -> None:
        """SIGINT (uvicorn's graceful shutdown), SIGKILL after 20 s."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                self.kill()


def start_server(
    archive: Path,
    token: str | None = None,
    *extra: str,
    child: str = "service_child",
    child_args: tuple[str, ...] = (),
    command: list[str] | None = None,
    home: Path | None = None,
    env: Mapping[str, str | None] | None = None,
    log_level: str | None = "warning",
    capture_stderr: bool = False,
    start_timeout_s: float = 120.0,
    **popen: Any,
) -> Server:
    """``bowlrec serve --archive ARCHIVE --port P EXTRA`` on a free port P of 127.0.0.1, once
    ``GET /health`` answers 200.

    ``child``: the script of this package that runs ``serve`` (``child_args`` before the serve
    options: e.g. ``pipeline_fault_child`` takes a chunk size first); ``command``: another
    program to give the serve options to (e.g. ``bowlrec_command("serve")``, the entry point's
    module). ``token``: set as
    ``BOWLREC_TOKEN`` and sent by :meth:`Server.client`. ``home``: the server's HOME (default:
    ``ARCHIVE-home`` beside the archive). ``env``: more variables (None removes one).
    stderr goes to ``home/serve-N.log`` (:meth:`Server.log`) unless ``capture_stderr`` (a
    pipe: the test reads ``proc.stderr``). ``popen``: more :class:`subprocess.Popen` keywords
    (``preexec_fn``, ``start_new_session``...)."""
    archive = Path(archive)
    home = home or archive.parent / f"{archive.name}-home"
    overrides: dict[str, str | None] = {**home_env(home), "BOWLREC_TOKEN": token}
    overrides.update(env or {})
    full_env = child_env(None, **overrides)
    level = ("--log-level", log_level) if log_level else ()
    last = ""
    for attempt in range(3):  # a free port can be taken between the probe and the bind
        port = free_port()
        options = ("--archive", str(archive), "--port", str(port), *level, *extra)
        log_path = None if capture_stderr else home / f"serve-{port}-{attempt}.log"
        stderr: Any = subprocess.PIPE if log_path is None else open(log_path, "wb")  # noqa: SIM115
        try:
            proc = subprocess.Popen(
                [*(command or child_command(child, *child_args)), *options],
                env=full_env,
                stdout=subprocess.DEVNULL,
                stderr=stderr,
                **popen,
            )
        finally:
            if log_path is not None:
                stderr.close()  # the child has its own descriptor
        url = f"http://{LOOPBACK}:{port}"
        deadline = time.monotonic() + start_timeout_s  # the first start may compile kernels
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                if httpx.get(f"{url}/health", timeout=1.0).status_code == 200:
                    return Server(proc, url, archive, _auth(token), log_path)
            except httpx.TransportError:
                time.sleep(0.05)
        if proc.poll() is None:
            if popen.get("start_new_session"):
                os.killpg(proc.pid, signal.SIGKILL)
            else:
                proc.kill()
        err = proc.communicate(timeout=10)[1]
        last = (err or b"").decode(errors="replace") if log_path is None else log_path.read_text()
        if "address already in use" not in last.lower():
            break
    raise RuntimeError(f"bowlrec serve did not start:\n{last}")


class ThreadServer:
    """uvicorn serving ``app`` on a free port of 127.0.0.1 in a thread of this process (a real
    socket and HTTP transport without a child process)."""

    def __init__(self, app: Any, archive: Path | None = None, token: str | None = None) -> None:
        import uvicorn

        self.archive = archive
        self.headers = _auth(token)
        self.sock = socket.socket()
        self.sock.bind((LOOPBACK, 0))
        self.port = int(self.sock.getsockname()[1])
        self.url = f"http://{LOOPBACK}:{self.port}"
        config = uvicorn.Config(app, host=LOOPBACK, port=self.port, log_level="warning")
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(
            target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True
        )

    def client(self, *, auth: bool = True, **kw: Any) -> httpx.Client:
        headers = {**(self.headers if auth else {}), **kw.pop("headers", {})}
        kw.setdefault("timeout", 60.0)
        return httpx.Client(base_url=self.url, headers=headers, **kw)

    def start(self) -> ThreadServer:
        self.thread.start()
        deadline = time.monotonic() + 30
        while not self.server.started:
            assert time.monotonic() < deadline and self.thread.is_alive(), "server did not start"
            time.sleep(0.02)
        return self

    def stop(self) -> None:
        self.server.should_exit = True
        if self.thread.is_alive():
            self.thread.join(60)
        self.sock.close()

    def __enter__(self) -> ThreadServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


@dataclass
class AppServer:
    """The service's ASGI app in this process, its lifespan (job threads, group commit) running
    until :meth:`stop`; clients talk to it through Starlette's TestClient transport (no socket).

    ``options``: more keywords of :func:`bowlrec.service.app.create_app` (``warm_up`` is False:
    the kernels are warm in a test process, and the viewer's files are extracted on demand)."""

    archive: Path
    token: str | None = None
    options: dict[str, Any] = field(default_factory=dict)
    raise_server_exceptions: bool = True
    url: str = f"http://{LOOPBACK}"

    def __post_init__(self) -> None:
        from fastapi.testclient import TestClient

        from bowlrec.service.app import create_app

        self.archive = Path(self.archive)
        self.headers = _auth(self.token)
        self.app = create_app(self.archive, self.token, **{"warm_up": False, **self.options})
        self._client = TestClient(
            self.app, base_url=self.url, raise_server_exceptions=self.raise_server_exceptions
        )
        self._client.__enter__()  # the lifespan starts
        self._running = True

    def client(self, *, auth: bool = True, **kw: Any) -> httpx.Client:
        headers = {**(self.headers if auth else {}), **kw.pop("headers", {})}
        kw.setdefault("timeout", 60.0)
        transport = self._client._transport  # the app, through the running lifespan's portal
        return httpx.Client(base_url=self.url, headers=headers, transport=transport, **kw)

    def stop(self) -> None:
        if self._running:
            self._running = False
            self._client.__exit__(None, None, None)


#: what the server fixtures of tests/conftest.py return: start(archive=None, token=None, ...)
StartServer = Callable[..., Server]
StartApp = Callable[..., AppServer]

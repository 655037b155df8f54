"""``bowlrec serve``: the HTTP service (FastAPI + uvicorn, imported only when it runs).

Before anything is served: a non-loopback host needs a token (or ``--insecure``), and that
token must be at least 32 characters; the sockets are bound before the archive is opened and
before "serving on" is printed (an address that cannot be listened on -- a port in use, an
address not of this machine, a host name that does not resolve, a privileged port -- is one
``error:`` line naming the address and the reason, exit 2). Ctrl-C stops the server
gracefully and prints ``bowlrec: stopped`` (exit 130); a second Ctrl-C during the shutdown
hurries it and never prints a traceback. The security model (token, cookie sessions, Host
allow-list, Origin checks, body limit) is described in ``docs/service.md``.
"""

from __future__ import annotations

import errno
import ipaddress
import os
import signal
import socket
import threading
import time
from pathlib import Path
from types import FrameType
from typing import Annotated, Any, Literal

import typer

from bowlrec.archive.location import config_value
from bowlrec.errors import MissingExtraError
from bowlrec.service.names import (
    DEFAULT_MAX_BODY_BYTES,
    MIN_TOKEN_LENGTH,
    host_name,
    is_loopback_name,
)

from ._app import app
from ._common import ARCHIVE_DEFAULT_HELP, EXIT_INTERRUPTED, ArchiveOption, fail, open_archive
from ._first_use import first_use

#: uvicorn's log levels, the values of --log-level
LogLevel = Literal["critical", "error", "warning", "info", "debug", "trace"]

#: the largest request-body limit serve accepts (MiB): 4 GiB
MAX_BODY_MB = 4096.0
DEFAULT_TOKEN_ENV = "BOWLREC_TOKEN"
#: the default request body limit, MiB (``--max-body-mb``)
DEFAULT_MAX_BODY_MB = DEFAULT_MAX_BODY_BYTES / 2**20
#: ports below this one need root (or CAP_NET_BIND_SERVICE)
PRIVILEGED_PORTS = 1024


def is_loopback(host: str) -> bool:
    """True for localhost, 127.0.0.0/8 and ::1 (the only hosts served without a token)."""
    name = host_name(host)
    return name is not None and is_loopback_name(name)


@app.command("serve")
def serve(
    archive: ArchiveOption = None,
    host: Annotated[
        str, typer.Option(help="Interface to bind; anything but loopback needs a token.")
    ] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="TCP port.", min=0, max=65535)] = 8000,
    token_env: Annotated[
        str,
        typer.Option(
            help="Environment variable holding the bearer token; when it is set (non-empty), "
            "every request except /health and /docs needs 'Authorization: Bearer TOKEN' "
            "(TOKEN: the variable's value)."
        ),
    ] = DEFAULT_TOKEN_ENV,
    insecure: Annotated[
        bool,
        typer.Option("--insecure", help="Allow a non-loopback host without a token."),
    ] = False,
    job_workers: Annotated[
        int,
        typer.Option(
            help="Processes that simulate jobs: 0 = in the server process (default), N = a "
            "local pool of N.",
            min=0,
        ),
    ] = 0,
    scheduler: Annotated[
        str | None,
        typer.Option(
            envvar="BOWLREC_SCHEDULER",
            help="Run jobs on this dask.distributed scheduler (tcp://HOST:PORT; needs "
            "bowlrec\\[dask]); default: 'scheduler' in the config file, if any.",
        ),
    ] = None,
    allowed_host: Annotated[
        list[str] | None,
        typer.Option(
            "--allowed-host",
            help="Also accept this name in the Host header of requests without the bearer "
            "token (repeatable; loopback names and the bound IP are always accepted). Needed "
            "when browsers reach the server by another name, e.g. behind 0.0.0.0 or in a "
            "container.",
        ),
    ] = None,
    max_body_mb: Annotated[
        float,
        typer.Option(help="Largest request body, in MiB (larger ones get 413).", min=0.0),
    ] = DEFAULT_MAX_BODY_MB,
    log_level: Annotated[
        LogLevel, typer.Option(help="uvicorn log level.", case_sensitive=False)
    ] = "info",
) -> None:
    """Serve the archive over HTTP (API docs at http://HOST:PORT/docs).

    Submit scenes and jobs, list and download runs, manage the ball library.
    """
    token = os.environ.get(token_env) or None
    if token is None and not is_loopback(host) and not insecure:
        fail(
            f"refusing to serve {host} without a token: set ${token_env} (or choose another "
            "variable with --token-env), bind to 127.0.0.1, or pass --insecure"
        )
    if token is not None and not is_loopback(host) and len(token) < MIN_TOKEN_LENGTH:
        fail(
            f"refusing to serve {host} with a short token: ${token_env} must be at least "
            f"{MIN_TOKEN_LENGTH} characters (it has {len(token)}); make one with python -c "
            "'import secrets; print(secrets.token_urlsafe(32))'"
        )
    if not 0 < max_body_mb <= MAX_BODY_MB:  # also refuses nan and inf
        fail(f"--max-body-mb must be in (0, {MAX_BODY_MB:g}] (got {max_body_mb!r})")
    max_body_bytes = int(max_body_mb * 1024 * 1024)
    allowed = list(allowed_host or [])
    for name in allowed:
        if host_name(name) is None:
            fail(f"--allowed-host {name!r}: not a host name (give NAME or an IP, no scheme)")
    if bound_ip(host) is not None:
        allowed.append(host.strip("[]"))  # the literal address the server is reached at
    try:
        sockets = bind_sockets(host, port)
    except OSError as err:
        fail(f"cannot listen on {host_port(host, port)}: {listen_error(err, host, port)}")
    auth = f"token from ${token_env}" if token else "no token"
    _serve(
        sockets,
        archive,
        host,
        token,
        auth,
        log_level=log_level,
        job_workers=job_workers,
        scheduler=scheduler,
        max_body_bytes=max_body_bytes,
        allowed_hosts=allowed,
    )


@app.command("ui")
def ui(
    archive: Annotated[
        Path | None,
        typer.Argument(help=f"The archive directory ({ARCHIVE_DEFAULT_HELP})."),
    ] = None,
    port: Annotated[
        int,
        typer.Option(help="TCP port on 127.0.0.1 (a free one is taken if it is in use).", min=0),
    ] = 8000,
    browser: Annotated[
        bool,
        typer.Option(help="Open the page in the browser (when the machine has a display)."),
    ] = True,
    log_level: Annotated[
        LogLevel, typer.Option(help="uvicorn log level.", case_sensitive=False)
    ] = "warning",
) -> None:
    """Browse an archive in the web browser: the runs, a run with the rerun viewer, Compare,
    balls, oil patterns and jobs.

    Serves on 127.0.0.1 only, without a token (use `bowlrec serve` for anything else).
    """
    try:
        sockets = bind_sockets("127.0.0.1", port)
    except OSError as err:
        if err.errno != errno.EADDRINUSE or port == 0:
            fail(f"cannot listen on 127.0.0.1:{port}: {listen_error(err, '127.0.0.1', port)}")
        sockets = bind_sockets("127.0.0.1", 0)
    _serve(
        sockets,
        archive,
        "127.0.0.1",
        None,
        "loopback only, no token",
        log_level=log_level,
        open_browser=browser and has_display(),
        create=False,
    )


def has_display() -> bool:
    """True when a graphical browser can be opened (macOS, Windows, or X11/Wayland)."""
    import sys

    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _serve(
    sockets: list[socket.socket],
    archive: Path | None,
    host: str,
    token: str | None,
    auth: str,
    *,
    log_level: str,
    open_browser: bool = False,
    job_workers: int = 0,
    scheduler: str | None = None,
    max_body_bytes: int | None = DEFAULT_MAX_BODY_BYTES,
    allowed_hosts: list[str] | None = None,
    create: bool = True,
) -> None:
    """Open the archive (``create``: a new one if there is none) and serve it on the bound
    ``sockets`` until Ctrl-C (exit 130)."""
    try:
        try:
            import uvicorn

            from bowlrec.service.app import create_app
        except ImportError as err:
            raise MissingExtraError(
                f"bowlrec serve needs {err.name or err}, which is not installed; install it "
                "with: pip install 'bowlrec[service]'",
                name=err.name,
            ) from None
        store = open_archive(archive, create=create)
        first_use("service")  # the server loads these before it answers
        if scheduler is None:
            scheduler = config_value("scheduler")
        application = create_app(  # JobsLockedError when another server runs its jobs
            store.root,
            token,
            job_workers=job_workers,
            scheduler=scheduler,
            max_body_bytes=max_body_bytes,
            allowed_hosts=allowed_hosts or (),
            writer_process=True,
        )
    except BaseException:
        for sock in sockets:
            sock.close()
        raise
    bound_port = sockets[0].getsockname()[1]
    url = f"http://{host_port(host, bound_port)}/"
    typer.echo(f"bowlrec: serving {store.root} on {url} ({auth}); docs at /docs", err=True)
    config = uvicorn.Config(application, host=host, port=bound_port, log_level=log_level)
    interrupted, cut_off = run_server(
        config, sockets, on_started=_browser(url) if open_browser else None
    )
    if interrupted:
        lost = f" ({cut_off} request(s) in progress cut off)" if cut_off else ""
        typer.echo(f"bowlrec: stopped{lost}", err=True)
        raise typer.Exit(EXIT_INTERRUPTED)


def _browser(url: str) -> Any:
    """A callback opening ``url`` in the default browser."""

    def open_page() -> None:
        import webbrowser

        webbrowser.open(url)

    return open_page


def run_server(
    config: Any, sockets: list[socket.socket], on_started: Any = None
) -> tuple[bool, int]:
    """Serve the ``uvicorn.Config`` on ``sockets`` until the server stops: whether Ctrl-C
    (SIGINT) stopped it, and how many requests in progress a forced stop cut off.

    The first SIGINT shuts the server down gracefully: it stops accepting, waits for the
    requests in progress, then shuts the application down (the jobs stop after their runs in
    flight). A second one during the shutdown stops the waiting for requests (those still in
    progress are cut off and counted, not logged with a traceback); the application is still
    shut down. uvicorn raises the signal again once it has restored the handler installed
    here, which only notes it; from then on SIGINT is ignored, so no later Ctrl-C interrupts
    the clean-up (or the interpreter's exit) with a traceback. ``on_started`` is called
    (in a thread) once the server accepts requests.
    """
    import asyncio
    import logging

    import uvicorn

    class Server(uvicorn.Server):
        async def shutdown(self, sockets: list[socket.socket] | None = None) -> None:
            await super().shutdown(sockets=sockets)
            done = getattr(self.lifespan, "shutdown_event", None)
            if self.force_exit and not (done is not None and done.is_set()):
                # a second Ctrl-C made uvicorn skip the application's shutdown: without it
                # the jobs would not stop and the lifespan task would be cancelled (logged
                # with a traceback)
                await self.lifespan.shutdown()

    server = Server(config)
    cut_off = 0
    if on_started is not None:

        def when_started() -> None:
            while not server.started and not server.should_exit:
                time.sleep(0.05)
            if server.started:
                on_started()

        threading.Thread(target=when_started, name="bowlrec-open-browser", daemon=True).start()

    def not_cut_off(record: logging.LogRecord) -> bool:
        """False for uvicorn's report of a request cancelled as a forced stop ends the loop."""
        nonlocal cut_off
        error = record.exc_info[1] if record.exc_info else None
        if server.force_exit and isinstance(error, asyncio.CancelledError):
            cut_off += 1
            return False
        return True

    interrupted = False

    def on_sigint(signum: int, frame: FrameType | None) -> None:
        nonlocal interrupted
        interrupted = True
        server.should_exit = True  # when it comes before uvicorn handles the signal itself
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, on_sigint) if main else None
    uvicorn_log = logging.getLogger("uvicorn.error")
    uvicorn_log.addFilter(not_cut_off)
    try:
        server.run(sockets=sockets)
    finally:
        uvicorn_log.removeFilter(not_cut_off)
        if main and not interrupted and previous is not None:
            signal.signal(signal.SIGINT, previous)
    return interrupted, cut_off


def host_port(host: str, port: int) -> str:
    """``HOST:PORT`` as a URL writes it (an IPv6 address in brackets)."""
    from bowlrec.spec.errors import MAX_ECHO, printable

    shown = f"[{host}]" if ":" in host and not host.startswith("[") else host
    return f"{printable(shown, MAX_ECHO)}:{port}"


def listen_error(err: OSError, host: str, port: int) -> str:
    """Why ``host:port`` cannot be listened on, and what to do, for ``error: cannot listen on
    HOST:PORT: ...``."""
    from bowlrec.spec.errors import MAX_ECHO, printable

    if isinstance(err, socket.gaierror):
        return (
            f"cannot resolve the host name ({err.strerror or err}); give an IP address or a "
            "name of this machine, e.g. --host 127.0.0.1"
        )
    if err.errno == errno.EADDRINUSE:
        return "address already in use (is another bowlrec serve running? use --port)"
    if err.errno == errno.EADDRNOTAVAIL:
        return (
            f"{printable(host.strip('[]'), MAX_ECHO)} is not an address of this machine (use "
            "127.0.0.1, 0.0.0.0 for every interface, or one of its own addresses)"
        )
    if err.errno in (errno.EACCES, errno.EPERM) and 0 < port < PRIVILEGED_PORTS:
        return (
            f"permission denied: ports below {PRIVILEGED_PORTS} need root (use --port "
            f"{PRIVILEGED_PORTS} or higher, e.g. 8000)"
        )
    reason = err.strerror or str(err)
    return reason[:1].lower() + reason[1:]


def bound_ip(host: str) -> str | None:
    """The host as an IP address when it is one and not a wildcard (0.0.0.0, ::)."""
    try:
        address = ipaddress.ip_address(host.strip("[]"))
    except ValueError:
        return None
    return None if address.is_unspecified else str(address)


def bind_sockets(host: str, port: int) -> list[socket.socket]:
    """Listening-ready sockets for every address of ``host`` (as asyncio would bind them);
    OSError when one cannot be bound (the others are closed)."""
    infos = socket.getaddrinfo(
        host.strip("[]") or None,
        port,
        type=socket.SOCK_STREAM,
        flags=socket.AI_PASSIVE,
    )
    sockets: list[socket.socket] = []
    seen: set[tuple[int, object]] = set()
    try:
        for family, kind, proto, _, address in infos:
            if (family, address) in seen:
                continue
            seen.add((family, address))
            sock = socket.socket(family, kind, proto)
            sockets.append(sock)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if family == socket.AF_INET6:
                sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
            if port == 0 and len(sockets) > 1:  # every address on the first one's port
                address = (address[0], sockets[0].getsockname()[1], *address[2:])
            try:
                sock.bind(address)
            except OSError as err:
                if family == socket.AF_INET6 and err.errno == errno.EADDRNOTAVAIL:
                    sockets.pop().close()  # IPv6 not enabled here: like asyncio, skip it
                    continue
                raise
            sock.set_inheritable(True)
        if not sockets:
            raise OSError(errno.EADDRNOTAVAIL, f"no address of {host} can be bound")
    except OSError:
        for sock in sockets:
            sock.close()
        raise
    return sockets

"""``bowlrec serve --workers N``: a supervisor process and N worker processes on one archive.

The supervisor (the ``serve`` process itself) has bound the listening sockets and opened the
archive. It holds what exists once per archive (:mod:`bowlrec.service.shared`): the group
committer, the one writer of summary-only runs; the jobs (their lock, queue and runner); the
cookie sessions. It starts N worker processes (spawned: fresh interpreters) that inherit the
sockets, so the kernel spreads the connections among them. A worker parses, checks and
simulates a request in parallel with the others and hands a finished summary-only run to the
supervisor, which seals the runs handed over by every worker meanwhile in one segment and
registers them in one index transaction before it answers (a recorded run is sealed by its
worker and registered under the archive's writer lock, as a batch worker's are).

A worker that dies while serving is reported on stderr (with its exit status or signal) and
replaced; one that dies before it serves stops the server (exit 1). SIGINT (Ctrl-C) or
SIGTERM stop the workers gracefully (each answers the requests it holds, whose runs the
supervisor still commits), then the supervisor commits what it was handed, stops the jobs and
exits: 130 after SIGINT, 0 after SIGTERM. A second signal cuts off the requests in progress.
A worker whose supervisor is gone stops by itself.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
import socket
import sys
import threading
import time
from dataclasses import dataclass
from multiprocessing.connection import wait
from types import FrameType
from typing import Any

#: how often the supervisor looks at its workers, and a worker at its supervisor (s)
POLL_S = 0.25


@dataclass(frozen=True)
class WorkerConfig:
    """What a worker process needs to build its application (picklable)."""

    root: str
    token: str | None
    max_body_bytes: int | None
    allowed_hosts: tuple[str, ...]
    session_ttl_s: float
    host: str
    port: int
    log_level: str
    address: str
    authkey: bytes
    supervisor_pid: int


def _describe_exit(code: int | None) -> str:
    if code is None:
        return "still running"
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        return f"killed by {name}"
    return f"exit status {code}"


def worker_main(config: WorkerConfig, sockets: list[socket.socket], ready: Any) -> None:
    """A worker process: the application with the supervisor's shared objects, served by
    uvicorn on the inherited ``sockets`` until SIGTERM (a second one cuts off the requests in
    progress) or until its supervisor is gone. Sets ``ready`` once it accepts requests."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the supervisor, which stops us
    import uvicorn

    from bowlrec.service.app import create_app
    from bowlrec.service.shared import WriterClient

    client = WriterClient(config.address, config.authkey)
    application = create_app(
        config.root,
        config.token,
        max_body_bytes=config.max_body_bytes,
        allowed_hosts=config.allowed_hosts,
        session_ttl_s=config.session_ttl_s,
        shared=client.shared(config.session_ttl_s),
    )

    class Server(uvicorn.Server):
        @contextlib.contextmanager
        def capture_signals(self) -> Any:
            def on_term(signum: int, frame: FrameType | None) -> None:
                if self.should_exit:
                    self.force_exit = True
                self.should_exit = True

            signal.signal(signal.SIGTERM, on_term)
            yield

    uconfig = uvicorn.Config(
        application, host=config.host, port=config.port, log_level=config.log_level
    )
    server = Server(uconfig)

    def watch() -> None:
        while not server.started and not server.should_exit:
            time.sleep(0.02)
        if server.started:
            ready.set()
        while not server.should_exit:
            if os.getppid() != config.supervisor_pid:  # the supervisor is gone
                server.should_exit = True
                return
            time.sleep(POLL_S)

    threading.Thread(target=watch, name="bowlrec-watch", daemon=True).start()
    server.run(sockets=sockets)


class _Worker:
    def __init__(self, ctx: Any, number: int, config: WorkerConfig, sockets: list[Any]) -> None:
        self.number = number
        self.ready = ctx.Event()
        self.process = ctx.Process(
            target=worker_main,
            args=(config, sockets, self.ready),
            name=f"bowlrec-worker-{number}",
        )
        self.process.start()


def run_workers(
    n: int,
    sockets: list[socket.socket],
    config: WorkerConfig,
    objects: dict[str, Any],
    echo: Any,
) -> tuple[bool, int]:
    """Serve with ``n`` worker processes until SIGINT or SIGTERM: (interrupted by SIGINT,
    worker processes that died while serving). ``objects``: the shared objects (committer,
    jobs, sessions), served to the workers here; the caller closes them afterwards.
    Raises SystemExit(1) when a worker dies before it serves."""
    from bowlrec.service.shared import WriterService

    service = WriterService(objects)
    config = WorkerConfig(
        **{**config.__dict__, "address": service.address, "authkey": service.authkey}
    )
    multiprocessing.allow_connection_pickling()  # the sockets go to the workers
    ctx = multiprocessing.get_context("spawn")
    stopping = threading.Event()
    signals: list[int] = []

    def on_signal(signum: int, frame: FrameType | None) -> None:
        signals.append(signum)
        stopping.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    workers: list[_Worker] = []
    died = 0
    failed: str | None = None
    try:
        workers = [_Worker(ctx, k + 1, config, sockets) for k in range(n)]
        while not stopping.is_set():
            wait([w.process.sentinel for w in workers], timeout=POLL_S)
            for k, w in enumerate(workers):
                if w.process.is_alive() or stopping.is_set():
                    continue
                how = _describe_exit(w.process.exitcode)
                if not w.ready.is_set():
                    failed = (
                        f"worker process {w.number} of {n} (pid {w.process.pid}) did not start "
                        f"({how}); stopping"
                    )
                    stopping.set()
                    break
                died += 1
                echo(
                    f"bowlrec: worker process {w.number} of {n} (pid {w.process.pid}) died "
                    f"({how}); the requests it was serving were cut off; starting another"
                )
                workers[k] = _Worker(ctx, w.number, config, sockets)
    finally:
        _stop(workers, signals)
        service.close()
        for s, handler in previous.items():  # no signal interrupts the clean-up after a stop
            signal.signal(s, signal.SIG_IGN if signals else handler)
    if failed is not None:
        echo(f"error: {failed}")
        raise SystemExit(1)
    return signal.SIGINT in signals, died


def _stop(workers: list[_Worker], signals: list[int]) -> None:
    """SIGTERM every worker and wait for them; a further SIGINT or SIGTERM to the supervisor
    meanwhile sends another (the worker then cuts off its requests in progress). A worker
    still starting (it has accepted no connection yet) is killed: it holds nothing."""
    seen = len(signals)
    for w in workers:
        if w.process.is_alive() and w.process.pid is not None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(w.process.pid, signal.SIGTERM if w.ready.is_set() else signal.SIGKILL)
    while any(w.process.is_alive() for w in workers):
        wait([w.process.sentinel for w in workers if w.process.is_alive()], timeout=POLL_S)
        if len(signals) > seen:  # hurry
            seen = len(signals)
            for w in workers:
                if w.process.is_alive() and w.process.pid is not None:
                    with contextlib.suppress(ProcessLookupError):
                        os.kill(w.process.pid, signal.SIGTERM)
    for w in workers:
        w.process.join()
    logging.getLogger(__name__).debug("workers stopped")
    sys.stderr.flush()

"""A killed batch or server leaves no process behind.

``bowlrec batch -j 2`` and ``bowlrec serve --job-workers 2`` (with a job running) are started as
real commands, each in a session of its own; once their two pool workers are busy the command's
process is SIGKILLed and left unreaped (a zombie: its pid still answers ``kill(pid, 0)``, so a
worker that only asks whether its parent's pid is alive would wait forever), and within a few
seconds no live process of that session may remain: not the fork server, not the resource
tracker, not a worker
(:mod:`bowlrec.batch.lifeline`). Survivors are killed in any case, so the suite never leaks.

Each scenario runs once by default; the ``slow`` variants repeat it with the kill landing at
other moments too (during start-up, before any worker exists).
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from helpers.processes import bowlrec_command
from helpers.servers import start_server

pytestmark = [
    pytest.mark.fault,
    pytest.mark.skipif(
        not sys.platform.startswith("linux"), reason="lists processes through /proc"
    ),
]

#: seconds the processes a killed command started may take to go
GRACE_S = 5.0
#: seconds a command may take to have both workers busy (a cold kernel cache compiles first)
BUSY_TIMEOUT_S = 120.0
#: CPU ticks a worker must have used to count as busy (it is forked warm, from 0)
BUSY_TICKS = 5


def job(n: int = 40_000) -> dict[str, Any]:
    """A summary-only random sweep: seconds of work for two workers."""
    return {
        "format": "bowlrec-job",
        "name": "orphans",
        "base": {"name": "orphans", "options": {"record": "summary"}},
        "sweep": {
            "kind": "random",
            "n": n,
            "seed": 7,
            "axes": {
                "delivery.speed_mps": {"low": 6.5, "high": 9.5},
                "delivery.omega_radps[1]": {"low": 15.0, "high": 35.0},
            },
        },
        "record": "summary",
    }


# -- processes, from /proc --------------------------------------------------------------------


@dataclass(frozen=True)
class Proc:
    pid: int
    ppid: int
    state: str
    ticks: int  # user + system CPU time
    cmdline: str


def _proc(pid: int) -> Proc | None:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return None
    fields = stat[stat.rindex(")") + 2 :].split()
    return Proc(
        pid=pid,
        ppid=int(fields[1]),
        state=fields[0],
        ticks=int(fields[11]) + int(fields[12]),
        cmdline=cmdline.replace(b"\0", b" ").decode(errors="replace"),
    )


def session(sid: int) -> list[Proc]:
    """The live (not zombie) processes of session ``sid``."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if int(fields[3]) != sid or fields[0] in ("Z", "X"):
            continue
        proc = _proc(int(entry))
        if proc is not None and proc.state not in ("Z", "X"):
            out.append(proc)
    return out


def workers(procs: list[Proc], parent: int) -> list[Proc]:
    """The pool workers among ``procs``: the children of ``parent``'s fork server."""
    servers = {
        p.pid for p in procs if p.ppid == parent and "multiprocessing.forkserver" in p.cmdline
    }
    return [p for p in procs if p.ppid in servers]


@contextlib.contextmanager
def command(
    cmd: list[str], cwd: Path, env: dict[str, str] | None = None
) -> Iterator[subprocess.Popen[bytes]]:
    """Run ``cmd`` in a new session; afterwards kill whatever of that session is still alive."""
    log = (cwd / "stderr.log").open("wb")
    proc = subprocess.Popen(
        cmd, cwd=cwd, env=env, start_new_session=True, stdout=subprocess.DEVNULL, stderr=log
    )
    try:
        yield proc
    finally:
        for p in session(proc.pid):
            with contextlib.suppress(OSError):
                os.kill(p.pid, signal.SIGKILL)
        with contextlib.suppress(OSError):
            os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
        log.close()


def wait_busy(proc: subprocess.Popen[bytes], ready: Callable[[], bool] = lambda: True) -> None:
    """Until both pool workers of ``proc`` have run (and ``ready()``)."""
    deadline = time.monotonic() + BUSY_TIMEOUT_S
    while time.monotonic() < deadline:
        assert proc.poll() is None, f"the command ended early ({proc.returncode})"
        busy = [w for w in workers(session(proc.pid), proc.pid) if w.ticks >= BUSY_TICKS]
        if len(busy) >= 2 and ready():
            return
        time.sleep(0.05)
    raise AssertionError(f"workers not busy after {BUSY_TIMEOUT_S} s: {session(proc.pid)}")


def kill_and_check(proc: subprocess.Popen[bytes], expect_workers: bool) -> None:
    """SIGKILL ``proc`` (left unreaped) and assert its session empties within GRACE_S."""
    before = session(proc.pid)
    if expect_workers:
        assert len(workers(before, proc.pid)) >= 2, before
    os.kill(proc.pid, signal.SIGKILL)
    deadline = time.monotonic() + GRACE_S
    while (left := session(proc.pid)) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert left == [], f"left running {GRACE_S} s after the kill: {left} (before: {before})"
    assert proc.wait(10) == -signal.SIGKILL  # (its other threads may still be exiting)


# -- bowlrec batch ----------------------------------------------------------------------------


def run_batch_and_kill(tmp_path: Path, delay: float | None) -> None:
    """``bowlrec batch -j 2``, killed once both workers are busy (``delay`` None) or ``delay``
    seconds after it started."""
    job_file = tmp_path / "job.json"
    job_file.write_text(json.dumps(job()))
    cmd = [sys.executable, "-m", "bowlrec.cli", "batch", str(job_file), "-j", "2"]
    cmd += ["--archive", str(tmp_path / "archive"), "--out", str(tmp_path / "out.parquet"), "-q"]
    with command(cmd, tmp_path) as proc:
        if delay is None:
            wait_busy(proc)
        else:
            time.sleep(delay)
            assert proc.poll() is None
        kill_and_check(proc, expect_workers=delay is None)


def test_killed_batch_leaves_no_process(tmp_path: Path) -> None:
    run_batch_and_kill(tmp_path, None)


@pytest.mark.slow
@pytest.mark.parametrize("round_", range(6))
def test_killed_batch_leaves_no_process_repeatedly(tmp_path: Path, round_: int) -> None:
    # busy workers, then kills landing during start-up (fork server preloading, workers forking)
    delay = None if round_ % 2 == 0 else random.Random(round_).uniform(0.2, 2.0)
    run_batch_and_kill(tmp_path, delay)


# -- bowlrec serve ----------------------------------------------------------------------------


def _request(url: str, body: Any = None) -> Any:
    data = None if body is None else json.dumps(body).encode()
    headers = {"content-type": "application/json"}
    with urllib.request.urlopen(urllib.request.Request(url, data, headers), timeout=10) as r:
        return json.loads(r.read())


@contextlib.contextmanager
def server(tmp_path: Path) -> Iterator[tuple[subprocess.Popen[bytes], str]]:
    """``bowlrec serve --job-workers 2`` (the entry point's module, in a session of its own)
    answering at the URL given; afterwards whatever of its session is still alive is killed."""
    pytest.importorskip("fastapi")
    pytest.importorskip("uvicorn")
    srv = start_server(
        tmp_path / "archive",
        None,
        "--job-workers",
        "2",
        command=bowlrec_command("serve"),
        home=tmp_path / "home",
        start_new_session=True,
        cwd=tmp_path,
    )
    try:
        yield srv.proc, srv.url
    finally:
        for p in session(srv.proc.pid):
            with contextlib.suppress(OSError):
                os.kill(p.pid, signal.SIGKILL)
        with contextlib.suppress(OSError):
            os.kill(srv.proc.pid, signal.SIGKILL)
        srv.proc.wait(10)


def run_server_and_kill(tmp_path: Path, busy: bool) -> None:
    """``bowlrec serve --job-workers 2`` running a job, killed once both workers are busy
    (``busy``) or just after the job was accepted."""
    with server(tmp_path) as (proc, url):
        job_id = _request(f"{url}/jobs", job())["job_id"]

        def running() -> bool:
            return bool(_request(f"{url}/jobs/{job_id}")["status"] == "running")

        if busy:
            wait_busy(proc, running)
        kill_and_check(proc, expect_workers=busy)


def test_killed_server_leaves_no_process(tmp_path: Path) -> None:
    run_server_and_kill(tmp_path, busy=True)


@pytest.mark.slow
@pytest.mark.parametrize("round_", range(4))
def test_killed_server_leaves_no_process_repeatedly(tmp_path: Path, round_: int) -> None:
    run_server_and_kill(tmp_path, busy=round_ != 1)


def test_a_pool_starts_when_bowlrec_is_pid_1(tmp_path: Path) -> None:
    """In a container without an init process bowlrec is pid 1, so the fork server's parent is
    pid 1 and is alive: the pool must start (the fork server must not take pid 1 for a sign
    that the batch's process died)."""
    unshare = shutil.which("unshare")
    if unshare is None:
        pytest.skip("no unshare(1) here")
    out = tmp_path / "t.csv"
    job = Path(__file__).resolve().parents[1] / "examples" / "jobs" / "speed-rev-grid.json"
    cmd = [unshare, "-pf", "--mount-proc", sys.executable, "-m", "bowlrec.cli", "batch"]
    cmd += [str(job), "--no-archive", "--out", str(out), "-j", "2", "-q"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    if proc.returncode != 0 and "unshare" in proc.stderr:
        pytest.skip(f"no PID namespace here: {proc.stderr.strip()}")
    assert proc.returncode == 0, proc.stderr
    assert len(out.read_text().splitlines()) == 21  # a header and 20 runs

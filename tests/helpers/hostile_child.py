"""The channels of the hostile-input suite and the guarded worker that runs them in-process.

Channels (each checks one :class:`hostile_inputs.Mutation` and returns its problems):

* ``cli``: Typer's ``CliRunner`` on :data:`bowlrec.cli.app` (``validate`` and
  ``simulate --no-archive --json`` for scenes, ``batch --no-archive -j 0 --out T.jsonl`` for jobs);
* ``http``: the ASGI app (``fastapi.testclient.TestClient`` on ``create_app(...,
  warm_up=False)``), ``POST /runs`` for scenes and ``POST /jobs`` for jobs (polled until final);
* ``subprocess``: the same commands as ``.venv/bin/bowlrec`` processes (address space limited);
* ``server``: the same requests over TCP to a real ``bowlrec serve``.

The in-process channels run in a worker process (``python -m helpers.hostile_child CHANNEL
WORKDIR``) so that a hostile input cannot take the test process or the machine down: the
worker's address space is limited (``RLIMIT_AS``, a MemoryError then fails the input), the
growth of its peak RSS is checked per input, and the parent kills and restarts it when an input
does not finish in time (a hang inside compiled code cannot be interrupted in-process).
Protocol: the parent writes one mutation id per line on stdin; the worker answers one JSON line
per input on its stdout (everything else the worker prints goes to stderr).

A problem is ``{"symptom": ..., "detail": ...}``; symptoms: ``traceback`` (an exception or a
printed traceback), ``exit_code``, ``5xx``, ``non_finite`` (NaN/Infinity in JSON output),
``bad_json``, ``memory``, ``timeout`` (also: a huge sweep that does not stop within
STOP_WITHIN_S of its interrupt), ``message`` (an error that does not name the file or a field,
or is list-shaped for a JSON body), ``message_long`` (more than MAX_MESSAGE_LINES lines or a
line over MAX_LINE_CHARS, e.g. a 100 kB input echoed back), ``job_failed`` (a job accepted with 202
that then broke as a whole).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import resource
import select
import shutil
import signal
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

from helpers import hostile_inputs as hi
from helpers.processes import child_command
from helpers.processes import child_env as _child_env
from helpers.servers import start_server

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]

#: address-space limit of the worker, subprocess and server processes
MEM_LIMIT_BYTES = int(os.environ.get("BOWLREC_HOSTILE_MEM_GB", "6")) * 2**30
#: a growth of the peak RSS above this during one input is reported
RSS_GROWTH_LIMIT_MB = 1024
#: huge sweeps are interrupted (SIGINT / cancel) after this many seconds
SOFT_INTERRUPT_S = float(os.environ.get("BOWLREC_HOSTILE_SOFT_S", "6"))
#: per-input deadline of the in-process worker (then killed and restarted)
HARD_TIMEOUT_S = {"scene": 60.0, "job": 120.0}
#: a job over HTTP must reach a final status within this many seconds
JOB_DEADLINE_S = 90.0
#: ... and a cancelled one within this many seconds of the cancel (else it is reported, and the
#: app or server is restarted so that the jobs queued behind it are not reported too)
CANCEL_DEADLINE_S = 30.0
#: an interrupted huge sweep must stop within this many seconds
STOP_WITHIN_S = 10.0
MAX_MESSAGE_LINES = 20
MAX_LINE_CHARS = 1000

#: a line that starts with a field path, ``ball.rg_m[0]: ...`` or ``sweep[0].axes['x']: ...``
_INDEX = r"\[(?:'[^']*'|\"[^\"]*\"|[^\]]*)\]"
#: a line naming a field (``ball.rg_m[1]:``), or the request body as a whole (HTTP)
FIELD_LINE = re.compile(
    rf"^\s*(?:request body|(?:[A-Za-z_][\w-]*|{_INDEX})(?:\.[A-Za-z_][\w-]*|{_INDEX})*)\s*:"
)
CONTINUATION = re.compile(r"^(?:\s+|- )\S")
NON_FINITE_TEXT = re.compile(r"(?<![\w.])[-+]?(?:nan|inf|infinity)(?![\w])", re.IGNORECASE)


def problem(symptom: str, detail: str) -> dict[str, str]:
    return {"symptom": symptom, "detail": " ".join(detail.split())[:600]}


def excerpt(text: str, n: int = 300) -> str:
    text = text.strip()
    return text if len(text) <= n else text[:n] + f"... [{len(text)} chars]"


# -- strict JSON ---------------------------------------------------------------------------------


class NonFinite(ValueError):
    pass


def _no_constant(token: str) -> Any:
    raise NonFinite(f"non-finite JSON token {token}")


def _finite_float(text: str) -> float:
    x = float(text)
    if not math.isfinite(x):
        raise NonFinite(f"number {text} overflows to {x}")
    return x


def strict_json(text: str | bytes) -> Any:
    """Parse JSON rejecting NaN, Infinity and numbers that overflow a double."""
    return json.loads(text, parse_constant=_no_constant, parse_float=_finite_float)


def json_problems(text: str | bytes, what: str) -> list[dict[str, str]]:
    try:
        strict_json(text)
    except NonFinite as err:
        return [problem("non_finite", f"{what}: {err}: {excerpt(_s(text))}")]
    except (ValueError, RecursionError) as err:
        return [problem("bad_json", f"{what}: not JSON ({err}): {excerpt(_s(text))}")]
    return []


def _s(text: str | bytes) -> str:
    return text.decode(errors="replace") if isinstance(text, bytes) else text


# -- messages ------------------------------------------------------------------------------------


def message_problems(lines: list[str], what: str, file_name: str | None) -> list[dict[str, str]]:
    """An error message: the first line names the file (``file_name``, CLI) or a field, every
    further line names a field or continues the one above (indented or a ``- `` bullet; a
    ``FILE: `` prefix on a line is allowed); at most
    MAX_MESSAGE_LINES lines of at most MAX_LINE_CHARS (else ``message_long``)."""
    out = []
    lines = [ln.removeprefix("error: ") for ln in lines if ln.strip()]
    if not lines:
        return [problem("message", f"{what}: empty error message")]
    first_has_file = bool(file_name) and file_name in lines[0]
    if file_name:  # "FILE: field: message" lines (the file named on each line)
        tag = f"{file_name}: "
        lines = [ln[ln.index(tag) + len(tag) :] if tag in ln else ln for ln in lines]
    if len(lines) > MAX_MESSAGE_LINES:
        out.append(problem("message_long", f"{what}: {len(lines)} lines: {excerpt(lines[0], 150)}"))
    long = [ln for ln in lines if len(ln) > MAX_LINE_CHARS]
    if long:
        out.append(
            problem(
                "message_long", f"{what}: a line of {len(long[0])} chars: {excerpt(long[0], 200)}"
            )
        )
    if not first_has_file and not FIELD_LINE.match(lines[0]):
        out.append(problem("message", f"{what}: names no file or field: {excerpt(lines[0], 200)}"))
    # a bulleted or indented line continues the field line above it ("- rg_min: ...")
    unnamed = [ln for ln in lines[1:] if not FIELD_LINE.match(ln) and not CONTINUATION.match(ln)]
    if unnamed:
        out.append(problem("message", f"{what}: a line names no field: {excerpt(unnamed[0], 200)}"))
    return out


# -- CLI results ---------------------------------------------------------------------------------


def command_args(m: hi.Mutation, path: Path, out: Path) -> list[list[str]]:
    """The commands run for a mutation written to ``path``."""
    if m.target == "job":
        return [["batch", str(path), "--no-archive", "-j", "0", "--out", str(out), "-q"]]
    return [["validate", str(path)], ["simulate", str(path), "--no-archive", "--json", "-q"]]


def cli_result_problems(
    m: hi.Mutation,
    args: list[str],
    code: int | None,
    stdout: str,
    stderr: str,
    path: Path,
    out: Path,
    interrupted: bool,
) -> list[dict[str, str]]:
    """Exit code, tracebacks, strict JSON output and the error message of one command."""
    cmd = args[0]
    probs = []
    if "Traceback (most recent call last)" in stdout + stderr:
        text = stdout + stderr
        tail = text[text.index("Traceback") :].strip().splitlines()
        probs.append(
            problem("traceback", f"{cmd}: printed traceback ending {' | '.join(tail[-2:])}")
        )
    allowed = {0, 2} | ({130} if interrupted and m.huge else set())
    if cmd == "batch" and runs_failed(stderr):
        allowed.add(1)  # a batch whose runs failed (their rows say why) exits 1
    if code not in allowed:
        probs.append(
            problem("exit_code", f"{cmd}: exit {code}; stderr: {excerpt(stderr or stdout, 300)}")
        )
    if code == 2:
        probs += message_problems(stderr.splitlines(), cmd, path.name)
    if code == 0 and cmd == "simulate":
        probs += json_problems(stdout, "simulate --json stdout")
    if code == 0 and cmd == "validate":
        body = re.sub(r"valid scene '.*?'$", "", stdout, flags=re.MULTILINE)
        hit = NON_FINITE_TEXT.search(body)
        if hit:
            line = next(ln for ln in body.splitlines() if hit.group(0) in ln)
            probs.append(problem("non_finite", f"validate prints {hit.group(0)}: {excerpt(line)}"))
    if cmd == "batch" and code in (0, 1, 130) and out.exists():
        for i, line in enumerate(out.read_text(errors="replace").splitlines()):
            p = json_problems(line, f"batch table row {i}")
            if p:
                probs += p
                break
    elif cmd == "batch" and code in (0, 1):
        probs.append(problem("exit_code", f"batch exit {code} but no table {out.name}"))
    return probs


def runs_failed(stderr: str) -> bool:
    """True when a batch's summary line counts failed runs and no ``error:`` line says the
    batch itself failed."""
    summary = re.search(r"^\d+ runs: .*?, (\d+) failed", stderr, re.MULTILINE)
    return summary is not None and int(summary.group(1)) > 0 and "error:" not in stderr


# -- the in-process CLI channel ------------------------------------------------------------------


class CliChannel:
    def __init__(self, workdir: Path) -> None:
        from typer.testing import CliRunner

        from bowlrec.cli import app

        self.app = app
        self.runner = CliRunner()
        self.workdir = workdir
        self.files = workdir / "files"
        # the examples tree, so that relative paths in jobs (base: ../bowler/x.json) resolve
        shutil.copytree(hi.EXAMPLES, self.files / "examples", dirs_exist_ok=True)

    def warm(self) -> None:
        for ex in ("examples/paper/case18.json", "examples/bowler/house-shot-right.json"):
            r = self.runner.invoke(self.app, ["simulate", str(ROOT / ex), "--no-archive", "-q"])
            assert r.exit_code == 0, r.output

    def check(self, m: hi.Mutation) -> list[dict[str, str]]:
        path = self.files / Path(m.example).parent / hi.safe_name(m)
        path.write_bytes(m.content())
        out = self.workdir / "table.jsonl"
        probs = []
        try:
            for args in command_args(m, path, out):
                out.unlink(missing_ok=True)
                probs += self._invoke(m, args, path, out)
        finally:
            path.unlink(missing_ok=True)
            out.unlink(missing_ok=True)
        return probs

    def _invoke(self, m: hi.Mutation, args: list[str], path: Path, out: Path):
        timer = None
        fired = threading.Event()
        if m.huge and args[0] == "batch":

            def interrupt() -> None:
                fired.set()
                os.kill(os.getpid(), signal.SIGINT)

            timer = threading.Timer(SOFT_INTERRUPT_S, interrupt)
            timer.start()
        t0 = time.monotonic()
        try:
            r = self.runner.invoke(self.app, args, catch_exceptions=True)
        except BaseException as err:  # noqa: BLE001 - e.g. KeyboardInterrupt from our timer
            return [problem("traceback", f"{args[0]}: {type(err).__name__} escaped: {err}")]
        finally:
            if timer is not None:
                timer.cancel()
        probs = []
        if r.exception is not None and not isinstance(r.exception, SystemExit):
            probs.append(problem(_exc_symptom(r.exception), f"{args[0]}: {_exc_text(r.exc_info)}"))
        code = r.exit_code if not probs else None
        probs += cli_result_problems(
            m, args, code, r.stdout, r.stderr, path, out, interrupted=fired.is_set()
        )
        late = time.monotonic() - t0 - SOFT_INTERRUPT_S
        if fired.is_set() and late > STOP_WITHIN_S:
            probs.append(problem("timeout", f"{args[0]}: stopped {late:.0f} s after SIGINT"))
        return [p for p in probs if not (p["symptom"] == "exit_code" and code is None)]


def _exc_symptom(err: BaseException) -> str:
    return "memory" if isinstance(err, MemoryError) else "traceback"


def _exc_text(exc_info: Any) -> str:
    """``Type: message at file:line (function)`` of the innermost bowlrec frame."""
    etype, err, tb = exc_info
    frames = traceback.extract_tb(tb)
    ours = [f for f in frames if "/bowlrec/" in f.filename] or frames
    where = ""
    if ours:
        f = ours[-1]
        where = f" at {f.filename.split('/bowlrec/')[-1]}:{f.lineno} ({f.name})"
    return f"{etype.__name__}: {excerpt(str(err), 200)}{where}"


# -- HTTP ----------------------------------------------------------------------------------------

FINAL = {"done", "failed", "interrupted", "cancelled"}


def http_problems(m: hi.Mutation, client: Any, poll_s: float = 0.05) -> list[dict[str, str]]:
    """POST the mutation (scene: /runs, job: /jobs; a job is polled until final, a huge one is
    cancelled first) and check every response."""
    body = m.body()
    assert body is not None
    endpoint = "/jobs" if m.target == "job" else "/runs"
    probs: list[dict[str, str]] = []
    headers = {"content-type": "application/json"}
    r = _request(client, "POST", endpoint, probs, content=body, headers=headers)
    if r is None:
        return probs
    probs += response_problems(m, r, f"POST {endpoint}")
    if r.status_code >= 300 or probs:
        return probs
    data = strict_json(r.content)
    if m.target == "scene":
        rid = data.get("run_id")
        rr = _request(client, "GET", f"/runs/{rid}", probs)
        if rr is not None:
            probs += response_problems(m, rr, "GET /runs/{id}")
        return probs
    return probs + job_problems(m, client, data["job_id"], poll_s)


def job_problems(m: hi.Mutation, client: Any, job_id: str, poll_s: float) -> list[dict[str, str]]:
    probs: list[dict[str, str]] = []
    start = time.monotonic()
    cancelled = 0.0  # when the cancel was sent
    while True:
        elapsed = time.monotonic() - start
        if m.huge and not cancelled and elapsed > SOFT_INTERRUPT_S:
            r = _request(client, "POST", f"/jobs/{job_id}/cancel", probs)
            if r is None:
                return probs
            if r.status_code != 409:  # 409: it finished meanwhile
                probs += response_problems(m, r, "POST /jobs/{id}/cancel")
            cancelled = time.monotonic()
        r = _request(client, "GET", f"/jobs/{job_id}", probs)
        if r is None:
            return probs
        p = response_problems(m, r, "GET /jobs/{id}")
        if p:
            return probs + p
        status = strict_json(r.content)
        if status["status"] in FINAL:
            if cancelled and time.monotonic() - cancelled > STOP_WITHIN_S:
                late = time.monotonic() - cancelled
                probs.append(
                    problem("timeout", f"job {status['status']} {late:.0f} s after cancel")
                )
            break
        since_cancel = time.monotonic() - cancelled if cancelled else 0.0
        if elapsed > JOB_DEADLINE_S or since_cancel > CANCEL_DEADLINE_S:
            if not cancelled:
                _request(client, "POST", f"/jobs/{job_id}/cancel", probs)
            what = f"{since_cancel:.0f} s after cancel" if cancelled else "(not a huge sweep)"
            return probs + [
                problem(
                    "timeout",
                    f"job still {status['status']} after {elapsed:.0f} s, {what}: "
                    f"{status['done']}/{status['total']} done",
                )
            ]
        time.sleep(poll_s)
    if status["status"] == "failed":
        probs.append(problem("job_failed", f"job accepted (202) then failed: {status['error']}"))
    for f in status.get("failures") or []:
        if "Traceback" in (f.get("error") or ""):
            probs.append(problem("traceback", f"failure row {f['index']}: {excerpt(f['error'])}"))
            break
    for rid in [r for r in status.get("run_ids") or [] if r][:3]:
        rr = _request(client, "GET", f"/runs/{rid}", probs)
        if rr is not None:
            probs += response_problems(m, rr, "GET /runs/{id}")
    return probs


def _request(client: Any, method: str, url: str, probs: list, **kw: Any) -> Any:
    try:
        return client.request(method, url, **kw)
    except MemoryError as err:
        probs.append(problem("memory", f"{method} {url}: MemoryError {err}"))
    except Exception as err:  # TestClient re-raises the app's unhandled exceptions
        mod = type(err).__module__
        if mod.startswith("httpx") or mod.startswith("httpcore"):
            probs.append(problem("5xx", f"{method} {url}: connection failed: {type(err).__name__}"))
        else:
            probs.append(problem("5xx", f"{method} {url}: unhandled {_exc_text(sys.exc_info())}"))
    return None


def response_problems(m: hi.Mutation, r: Any, what: str) -> list[dict[str, str]]:
    probs = []
    if r.status_code >= 500:
        probs.append(problem("5xx", f"{what}: {r.status_code} {excerpt(r.text, 300)}"))
        return probs
    p = json_problems(r.content, f"{what} {r.status_code} body")
    if p:
        return probs + p
    if r.status_code == 422:
        detail = strict_json(r.content).get("detail")
        if isinstance(detail, str):
            probs += message_problems(detail.splitlines(), f"{what} 422", None)
        elif m is None or m.body_is_json():
            probs.append(
                problem("message", f"{what} 422 list-shaped for a JSON body: {excerpt(r.text)}")
            )
    return probs


class HttpChannel:
    def __init__(self, workdir: Path) -> None:
        from fastapi.testclient import TestClient

        from bowlrec.service.app import create_app

        self.archive = workdir / "archive"
        self.app = create_app(self.archive, warm_up=False)
        # a loopback Host, as a local client sends it (the service refuses unknown hosts)
        self.client = TestClient(
            self.app, base_url="http://127.0.0.1", raise_server_exceptions=True
        )
        self.client.__enter__()

    def warm(self) -> None:
        from bowlrec.service.app import _warm_up

        _warm_up()

    def check(self, m: hi.Mutation) -> list[dict[str, str]]:
        return http_problems(m, self.client)

    def final_check(self) -> list[dict[str, str]]:
        """Every archived run's index row (GET /runs) parses strictly."""
        probs: list[dict[str, str]] = []
        r = _request(self.client, "GET", "/runs", probs)
        if r is not None:
            probs += response_problems(None, r, "GET /runs")  # type: ignore[arg-type]
            if not probs:
                probs += _row_problems(r)
        return probs


def _row_problems(r: Any) -> list[dict[str, str]]:
    data = strict_json(r.content)
    if r.status_code != 200 or not isinstance(data, dict) or "runs" not in data:
        return [problem("bad_json", f"GET /runs: {r.status_code} {excerpt(r.text)}")]
    rows = data["runs"]
    bad = [
        (row.get("run_id"), k)
        for row in rows
        for k, v in row.items()
        if isinstance(v, float) and not math.isfinite(v)
    ]
    return [problem("non_finite", f"index rows with non-finite values: {bad[:5]}")] if bad else []


# -- the worker (child side) ---------------------------------------------------------------------


def limit_memory() -> None:
    """preexec_fn: cap the address space so a runaway allocation fails instead of the host."""
    resource.setrlimit(resource.RLIMIT_AS, (MEM_LIMIT_BYTES, MEM_LIMIT_BYTES))


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def worker_main(channel: str, workdir: Path) -> None:
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # anything printed by the product goes to stderr, not into the protocol
    sys.stdout = sys.stderr
    signal.signal(signal.SIGINT, lambda *_: None)  # a stray interrupt after an input finished
    workdir.mkdir(parents=True, exist_ok=True)
    chan: Any = CliChannel(workdir) if channel == "cli" else HttpChannel(workdir)
    chan.warm()
    table = hi.by_id(channel)
    proto.write("READY\n")
    for line in sys.stdin:
        mid = line.rstrip("\n")
        if mid == "FINAL":
            proto.write(json.dumps({"id": mid, "problems": chan.final_check()}) + "\n")
            continue
        before = _peak_rss_mb()
        t0 = time.monotonic()
        try:
            probs = chan.check(table[mid])
        except MemoryError as err:
            probs = [problem("memory", f"MemoryError in the channel: {err}")]
        except Exception:
            probs = [problem("traceback", f"channel error: {_exc_text(sys.exc_info())}")]
        grown = _peak_rss_mb() - before
        if grown > RSS_GROWTH_LIMIT_MB:
            probs.append(problem("memory", f"peak RSS grew by {grown:.0f} MB"))
        result = {"id": mid, "problems": probs, "elapsed_s": round(time.monotonic() - t0, 3)}
        if channel == "http" and any(p["symptom"] == "timeout" for p in probs):
            result["restart"] = True  # a job still running would delay every later job
        proto.write(json.dumps(result) + "\n")


# -- the worker (parent side) --------------------------------------------------------------------


def child_env(workdir: Path) -> dict[str, str]:
    return _child_env(
        BOWLREC_ARCHIVE=str(workdir / "default-archive"),
        BOWLREC_CONFIG=str(workdir / "no-config.toml"),
        PYTHONUNBUFFERED="1",
    )


class Worker:
    """A guarded in-process channel in a child process; restarted after a timeout or a crash."""

    def __init__(self, channel: str, workdir: Path) -> None:
        self.channel = channel
        self.workdir = workdir
        self.proc: subprocess.Popen[bytes] | None = None
        self.buf = b""
        self.starts = 0
        self.log: Path | None = None

    def start(self) -> None:
        self.starts += 1
        wd = self.workdir / f"w{self.starts}"
        wd.mkdir(parents=True, exist_ok=True)
        self.log = wd / "stderr.log"
        self.proc = subprocess.Popen(
            child_command("hostile_child", self.channel, str(wd)),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=open(self.log, "wb"),  # noqa: SIM115 - the child owns it
            env=child_env(wd),
            preexec_fn=limit_memory,
            cwd=wd,
        )
        self.buf = b""
        line = self._readline(300.0)
        if line != "READY":
            raise RuntimeError(f"{self.channel} worker did not start: {self._stderr_tail()}")

    def _readline(self, timeout: float) -> str | None:
        """A line from the child; None at timeout; '' when it died."""
        assert self.proc is not None and self.proc.stdout is not None
        fd = self.proc.stdout.fileno()
        deadline = time.monotonic() + timeout
        while b"\n" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            ready, _, _ = select.select([fd], [], [], left)
            if ready:
                chunk = os.read(fd, 65536)
                if not chunk:
                    return ""
                self.buf += chunk
        line, _, self.buf = self.buf.partition(b"\n")
        return line.decode()

    def _stderr_tail(self, n: int = 600) -> str:
        text = self.log.read_text(errors="replace") if self.log and self.log.exists() else ""
        return text[-n:]

    def run(self, mid: str, timeout: float) -> dict[str, Any]:
        if self.proc is None or self.proc.poll() is not None:
            self.start()
        assert self.proc is not None and self.proc.stdin is not None
        t0 = time.monotonic()
        try:
            self.proc.stdin.write(mid.encode() + b"\n")
            self.proc.stdin.flush()
        except BrokenPipeError:
            pass
        line = self._readline(timeout)
        if line:
            res = json.loads(line)
            if res.pop("restart", False):
                self.kill()
            return res
        if line is None:
            self.kill()
            p = problem("timeout", f"no answer within {timeout:.0f} s (worker killed)")
        else:
            rc = self.proc.wait(10)
            tail = self._stderr_tail()
            sym = "memory" if "MemoryError" in tail or rc == -signal.SIGKILL else "traceback"
            p = problem(sym, f"worker died (exit {rc}): {tail[-300:]}")
            self.proc = None
        return {"id": mid, "problems": [p], "elapsed_s": round(time.monotonic() - t0, 3)}

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10)
        self.proc = None

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            with contextlib.suppress(BrokenPipeError):
                assert self.proc.stdin is not None
                self.proc.stdin.close()
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.kill()
        self.proc = None


def run_in_process(
    channel: str,
    ids: list[str],
    workdir: Path,
    final: bool = True,
    progress: Callable[[int, dict[str, Any]], None] | None = None,
) -> dict[str, Any]:
    """Run ``ids`` through a guarded worker: {"results": [...], "final": [...], "restarts": n}."""
    table = hi.by_id(channel)
    worker = Worker(channel, workdir)
    results = []
    try:
        for i, mid in enumerate(ids):
            m = table[mid]
            timeout = HARD_TIMEOUT_S[m.target] + (30.0 if m.huge else 0.0)
            res = worker.run(mid, timeout)
            results.append(res)
            if progress is not None:
                progress(i, res)
        final_probs: list[dict[str, str]] = []
        if final and channel == "http":
            res = worker.run("FINAL", 120.0)
            final_probs = res["problems"]
    finally:
        worker.close()
    return {"results": results, "final": final_probs, "restarts": worker.starts - 1}


# -- real subprocesses ---------------------------------------------------------------------------


def bowlrec_exe() -> str:
    exe = Path(sys.executable).parent / "bowlrec"
    return str(exe) if exe.exists() else shutil.which("bowlrec") or "bowlrec"


def subprocess_problems(m: hi.Mutation, workdir: Path) -> list[dict[str, str]]:
    """The CLI commands as real ``bowlrec`` processes (address space limited, timed out)."""
    files = workdir / "files"
    if not (files / "examples").exists():
        shutil.copytree(hi.EXAMPLES, files / "examples", dirs_exist_ok=True)
    path = files / Path(m.example).parent / hi.safe_name(m)
    path.write_bytes(m.content())
    out = workdir / "table.jsonl"
    probs = []
    try:
        for args in command_args(m, path, out):
            out.unlink(missing_ok=True)
            probs += _one_process(m, args, path, out, workdir)
    finally:
        path.unlink(missing_ok=True)
        out.unlink(missing_ok=True)
    return probs


def _one_process(m: hi.Mutation, args: list[str], path: Path, out: Path, workdir: Path):
    proc = subprocess.Popen(
        [bowlrec_exe(), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=child_env(workdir),
        preexec_fn=limit_memory,
        cwd=workdir,
    )
    interrupted = False
    late = 0.0
    hard = HARD_TIMEOUT_S[m.target]
    try:
        if m.huge and args[0] == "batch":
            try:
                stdout, stderr = proc.communicate(timeout=SOFT_INTERRUPT_S)
            except subprocess.TimeoutExpired:
                proc.send_signal(signal.SIGINT)
                interrupted = True
                t0 = time.monotonic()
                stdout, stderr = proc.communicate(timeout=30.0)
                late = time.monotonic() - t0
        else:
            stdout, stderr = proc.communicate(timeout=hard)
    except subprocess.TimeoutExpired:
        proc.kill()
        stdout, stderr = proc.communicate()
        what = "after SIGINT" if interrupted else f"within {hard:.0f} s"
        return [problem("timeout", f"{args[0]}: did not finish {what}: {excerpt(_s(stderr))}")]
    err = _s(stderr)
    probs = []
    if interrupted and late > STOP_WITHIN_S:
        probs.append(problem("timeout", f"{args[0]}: stopped {late:.0f} s after SIGINT"))
    if "MemoryError" in err:
        probs.append(problem("memory", f"{args[0]}: MemoryError: {excerpt(err[-300:])}"))
    probs += cli_result_problems(
        m, args, proc.returncode, _s(stdout), err, path, out, interrupted=interrupted
    )
    return probs


# -- a real server -------------------------------------------------------------------------------


class RealServer:
    """``bowlrec serve`` on 127.0.0.1 (:func:`helpers.servers.start_server`), address space
    limited."""

    def __init__(self, workdir: Path) -> None:
        self.workdir = workdir
        self.server: Any = None
        self.last_log = ""
        self.starts = 0

    def start(self) -> None:
        self.starts += 1
        extra = {"BOWLREC_ARCHIVE": str(self.workdir / "default-archive")}
        extra["BOWLREC_CONFIG"] = str(self.workdir / "no-config.toml")
        self.server = start_server(
            self.workdir / "archive",
            home=self.workdir / f"home-{self.starts}",
            env={**extra, "PYTHONUNBUFFERED": "1"},
            preexec_fn=limit_memory,
        )

    @property
    def proc(self) -> subprocess.Popen[bytes] | None:
        return None if self.server is None else self.server.proc

    @property
    def url(self) -> str:
        return "" if self.server is None else str(self.server.url)

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def client(self) -> Any:
        return self.server.client(timeout=HARD_TIMEOUT_S["job"])

    def stop(self) -> None:
        if self.server is not None:
            self.server.stop()
            self.last_log = self.server.log()
        self.server = None

    def log_tail(self, n: int = 400) -> str:
        text = self.server.log() if self.server is not None else self.last_log
        return text[-n:]


def server_problems(m: hi.Mutation, server: RealServer) -> list[dict[str, str]]:
    if not server.alive():
        server.start()
    with server.client() as client:
        probs = http_problems(m, client, poll_s=0.1)
    if not server.alive():
        probs.append(problem("5xx", f"the server died: {excerpt(server.log_tail())}"))
    elif any(p["symptom"] == "timeout" for p in probs):
        server.stop()  # a job still running would delay every later job: a fresh server
    elif any(p["symptom"] == "5xx" for p in probs):
        errors = [ln for ln in server.log_tail(4000).splitlines() if re.match(r"^\w+Error", ln)]
        if errors:
            probs.append(problem("5xx", f"server log: {excerpt(errors[-1], 300)}"))
    return probs


def server_final_problems(server: RealServer) -> list[dict[str, str]]:
    if not server.alive():
        server.start()
    probs: list[dict[str, str]] = []
    with server.client() as client:
        r = _request(client, "GET", "/runs", probs)
    if r is not None:
        probs += response_problems(None, r, "GET /runs")  # type: ignore[arg-type]
        if not probs:
            probs += _row_problems(r)
    return probs


if __name__ == "__main__":
    worker_main(sys.argv[1], Path(sys.argv[2]))

"""SIGKILL campaign over the batch pipeline: a batch parent, one process-pool worker, a Dask
worker or the HTTP service is killed mid-job, at random moments and in the middle of segment
writes; every run reported done must then be indexed and readable, and rerunning the same job
must finish it with no run lost, none simulated twice and no duplicate copy.

The job: a random sweep of ``N_RUNS`` summary-only runs over ``delivery.speed_mps`` and
``delivery.omega_radps[1]`` of the paper's scene 16 (``options.rtol`` 2e-4: the integrator),
in chunks of ``CHUNK`` runs (``bowlrec batch --chunk-size``; the service's engine default is cut
to ``SERVICE_CHUNK`` by tests/helpers/pipeline_fault_child.py), so that a job seals dozens of
segments and a kill lands between or inside segment writes.

Kill kinds (one episode = one fresh archive and job, one or two kills, then a rerun to the end):

``parent``  ``bowlrec batch --workers 2`` killed with its process group (``os.killpg``): the
            parent, the fork server and the pool workers die at once;
``worker``  one worker of the batch's process pool (a child of the fork server, itself a child
            of the parent): the batch either finishes (a new pool reruns the chunks in flight;
            a chunk whose worker died twice is a failed row) or exits non-zero; while it runs
            on, the next kill lands in the same batch;
``dask``    one worker process of a ``distributed.LocalCluster`` (``processes=True``, restarted by
            its nanny) while ``bowlrec batch --scheduler`` runs: the batch carries on (the
            scheduler reruns the lost tasks) and the next kill lands in the same batch;
``service`` ``bowlrec serve`` mid ``POST /jobs`` (``--job-workers 0``: the server process alone,
            as tests/test_service.py does; ``--job-workers 2``: its process group), then
            restarted: the job is ``interrupted`` and ``resume`` finishes it.

Kill moments (``mode``): ``part``: while a segment temporary (``.<segment>.h5.<r>.part``) exists,
killing the worker that has it open where the kind allows (mid-write); ``sealed``: as soon as a
new segment file is renamed into place (before or while the parent registers it); ``random``:
a random few ms after the n-th new segment. n is drawn so that the kill lands before the job
ends.

After every kill: the runs reported done (the table's ``ok``/``archived`` rows when the killed
batch still wrote its table, the service's last polled ``done`` count, else what the index
lists, read-only) are all listed; every listed run reads back with its digest checked (every
sealed segment file's digests in bulk with :meth:`SegmentFile.verify`, each listed row against
the run stored at that row, and :meth:`Archive.load` on a sample, or on every listed run in the
heavy variant); no run listed before was lost. After the rerun: exit 0, the index lists exactly
the job's run IDs (:func:`bowlrec.batch.prepare_runs`), each once, no run listed before the
rerun was simulated again, ``Archive.repair()`` finds no damage and nothing left to register,
and no segment holds a duplicate copy. The one exception, by design: a Dask task whose worker
died after it sealed its segment is recomputed elsewhere, and its first segment (never
registered) becomes a *shadowed* copy when the next writer recovers it (docs/archive-format.md,
"Duplicates"); for Dask kills the test checks that every such copy is accounted for as shadowed
and that the listing still holds each run once.

A wrong report that loses no run (the service's ``done`` after a restart) is collected and
asserted at the end, so that one campaign checks every kind.

The campaign seed is printed with a table of the kills (run with ``-s`` to see it); set
``BOWLREC_FAULT_SEED`` to replay one. The CI variant makes 8 kills (two per kind); the ``slow``
variant (``--tier slow``) makes 24 or more and loads every listed run after every kill.

``test_sigkill_of_the_parent_alone_takes_its_pool_with_it`` kills the batch parent, or a server
with a job pool, alone (not its process group) and checks that its pool does not outlive it.
"""

from __future__ import annotations

import contextlib
import csv
import json
import logging
import math
import os
import random
import signal
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from helpers.processes import child_env
from helpers.servers import start_server

from bowlrec.archive import Archive, SegmentFile
from bowlrec.batch import load_job, prepare_runs

pytestmark = [
    pytest.mark.fault,
    pytest.mark.skipif(
        not Path("/proc/self/task").is_dir(), reason="finds worker processes in /proc (Linux)"
    ),
]

ROOT = Path(__file__).resolve().parents[1]

#: runs per job; runs per chunk of ``bowlrec batch``; runs per chunk of a service job
N_RUNS = 3000
CHUNK = 50
SERVICE_CHUNK = 100
#: a kill lands after at most this fraction of the chunks still to do (so before the end)
REACH = 0.6
MODES = ("part", "sealed", "random")
#: seconds a killed process group (or an exited batch's pool) has to disappear
GONE_S = 15.0
#: seconds a batch may take (a few are needed; more means it hangs)
RUN_TIMEOUT_S = 120.0


# -- the job -------------------------------------------------------------------------------------


def write_job(folder: Path, seed: int) -> tuple[Path, list[str]]:
    """A job file in ``folder`` and its run IDs in job order."""
    base = json.loads((ROOT / "examples" / "paper" / "case16.json").read_text())
    base["options"].update(rtol=2e-4, record="summary")
    job = {
        "format": "bowlrec-job",
        "name": f"sigkill-{seed}",
        "base": base,
        "sweep": {
            "kind": "random",
            "n": N_RUNS,
            "seed": seed,
            "axes": {
                "delivery.speed_mps": {"low": 6.5, "high": 9.0},
                "delivery.omega_radps[1]": {"low": 15.0, "high": 32.0},
            },
        },
        "record": "summary",
    }
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "job.json"
    path.write_text(json.dumps(job))
    expected = [p.run_id for p in prepare_runs(load_job(path), base_dir=folder)]
    assert None not in expected and len(set(expected)) == N_RUNS
    return path, expected  # type: ignore[return-value]


# -- processes (/proc) ---------------------------------------------------------------------------


def _alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie is dead)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _children(pid: int) -> list[int]:
    """Children of every thread of ``pid``."""
    out: list[int] = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        with contextlib.suppress(OSError):
            out += [int(x) for x in (task / "children").read_text().split()]
    return out


def _descendants(pid: int) -> list[int]:
    out: list[int] = []
    todo = _children(pid)
    while todo:
        p = todo.pop()
        out.append(p)
        todo += _children(p)
    return out


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _pool_workers(parent: int) -> list[int]:
    """The live workers of ``parent``'s process pool: children of its fork server."""
    return [
        w
        for c in _children(parent)
        if "multiprocessing.forkserver" in _cmdline(c)
        for w in _children(c)
        if _alive(w)
    ]


def _writing(pids: list[int]) -> list[int]:
    """Those of ``pids`` that have a segment temporary open (they are sealing a segment)."""
    out = []
    for pid in pids:
        with contextlib.suppress(OSError):
            for fd in Path(f"/proc/{pid}/fd").iterdir():
                with contextlib.suppress(OSError):
                    if os.readlink(fd).endswith(".part"):
                        out.append(pid)
                        break
    return out


def _wait_gone(pids: list[int], timeout: float = GONE_S) -> list[int]:
    """Wait for ``pids`` to end; those still alive after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while (left := [p for p in pids if _alive(p)]) and time.monotonic() < deadline:
        time.sleep(0.05)
    return left


def _clean_env() -> dict[str, str]:
    return child_env()


# -- the archive on disk -------------------------------------------------------------------------


def _names(archive: Path) -> list[str]:
    try:
        return os.listdir(archive / "segments")
    except FileNotFoundError:
        return []


def _n_sealed(names: list[str]) -> int:
    return sum(1 for n in names if n.endswith(".h5") and not n.startswith("."))


def _parts(archive: Path) -> list[Path]:
    return sorted((archive / "segments").glob(".*.part"))


def _copies(archive: Path) -> Counter[str]:
    """How many sealed segment files hold each run ID (registered or not)."""
    copies: Counter[str] = Counter()
    for path in (archive / "segments").glob("*.h5"):
        with SegmentFile(path) as seg:
            copies.update(seg.run_ids())
    return copies


def _assert_readable(
    archive: Archive, rows: list[dict[str, Any]], job: set[str], sample: int | None
) -> None:
    """Every sealed segment file reads back whole (every run's digest, only the job's runs);
    every listed row names the run stored at that row; ``Archive.load`` (digest checked) on
    ``sample`` listed runs (None: on all of them)."""
    by_path: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        by_path.setdefault(r["path"], []).append(r)
    for path in sorted(archive.segments_dir.glob("*.h5")):
        with SegmentFile(path) as seg:
            ids = seg.run_ids()
            healthy, damaged = seg.verify()
        assert not damaged, f"{path.name}: damaged runs {damaged}"
        assert len(healthy) == len(ids) and set(ids) <= job, path.name
        for r in by_path.pop(str(path.relative_to(archive.root)), []):
            assert ids[r["row"]] == r["run_id"], (path.name, r["row"], r["run_id"])
    assert not by_path, f"listed runs in segment files that do not exist: {sorted(by_path)}"
    chosen = (
        rows if sample is None else random.Random(len(rows)).sample(rows, min(sample, len(rows)))
    )
    for r in chosen:
        stored = archive.load(r["run_id"])
        assert stored.run_id == r["run_id"]
        assert stored.trajectory.summary.outcome == r["outcome"]


def _read_table(prefix: Path) -> list[dict[str, str]] | None:
    path = prefix.with_suffix(".csv")
    if not path.exists():
        return None
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


# -- the campaign --------------------------------------------------------------------------------


@dataclass
class Kill:
    """One SIGKILL and what was seen around it."""

    kind: str
    mode: str
    episode: int
    sealed: int  # sealed segment files when it landed
    parts: int  # segment temporaries when it landed
    mid_write: bool = False  # a killed process had a segment temporary open
    exit_code: int | None = None  # the killed (or surviving) batch's exit code
    listed: int = 0  # runs listed after the kill
    reported: int = 0  # runs the killed batch or service reported done


@dataclass
class Campaign:
    """Episodes of kills: each a fresh archive and job, then a rerun checked to the end."""

    tmp: Path
    seed: int
    full_load: bool
    rng: random.Random = field(init=False)
    kills: list[Kill] = field(default_factory=list)
    episodes: int = 0
    attempts: dict[str, int] = field(default_factory=dict)
    #: wrong reports that lose no run (checked at the end, so the campaign runs through)
    violations: list[str] = field(default_factory=list)
    shadowed: Counter[str] = field(default_factory=Counter)
    temporaries_removed: int = 0

    def __post_init__(self) -> None:
        self.rng = random.Random(self.seed)

    def new_episode(self) -> tuple[Path, Path, list[str]]:
        """(folder, job file, run IDs) of a new episode."""
        self.episodes += 1
        folder = self.tmp / f"e{self.episodes:02d}"
        job, expected = write_job(folder, self.rng.randrange(1_000_000))
        return folder, job, expected

    def target(self, archive: Path, listed: set[str], chunk: int) -> int:
        """The number of sealed segment files after which to kill: 1 to REACH of the chunks
        still to do from now."""
        todo = math.ceil((N_RUNS - len(listed)) / chunk)
        return _n_sealed(_names(archive)) + self.rng.randint(1, max(1, int(REACH * todo)))

    def mode(self, kind: str) -> str:
        """Kill moments cycle through MODES per kind (one step per kill attempt)."""
        step = self.attempts[kind] = self.attempts.get(kind, self.seed % len(MODES)) + 1
        return MODES[step % len(MODES)]

    def summary(self, elapsed: float) -> str:
        lines = [
            f"seed {self.seed}: {len(self.kills)} kills in {self.episodes} episodes, "
            f"{elapsed:.1f} s; kills mid-write {sum(k.mid_write for k in self.kills)}, "
            f"with a temporary on disk {sum(k.parts > 0 for k in self.kills)}; shadowed copies "
            f"{dict(self.shadowed)}; temporaries removed by repair {self.temporaries_removed}",
            "kind     mode    ep  sealed parts mid-write exit listed reported",
        ]
        lines += [
            f"{k.kind:8} {k.mode:7} {k.episode:2} {k.sealed:6} {k.parts:5} {k.mid_write!s:9} "
            f"{k.exit_code!s:4} {k.listed:6} {k.reported:8}"
            for k in self.kills
        ]
        return "\n".join(lines)


def wait_for_moment(
    alive: Callable[[], bool],
    archive: Path,
    target: int,
    mode: str,
    rng: random.Random,
    poll: Callable[[], None] | None = None,
    timeout: float = 180.0,
) -> bool:
    """Wait for the kill moment (``target`` sealed segment files, then per ``mode``); False
    when the process ended first."""
    deadline = time.monotonic() + timeout
    last_poll = 0.0
    while alive():
        assert time.monotonic() < deadline, "the job made no progress"
        if poll is not None and time.monotonic() - last_poll > 0.05:
            poll()
            last_poll = time.monotonic()
        names = _names(archive)
        if _n_sealed(names) >= target:
            if mode == "sealed":
                return True
            if mode == "random":
                time.sleep(rng.uniform(0.0, 0.03))
                return alive()
            if any(n.endswith(".part") for n in names):
                return True
            time.sleep(0.0005)
        else:
            time.sleep(0.002)
    return False


def check_after_kill(
    c: Campaign,
    archive_dir: Path,
    job: set[str],
    before: set[str],
    reported: set[str],
    parts_before: set[Path],
    max_new_parts: int = 2,
) -> set[str]:
    """What a kill left: the index lists only the job's runs, each once, every one readable;
    nothing listed before is lost and every run reported done is listed; at most
    ``max_new_parts`` new segment temporaries. The listed IDs."""
    archive = Archive(archive_dir, create=False)  # lists what was registered: no recovery
    try:
        rows = archive.list_runs()
        listed = [r["run_id"] for r in rows]
        assert len(listed) == len(set(listed)), "a run is listed twice"
        now = set(listed)
        assert now <= job, "the index lists runs that are not the job's"
        assert before <= now, f"{len(before - now)} run(s) listed before the kill were lost"
        assert reported <= now, f"{len(reported - now)} run(s) reported done are not indexed"
        _assert_readable(archive, rows, job, None if c.full_load else 25)
    finally:
        archive.close()
    # a killed writer leaves at most its own temporary: one per process the kill took down
    # (those of earlier kills may still be there until the next writer removes them)
    new_parts = set(_parts(archive_dir)) - parts_before
    assert len(new_parts) <= max_new_parts, new_parts
    return now


def check_final(c: Campaign, kind: str, archive_dir: Path, expected: list[str]) -> None:
    """After the rerun to the end: repair finds nothing to do but old temporaries; the index
    lists exactly the job's runs, each once; no duplicate copy (shadowed copies only after a
    Dask worker died, each accounted for)."""
    archive = Archive(archive_dir)
    try:
        report = archive.repair(min_age_s=0.0)
        assert report["damaged_runs"] == [] and report["quarantined_segments"] == [], report
        assert report["index_rows_fixed"] == 0 and report["segments_unreadable"] == 0, report
        # the rerun registered every segment sealed before it started and its own: a segment
        # found now was written after it started by a process that outlived its kill
        assert report["segments_registered"] == 0, report
        c.temporaries_removed += report["temporaries_removed"]
        rows = archive.list_runs()
        listed = [r["run_id"] for r in rows]
        assert len(listed) == len(set(listed)) == len(expected), "a run is listed twice"
        assert set(listed) == set(expected)
        info = archive.info()
        assert (info["runs"], info["damaged_runs"]) == (len(expected), 0), info
        copies = _copies(archive_dir)
        assert set(copies) == set(expected)
        extra = sum(n - 1 for n in copies.values())
        assert info["duplicate_copies"] == extra, (info, extra)
        if kind != "dask":
            assert extra == 0, f"{extra} duplicate copies of runs in the segment files"
        c.shadowed[kind] += extra
        _assert_readable(archive, rows, set(expected), None if c.full_load else 200)
    finally:
        archive.close()
    assert not _parts(archive_dir)


# -- bowlrec batch episodes (parent, worker, dask) -------------------------------------------------


def start_batch(
    job: Path, archive: Path, out: Path, extra: list[str]
) -> tuple[subprocess.Popen[bytes], Path]:
    """``bowlrec batch`` in a new session (its own process group); stderr to ``out``.stderr.
    Python's faulthandler is on, so that a batch found hanging dumps its threads."""
    cmd = [sys.executable, "-X", "faulthandler", "-m", "bowlrec.cli", "batch", str(job)]
    cmd += ["-a", str(archive), "--out", str(out), "--chunk-size", str(CHUNK), "--quiet", *extra]
    err = out.with_suffix(".stderr")
    with open(err, "wb") as fh:
        proc = subprocess.Popen(
            cmd,
            stdout=subprocess.DEVNULL,
            stderr=fh,
            start_new_session=True,
            env=_clean_env(),
        )
    return proc, err


def wait_batch(proc: subprocess.Popen[bytes], err: Path) -> int:
    """The batch's exit code; a batch still running after RUN_TIMEOUT_S hangs: its threads'
    stacks (SIGABRT: faulthandler) are in the assertion message."""
    try:
        return proc.wait(timeout=RUN_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        stuck = [proc.pid, *_descendants(proc.pid)]
        described = "\n".join(f"  {p} {_cmdline(p)[:100]}" for p in stuck)
        with contextlib.suppress(ProcessLookupError):
            os.kill(proc.pid, signal.SIGABRT)
        time.sleep(2.0)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(30)
        raise AssertionError(
            f"the batch still ran after {RUN_TIMEOUT_S:.0f} s (processes:\n{described}\n); "
            f"its stderr and threads:\n{err.read_text(errors='replace')[-6000:]}"
        ) from None


@dataclass
class DaskCluster:
    """A LocalCluster of two single-thread worker processes, and their pids."""

    cluster: Any

    @property
    def address(self) -> str:
        return str(self.cluster.scheduler_address)

    def worker_pids(self) -> list[int]:
        pids = []
        for nanny in list(self.cluster.workers.values()):
            proc = getattr(getattr(nanny, "process", None), "process", None)
            pid = getattr(proc, "pid", None)
            if pid is not None and _alive(pid):
                pids.append(int(pid))
        return pids

    def wait_ready(self, timeout: float = 60.0) -> list[int]:
        deadline = time.monotonic() + timeout
        while len(pids := self.worker_pids()) < 2:
            assert time.monotonic() < deadline, "a killed Dask worker was not restarted"
            time.sleep(0.05)
        return pids


@contextlib.contextmanager
def dask_cluster() -> Iterator[DaskCluster]:
    distributed = pytest.importorskip(
        "distributed", reason="dask.distributed not installed (pip install 'bowlrec[dask]')"
    )
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        silence_logs=logging.CRITICAL,
    ) as cluster:
        yield DaskCluster(cluster)


def batch_episode(c: Campaign, kind: str, n_kills: int, dask: DaskCluster | None = None) -> int:
    """One archive and job; up to ``n_kills`` kills of ``kind``, then a rerun to the end,
    checked. A batch whose worker was killed may carry on (the next kill lands in the same
    batch); after a batch ended, the next kill lands in a rerun of the same job. The kills
    made."""
    folder, job, expected = c.new_episode()
    archive = folder / "a"
    extra = ["--scheduler", dask.address] if dask is not None else ["--workers", "2"]
    ids = set(expected)
    listed: set[str] = set()
    made = 0
    for attempt in range(1, n_kills + 1):
        out = folder / f"t{attempt}"
        parts_before = set(_parts(archive))
        proc, err = start_batch(job, archive, out, extra)
        landed: list[Kill] = []  # this batch's kills
        seen: set[int] = set()  # every process the batch had when a kill landed
        try:
            while made + len(landed) < n_kills:
                if dask is not None:
                    dask.wait_ready()
                kill = _kill_one(c, kind, proc, archive, listed, dask, seen)
                if kill is None:
                    break
                landed.append(kill)
                if kind == "parent":
                    break
            code = wait_batch(proc, err)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
        # the batch ended: its fork server and pool workers, old and new, went with it
        assert not _wait_gone(sorted(seen)), "processes of the batch outlived it"
        stderr = err.read_text(errors="replace")
        table = _read_table(out)
        reported = _batch_reported(kind, landed, code, table, stderr, expected)
        # each kill takes down both writers of the 2-process pool: the one it hits and, for a
        # pool worker, the sibling that the broken pool terminates (the batch then carries on
        # with a new pool, so two kills can land in one batch)
        max_parts = 2 * max(1, len(landed))
        listed = check_after_kill(c, archive, ids, listed, reported, parts_before, max_parts)
        for k in landed:
            k.exit_code, k.listed, k.reported = code, len(listed), len(reported)
        c.kills += landed
        made += len(landed)
        if not landed or made >= n_kills or len(listed) == len(ids):
            break
    _rerun_to_end(c, kind, job, archive, folder / "final", extra, expected, listed)
    return made


def _kill_one(
    c: Campaign,
    kind: str,
    proc: subprocess.Popen[bytes],
    archive: Path,
    listed: set[str],
    dask: DaskCluster | None,
    seen: set[int],
) -> Kill | None:
    """Wait for a kill moment of the running batch and kill per ``kind`` (the parent's process
    group, one pool worker or one Dask worker); None when the batch ended first."""
    mode = c.mode(kind)
    target = c.target(archive, listed, CHUNK)
    running = lambda: proc.poll() is None  # noqa: E731
    if not wait_for_moment(running, archive, target, mode, c.rng):
        return None
    names = _names(archive)
    kill = Kill(kind, mode, c.episodes, _n_sealed(names), sum(n.endswith(".part") for n in names))
    seen.update(_descendants(proc.pid))
    if kind == "parent":
        group = [proc.pid, *_descendants(proc.pid)]
        kill.mid_write = bool(_writing(group))
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
        return kill
    deadline = time.monotonic() + 10.0
    while not (workers := dask.worker_pids() if dask is not None else _pool_workers(proc.pid)):
        if not running():
            return None
        assert time.monotonic() < deadline, f"no {kind} worker to kill"
        time.sleep(0.01)  # a pool being replaced after an earlier kill
    writing = _writing(workers) if mode == "part" else []
    victim = writing[0] if writing else c.rng.choice(workers)
    kill.mid_write = victim in writing
    os.kill(victim, signal.SIGKILL)
    assert _wait_gone([victim], 10.0) == []
    return kill


def _batch_reported(
    kind: str,
    landed: list[Kill],
    code: int,
    table: list[dict[str, str]] | None,
    stderr: str,
    expected: list[str],
) -> set[str]:
    """The runs the batch reported done (its table's ok and archived rows; none without a
    table), after checking its exit against what was killed: a killed parent dies with no
    table; a batch whose pool worker died finishes (a new pool reruns the chunks in flight;
    a chunk whose worker died twice is a failed row, and the exit status is then 1) or stops
    with an error; a batch whose
    Dask worker died finishes (the scheduler reruns its tasks)."""
    if landed and kind == "parent":
        assert code == -signal.SIGKILL and table is None
        return set()
    if code != 0 and table is None:
        assert kind == "worker" and landed, f"batch exited {code}:\n{stderr}"
        assert "error:" in stderr, stderr
        return set()
    if code != 0:  # finished with failed rows (a chunk's worker died twice): exit status 1
        assert code == 1 and kind == "worker" and landed, f"batch exited {code}:\n{stderr}"
        assert " failed (" in stderr and "died twice" in stderr, stderr
    assert table is not None, stderr
    assert [r["run_id"] or None for r in table] == [
        rid if r["run_id"] else None for rid, r in zip(expected, table, strict=True)
    ]
    statuses = Counter(r["status"] for r in table)
    assert set(statuses) <= {"ok", "archived", "failed"}, statuses
    for r in table:
        if r["status"] == "failed":  # only a chunk whose worker died
            assert kind in ("worker", "dask") and r["error"].startswith("worker:"), r
    return {r["run_id"] for r in table if r["status"] in ("ok", "archived")}


def _rerun_to_end(
    c: Campaign,
    kind: str,
    job: Path,
    archive: Path,
    out: Path,
    extra: list[str],
    expected: list[str],
    listed: set[str],
) -> None:
    """Rerun the job to the end: exit 0, every row done, nothing listed before simulated
    again; then the final checks."""
    proc, err = start_batch(job, archive, out, extra)
    code = wait_batch(proc, err)
    assert code == 0, err.read_text(errors="replace")
    table = _read_table(out)
    assert table is not None
    assert [r["run_id"] for r in table] == expected
    assert {r["status"] for r in table} <= {"ok", "archived"}
    simulated = {r["run_id"] for r in table if r["status"] == "ok"}
    assert not simulated & listed, "runs archived before the rerun were simulated again"
    check_final(c, kind, archive, expected)


# -- service episodes ------------------------------------------------------------------------------


@dataclass
class Service:
    proc: subprocess.Popen[bytes]
    url: str
    workers: int

    def kill(self) -> list[int]:
        """SIGKILL: the server process alone (job workers 0) or its process group; the pids
        that went down."""
        group = [self.proc.pid, *_descendants(self.proc.pid)]
        if self.workers:
            os.killpg(self.proc.pid, signal.SIGKILL)
        else:
            os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait(timeout=60)
        return group

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)  # uvicorn's graceful shutdown
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(10)


def start_service(archive: Path, workers: int, log: Path) -> Service:
    """``bowlrec serve --job-workers WORKERS`` whose jobs run in chunks of SERVICE_CHUNK
    (tests/helpers/pipeline_fault_child.py), in a session of its own; its HOME and stderr log
    in ``log``'s folder."""
    pytest.importorskip("httpx")
    pytest.importorskip("fastapi")
    pytest.importorskip("uvicorn")
    server = start_server(
        archive,
        None,
        "--job-workers",
        str(workers),
        child="pipeline_fault_child",
        child_args=(str(SERVICE_CHUNK),),
        home=log.parent / f"{log.stem}-home",
        start_new_session=True,
        start_timeout_s=60,
    )
    return Service(server.proc, server.url, workers)


@dataclass
class _JobWatch:
    """Polls a service job's status (the last one seen is what the service reported)."""

    srv: Service
    client: Any
    job_id: str
    last: dict[str, Any] = field(default_factory=dict)

    def poll(self) -> None:
        import httpx

        with contextlib.suppress(httpx.TransportError):
            self.last.update(self.client.get(f"/jobs/{self.job_id}").json())

    def running(self) -> bool:
        return self.srv.proc.poll() is None and self.last.get("status") != "done"


def _runs_file_ids(archive: Path, job_id: str) -> set[str]:
    path = archive / "jobs" / f"{job_id}.runs"
    if not path.exists():
        return set()
    return {line.split()[1] for line in path.read_text().splitlines() if len(line.split()) == 2}


def service_episode(c: Campaign, n_kills: int, workers: int) -> int:
    """One archive and job submitted to ``bowlrec serve``; up to ``n_kills`` kills of the
    server (each after the first lands in a resumed job), each followed by a restart; then
    ``resume`` to the end, checked. The kills made."""
    import httpx

    folder, job_path, expected = c.new_episode()
    archive = folder / "a"
    log = folder / "server.log"
    ids = set(expected)
    listed: set[str] = set()
    job_id: str | None = None
    made = 0
    srv = start_service(archive, workers, log)
    try:
        client = httpx.Client(base_url=srv.url, timeout=60.0)
        for _ in range(n_kills):
            if job_id is None:
                r = client.post("/jobs", json=json.loads(job_path.read_text()))
                assert r.status_code == 202, r.text
                job_id = r.json()["job_id"]
            else:
                r = client.post(f"/jobs/{job_id}/resume")
                assert r.status_code == 202, r.text
            parts_before = set(_parts(archive))
            watch = _JobWatch(srv, client, job_id)
            mode = c.mode("service")
            target = c.target(archive, listed, SERVICE_CHUNK)
            if not wait_for_moment(watch.running, archive, target, mode, c.rng, watch.poll):
                break
            names = _names(archive)
            kill = Kill(
                "service",
                f"{mode}/{workers}",
                c.episodes,
                _n_sealed(names),
                sum(n.endswith(".part") for n in names),
                False,
            )
            group = [srv.proc.pid, *_descendants(srv.proc.pid)]
            kill.mid_write = bool(_writing(group if workers else [srv.proc.pid]))
            client.close()
            srv.kill()
            if workers:
                assert not _wait_gone(group), "a process of the killed server's group survived"
            reported = int(watch.last.get("done", 0))
            listed = check_after_kill(c, archive, ids, listed, set(), parts_before)
            assert len(listed) >= reported, f"{reported} runs reported done, {len(listed)} listed"
            # the runs file names every run the index lists (logged before registering)
            assert listed <= _runs_file_ids(archive, job_id)
            kill.listed, kill.reported = len(listed), reported
            c.kills.append(kill)
            made += 1

            srv = start_service(archive, workers, log)
            client = httpx.Client(base_url=srv.url, timeout=60.0)
            after = client.get(f"/jobs/{job_id}").json()
            now = _listed_ids(archive)  # the restart registered what the kill left sealed
            assert listed <= now
            assert after["status"] in ("interrupted", "done"), after["status"]
            # the run IDs logged so far are the job's, in job order (None: not logged yet)
            assert all(a in (None, e) for a, e in zip(after["run_ids"], expected, strict=True))
            # ``done`` is recounted from the archive at the restart: the job's runs that exist
            archived = len(ids & now)
            assert after["done"] <= archived
            if after["done"] != archived:
                logged = {rid for rid in after["run_ids"] if rid is not None}
                c.violations.append(
                    f"episode {c.episodes} ({kill.mode}): after the restart job {job_id} reports "
                    f"done={after['done']} (status {after['status']}), but {archived} of its "
                    f"runs are archived: {len((ids & now) - logged)} archived run(s) are missing "
                    "from its run_ids (jobs/<id>.runs)"
                )
            listed = now
            if after["status"] == "done":
                break
        assert job_id is not None
        status = client.get(f"/jobs/{job_id}").json()
        if status["status"] != "done":
            r = client.post(f"/jobs/{job_id}/resume")
            assert r.status_code == 202, r.text
            final = _wait_job(client, job_id)
            # the runs archived before the resume were skipped, not simulated again
            assert final["skipped"] == len(ids & listed), (final, status)
        else:
            final = status
        assert (final["done"], final["failed"], final["total"]) == (N_RUNS, 0, N_RUNS), final
        assert final["run_ids"] == expected
        client.close()
    finally:
        srv.stop()
    check_final(c, "service", archive, expected)
    return made


def _listed_ids(archive: Path) -> set[str]:
    a = Archive(archive, create=False)
    try:
        return {r["run_id"] for r in a.list_runs()}
    finally:
        a.close()


def _wait_job(client: Any, job_id: str, timeout: float = 300.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status = client.get(f"/jobs/{job_id}").json()
        if status["status"] in ("done", "failed", "cancelled", "interrupted"):
            assert status["status"] == "done", status
            return dict(status)
        time.sleep(0.05)
    raise AssertionError(f"job {job_id} did not finish: {status}")


# -- the tests -----------------------------------------------------------------------------------


def run_campaign(
    tmp_path: Path, plan: dict[str, int], per_episode: int, full_load: bool
) -> Campaign:
    """Kill ``plan[kind]`` times per kind (``service`` kills alternate between a server
    simulating in-process and one with a pool of two)."""
    seed = int(os.environ.get("BOWLREC_FAULT_SEED", random.randrange(1 << 30)))
    print(f"\nSIGKILL campaign seed {seed} (replay: BOWLREC_FAULT_SEED={seed})")
    c = Campaign(tmp_path, seed, full_load)
    start = time.monotonic()
    dask_ctx = dask_cluster() if plan.get("dask") else contextlib.nullcontext()
    try:
        with dask_ctx as dask:
            for kind, wanted in plan.items():
                done = episodes = 0
                while done < wanted:
                    episodes += 1
                    assert episodes <= 3 * wanted, f"{kind}: kills keep missing their moment"
                    n = min(per_episode, wanted - done)
                    if kind == "service":
                        done += service_episode(c, n, workers=2 * (episodes % 2 == 0))
                    else:
                        done += batch_episode(c, kind, n, dask if kind == "dask" else None)
    finally:
        print(c.summary(time.monotonic() - start))
        print("\n".join(c.violations))
    assert not c.violations, "\n".join(c.violations)
    return c


def test_sigkill_campaign(tmp_path: Path) -> None:
    """Two kills per kind (8), each kind's second kill landing in the rerun of the first."""
    c = run_campaign(
        tmp_path, {"parent": 2, "worker": 2, "dask": 2, "service": 2}, 2, full_load=False
    )
    assert len(c.kills) >= 8


@pytest.mark.slow
def test_sigkill_campaign_heavy(tmp_path: Path) -> None:
    """Six kills per kind (24), every listed run loaded after every kill."""
    c = run_campaign(
        tmp_path, {"parent": 6, "worker": 6, "dask": 6, "service": 6}, 2, full_load=True
    )
    assert len(c.kills) >= 20
    assert {k.kind for k in c.kills} == {"parent", "worker", "dask", "service"}
    assert sum(k.mid_write for k in c.kills) >= 3


@pytest.mark.parametrize("what", ["batch", "service"])
def test_sigkill_of_the_parent_alone_takes_its_pool_with_it(tmp_path: Path, what: str) -> None:
    """SIGKILL of the batch parent, or of a server with a job pool, the process alone (``kill
    -9 PID``, the OOM killer) mid-job: its fork server and pool workers must not outlive it (a
    worker left running keeps sealing the chunks already queued to it into the archive after
    its parent died, then waits forever for more); the rerun finishes the job, no duplicates."""
    c = Campaign(tmp_path, 1, full_load=False)
    folder, job, expected = c.new_episode()
    archive = folder / "a"
    srv: Service | None = None
    client: Any = None
    if what == "batch":
        proc, _ = start_batch(job, archive, folder / "t1", ["--workers", "2"])
    else:
        import httpx

        srv = start_service(archive, 2, folder / "server.log")
        proc = srv.proc
        client = httpx.Client(base_url=srv.url, timeout=60.0)
        r = client.post("/jobs", json=json.loads(job.read_text()))
        assert r.status_code == 202, r.text
        job_id = r.json()["job_id"]
    survivors: list[int] = []
    try:
        chunk = CHUNK if what == "batch" else SERVICE_CHUNK
        target = _n_sealed(_names(archive)) + int(0.3 * N_RUNS / chunk)
        ready = lambda: proc.poll() is None  # noqa: E731
        assert wait_for_moment(ready, archive, target, "part", c.rng), "the job ended first"
        pool = _descendants(proc.pid)
        assert len(_pool_workers(proc.pid)) == 2
        sealed_at_kill = {n for n in _names(archive) if n.endswith(".h5")}
        os.kill(proc.pid, signal.SIGKILL)  # the process alone, not its group
        proc.wait(timeout=60)
        survivors = _wait_gone(pool, 10.0)
        described = [f"{p} {_cmdline(p)[:90]}" for p in survivors]
        late = {n for n in _names(archive) if n.endswith(".h5")} - sealed_at_kill

        # rerun the job to the end (the survivors still alive, as they would be)
        if srv is None:
            _rerun_to_end(
                c,
                "parent",
                job,
                archive,
                folder / "final",
                ["--workers", "2"],
                expected,
                _listed_ids(archive),
            )
        else:
            client.close()
            srv = start_service(archive, 2, folder / "server.log")
            client = httpx.Client(base_url=srv.url, timeout=60.0)
            assert client.post(f"/jobs/{job_id}/resume").status_code == 202
            final = _wait_job(client, job_id)
            assert (final["done"], final["failed"]) == (N_RUNS, 0), final
            client.close()
            srv.stop()
            check_final(c, "service", archive, expected)
    finally:
        if client is not None:
            client.close()
        if srv is not None:
            srv.stop()
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        for pid in survivors:  # processes this test started: end them by pid
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        _wait_gone(survivors)
    assert not survivors, (
        f"{len(survivors)} process(es) of the killed {what} still ran 10 s after it died "
        f"(segments sealed after the kill: {len(late)}):\n" + "\n".join(described)
    )

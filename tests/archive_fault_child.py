"""Child processes for tests/test_archive_faults.py (one script, several roles).

Usage: python archive_fault_child.py ROLE ARGS...

``writer ARCHIVE TEMPLATE.h5 START STOP SEED``
    Seals segments of 5-50 copies of the template run (run IDs ``f"{i:020x}"`` for i from
    START up to STOP; STOP -1: forever) and registers each. Prints ``ready`` once, then for
    every segment ``begin FIRST N`` (its planned run IDs are FIRST .. FIRST + N - 1), ``seal``
    before :meth:`Archive.seal`, ``register`` before :meth:`Archive.register`, one ``run ID``
    line per run only after ``register()`` returned, then ``done``; ``finished`` at STOP.

``die-in-commit ARCHIVE TEMPLATE.h5 START N``
    Seals a segment of N template copies (run IDs from START), then registers it with the index
    connection's page cache cut to the minimum (a transaction bigger than the cache: SQLite
    spills pages to the database file before COMMIT) and SIGKILLs itself once the rows are
    written, before COMMIT: the index is left with a hot rollback journal.

``create``
    Reads archive directories from stdin, one a line; opens ``Archive(line)`` at once and prints
    ``ok`` or ``error <message>`` (a barrier: the parent sends each line to every child).

``balls ARCHIVE PROC_INDEX``
    Prints ``ready``, waits for a line on stdin (a barrier), then adds 50 balls in a shuffled
    order: 40 named only for this process, 5 under names every process uses with a spec of its
    own, 5 under names every process uses with the same spec. Prints one JSON line per add.

``reader ARCHIVE [WARM_COPY UID]``
    Lists runs, loads the first 20 listed runs and lists the ball library; prints one JSON
    document.
    With WARM_COPY and UID, first does the same on WARM_COPY (so every module is imported) and
    then drops to user UID before touching ARCHIVE (for when UID cannot run this interpreter).

``count ARCHIVE STOP_FILE``
    Lists runs in a loop until STOP_FILE exists; prints one JSON document with every count seen
    (in order) and the errors met.
"""

from __future__ import annotations

import json
import os
import random
import signal
import sys
import traceback
from pathlib import Path
from typing import Any


def writer(archive_dir: str, template: str, start: int, stop: int, seed: int) -> None:
    from bowlrec.archive import Archive
    from bowlrec.sinks import RunData
    from bowlrec.sinks.hdf5_run import read_run_file

    archive = Archive(archive_dir)
    stored = read_run_file(template)
    plan = stored.scene.resolve()
    rng = random.Random(seed)
    i = start
    print("ready", flush=True)
    while stop < 0 or i < stop:
        n = rng.randint(5, 50)
        if stop >= 0:
            n = min(n, stop - i)
        ids = [f"{k:020x}" for k in range(i, i + n)]
        print(f"begin {ids[0]} {n}", flush=True)
        builder = archive.builder()
        for rid in ids:
            run = RunData(stored.scene, plan, stored.trajectory, rid)
            builder.append(archive.record(run, wall_time_s=0.0))
        print("seal", flush=True)
        info = archive.seal(builder)
        print("register", flush=True)
        archive.register([info])
        print("".join(f"run {rid}\n" for rid in ids) + "done", flush=True)
        i += n
    print("finished", flush=True)


def die_in_commit(archive_dir: str, template: str, start: int, n: int) -> None:
    import bowlrec.archive.registry as registry
    from bowlrec.archive import Archive
    from bowlrec.sinks import RunData
    from bowlrec.sinks.hdf5_run import read_run_file

    archive = Archive(archive_dir)
    with archive.writer_lock():  # (the first index_writer() of a process runs recover())
        archive.index_writer().execute("PRAGMA cache_size=1")  # the connection register() uses
    stored = read_run_file(template)
    plan = stored.scene.resolve()
    builder = archive.builder()
    for i in range(start, start + n):
        run = RunData(stored.scene, plan, stored.trajectory, f"{i:020x}")
        builder.append(archive.record(run, wall_time_s=0.0))
    info = archive.seal(builder)
    register_segment = registry.register_segment

    def register_and_die(*args: Any, **kwargs: Any) -> Any:
        register_segment(*args, **kwargs)
        print("killing", flush=True)
        os.kill(os.getpid(), signal.SIGKILL)

    registry.register_segment = register_and_die
    archive.register([info])


def create() -> None:
    from bowlrec.archive import Archive

    print("ready", flush=True)
    for line in sys.stdin:
        try:
            Archive(line.strip())
            print("ok", flush=True)
        except Exception as err:  # reported to the parent, which fails the test
            print(f"error {type(err).__name__}: {err}".replace("\n", " "), flush=True)


def balls(archive_dir: str, proc: int) -> None:
    from bowlrec.archive import Archive, ball_sha
    from bowlrec.paper import paper_scene
    from bowlrec.spec import Ball

    base = paper_scene(16).ball.model_dump(mode="json")

    def spec(mass_kg: float) -> Ball:
        return Ball.model_validate({**base, "mass_kg": mass_kg})

    work = [(f"p{proc}-{k}", spec(5.0 + 0.01 * k)) for k in range(40)]
    work += [(f"shared-{k}", spec(6.0 + 0.01 * proc + 0.1 * k)) for k in range(5)]
    work += [(f"same-{k}", spec(7.0 + 0.1 * k)) for k in range(5)]
    random.Random(proc).shuffle(work)
    archive = Archive(archive_dir)
    print("ready", flush=True)
    sys.stdin.readline()  # the parent's "go", sent to every child at once
    for name, ball in work:
        entry, added = archive.balls.add(name, ball)
        doc = {
            "name": name,
            "version": entry.version,
            "sha": entry.sha,
            "spec_sha": ball_sha(ball),
            "added": added,
        }
        print(json.dumps(doc), flush=True)


#: the reader loads the first runs listed, at most this many
MAX_LOADS = 20


def _read_all(archive_dir: str) -> dict[str, Any]:
    from bowlrec.archive import Archive

    archive = Archive(archive_dir, create=False)
    ids = [r["run_id"] for r in archive.list_runs()]
    loaded = {}
    for rid in ids[:MAX_LOADS]:
        traj = archive.load(rid).trajectory
        loaded[rid] = {k: v.tobytes().hex() for k, v in traj.arrays().items()}
    balls = [(e.name, e.version, e.sha) for e in archive.balls.list(all_versions=True)]
    return {
        "runs": ids,
        "loaded": loaded,
        "balls": balls,
        "writable": os.access(archive_dir, os.W_OK),
    }


def reader(archive_dir: str, warm_copy: str | None, uid: int | None) -> None:
    if warm_copy is not None and uid is not None:
        _read_all(warm_copy)  # imports every module the reads need while they are readable
        os.setgroups([])
        os.setgid(uid)
        os.setuid(uid)
    doc = _read_all(archive_dir)
    doc["euid"] = os.geteuid()
    print(json.dumps(doc), flush=True)


def count(archive_dir: str, stop_file: str) -> None:
    from bowlrec.archive import Archive

    archive = Archive(archive_dir, create=False)
    counts: list[int] = []
    errors: list[str] = []
    stop = Path(stop_file)
    print("ready", flush=True)
    while not stop.exists():
        try:
            counts.append(len(archive.list_runs()))
        except Exception:
            errors.append(traceback.format_exc(limit=3))
    print(json.dumps({"counts": counts, "errors": errors[:5], "n_errors": len(errors)}))


def main() -> None:
    role, args = sys.argv[1], sys.argv[2:]
    if role == "writer":
        writer(args[0], args[1], int(args[2]), int(args[3]), int(args[4]))
    elif role == "die-in-commit":
        die_in_commit(args[0], args[1], int(args[2]), int(args[3]))
    elif role == "create":
        create()
    elif role == "balls":
        balls(args[0], int(args[1]))
    elif role == "reader":
        reader(
            args[0],
            args[1] if len(args) > 1 else None,
            int(args[2]) if len(args) > 2 else None,
        )
    elif role == "count":
        count(args[0], args[1])
    else:
        raise SystemExit(f"unknown role {role!r}")


if __name__ == "__main__":
    main()

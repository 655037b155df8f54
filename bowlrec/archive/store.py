"""An archive directory: one HDF5 file per run, an SQLite index, a ball-spec library.

::

    ARCHIVE/
      archive.json              format marker {"format": "bowlrec-archive", "format_version": ...}
      index.sqlite              runs table (one row per run) + balls table (the library)
      runs/<id[:2]>/<id>.h5     one run per file (bowlrec.sinks.hdf5_run), never rewritten
      .writer.lock              held (flock) while a process adds or removes runs

Adding a run writes its file whole under a temporary name, fsyncs it, renames it into place,
then commits its index row. A writer killed at any moment loses at most that run: a leftover
temporary is deleted by the next writer, and a run file without an index row (a kill between
the rename and the commit) is indexed by the next writer (:meth:`Archive.repair`).
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bowlrec.sinks.atomic import atomic_path, remove_stale_parts

from .balls import BallLibrary
from .index import INDEX_COLUMNS, Filter, connect, select_sql
from .run_id import run_id as content_id

if TYPE_CHECKING:
    from bowlrec.core.trajectory import Trajectory
    from bowlrec.sinks.common import RunData
    from bowlrec.sinks.hdf5_run import StoredRun
    from bowlrec.spec import Scene

__all__ = ["ARCHIVE_FORMAT", "AddResult", "Archive", "ArchiveError", "RunNotFoundError"]

ARCHIVE_FORMAT = "bowlrec-archive"
ARCHIVE_FORMAT_VERSION = "1.0"


class ArchiveError(RuntimeError):
    """The directory is not a usable archive."""


class RunNotFoundError(KeyError):
    """No run with that ID (or ID prefix) in the archive."""

    def __str__(self) -> str:
        return str(self.args[0])


@dataclass(frozen=True)
class AddResult:
    """What :meth:`Archive.add` or :meth:`Archive.simulate` did."""

    run_id: str
    path: Path
    #: False when the run was already archived (nothing was written)
    added: bool
    #: the trajectory (simulated now, or read back from the archive when it already existed)
    trajectory: Trajectory | None = None


class Archive:
    """A directory of runs with an index and a ball library (created on first use)."""

    def __init__(self, root: str | os.PathLike[str], *, create: bool = True) -> None:
        self.root = Path(root).expanduser()
        self.runs_dir = self.root / "runs"
        self.index_path = self.root / "index.sqlite"
        marker = self.root / "archive.json"
        if not marker.exists():
            if not create:
                raise ArchiveError(f"{self.root} is not a bowlrec archive (no archive.json)")
            if self.root.exists() and any(self.root.iterdir()):
                raise ArchiveError(
                    f"{self.root} exists, is not empty and is not a bowlrec archive; "
                    "choose an empty or new directory"
                )
            self.runs_dir.mkdir(parents=True, exist_ok=True)
            with atomic_path(marker) as tmp:
                tmp.write_text(
                    json.dumps({"format": ARCHIVE_FORMAT, "format_version": ARCHIVE_FORMAT_VERSION})
                    + "\n"
                )
        else:
            meta = json.loads(marker.read_text())
            if meta.get("format") != ARCHIVE_FORMAT:
                raise ArchiveError(f"{marker}: not a bowlrec archive marker")
            major = str(meta.get("format_version", "")).split(".")[0]
            if major != ARCHIVE_FORMAT_VERSION.split(".")[0]:
                raise ArchiveError(
                    f"{self.root}: archive format {meta.get('format_version')} is not supported "
                    f"(this bowlrec reads {ARCHIVE_FORMAT_VERSION.split('.')[0]}.x)"
                )
        self.balls = BallLibrary(self.index_path)

    def __repr__(self) -> str:
        return f"Archive({str(self.root)!r})"

    # -- writing -------------------------------------------------------------------------------

    @contextlib.contextmanager
    def writer_lock(self) -> Iterator[None]:
        """Exclusive across processes (flock; released by the OS if the holder dies)."""
        with open(self.root / ".writer.lock", "a") as fh:
            fcntl.flock(fh, fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(fh, fcntl.LOCK_UN)

    def run_path(self, run_id: str) -> Path:
        """Where the run file of ``run_id`` lives (whether or not it exists)."""
        return self.runs_dir / run_id[:2] / f"{run_id}.h5"

    def has_run(self, run_id: str) -> bool:
        """True when the run's file is in place (an indexed run always has its file)."""
        return self.run_path(run_id).exists()

    def add(
        self,
        run: RunData,
        *,
        wall_time_s: float,
        ball_ref: str | None = None,
        solver: str = "",
        durable: bool = True,
    ) -> AddResult:
        """Store a finished run (idempotent: an already archived run ID writes nothing).

        ``ball_ref`` ("name@version") names the library ball the scene used; when None the
        library is searched for a spec equal to the scene's ball.
        """
        from bowlrec.sinks.common import RunData as _RunData
        from bowlrec.sinks.hdf5_run import write_run_file

        from .provenance import provenance

        rid = run.run_id or content_id(run.plan)
        run = _RunData(run.scene, run.plan, run.trajectory, rid)
        path = self.run_path(rid)
        with self.writer_lock():
            if path.exists():
                self._ensure_indexed(rid)
                return AddResult(rid, path, False, run.trajectory)
            if ball_ref is None:
                entry = self.balls.find(run.scene.ball)
                ball_ref = entry.ref if entry is not None else ""
            attrs = provenance(run, wall_time_s=wall_time_s, ball_ref=ball_ref, solver=solver)
            write_run_file(path, run, attrs, durable=durable)
            self._index(self._row(rid, attrs, run))
        return AddResult(rid, path, True, run.trajectory)

    def simulate(
        self, scene: Scene, *, ball_ref: str | None = None, method: str = "auto"
    ) -> AddResult:
        """Simulate ``scene`` and store it, unless its run ID is archived already (then the
        stored trajectory is returned and nothing is simulated or written)."""
        from bowlrec.core.solver import solve, use_closed_form
        from bowlrec.sinks.common import RunData

        plan = scene.resolve()
        rid = content_id(plan)
        if self.has_run(rid):
            with self.writer_lock():
                self._ensure_indexed(rid)
            return AddResult(rid, self.run_path(rid), False, self.load(rid).trajectory)
        start = time.perf_counter()
        traj = solve(plan, method)
        wall = time.perf_counter() - start
        used = (
            method
            if method != "auto"
            else ("closed_form" if use_closed_form(plan) else "integrator")
        )
        return self.add(
            RunData(scene, plan, traj, rid), wall_time_s=wall, ball_ref=ball_ref, solver=used
        )

    def remove(self, run_id: str) -> str:
        """Delete a run (its file, then its index row); returns the full run ID.

        A kill between the two steps leaves a row without a file, which :meth:`repair` drops, so
        a removed run never comes back.
        """
        rid = self.resolve_id(run_id)
        with self.writer_lock():
            with contextlib.suppress(FileNotFoundError):
                self.run_path(rid).unlink()
            with connect(self.index_path) as con:
                con.execute("DELETE FROM runs WHERE run_id = ?", (rid,))
        return rid

    def repair(self) -> dict[str, int]:
        """Finish what killed writers left: delete temporaries, index unindexed run files and
        drop index rows whose file is gone. Returns counts of each."""
        from bowlrec.sinks.hdf5_run import RunFileError

        with self.writer_lock():
            removed = remove_stale_parts(self.runs_dir)
            on_disk = {p.stem: p for p in self.runs_dir.glob("*/*.h5")}
            with connect(self.index_path) as con:
                indexed = {r[0] for r in con.execute("SELECT run_id FROM runs")}
            added = 0
            for rid in sorted(on_disk.keys() - indexed):
                try:
                    self._ensure_indexed(rid)
                    added += 1
                except (OSError, RunFileError):
                    continue
            gone = sorted(indexed - on_disk.keys())
            with connect(self.index_path) as con:
                con.executemany("DELETE FROM runs WHERE run_id = ?", [(r,) for r in gone])
        return {"temporaries_removed": removed, "runs_indexed": added, "rows_dropped": len(gone)}

    def reindex(self) -> int:
        """Rebuild the runs index from the run files (the source of truth); the run count."""
        with self.writer_lock():
            with connect(self.index_path) as con:
                con.execute("DELETE FROM runs")
            for path in sorted(self.runs_dir.glob("*/*.h5")):
                self._ensure_indexed(path.stem)
        return len(self.list_runs())

    def _ensure_indexed(self, rid: str) -> None:
        from bowlrec.sinks.hdf5_run import read_run_file

        with connect(self.index_path) as con:
            if con.execute("SELECT 1 FROM runs WHERE run_id = ?", (rid,)).fetchone():
                return
        stored = read_run_file(self.run_path(rid))
        from bowlrec.sinks.common import RunData

        run = RunData(stored.scene, stored.scene.resolve(), stored.trajectory, rid)
        self._index(self._row(rid, stored.attrs, run))

    def _row(self, rid: str, attrs: dict[str, Any], run: RunData) -> dict[str, Any]:
        import numpy as np

        from .balls import ball_sha, parse_ball_ref

        s = run.trajectory.summary
        ref = str(attrs.get("ball_ref", ""))
        ball_name, ball_version = parse_ball_ref(ref) if ref else (None, None)
        row: dict[str, Any] = {
            "run_id": rid,
            "name": run.scene.name,
            "created_at": attrs.get("created_at"),
            "ball_name": ball_name,
            "ball_version": ball_version,
            "ball_sha": ball_sha(run.scene.ball),
            "pattern": pattern_label(run.scene),
            "speed_mps": float(np.linalg.norm(run.plan.velocity0_mps[:2])),
            "rev_rate_rpm": float(np.linalg.norm(run.plan.omega0_radps)) * 60.0 / (2 * np.pi),
            "mass_kg": run.plan.mass_kg,
            "n_samples": run.trajectory.n_samples,
            "rtol": run.plan.rtol,
            "record": run.scene.options.record,
            "solver": attrs.get("solver"),
            "wall_time_s": attrs.get("wall_time_s"),
            "physics_version": attrs.get("physics_version"),
            "bowlrec_version": attrs.get("bowlrec_version"),
            "path": str(self.run_path(rid).relative_to(self.root)),
        }
        row.update({k: v for k, v in s.to_dict().items() if k in INDEX_COLUMNS})
        return row

    def _index(self, row: dict[str, Any]) -> None:
        cols = ", ".join(row)
        marks = ", ".join("?" for _ in row)
        with connect(self.index_path) as con:
            con.execute(
                f"INSERT OR REPLACE INTO runs ({cols}) VALUES ({marks})", list(row.values())
            )

    # -- reading -------------------------------------------------------------------------------

    def list_runs(
        self,
        *,
        ball: str | None = None,
        pattern: str | None = None,
        outcome: str | None = None,
        name: str | None = None,
        where: Sequence[Filter | str] = (),
        order_by: str = "created_at",
        limit: int | None = None,
    ) -> list[dict[str, Any]]:
        """Index rows (dicts keyed by :data:`~bowlrec.archive.index.INDEX_COLUMNS`), filtered.

        ``ball`` is a library name or ``name@version``; ``where`` holds conditions such as
        ``"hook_m>=0.1"`` (any index column, ops <= >= != = < >). Reads only the index.
        """
        filters = [w if isinstance(w, Filter) else Filter.parse(w) for w in where]
        clauses = [] if ball is None else [self._ball_clause(ball)]
        for column, value in (("pattern", pattern), ("outcome", outcome), ("name", name)):
            if value is not None:
                filters.append(Filter(column, "=", value))
        sql, params = select_sql(filters, order_by, limit, clauses)
        with connect(self.index_path) as con:
            return [dict(r) for r in con.execute(sql, params)]

    def _ball_clause(self, ball: str) -> tuple[str, list[Any]]:
        """Runs that used library ball ``name`` (any version) or ``name@version``: by the
        reference stored with the run, or by an identical spec (runs made before the ball was
        added to the library)."""
        from .balls import parse_ball_ref

        bname, bversion = parse_ball_ref(ball)
        shas = [
            e.sha
            for e in self.balls.list(bname, all_versions=True)
            if bversion is None or e.version == bversion
        ]
        by_ref = "ball_name = ?" + ("" if bversion is None else " AND ball_version = ?")
        params: list[Any] = [bname] + ([] if bversion is None else [bversion])
        if shas:
            by_ref += f" OR ball_sha IN ({', '.join('?' for _ in shas)})"
            params += shas
        return by_ref, params

    def resolve_id(self, run_id: str) -> str:
        """The full run ID for an ID or a unique prefix of at least 4 characters."""
        if len(run_id) < 4 or not all(c in "0123456789abcdef" for c in run_id):
            raise RunNotFoundError(f"{run_id!r} is not a run ID (hex, at least 4 characters)")
        with connect(self.index_path) as con:
            rows = con.execute(
                "SELECT run_id FROM runs WHERE run_id >= ? AND run_id < ? LIMIT 2",
                (run_id, run_id + "g"),
            ).fetchall()
        if not rows:
            raise RunNotFoundError(f"no run {run_id!r} in archive {self.root}")
        if len(rows) > 1:
            raise RunNotFoundError(f"run ID prefix {run_id!r} is ambiguous; give more characters")
        return str(rows[0][0])

    def row(self, run_id: str) -> dict[str, Any]:
        """The index row of one run."""
        rid = self.resolve_id(run_id)
        with connect(self.index_path) as con:
            return dict(con.execute("SELECT * FROM runs WHERE run_id = ?", (rid,)).fetchone())

    def load(self, run_id: str) -> StoredRun:
        """Read a run back (scene, trajectory, provenance) from its file."""
        from bowlrec.sinks.hdf5_run import read_run_file

        rid = run_id if self.has_run(run_id) else self.resolve_id(run_id)
        return read_run_file(self.run_path(rid))

    def run_data(self, run_id: str) -> RunData:
        """A stored run as the sinks take it (the plan re-resolved from the stored scene)."""
        from bowlrec.sinks.common import RunData

        stored = self.load(run_id)
        return RunData(stored.scene, stored.scene.resolve(), stored.trajectory, stored.run_id)

    def export(self, run_id: str, dest: str | os.PathLike[str]) -> Path:
        """Copy a run's HDF5 file to ``dest`` (a file or an existing directory)."""
        rid = self.resolve_id(run_id)
        dest = Path(dest)
        if dest.is_dir():
            dest = dest / f"{rid}.h5"
        with atomic_path(dest) as tmp:
            shutil.copyfile(self.run_path(rid), tmp)
        return dest

    def __len__(self) -> int:
        with connect(self.index_path) as con:
            return int(con.execute("SELECT COUNT(*) FROM runs").fetchone()[0])


def pattern_label(scene: Scene) -> str:
    """The lane's friction map as a short label for filtering (its ``kind`` for now)."""
    return str(scene.lane.friction.kind)

"""Reading runs back, their digests checked: a stored run (scene, trajectory, provenance), the
run as the sinks take it, and a one-run export file. Reads only: nothing is written to the
archive (an export writes its destination file).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from bowlrec.errors import RunDamagedError, SegmentError

from .directory import ArchiveDir
from .index import iso_time
from .queries import locate, resolve_id

if TYPE_CHECKING:
    from bowlrec.sinks.common import RunData
    from bowlrec.sinks.hdf5_run import StoredRun

__all__ = ["export", "load", "run_data"]


def load(d: ArchiveDir, run_id: str) -> StoredRun:
    """Read a run back (an ID or a unique prefix), its digest checked.

    Raises RunNotFoundError, or RunDamagedError (naming the run and its segment) when the
    stored bytes are damaged or the segment cannot be read.
    """
    from bowlrec.sinks.hdf5_run import StoredRun
    from bowlrec.spec import Scene

    found = locate(d, run_id)
    if found is None:
        run_id = resolve_id(d, run_id)
        found = locate(d, run_id)
        assert found is not None
    for attempt in (1, 2):
        segment_id, row, path = found
        try:
            rec = d.segment(path).read_run(row)
            break
        except SegmentError as err:
            moved = locate(d, run_id)
            if attempt == 1 and moved is not None and moved != found:
                found = moved  # rewritten by a compaction in another process: read it there
                continue
            reason = "segment file missing" if not path.exists() else f"unreadable: {err}"
            raise RunDamagedError(run_id, segment_id, reason) from None
    if rec.run_id != run_id:
        raise RunDamagedError(run_id, segment_id, f"row {row} holds run {rec.run_id}")
    scene = Scene.model_validate_json(rec.scene_json)
    opts = scene.options
    attrs = dict(rec.attrs)
    attrs.update(
        {
            "run_id": run_id,
            "name": scene.name,
            "created_at": iso_time(attrs.pop("created_at_ns")),
            "rtol": opts.rtol,
            "record": opts.record,
            "record_dt_s": opts.record_dt_s,
            "record_terms": opts.record_terms,
            "slide_to_roll": opts.slide_to_roll,
            "scene_json": rec.scene_json,
        }
    )
    return StoredRun(
        run_id=run_id, scene=scene, trajectory=rec.trajectory, attrs=attrs, records=rec.records
    )


def run_data(d: ArchiveDir, run_id: str) -> RunData:
    """A stored run as the sinks take it: the plan re-resolved from the stored scene, the
    provenance as its run file stores it (the stored attributes that are single values, and
    the segment holding the run)."""
    from bowlrec.sinks.common import RunData

    stored = load(d, run_id)
    own = ("format", "format_version", "run_id", "name", "scene_json", "segment_id")
    provenance = {
        k: v
        for k, v in stored.attrs.items()
        if k not in own and isinstance(v, str | int | float | bool)
    }
    found = locate(d, stored.run_id)
    if found is not None:
        provenance["segment_id"] = found[0]
    return RunData(
        stored.scene, stored.scene.resolve(), stored.trajectory, stored.run_id, provenance
    )


def export(d: ArchiveDir, run_id: str, dest: str | os.PathLike[str]) -> Path:
    """Write one run to ``dest``: an existing directory or a ``.h5`` file gets a self-contained
    run file (format ``bowlrec-run`` 1.0, 1.1 with pins, with the resolved parameters and the
    run's provenance); another suffix the format it names, as ``bowlrec runs export`` does
    (``.csv``, ``.mcap``, ``.rrd``, ...; UnknownFormatError for a suffix that names none)."""
    from bowlrec.sinks.registry import sink_for

    run = run_data(d, run_id)
    out = Path(dest)
    if out.is_dir():
        out = out / f"{run.run_id}.h5"
    return sink_for(out).write(run, out)

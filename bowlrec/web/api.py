"""The API the pages call (and scripts may): figures as SVG/PNG, a run's bowler report,
Compare, the oil patterns, a job's results, swept-metric plot and live progress.

The figures are :mod:`bowlrec.figures`' (imported when one is asked for: matplotlib is an
optional extra), rendered by :func:`bowlrec.figures.render.figure_bytes` (SVG reproducibly).
Figures of archived runs are drawn from the run's samples; a summary-only run is re-recorded
from its stored scene (:func:`bowlrec.archive.replay.replay_data`, deterministic, checked
against the stored summary). Drawn figures are cached in ``ARCHIVE/cache/figure/`` like the
replay files; re-recorded runs are kept in memory for the last few runs asked for.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import math
import threading
from collections import OrderedDict
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

from fastapi import APIRouter, Query, Request
from fastapi.responses import Response, StreamingResponse

from bowlrec.atomic_files import atomic_path
from bowlrec.errors import InputError, NotFoundError

from .jobs import all_jobs

if TYPE_CHECKING:
    from bowlrec.archive import Archive
    from bowlrec.spec.run import RunData

__all__ = [
    "JOB_METRICS",
    "MAX_COMPARE",
    "ReplayCache",
    "ball_card",
    "cached_report",
    "figures",
    "job_axes",
    "pattern_cards",
]

FigureFormat = Literal["svg", "png"]
MEDIA = {"svg": "image/svg+xml", "png": "image/png"}
#: runs in one Compare figure at most
MAX_COMPARE = 40
#: job results listed (and plotted) at most
MAX_JOB_ROWS = 5000
#: metrics a job's plot offers on its y axis: index column -> label (scaled to its unit); the
#: archive's signed lane-frame values (+: toward the left gutter)
JOB_METRICS: dict[str, tuple[str, float]] = {
    "hook_m": ("hook (cm, +left)", 100.0),
    "pocket_deg": ("pocket angle (deg, +left)", 1.0),
    "slide_m": ("slide (m)", 1.0),
    "y_end_m": ("end y (m, from the right gutter)", 1.0),
    "speed_end_mps": ("speed at the end (m/s)", 1.0),
    "rev_rate_end_rpm": ("rev rate at the end (rpm)", 1.0),
    "time_s": ("time (s)", 1.0),
}
#: job states after which nothing changes (the event stream ends)
FINAL_STATES = frozenset({"done", "failed", "cancelled", "interrupted", "damaged"})
#: seconds between looks at a job's progress for its event stream
POLL_S = 0.25

figures = APIRouter(tags=["figures"])


class ReplayCache:
    """The last few runs with samples (re-recorded ones included), by run ID, and their
    bowler reports; thread-safe. A run is re-recorded once even when asked for by several
    requests at once."""

    def __init__(self, archive: Archive, size: int = 8) -> None:
        self.archive = archive
        self.size = size
        self._runs: OrderedDict[str, RunData] = OrderedDict()
        self._reports: dict[str, dict[str, Any] | None] = {}
        self._mutex = threading.Lock()
        self._locks: dict[str, threading.Lock] = {}

    def _lock(self, rid: str) -> threading.Lock:
        with self._mutex:
            return self._locks.setdefault(rid, threading.Lock())

    def run(self, rid: str) -> RunData:
        """The run ``rid`` with samples."""
        from bowlrec.archive.replay import replay_data

        with self._lock(rid):
            with self._mutex:
                if rid in self._runs:
                    self._runs.move_to_end(rid)
                    return self._runs[rid]
            try:
                run = replay_data(self.archive, rid)
            except BaseException:
                with self._mutex:
                    self._locks.pop(rid, None)
                raise
            with self._mutex:
                self._runs[rid] = run
                while len(self._runs) > self.size:
                    old, _ = self._runs.popitem(last=False)
                    self._reports.pop(old, None)
                    self._locks.pop(old, None)
            return run

    def report(self, rid: str) -> dict[str, Any] | None:
        """The bowler report of run ``rid`` (None when it has none: see bowler_report_of)."""
        from bowlrec.archive.replay import bowler_report_of

        with self._mutex:
            if rid in self._reports:
                return self._reports[rid]
        report = bowler_report_of(self.run(rid))
        with self._mutex:
            self._reports[rid] = report
        return report


def _state(request: Request) -> Any:
    return request.app.state.bowlrec


def cached_report(state: Any, rid: str) -> dict[str, Any] | None:
    """The bowler report of archived run ``rid`` (see :class:`ReplayCache`)."""
    report: dict[str, Any] | None = state.replays.report(rid)
    return report


def _cached_figure(state: Any, key: str, fmt: str, draw: Callable[[], bytes]) -> Path:
    """The figure ``key`` drawn once into ``ARCHIVE/cache/figure/`` (atomically)."""
    path = state.cache_dir / "figure" / key[:2] / f"{key}.{fmt}"
    with state.file_lock(path):
        if not path.exists():
            data = draw()
            path.parent.mkdir(parents=True, exist_ok=True)
            with atomic_path(path) as tmp:
                tmp.write_bytes(data)
    return Path(path)


def _figure_response(path: Path, fmt: str) -> Response:
    return Response(
        path.read_bytes(),
        media_type=MEDIA[fmt],
        headers={"Cache-Control": "private, max-age=3600"},
    )


# -- runs ----------------------------------------------------------------------------------------


@figures.get("/runs/{run_id}/figure.{fmt}", response_class=Response)
def run_figure(request: Request, run_id: str, fmt: FigureFormat) -> Response:
    """The paper-style figure of a run (lane, oil, path, rotation axes) as SVG or PNG; a
    summary-only run is re-recorded from its scene first (deterministic)."""
    from bowlrec.figures.render import figure_bytes
    from bowlrec.figures.trajectory import runs_figure

    state = _state(request)
    rid = state.archive.resolve_id(run_id)

    def draw() -> bytes:
        return figure_bytes(runs_figure([state.replays.run(rid)]), fmt)

    path = _cached_figure(state, f"{rid}-run", fmt, draw)
    return _figure_response(path, fmt)


@figures.get("/runs/{run_id}/report", response_model=dict[str, Any] | None)
def run_report(request: Request, run_id: str) -> dict[str, Any] | None:
    """The run in bowlers' terms (laydown, launch, breakpoint, entry, hook in boards; the
    handedness inferred from the hook's direction); null when it cannot be computed."""
    state = _state(request)
    return cached_report(state, state.archive.resolve_id(run_id))


@figures.get("/runs/{run_id}/pins", response_model=dict[str, Any] | None)
def run_pins(request: Request, run_id: str) -> dict[str, Any] | None:
    """The run's pins for the pin-deck view: the leave, pinfall, standing and touched pins,
    the exit board, the deck (spots, m) and each pin's and the ball's recorded motion seen
    from above (lane frame, m; :func:`bowlrec.sinks.pin_replay.pins_json`); null for a run
    without pin action."""
    from bowlrec.sinks.pin_replay import pins_json

    state = _state(request)
    rid = state.archive.resolve_id(run_id)
    return pins_json(state.replays.run(rid))


@figures.get("/compare/figure.{fmt}", response_class=Response)
def compare_figure(
    request: Request,
    fmt: FigureFormat,
    ids: Annotated[list[str], Query(description="Run IDs (or prefixes), in legend order.")],
) -> Response:
    """Several runs' paths overlaid in one paper-style figure (2 to MAX_COMPARE runs)."""
    from bowlrec.figures.render import figure_bytes
    from bowlrec.figures.trajectory import runs_figure

    state = _state(request)
    rids = [state.archive.resolve_id(i) for i in ids]
    if not 1 <= len(rids) <= MAX_COMPARE:
        raise InputError(f"ids: {len(rids)} runs given; compare 1 to {MAX_COMPARE} runs")
    key = hashlib.sha256(" ".join(rids).encode()).hexdigest()[:40] + "-compare"

    def draw() -> bytes:
        return figure_bytes(runs_figure([state.replays.run(r) for r in rids]), fmt)

    path = _cached_figure(state, key, fmt, draw)
    return _figure_response(path, fmt)


# -- library and patterns ------------------------------------------------------------------------


def ball_card(entry: Any) -> dict[str, Any]:
    """What the library page shows of a ball: its spec sheet, legality and JSON."""
    from bowlrec.bowling.ball import BowlerBall
    from bowlrec.bowling.legality import check_legality

    ball = entry.ball
    bowler = isinstance(ball, BowlerBall)
    legality = check_legality(ball) if bowler else None
    return {
        "ref": entry.ref,
        "name": entry.name,
        "added_at": entry.added_at[:19].replace("T", " "),
        "note": entry.note,
        "sheet": ball.spec_sheet() if bowler else None,
        "legality": None if legality is None else str(legality),
        "legal": None if legality is None else legality.is_legal,
        "json": json.dumps(entry.to_json_dict()["spec"], indent=2),
    }


def catalog_layouts() -> list[dict[str, Any]]:
    """The layouts and PAPs of bowlrec's sourced catalog (id, notation, source) that a
    library ball can be drawn with."""
    from bowlrec.bowling.layout import load_example_library

    library = load_example_library()
    return [
        {"kind": kind, "id": e.id, "source": e.source, "note": e.note}
        for kind, entries in (("layout", library.layouts), ("pap", library.paps))
        for e in entries
    ]


@figures.get("/balls/{ref}/figure.{fmt}", response_class=Response)
def ball_figure(
    request: Request,
    ref: str,
    fmt: FigureFormat,
    layout: Annotated[
        str | None, Query(description="A layout of the catalog (default: its first).")
    ] = None,
    pap: Annotated[
        str | None, Query(description="A PAP of the catalog (default: its first).")
    ] = None,
) -> Response:
    """A library ball drilled with a layout of bowlrec's catalog, for a bowler's PAP of the
    catalog: the map of the ball's surface around the grip with the PAP, the pin and (for an
    asymmetric core) the PSA. 404 for a ball given in physical terms (it has no pin or RG
    axes to lay out)."""
    from bowlrec.bowling.layout import load_example_library
    from bowlrec.figures.ball import ball_figure as draw
    from bowlrec.figures.render import figure_bytes

    entry = _state(request).archive.balls.get(ref)
    library = load_example_library()
    ids = {"layout": [e.id for e in library.layouts], "pap": [e.id for e in library.paps]}
    for what, given in (("layout", layout), ("pap", pap)):
        if given is not None and given not in ids[what]:
            raise InputError(
                f"{what}: {given[:60]!r} is not in the catalog; one of {', '.join(ids[what])}"
            )
    chosen = library.layout(layout or ids["layout"][0])
    fig = draw(entry, layout=chosen, pap=library.pap(pap or ids["pap"][0]))
    if fig is None:
        raise NotFoundError(f"ball {entry.ref} has no layout to draw (a physical spec)")
    return Response(figure_bytes(fig, fmt), media_type=MEDIA[fmt])


def pattern_cards() -> list[dict[str, Any]]:
    """The preset oil patterns with their statistics (name, description, volume, ratio)."""
    from bowlrec.bowling.oil import pattern_statistics, preset, preset_names

    cards = []
    for name in preset_names():
        pattern = preset(name)
        stats = pattern_statistics(pattern)
        cards.append(
            {
                "name": name,
                "title": getattr(pattern, "name", name),
                "description": getattr(pattern, "description", ""),
                "stats": {k: v for k, v in vars(stats).items() if not k.startswith("_")},
            }
        )
    return cards


@figures.get("/patterns", response_model=list[dict[str, Any]])
def list_patterns() -> list[dict[str, Any]]:
    """The oil patterns that ship with bowlrec (``pattern`` of a bowler scene) and their
    statistics."""
    return pattern_cards()


@figures.get("/patterns/{name}/figure.{fmt}", response_class=Response)
def pattern_figure(name: str, fmt: FigureFormat) -> Response:
    """An oil pattern drawn as a Kegel graph (oil per board along the lane)."""
    from bowlrec.bowling.oil import preset, preset_names
    from bowlrec.figures.oil import pattern_figure as draw
    from bowlrec.figures.render import figure_bytes

    if name not in preset_names():
        raise NotFoundError(
            f"no oil pattern {name[:60]!r}; the patterns are {', '.join(preset_names())}"
        )
    return Response(
        figure_bytes(draw(preset(name)), fmt),
        media_type=MEDIA[fmt],
        headers={"Cache-Control": "max-age=3600"},
    )


# -- jobs ----------------------------------------------------------------------------------------


def job_axes(spec: Any) -> list[str]:
    """The numeric parameters a job spec sweeps (dotted scene paths), in the spec's order."""
    axes: list[str] = []
    for point in spec.points(0, min(spec.count(), 256)):
        for path, value in point.overrides.items():
            if path not in axes and isinstance(value, int | float) and not isinstance(value, bool):
                axes.append(path)
    return axes


def _job_results(state: Any, job_id: str, spec: Any, limit: int) -> list[dict[str, Any]]:
    """The job's runs in job order: index, run ID, swept values (from its ``spec``) and the
    index metrics."""
    status = all_jobs(state).get(job_id, with_runs=True)
    run_ids = (status.run_ids or [])[:limit]
    points = spec.points(0, len(run_ids))
    rows = state.archive.rows([r for r in run_ids if r is not None])
    out = []
    for point, rid in zip(points, run_ids, strict=True):
        row = rows.get(rid) if rid is not None else None
        out.append(
            {
                "index": point.index,
                "run_id": rid,
                "values": point.overrides,
                **{m: (None if row is None else row.get(m)) for m in ("outcome", *JOB_METRICS)},
            }
        )
    return out


@figures.get("/jobs/{job_id}/results", response_model=list[dict[str, Any]])
def job_results(
    request: Request,
    job_id: str,
    limit: Annotated[int, Query(ge=1, le=MAX_JOB_ROWS)] = 500,
) -> list[dict[str, Any]]:
    """The job's runs in job order (the first ``limit``): swept values, run ID, outcome and
    metrics in SI units (null for a run not archived yet or failed)."""
    state = _state(request)
    return _job_results(state, job_id, all_jobs(state).spec(job_id), limit)


@figures.get("/jobs/{job_id}/figure.{fmt}", response_class=Response)
def job_figure(
    request: Request,
    job_id: str,
    fmt: FigureFormat,
    x: Annotated[str, Query(description="A swept parameter (dotted path).")],
    y: Annotated[str, Query(description="A metric: " + ", ".join(JOB_METRICS))] = "hook_m",
) -> Response:
    """A metric of the job's runs against one of its swept parameters (first MAX_JOB_ROWS
    runs; runs not archived are left out)."""
    from bowlrec.figures.render import figure_bytes
    from bowlrec.figures.sweep import sweep_figure

    state = _state(request)
    spec = all_jobs(state).spec(job_id)
    axes = job_axes(spec)
    if x not in axes:
        raise InputError(f"x: {x[:60]!r} is not swept by this job; swept: {', '.join(axes)}")
    if y not in JOB_METRICS:
        raise InputError(f"y: {y[:60]!r} is not a metric; metrics: {', '.join(JOB_METRICS)}")
    label, scale = JOB_METRICS[y]
    xs, ys = [], []
    for r in _job_results(state, job_id, spec, MAX_JOB_ROWS):
        value = r["values"].get(x)
        if value is not None and r[y] is not None and math.isfinite(r[y]):
            xs.append(float(value))
            ys.append(float(r[y]) * scale)
    name = all_jobs(state).get(job_id, with_runs=False).name
    fig = sweep_figure(xs, ys, x_label=x, y_label=label, title=f"job {name}")
    return Response(figure_bytes(fig, fmt), media_type=MEDIA[fmt])


@figures.get("/jobs/{job_id}/events")
async def job_events(request: Request, job_id: str) -> StreamingResponse:
    """The job's progress as server-sent events: one ``data:`` line of the job's status (as
    ``GET /jobs/{id}`` without run IDs) whenever it changes, ending when the job is done,
    failed, cancelled or interrupted."""
    state = _state(request)
    first = all_jobs(state).get(job_id, with_runs=False)  # 404 before the stream starts

    async def stream() -> AsyncIterator[bytes]:
        last = None
        status = first
        while True:
            text = status.model_dump_json()
            if text != last:
                yield f"data: {text}\n\n".encode()
                last = text
            if status.status in FINAL_STATES or await request.is_disconnected():
                return
            await asyncio.sleep(POLL_S)
            status = all_jobs(state).get(job_id, with_runs=False)

    return StreamingResponse(
        stream(),
        media_type="text/event-stream",
        headers={"Cache-Control": "no-store", "X-Accel-Buffering": "no"},
    )

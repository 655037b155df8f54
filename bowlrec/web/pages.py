"""The HTML pages of ``bowlrec serve``: server-rendered (Jinja2) with a little JavaScript.

``/`` is the runs table; the other pages live under ``/ui/``: a run (``/ui/runs/{id}``),
Compare (``/ui/compare?ids=A&ids=B``), the ball library (``/ui/balls``), oil patterns
(``/ui/patterns``) and jobs (``/ui/jobs``, ``/ui/jobs/{id}``). Their figures, files and live
progress come from the JSON/figure API (:mod:`bowlrec.web.api`), which the pages call with the
browser's cookie session; a server with a token shows a sign-in form until the session is open.
Everything the pages load is served by this server (``/static``, ``/viewer``): no CDN.

The pages do not know how a request signs in: the application that serves them keeps, in
``app.state.bowlrec``, an object with the methods of :class:`Host` (the service's state), whose
``signed_in`` is the same check the API's routes make, and whose ``status_for`` gives an error
the status the API gives it.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Protocol

from fastapi import APIRouter, Depends, Request
from fastapi.responses import HTMLResponse, Response
from fastapi.templating import Jinja2Templates

from bowlrec.archive.index import cell_text
from bowlrec.bowling.report import board_count, summary_rows
from bowlrec.core.codes import OUTCOMES
from bowlrec.errors import BowlrecError, InputError
from bowlrec.versions import __version__

from .jobs import all_jobs
from .seeds import SEEDS
from .tables import PAGE_SIZES, RANGES, RUN_COLUMNS, RunsQuery, runs_page

__all__ = ["TEMPLATES_DIR", "Host", "SignedIn", "pages"]

TEMPLATES_DIR = Path(__file__).parent / "templates"
templates = Jinja2Templates(directory=str(TEMPLATES_DIR))
templates.env.globals["version"] = __version__

pages = APIRouter(include_in_schema=False)

#: headers of every page: only this server's scripts, styles, images and frames; no page of
#: another site may frame ours (clickjacking)
PAGE_HEADERS = {
    "Content-Security-Policy": (
        "default-src 'self'; img-src 'self' data:; style-src 'self'; script-src 'self'; "
        "frame-src 'self'; connect-src 'self'; frame-ancestors 'self'; form-action 'self'"
    ),
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "same-origin",
}

#: summary fields of a run as the run and Compare pages show them: (label, key, scale, format)
SUMMARY_FIELDS: tuple[tuple[str, str, float, str], ...] = (
    ("outcome", "outcome", 1.0, ""),
    ("slide (m)", "slide_m", 1.0, ".4f"),
    ("hook", "hook", 1.0, ""),
    ("pocket angle", "pocket", 1.0, ""),
    ("time (s)", "time_s", 1.0, ".4f"),
    ("end x (m, lane frame)", "x_end_m", 1.0, ".4f"),
    ("end y (m, lane frame: from the right gutter)", "y_end_m", 1.0, ".4f"),
    ("speed at release (m/s)", "speed_mps", 1.0, ".3f"),
    ("speed at the end (m/s)", "speed_end_mps", 1.0, ".3f"),
    ("rev rate at release (rpm)", "rev_rate_rpm", 1.0, ".1f"),
    ("rev rate at the end (rpm)", "rev_rate_end_rpm", 1.0, ".1f"),
    ("mass (kg)", "mass_kg", 1.0, ".4f"),
    ("ball", "ball", 1.0, ""),
    ("pattern", "pattern", 1.0, ""),
    ("recorded", "record", 1.0, ""),
    ("samples", "n_samples", 1.0, "d"),
    ("steps / RHS", "steps_rhs", 1.0, ""),
    ("physics", "physics_version", 1.0, ""),
    ("created (UTC)", "created_at", 1.0, ""),
)
#: bowler-report fields shown on a run page: (label, key, format)
REPORT_FIELDS: tuple[tuple[str, str, str], ...] = (
    ("hand", "handedness", ""),
    ("laydown board", "laydown_board", ".1f"),
    ("launch speed (mph)", "launch_speed_mph", ".2f"),
    ("launch angle (deg)", "launch_angle_deg", ".2f"),
    ("rev rate at release (rpm)", "rev_rate_release_rpm", ".0f"),
    ("axis rotation / tilt at release (deg)", "axis_release", ""),
    ("board at the arrows", "arrows_board", ".1f"),
    ("breakpoint (board @ ft)", "breakpoint", ""),
    ("entry board", "entry_board", ".1f"),
    ("entry angle (deg)", "entry_angle_deg", ".2f"),
    ("entry speed (mph)", "entry_speed_mph", ".2f"),
    ("hook (boards)", "hook_boards", ".1f"),
    ("slide (ft)", "slide_ft", ".1f"),
)


class Host(Protocol):
    """What the pages need of the application serving them, besides its archive and jobs
    (``app.state.bowlrec``)."""

    def signed_in(self, request: Request) -> bool:
        """True when ``request`` may see the archive (the API's own check)."""
        ...

    def status_for(self, err: BowlrecError) -> int:
        """The HTTP status the API answers ``err`` with."""
        ...


def _state(request: Request) -> Any:
    return request.app.state.bowlrec


def _signed_in(request: Request) -> bool:
    """True when the request may see the archive: the serving application's check."""
    host: Host = _state(request)
    return bool(host.signed_in(request))


#: a page's parameter: whether its request may see the archive
SignedIn = Annotated[bool, Depends(_signed_in)]


def _render(
    request: Request, signed_in: bool, template: str, status_code: int = 200, **context: Any
) -> HTMLResponse:
    if not signed_in:
        template, status_code = "signin.html", 401
        context = {"page": "signin", "title": "Sign in"}
    context.setdefault("page", template.removesuffix(".html"))
    response = templates.TemplateResponse(request, template, context, status_code=status_code)
    response.headers.update(PAGE_HEADERS)
    return response


def _error_page(request: Request, err: BowlrecError) -> HTMLResponse:
    """The error as a page, with the status the API gives it (for a signed-in request)."""
    host: Host = _state(request)
    return _render(
        request,
        True,
        "error.html",
        status_code=host.status_for(err),
        title="Error",
        message=_state(request).redact(str(err)),
    )


def fmt(value: Any, spec: str = "", scale: float = 1.0) -> str:
    """A value as a page shows it ('' for None; numbers scaled and formatted)."""
    if value is None:
        return ""
    if spec and isinstance(value, int | float) and not isinstance(value, bool):
        return format(value * scale if scale != 1.0 else value, spec)
    return str(value)


templates.env.filters["fmt"] = fmt


def summary_cells(row: dict[str, Any]) -> list[tuple[str, str]]:
    """(label, shown value) of each :data:`SUMMARY_FIELDS` entry for an index row."""
    row = dict(row)
    row["ball"] = cell_text(row, "ball")
    row["steps_rhs"] = f"{row.get('n_steps')} / {row.get('n_rhs')}"
    row["created_at"] = cell_text(row, "created_at")
    sides = dict(summary_rows(_number(row.get("hook_m")), _number(row.get("pocket_deg"))))
    row["hook"], row["pocket"] = sides.get("hook"), sides.get("pocket angle")
    return [(label, fmt(row.get(key), spec, scale)) for label, key, scale, spec in SUMMARY_FIELDS]


def _number(value: Any) -> float | None:
    """A finite float of an index cell, else None (NaN: no value)."""
    if isinstance(value, int | float) and not isinstance(value, bool) and value == value:
        return float(value)
    return None


def report_cells(report: dict[str, Any]) -> list[tuple[str, str]]:
    """(label, shown value) of each :data:`REPORT_FIELDS` entry of a bowler report."""
    shown = dict(report)
    shown["axis_release"] = (
        f"{report['axis_rotation_release_deg']:.1f} / {report['axis_tilt_release_deg']:.1f}"
    )
    shown["breakpoint"] = f"{report['breakpoint_board']:.1f} @ {report['breakpoint_ft']:.1f}"
    shown["handedness"] = f"{report['handedness']} (boards: {board_count(report['handedness'])})"
    return [(label, fmt(shown.get(key), spec)) for label, key, spec in REPORT_FIELDS]


# -- runs ----------------------------------------------------------------------------------------


@pages.get("/", response_class=HTMLResponse)
def runs_table(request: Request, signed_in: SignedIn) -> Response:
    """The runs table: filters, sort and pages on the server (the index only)."""
    state = _state(request)
    params = dict(request.query_params)
    context: dict[str, Any] = {
        "title": "Runs",
        "columns": RUN_COLUMNS,
        "outcomes": list(OUTCOMES.values()),
        "ranges": RANGES,
        "page_sizes": PAGE_SIZES,
        "params": params,
        "balls": [e.name for e in state.archive.balls.list()] if signed_in else [],
    }
    try:
        query = RunsQuery.parse(params)
        table = runs_page(state.archive, query) if signed_in else None
    except InputError as err:
        return _render(
            request, signed_in, "runs.html", 422, error=state.redact(str(err)), **context
        )
    return _render(request, signed_in, "runs.html", query=query, table=table, **context)


@pages.get("/ui/runs/{run_id}", response_class=HTMLResponse)
def run_page(request: Request, run_id: str, signed_in: SignedIn) -> Response:
    """One run: summary, bowler report, figure, downloads, the pin deck (a run with pin
    action; drawn by the page's script from ``/runs/{id}/pins``), scene and the rerun viewer."""
    if not signed_in:
        return _render(request, False, "run.html")
    state = _state(request)
    from .api import cached_report

    try:
        rid = state.archive.resolve_id(run_id)
        row = state.archive.row(rid)
        scene = state.archive.load(rid).scene
    except BowlrecError as err:
        return _error_page(request, err)
    try:
        report, report_error = cached_report(state, rid), None
    except BowlrecError as err:
        report, report_error = None, state.redact(str(err))
    base = str(request.base_url).rstrip("/")
    return _render(
        request,
        True,
        "run.html",
        title=f"Run {rid[:12]}",
        rid=rid,
        row=row,
        summary=summary_cells(row),
        report=None if report is None else report_cells(report),
        report_error=report_error,
        scene_json=json.dumps(scene.model_dump(mode="json"), indent=2),
        summary_only=row.get("record") == "summary",
        has_pins=scene.options.pin_options is not None,
        viewer_url=f"/viewer/index.html?url={base}/runs/{rid}/recording.rrd&hide_welcome_screen",
    )


@pages.get("/ui/compare", response_class=HTMLResponse)
def compare_page(request: Request, signed_in: SignedIn) -> Response:
    """Several runs: their paths overlaid in one figure and their summaries side by side."""
    state = _state(request)
    ids = [i for i in request.query_params.getlist("ids") if i.strip()]
    if not signed_in:
        return _render(request, False, "compare.html")
    rows = []
    try:
        for given in ids:
            rows.append(state.archive.row(state.archive.resolve_id(given.strip())))
    except BowlrecError as err:
        return _error_page(request, err)
    from .api import MAX_COMPARE

    too_many = len(rows) > MAX_COMPARE
    cells = [summary_cells(r) for r in rows]
    table = [(label, [c[i][1] for c in cells]) for i, (label, *_rest) in enumerate(SUMMARY_FIELDS)]
    query = "&".join(f"ids={r['run_id']}" for r in rows)
    return _render(
        request,
        True,
        "compare.html",
        title="Compare",
        rows=rows,
        table=table,
        figure_query=query,
        too_many=too_many,
        max_compare=MAX_COMPARE,
    )


# -- library and patterns ------------------------------------------------------------------------


@pages.get("/ui/balls", response_class=HTMLResponse)
def balls_page(request: Request, signed_in: SignedIn) -> Response:
    """The ball library: spec sheets, legality and layouts (latest version of each ball)."""
    if not signed_in:
        return _render(request, False, "balls.html")
    from .api import ball_card, catalog_layouts

    state = _state(request)
    cards = [ball_card(e) for e in state.archive.balls.list()]
    choices = catalog_layouts()
    return _render(
        request,
        True,
        "balls.html",
        title="Ball library",
        cards=cards,
        layouts=[c for c in choices if c["kind"] == "layout"],
        paps=[c for c in choices if c["kind"] == "pap"],
    )


@pages.get("/ui/patterns", response_class=HTMLResponse)
def patterns_page(request: Request, signed_in: SignedIn) -> Response:
    """The oil patterns that ship with bowlrec, each drawn as a Kegel graph."""
    from .api import pattern_cards

    return _render(request, signed_in, "patterns.html", title="Oil patterns", cards=pattern_cards())


# -- jobs ----------------------------------------------------------------------------------------


@pages.get("/ui/jobs", response_class=HTMLResponse)
def jobs_page(request: Request, signed_in: SignedIn) -> Response:
    """Every job of the archive, and a JSON editor to submit a job or a scene."""
    if not signed_in:
        return _render(request, False, "jobs.html")
    state = _state(request)
    seeds = [{"label": s.label, "kind": s.kind, "text": s.text()} for s in SEEDS]
    jobs = all_jobs(state).list()
    return _render(request, True, "jobs.html", title="Jobs", jobs=jobs, seeds=seeds)


@pages.get("/ui/jobs/{job_id}", response_class=HTMLResponse)
def job_page(request: Request, job_id: str, signed_in: SignedIn) -> Response:
    """A job: live progress, its results table and a swept metric against a swept parameter."""
    if not signed_in:
        return _render(request, False, "job.html")
    state = _state(request)
    from .api import JOB_METRICS, job_axes

    try:
        jobs = all_jobs(state)
        status = jobs.get(job_id, with_runs=False)
        axes = job_axes(jobs.spec(job_id))
    except BowlrecError as err:
        return _error_page(request, err)
    return _render(
        request,
        True,
        "job.html",
        title=f"Job {status.name}",
        job=status,
        axes=axes,
        metrics=JOB_METRICS,
    )

"""The FastAPI application: scenes, runs and their files, the ball library and jobs.

Errors are ``{"detail": "<message>"}``, one line unless noted. An error of :mod:`bowlrec.errors`
is answered in one handler with the status of its category (:data:`STATUS_CODES`): 422 for an
InputError (an invalid scene, ball or job spec -- one ``field: message`` line per error, as
:func:`bowlrec.spec.format_validation_error` writes them -- a bad run filter or ball reference),
404 for a NotFoundError (unknown run, ball or job), 409 for a ConflictError (a summary-only run
whose re-recording differs from its stored summary, a job not cancellable or resumable, a job
whose record is damaged) and a DamagedError (a stored run found damaged: the message names the
run and its segment; `bowlrec runs repair` quarantines it), 503 with ``Retry-After`` for a
BusyError (every recording slot is busy and enough recorded runs wait), 507 for a StorageError
(the archive could not be written, e.g. a full disk; nothing stored was lost), 501 for an
UnavailableError (an optional format library is not installed). The HTTP layer adds 400 (a
``Host`` that is not allowed -- DNS-rebinding protection; the message says how to allow it), 401
(missing or wrong bearer token, and no valid session cookie), 403 (a state-changing request from
another site: ``Sec-Fetch-Site`` or ``Origin`` not this server's) and 413 (the request body
exceeds the limit, ``serve --max-body-mb``). Messages never name a server path (the archive's
root reads ``ARCHIVE``, other paths ``<path>``), and control characters in them are escaped.
Malformed requests are 422 with the same lines (never a list): the body as a whole is ``request
body`` (``request body: not valid JSON at line 1 column 14: Expecting ',' delimiter``, ``request
body: must be a JSON object (got an array)``, an empty body, a ``Content-Type`` that is not
JSON), a field of the body is named by its path (``name: Field required``), a parameter as
``query parameter limit: ...`` or ``path parameter kind: ...``; a body that cannot be parsed at
all (nested too deeply, an integer of more than 4300 digits, bytes that are not UTF-8) is 400
(``request body: cannot be parsed: nested too deeply``). An unknown path is 404 and a method a
path does not take 405, each naming the path. Bad input is never 5xx other than 503.

Requests carrying the bearer token skip the Host and Origin checks; a browser authenticates
with a cookie session (``POST /session``). See :mod:`bowlrec.service.security` and
``docs/service.md``.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import sys
import threading
from collections.abc import AsyncIterator, Iterable
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Body, Depends, FastAPI, HTTPException, Query, Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException as StarletteHTTPException

from bowlrec.api import simulate_into
from bowlrec.archive import Archive, parse_ball_ref
from bowlrec.archive.group_commit import GroupCommitter
from bowlrec.errors import (
    BallRefError,
    BowlrecError,
    BusyError,
    ConflictError,
    DamagedError,
    InputError,
    JobConflictError,
    JobNotFoundError,
    NotFoundError,
    SamplesRequiredError,
    StorageError,
    UnavailableError,
)
from bowlrec.sinks.registry import sink_named
from bowlrec.spec.errors import MAX_ECHO, format_errors, printable
from bowlrec.versions import __version__
from bowlrec.web import assets
from bowlrec.web.api import ReplayCache, figures
from bowlrec.web.pages import pages
from bowlrec.web.seeds import JOB_EXAMPLE, SCENE_EXAMPLE
from bowlrec.web.viewer_assets import ViewerAssets

from .body_limit import DEFAULT_MAX_BODY_BYTES, BodyLimitMiddleware
from .jobs import JobManager
from .models import (
    BallAddRequest,
    BallAddResponse,
    BallEntryModel,
    BallRemoved,
    ErrorResponse,
    Health,
    JobStatus,
    RunList,
    RunRow,
    SessionClosed,
    SessionInfo,
    SessionRequest,
    SubmitResponse,
    parse_ball_spec,
    parse_scene_spec,
)
from .names import host_name
from .redact import Redactor
from .security import (
    COOKIE_NAME,
    DEFAULT_SESSION_TTL_S,
    SecurityMiddleware,
    SessionStore,
    bearer_matches,
    token_matches,
)
from .slots import RecordingSlots
from .writer import WriterProcess

__all__ = ["create_app"]

log = logging.getLogger(__name__)

#: file kinds of ``GET /runs/{id}/files/{kind}``: sinks of :mod:`bowlrec.sinks.registry` by
#: name, each with its media type
FILE_KINDS: dict[str, str] = {
    "hdf5": "application/x-hdf5",
    "mcap": "application/octet-stream",
    "rrd": "application/octet-stream",
    "csv": "text/csv",
}
FileKind = Literal["hdf5", "mcap", "rrd", "csv"]
#: file kinds that replay samples: a summary-only run is re-recorded from its scene for them
REPLAY_KINDS = frozenset({"mcap", "rrd"})

#: the largest ``limit`` of ``GET /runs``: SQLite's largest integer
MAX_LIST_LIMIT = 2**63 - 1

#: the HTTP status of each category of :class:`~bowlrec.errors.BowlrecError` (the first
#: category an error belongs to); a BowlrecError of none is 500
STATUS_CODES: dict[type[BowlrecError], int] = {
    InputError: 422,
    NotFoundError: 404,
    ConflictError: 409,
    DamagedError: 409,
    BusyError: 503,
    StorageError: 507,
    UnavailableError: 501,
}

_ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorResponse} for code in sorted({400, 401, 403, 413, *STATUS_CODES.values()})
}


def status_for(err: BowlrecError) -> int:
    """The HTTP status of ``err``'s category (:data:`STATUS_CODES`; 500 for none)."""
    return next((code for kind, code in STATUS_CODES.items() if isinstance(err, kind)), 500)


class _State:
    """What the endpoints and the pages share: the archive, the jobs, per-file generation locks,
    the sign-in check and the status of an error (the pages' :class:`bowlrec.web.pages.Host`).
    """

    def __init__(
        self,
        archive: Archive,
        jobs: JobManager,
        token: str | None,
        session_ttl_s: float = DEFAULT_SESSION_TTL_S,
        writer: WriterProcess | None = None,
    ) -> None:

        self.archive = archive
        self.jobs = jobs
        #: where the committer's groups are sealed and registered (None: its own thread)
        self.writer = writer
        #: seals the summary-only runs of concurrent POST /runs requests together
        self.commits = GroupCommitter(archive, commit=writer)
        self.token = token
        self.sessions = SessionStore(session_ttl_s)
        #: server paths out of error details
        self.redact = Redactor(archive.root)
        self.cache_dir = archive.root / "cache"
        #: recorded simulations at once: each may hold up to 2,000,000 samples (about 0.75 GB,
        #: benchmarks/results/hardening.md), so the server's memory is bounded by the core count
        self.recordings = RecordingSlots(os.cpu_count() or 1)
        #: runs with samples for figures and replay files (summary-only ones re-recorded)
        self.replays = ReplayCache(archive)
        #: the rerun web viewer's files, served at /viewer/
        self.viewer = ViewerAssets()
        self._file_locks: dict[Path, threading.Lock] = {}
        self._mutex = threading.Lock()

    def file_lock(self, path: Path) -> threading.Lock:
        with self._mutex:
            return self._file_locks.setdefault(path, threading.Lock())

    def signed_in(self, request: Request) -> bool:
        """The one sign-in check of the API's routes and the pages: True on a server without a
        token, for the bearer token, or for the cookie of an open session."""
        if self.token is None:
            return True
        if bearer_matches(request.headers.get("authorization"), self.token):
            return True
        return self.sessions.valid(request.cookies.get(COOKIE_NAME))

    @staticmethod
    def status_for(err: BowlrecError) -> int:
        """The HTTP status of ``err`` (:func:`status_for`)."""
        return status_for(err)


async def _state(request: Request) -> _State:
    """The app's shared state (async: a dependency that does not block runs on the event loop
    instead of taking a worker thread, as a sync one would)."""
    state: _State = request.app.state.bowlrec
    return state


_bearer = HTTPBearer(auto_error=False, description="The server's token (serve --token-env).")


async def _check_token(
    request: Request,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
) -> None:
    """The bearer token or a valid session cookie (``POST /session``): 401 unless
    :meth:`_State.signed_in`."""
    if (await _state(request)).signed_in(request):
        return
    raise HTTPException(
        401,
        "missing or wrong bearer token (send 'Authorization: Bearer <token>', or open a "
        "cookie session with POST /session)",
        headers={"WWW-Authenticate": "Bearer"},
    )


StateDep = Annotated[_State, Depends(_state)]


# -- runs ----------------------------------------------------------------------------------------

runs = APIRouter(prefix="/runs", tags=["runs"], responses=_ERRORS)


@runs.post("", response_model=SubmitResponse, status_code=201)
async def submit_scene(
    state: StateDep,
    response: Response,
    scene: Annotated[dict[str, Any], Body(openapi_examples=SCENE_EXAMPLE)],
) -> SubmitResponse:
    """Simulate a scene (physical, or bowler-language with ``"format": "bowler"``) and archive
    it. Synchronous; idempotent: the same scene gives the same run ID, and a scene already
    archived returns 200 with ``added: false`` (201 when it was added). ``ball`` may be a
    library reference ``"name"`` or ``"name@version"``. The response comes once the run is
    sealed and indexed; summary-only runs of concurrent requests are sealed together in one
    segment (group commit)."""
    # the blocking work in one worker thread; the response is serialized on the event loop
    # (a sync endpoint would hand its serialization to a worker thread as well)
    return await run_in_threadpool(_submit, state, response, scene)


def _submit(state: _State, response: Response, scene: dict[str, Any]) -> SubmitResponse:
    """POST /runs's work: parse, simulate and archive (blocking)."""
    parsed = parse_scene_spec(scene, state.archive.balls)
    recorded = parsed.scene.options.record != "summary"
    with state.recordings.slot() if recorded else contextlib.nullcontext():
        result = simulate_into(
            state.archive, parsed.scene, ball_ref=parsed.ball_ref, group=state.commits
        )
    if result.trajectory is None:  # pragma: no cover - simulate always returns it
        raise HTTPException(500, "the archive returned no trajectory")
    name = parsed.scene.name
    if not result.added:
        response.status_code = 200
        # the name is not part of the content ID: the archived run keeps the name it was
        # first stored under
        stored = state.archive.rows([result.run_id]).get(result.run_id)
        name = stored["name"] if stored is not None else name
    return SubmitResponse(
        run_id=result.run_id,
        added=result.added,
        name=name,
        ball_ref=parsed.ball_ref,
        summary=result.trajectory.summary,
    )


@runs.get("", response_model=RunList)
def list_runs(
    state: StateDep,
    ball: Annotated[str | None, Query(description="Library ball NAME or NAME@VERSION.")] = None,
    pattern: Annotated[str | None, Query(description="Lane pattern (friction kind).")] = None,
    outcome: Annotated[str | None, Query(description="pins, gutter, stopped, ...")] = None,
    name: Annotated[str | None, Query(description="Scene name.")] = None,
    where: Annotated[
        list[str] | None,
        Query(description="Condition on an index column, repeatable: hook_m>=0.1, speed_mps<8."),
    ] = None,
    order_by: Annotated[
        str, Query(description="Index column to sort by ('-' prefix: descending).")
    ] = "created_at",
    limit: Annotated[
        int | None, Query(ge=0, le=MAX_LIST_LIMIT, description="At most this many rows.")
    ] = None,
) -> RunList:
    """Index rows of the matching runs (reads only the index)."""
    rows = state.archive.list_runs(
        ball=ball,
        pattern=pattern,
        outcome=outcome,
        name=name,
        where=where or (),
        order_by=order_by,
        limit=limit,
    )
    return RunList(count=len(rows), runs=[RunRow(**r) for r in rows])


@runs.get("/{run_id}", response_model=RunRow)
def get_run(state: StateDep, run_id: str) -> RunRow:
    """The run's index row (summary metrics, ball, pattern, provenance); ``run_id`` may be a
    unique prefix of 4+ characters."""
    return RunRow(**state.archive.row(state.archive.resolve_id(run_id)))


@runs.get("/{run_id}/spec", response_model=dict[str, Any])
def get_spec(state: StateDep, run_id: str) -> dict[str, Any]:
    """The scene as archived (physical scene JSON; POSTing it back gives the same run ID)."""
    rid = state.archive.resolve_id(run_id)
    spec: dict[str, Any] = state.archive.load(rid).scene.model_dump(mode="json")
    return spec


def _cached_file(state: _State, rid: str, kind: str) -> Path:
    """The run written by sink ``kind`` (a one-run HDF5 file, a CSV, an MCAP or an RRD),
    generated once into ``ARCHIVE/cache/<kind>/`` from the run's checked bytes (the writers
    rename a complete file into place, so readers never see a partial one). MCAP and RRD
    replay samples: a summary-only run is re-recorded for them (:class:`ReplayCache`)."""
    sink = sink_named(kind)
    path = state.cache_dir / kind / rid[:2] / f"{rid}{sink.suffix}"
    with state.file_lock(path):
        if path.exists():
            return path
        run = state.replays.run(rid) if kind in REPLAY_KINDS else state.archive.run_data(rid)
        try:
            return sink.write(run, path)
        except SamplesRequiredError as err:
            raise SamplesRequiredError(f"run {rid} cannot be replayed: {err}") from None


@runs.get(
    "/{run_id}/files/{kind}",
    response_class=FileResponse,
    responses={200: {"content": {"application/octet-stream": {}, "application/x-hdf5": {}}}},
)
def get_file(state: StateDep, run_id: str, kind: FileKind) -> FileResponse:
    """The run as a self-contained one-run HDF5 file (``hdf5``, format ``bowlrec-run``), its
    samples as CSV (``csv``; the summary row for a summary-only run), or its replay as MCAP
    (``mcap``, Foxglove) or a rerun recording (``rrd``), generated on first request and cached
    in the archive. A summary-only run is re-recorded from its stored scene for MCAP and RRD
    (deterministic; checked against the stored summary, 409 if it differs). 409 for a run
    found damaged, 501 when the format's optional libraries are not installed."""
    rid = state.archive.resolve_id(run_id)
    path = _cached_file(state, rid, kind)
    return FileResponse(path, media_type=FILE_KINDS[kind], filename=path.name)


@runs.get(
    "/{run_id}/recording.rrd",
    response_class=FileResponse,
    responses={200: {"content": {"application/octet-stream": {}}}},
)
def get_recording(state: StateDep, run_id: str) -> FileResponse:
    """The run's rerun recording, as ``files/rrd``, at a URL ending in ``.rrd``: the rerun
    web viewer opens a ``?url=`` only by its suffix (the web page's viewer plays this)."""
    rid = state.archive.resolve_id(run_id)
    path = _cached_file(state, rid, "rrd")
    return FileResponse(path, media_type=FILE_KINDS["rrd"], filename=path.name)


# -- balls ---------------------------------------------------------------------------------------

balls = APIRouter(prefix="/balls", tags=["balls"], responses=_ERRORS)


def _entry(entry: Any) -> BallEntryModel:
    d = entry.to_json_dict()
    return BallEntryModel(ref=entry.ref, sha=entry.sha, **d)


@balls.get("", response_model=list[BallEntryModel])
def list_balls(
    state: StateDep,
    name: Annotated[str | None, Query(description="Only this name.")] = None,
    all_versions: Annotated[bool, Query(description="Every version, not only the latest.")] = False,
) -> list[BallEntryModel]:
    """Library balls sorted by name (latest version of each unless ``all_versions``)."""
    return [_entry(e) for e in state.archive.balls.list(name, all_versions=all_versions)]


@balls.get("/export", response_model=dict[str, Any])
def export_balls(state: StateDep) -> dict[str, Any]:
    """Every version of every ball as a ``bowlrec-ball-library`` document
    (``bowlrec balls import`` or ``POST /balls/import`` read it)."""
    return state.archive.balls.export_json()


@balls.post("/import", response_model=list[BallAddResponse])
def import_balls(state: StateDep, document: Annotated[dict[str, Any], Body()]) -> Any:
    """Add every spec of an exported library document (specs already present are skipped)."""
    pairs = state.archive.balls.import_json(document)
    return [BallAddResponse(added=added, entry=_entry(e)) for e, added in pairs]


@balls.get("/{ref}", response_model=BallEntryModel)
def get_ball(state: StateDep, ref: str) -> BallEntryModel:
    """One entry: ``name`` (latest version) or ``name@version``."""
    return _entry(state.archive.balls.get(ref))


@balls.post("", response_model=BallAddResponse, status_code=201)
def add_ball(state: StateDep, body: BallAddRequest, response: Response) -> BallAddResponse:
    """Store a spec under a name: 201 with a new version, or 200 with ``added: false`` when the
    latest version has this exact spec."""
    entry, added = state.archive.balls.add(body.name, parse_ball_spec(body.spec), body.note)
    if not added:
        response.status_code = 200
    return BallAddResponse(added=added, entry=_entry(entry))


@balls.delete("/{ref}", response_model=BallRemoved)
def remove_ball(state: StateDep, ref: str) -> BallRemoved:
    """Delete one version, ``name@version`` (runs that used it keep their copy of the spec)."""

    name, version = parse_ball_ref(ref)
    if version is None:
        raise BallRefError(f"give the version to delete: {ref}@VERSION")
    state.archive.balls.remove(name, version)
    return BallRemoved(removed=f"{name}@{version}")


# -- jobs ----------------------------------------------------------------------------------------

jobs = APIRouter(prefix="/jobs", tags=["jobs"], responses=_ERRORS)


@jobs.post("", response_model=JobStatus, status_code=202)
def submit_job(
    state: StateDep, job: Annotated[dict[str, Any], Body(openapi_examples=JOB_EXAMPLE)]
) -> JobStatus:
    """Queue a batch job (a ``bowlrec-job`` spec: base scene + sweeps, see
    ``schemas/job.schema.json``) or ``{"name": ..., "scenes": [...]}`` (explicit scenes, each
    keeping its own options); poll ``GET /jobs/{job_id}``. A job invalid as a whole gets 422; a
    run invalid only in combination becomes a failure row. Scenes must be inline."""
    return state.jobs.submit(job)


@jobs.get("", response_model=list[JobStatus])
def list_jobs(state: StateDep) -> list[Any]:
    """Every job of this archive, newest first: the service's and the command line's
    (``bowlrec batch`` into this archive; ``source`` says which)."""
    from bowlrec.web.jobs import all_jobs

    return all_jobs(state).list()


@jobs.get("/{job_id}", response_model=JobStatus)
def get_job(state: StateDep, job_id: str) -> Any:
    """Status and progress (done/failed/skipped of total), failures and the run IDs, of a
    service job or a command-line one."""
    from bowlrec.web.jobs import all_jobs

    return all_jobs(state).get(job_id)


def _own(state: _State, job_id: str, action: str) -> None:
    """JobConflictError (409) for a command-line job: its batch runs in its own process."""
    from bowlrec.web.jobs import all_jobs

    try:
        state.jobs.get(job_id, with_runs=False)
    except JobNotFoundError:
        if all_jobs(state).recorded.get(job_id, with_runs=False) is not None:
            raise JobConflictError(
                f"job {job_id} was run from the command line (bowlrec batch) in its own "
                f"process: the service cannot {action} it"
            ) from None
        raise


@jobs.post("/{job_id}/cancel", response_model=JobStatus, status_code=202)
def cancel_job(state: StateDep, job_id: str) -> JobStatus:
    """Stop a queued or running job after the scene in progress (finished runs stay); 409 for a
    command-line job."""
    _own(state, job_id, "cancel")
    return state.jobs.cancel(job_id)


@jobs.post("/{job_id}/resume", response_model=JobStatus, status_code=202)
def resume_job(state: StateDep, job_id: str) -> JobStatus:
    """Queue an interrupted, cancelled or failed job again; archived runs are skipped; 409
    for a command-line job (rerun its batch command instead)."""
    _own(state, job_id, "resume")
    return state.jobs.resume(job_id)


# -- cookie sessions -----------------------------------------------------------------------------

sessions = APIRouter(prefix="/session", tags=["service"], responses=_ERRORS)


def _secure(request: Request) -> bool:
    return request.url.scheme == "https"


@sessions.post("", response_model=SessionInfo)
def open_session(
    state: StateDep,
    request: Request,
    response: Response,
    body: Annotated[SessionRequest | None, Body()] = None,
) -> SessionInfo:
    """Open a cookie session with the token, sent as ``Authorization: Bearer <token>`` or in
    the body ``{"token": "..."}``: the answer sets the ``bowlrec_session`` cookie (HttpOnly,
    SameSite=Strict, Path=/, Secure over https), which then authenticates requests like the
    bearer header (for what a page cannot add a header to: iframes, images, download links,
    EventSource). A server without a token needs no session: ``auth`` is false and no cookie
    is set. 401 for a missing or wrong token."""
    if state.token is None:
        return SessionInfo(auth=False, expires_at=None)
    given = body.token if body is not None else None
    if not (
        bearer_matches(request.headers.get("authorization"), state.token)
        or (given is not None and token_matches(given, state.token))
    ):
        raise HTTPException(
            401,
            "missing or wrong token (send 'Authorization: Bearer <token>' or {\"token\": ...})",
            headers={"WWW-Authenticate": "Bearer"},
        )
    state.sessions.close(request.cookies.get(COOKIE_NAME))  # a new ID each time
    session_id, expires = state.sessions.open()
    response.set_cookie(
        COOKIE_NAME,
        session_id,
        max_age=max(1, math.ceil(state.sessions.ttl_s)),
        path="/",
        secure=_secure(request),
        httponly=True,
        samesite="strict",
    )
    when = datetime.fromtimestamp(expires, UTC).isoformat(timespec="seconds")
    return SessionInfo(auth=True, expires_at=when)


@sessions.delete("", response_model=SessionClosed, dependencies=[Depends(_check_token)])
def close_session(state: StateDep, request: Request, response: Response) -> SessionClosed:
    """Close the session of the request's cookie and clear the cookie. On a server with a
    token the request needs the session's cookie (valid) or the bearer token (401
    otherwise)."""
    closed = state.sessions.close(request.cookies.get(COOKIE_NAME))
    response.delete_cookie(
        COOKIE_NAME, path="/", secure=_secure(request), httponly=True, samesite="strict"
    )
    return SessionClosed(closed=closed)


#: Pydantic's error types for a value that is not a mapping (the body as a whole)
_NOT_AN_OBJECT = {"dict_type", "model_type", "model_attributes_type"}
#: what a request part is called in an error line
_PLACES = {"query": "query parameter", "path": "path parameter", "header": "header"}


def _json_kind(value: Any) -> str:
    """What a parsed JSON value is, for ``must be a JSON object (got ...)``."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, int | float):
        try:
            text = repr(value)
        except ValueError:  # an integer too long to convert
            return "a number too long to show"
        return f"the number {text}" if len(text) <= MAX_ECHO else f"a number of {len(text)} digits"
    if isinstance(value, str):
        return "a string"
    return type(value).__name__


def _json_position(doc: Any, pos: Any) -> str:
    """`` at line L column C`` of character ``pos`` in the text ``doc`` (as
    :class:`json.JSONDecodeError` counts them), or nothing when either is unknown."""
    if isinstance(doc, bytes):
        doc = doc.decode("utf-8", "replace")
    if not isinstance(doc, str) or not isinstance(pos, int) or not 0 <= pos <= len(doc):
        return ""
    line = doc.count("\n", 0, pos) + 1
    column = pos - doc.rfind("\n", 0, pos)
    return f" at line {line} column {column}"


def _body_error(e: dict[str, Any], doc: Any, content_type: str | None) -> str | None:
    """The message for an error about the body as a whole, or None for a field's error."""
    kind, rest = e["type"], tuple(e.get("loc") or ())[1:]
    if kind == "json_invalid":  # the location is a character position, not a field
        reason = str((e.get("ctx") or {}).get("error") or "cannot be parsed")
        where = _json_position(doc, rest[0] if rest else None)
        return f"not valid JSON{where}: {reason}"
    if rest:
        return None
    if kind == "missing":
        return "empty (send a JSON object with the header Content-Type: application/json)"
    value = e.get("input")
    if isinstance(value, bytes):  # the body was not read as JSON: its Content-Type says so
        if not content_type:
            return "sent without a Content-Type header (send Content-Type: application/json)"
        shown = printable(content_type, MAX_ECHO)
        return f"Content-Type '{shown}' is not JSON (send Content-Type: application/json)"
    if kind in _NOT_AN_OBJECT:
        return f"must be a JSON object (got {_json_kind(value)})"
    return None


def request_error_text(err: RequestValidationError, content_type: str | None = None) -> str:
    """One ``where: message`` line per error of a request FastAPI could not parse: ``request
    body`` for the body as a whole (not JSON -- with the line and column --, not an object,
    missing, or sent without a JSON ``Content-Type``), the field's path for a field of the
    body (``name``, ``spec.mass_kg``), ``query parameter limit``, ``path parameter kind``.
    ``content_type``: the request's ``Content-Type`` header."""

    details = []
    for e in err.errors():
        part, *rest = tuple(e.get("loc") or ("request",))
        if part == "body":
            message = _body_error(dict(e), getattr(err, "body", None), content_type)
            if message is not None:
                details.append(
                    {**e, "loc": ("request body",), "msg": message, "type": "invalid_spec"}
                )
                continue
            loc: tuple[Any, ...] = tuple(rest)
        elif part in _PLACES and rest:
            loc = (f"{_PLACES[part]} {rest[0]}", *rest[1:])
        else:
            loc = (str(part), *rest)
        details.append({**e, "loc": loc or ("request body",)})
    return format_errors(details)


#: the detail FastAPI gives a body it could not read (other than invalid JSON)
_UNPARSED_BODY = "There was an error parsing the body"


def echoes_request_path(err: StarletteHTTPException) -> bool:
    """Whether :func:`http_error_text` answers ``err`` with a line that names only the
    request's own URL path (an unknown path, a method the path does not take): a path the
    client sent, which is not redacted as a server path would be."""
    return (err.status_code, err.detail) in ((404, "Not Found"), (405, "Method Not Allowed"))


def http_error_text(request: Request, err: StarletteHTTPException) -> str:
    """The one-line detail of an HTTP error: the service's own message, or for what the
    framework raises (an unknown path, a method the path does not take, a body that could
    not be read) a line that names the path or the body and says what to do."""
    detail = err.detail if isinstance(err.detail, str) else str(err.detail)
    path = printable(request.url.path, MAX_ECHO)
    if err.status_code == 404 and detail == "Not Found":
        return f"no such path: {path} (the API is described at /docs)"
    if err.status_code == 405 and detail == "Method Not Allowed":
        return f"method {request.method} is not allowed on {path} (see /docs)"
    if err.status_code == 400 and detail == _UNPARSED_BODY:
        cause = err.__cause__
        if isinstance(cause, RecursionError):
            return "request body: cannot be parsed: nested too deeply"
        if isinstance(cause, UnicodeDecodeError):
            return f"request body: cannot be parsed: not UTF-8 (byte {cause.start})"
        if isinstance(cause, ValueError) and "integer string conversion" in str(cause):
            digits = sys.get_int_max_str_digits()
            return f"request body: cannot be parsed: an integer has more than {digits} digits"
        return "request body: cannot be parsed"
    return detail


# -- the app -------------------------------------------------------------------------------------


def _warm_up() -> None:
    """Load the compiled kernels a request and a job run in this process use (numba's on-disk
    cache; compiled when missing or stale) before the first request: the ``service`` group of
    :func:`bowlrec.core.warm.warm_up`."""
    from bowlrec.core.warm import warm_up

    warm_up("service")


def create_app(
    archive_dir: str | os.PathLike[str],
    token: str | None = None,
    *,
    warm_up: bool = True,
    job_workers: int = 0,
    scheduler: str | None = None,
    max_body_bytes: int | None = DEFAULT_MAX_BODY_BYTES,
    allowed_hosts: Iterable[str] = (),
    session_ttl_s: float = DEFAULT_SESSION_TTL_S,
    writer_process: bool = False,
) -> FastAPI:
    """The service for the archive at ``archive_dir`` (created if missing).

    Raises :class:`~bowlrec.service.jobs.JobsLockedError` when another live server uses the
    archive. ``token``: when given, every request except ``/health``, the docs, the static
    and viewer files and ``POST /session`` needs ``Authorization: Bearer <token>`` or the
    cookie of a session opened with ``POST /session`` (401 otherwise). ``warm_up`` loads the
    kernels at start-up so the first submission is not slower than the rest. Jobs simulate in
    the server process (``job_workers`` 0), a local pool of ``job_workers`` processes, or on
    the dask.distributed cluster at ``scheduler``.

    ``max_body_bytes``: request bodies longer than this get 413 (None: no limit; default 32
    MiB). ``allowed_hosts``: ``Host`` names accepted besides the loopback ones (requests
    without the bearer token naming another host get 400). ``session_ttl_s``: the lifetime of
    a cookie session. Raises ValueError for an allowed host that is not a host name.
    ``writer_process``: the group commits of ``POST /runs`` are sealed and registered in a
    process of their own (:mod:`bowlrec.service.writer`; ``bowlrec serve`` does this), else in
    a thread of the server process.
    """

    hosts = list(allowed_hosts)
    for entry in hosts:
        if host_name(entry) is None:
            raise ValueError(f"not a host name: {entry!r}")
    if max_body_bytes is not None and max_body_bytes < 0:
        raise ValueError("max_body_bytes must be >= 0 (or None: no limit)")
    archive = Archive(archive_dir)
    state = _State(
        archive,
        JobManager(archive, workers=job_workers, scheduler=scheduler),
        token or None,
        session_ttl_s,
        WriterProcess(archive.directory) if writer_process else None,
    )
    state.jobs.open()  # fails now (JobsLockedError) if another server runs this archive's jobs

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        state.jobs.start()
        if state.writer is not None:
            state.writer.start()
        state.commits.start()
        if warm_up:
            assets.prepare_viewer_in_background(state.viewer)
        if warm_up:
            await run_in_threadpool(_warm_up)
        try:
            yield
        finally:
            await run_in_threadpool(state.commits.close)
            if state.writer is not None:
                await run_in_threadpool(state.writer.close)
            await run_in_threadpool(state.jobs.stop)

    app = FastAPI(
        title="bowlrec",
        version=__version__,
        summary="Bowling-ball motion simulator and trajectory archive",
        description=__doc__,
        lifespan=lifespan,
        docs_url=None,  # /docs and /redoc: bowlrec.web.assets, from local files (no CDN)
        redoc_url=None,
    )
    app.state.bowlrec = state
    secured = [Depends(_check_token)]
    app.include_router(figures, dependencies=secured, responses=_ERRORS)
    for router in (runs, balls, jobs):
        app.include_router(router, dependencies=secured)
    app.include_router(sessions)
    app.include_router(pages)
    assets.mount(app)
    if max_body_bytes is not None:
        app.add_middleware(BodyLimitMiddleware, max_bytes=max_body_bytes)
    # added last: the outermost layer, before the body is read
    app.add_middleware(SecurityMiddleware, token=state.token, allowed_hosts=hosts)

    @app.get("/health", response_model=Health, tags=["service"])
    def health() -> Health:
        """Liveness and the run count; never needs the token (the Host check applies)."""
        return Health(version=__version__, runs=len(archive), auth=state.token is not None)

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, err: StarletteHTTPException) -> Response:
        if err.status_code in (204, 304):  # pragma: no cover - the service raises none
            return Response(status_code=err.status_code, headers=err.headers)
        detail = http_error_text(request, err)
        if not echoes_request_path(err):  # those name only the client's own URL path
            detail = state.redact(detail)
        return JSONResponse({"detail": detail}, status_code=err.status_code, headers=err.headers)

    @app.exception_handler(RequestValidationError)
    async def _malformed(request: Request, err: RequestValidationError) -> JSONResponse:
        # a body that is not a JSON object, or a parameter of the wrong type: the same
        # "field: message" lines as an invalid spec, never FastAPI's list
        text = request_error_text(err, request.headers.get("content-type"))
        return JSONResponse({"detail": state.redact(text)}, status_code=422)

    @app.exception_handler(BowlrecError)
    async def _bowlrec_error(request: Request, err: BowlrecError) -> JSONResponse:
        # the one place an error of the hierarchy becomes a status: its category's
        status = status_for(err)
        if status == 500:  # pragma: no cover - every error bowlrec raises has a category
            raise err  # answered as an internal error, and logged
        headers = {"Retry-After": "1"} if isinstance(err, BusyError) else None
        return JSONResponse({"detail": state.redact(str(err))}, status_code=status, headers=headers)

    @app.exception_handler(Exception)
    async def _internal(request: Request, err: Exception) -> JSONResponse:
        # logged (with the traceback) by the server; the client gets no server detail
        return JSONResponse(
            {"detail": "internal server error (the server's log has the details)"},
            status_code=500,
        )

    return app

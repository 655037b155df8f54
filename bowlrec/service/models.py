"""Request and response bodies of the HTTP service (Pydantic models, shown in ``/docs``).

Scene and ball specs are taken as plain JSON objects and validated by the service itself (so an
invalid spec is answered with one field-named message, see :mod:`bowlrec.service.app`); the
models here describe everything else.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from bowlrec.archive.ball_import import checked_ball
from bowlrec.core.trajectory import Summary
from bowlrec.errors import SpecError
from bowlrec.scene_input import ParsedScene, parse_scene

if TYPE_CHECKING:
    from bowlrec.archive import BallLibrary

__all__ = [
    "BallAddRequest",
    "BallAddResponse",
    "BallEntryModel",
    "BallRemoved",
    "ErrorResponse",
    "Health",
    "JobFailure",
    "JobStatus",
    "JobStatusName",
    "RunList",
    "RunRow",
    "SessionClosed",
    "SessionInfo",
    "SessionRequest",
    "StoredJobStatus",
    "SubmitResponse",
    "ParsedScene",
    "SpecError",
    "SummaryModel",
    "parse_ball_spec",
    "parse_scene_spec",
]

#: the statuses a job record stores
StoredJobStatus = Literal["queued", "running", "done", "failed", "interrupted", "cancelled"]
#: the statuses the service reports: a stored one, or ``damaged`` (the job's record in the
#: archive cannot be read or is invalid; ``error`` says why)
JobStatusName = Literal[
    "queued", "running", "done", "failed", "interrupted", "cancelled", "damaged"
]


class ErrorResponse(BaseModel):
    """Every error the service raises itself: 400 (Host not allowed), 401, 403 (cross-site),
    404, 409, 413 (body too long), 422 (spec and filter errors), 501, 507."""

    detail: str = Field(
        description="What went wrong; for an invalid spec one 'field: message' "
        "line per error, e.g. 'ball.mass_kg: Input should be greater than 0'."
    )


class Health(BaseModel):
    """``GET /health`` (never needs the token; the Host check applies)."""

    status: Literal["ok"] = "ok"
    version: str = Field(description="bowlrec version of the server.")
    runs: int = Field(description="Runs in the archive's index.")
    auth: bool = Field(description="True when requests need a bearer token.")


#: The Table III quantities of one delivery (SI units): the solver's own ``Summary`` dataclass,
#: which pydantic validates and documents as it is (no second copy of its fields to keep in step).
SummaryModel = Summary


class SubmitResponse(BaseModel):
    """``POST /runs``: the run's content ID and summary (201 when added, 200 when it existed)."""

    run_id: str = Field(description="Content ID: the same scene always gives the same ID.")
    added: bool = Field(description="False when the run was already archived (nothing written).")
    name: str = Field(
        description="The run's name: the scene's, or for a run already archived (added: "
        "false) the name it was stored under (the name is not part of the content ID)."
    )
    ball_ref: str | None = Field(description="Library ball used (name@version), if any.")
    summary: SummaryModel


class RunRow(BaseModel):
    """One row of the archive index (``bowlrec.archive.index.INDEX_COLUMNS``)."""

    model_config = ConfigDict(extra="allow")

    run_id: str
    segment_id: str | None = Field(default=None, description="The segment holding the run.")
    row: int | None = Field(default=None, description="The run's row in its segment.")
    name: str | None = None
    created_at: str | None = None
    ball_name: str | None = None
    ball_version: int | None = None
    ball_sha: str | None = None
    pattern: str | None = None
    outcome: str | None = None
    pinfall: int | None = Field(
        default=None, description="Pins down after the ball (runs with pin action)."
    )
    leave: str | None = Field(
        default=None, description="The pins left standing in bowlers' names (runs with pins)."
    )
    slide_m: float | None = None
    hook_m: float | None = None
    pocket_deg: float | None = None
    time_s: float | None = None
    x_end_m: float | None = None
    y_end_m: float | None = None
    speed_end_mps: float | None = None
    rev_rate_end_rpm: float | None = None
    speed_mps: float | None = None
    rev_rate_rpm: float | None = None
    mass_kg: float | None = None
    n_samples: int | None = None
    n_steps: int | None = None
    n_rhs: int | None = None
    n_events: int | None = None
    rtol: float | None = None
    record: str | None = None
    solver: str | None = None
    wall_time_s: float | None = None
    physics_version: str | None = None
    bowlrec_version: str | None = None
    path: str | None = Field(
        default=None, description="Segment file holding the run, relative to the archive."
    )


class RunList(BaseModel):
    """``GET /runs``: the matching index rows."""

    count: int
    runs: list[RunRow]


class BallEntryModel(BaseModel):
    """One version of a named library ball."""

    name: str
    version: int
    ref: str = Field(description="name@version, as runs reference it.")
    sha: str = Field(description="SHA-256 of the spec's canonical JSON.")
    added_at: str
    note: str = ""
    spec: dict[str, Any] = Field(
        description="A physical ball (bowlrec.spec.Ball) or a spec sheet (has weight_lb)."
    )


class BallAddRequest(BaseModel):
    """``POST /balls``: store ``spec`` under ``name`` (a changed spec becomes a new version)."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(description="1-100 letters, digits, spaces and . _ + -")
    spec: dict[str, Any] = Field(
        description="A physical ball (mass_kg, radius_m, rg_m, ...) or a bowler spec sheet "
        "(weight_lb, rg_in, differential_in, ...)."
    )
    note: str = ""


class BallAddResponse(BaseModel):
    """The stored entry; ``added`` is False when the latest version already had this spec."""

    added: bool
    entry: BallEntryModel


class BallRemoved(BaseModel):
    """``DELETE /balls/{name}@{version}``."""

    removed: str


class JobFailure(BaseModel):
    """A scene of a job that could not be simulated."""

    index: int
    run_id: str | None = None
    error: str


class JobStatus(BaseModel):
    """A job's progress, counted in runs (one per scene of the expanded job).

    ``done``: runs now in the archive (simulated by this job or found archived already;
    ``skipped`` counts the latter); ``failed``: runs that could not be archived (an invalid
    combination, a solver error, or an outcome the batch engine treats as a failure: airborne,
    max_steps, stalled), listed in ``failures``.

    status: queued -> running -> done (every run attempted; failures are listed, the job is
    still done) | failed (the job itself broke, ``error``) | cancelled (``POST
    /jobs/{id}/cancel``) | interrupted (the server stopped while the job was queued or running;
    ``POST /jobs/{id}/resume`` continues it, skipping runs already archived). ``damaged``: the
    job's files in the archive (``jobs/<id>.json``, ``jobs/<id>.spec.json``) are missing,
    truncated or invalid; ``error`` says which and why, and the job can be neither cancelled
    nor resumed (409).
    """

    job_id: str
    name: str
    status: JobStatusName
    total: int
    done: int
    failed: int
    skipped: int
    created_at: str
    updated_at: str
    error: str | None = None
    resumable: bool = Field(description="True when POST /jobs/{id}/resume would continue it.")
    run_ids: list[str | None] | None = Field(
        default=None,
        description="Content ID of every run, in job order (null for a run invalid before "
        "simulation; GET /jobs/{id} only).",
    )
    failures: list[JobFailure] = Field(default_factory=list)
    source: str = Field(
        default="service",
        description="Who runs the job: 'service' (POST /jobs) or 'command line' (bowlrec "
        "batch into this archive, recorded in ARCHIVE/jobs/cli/; the service can neither "
        "cancel nor resume it).",
    )


# -- spec validation ------------------------------------------------------------------------------


def parse_scene_spec(data: Any, balls: BallLibrary | None = None) -> ParsedScene:
    """Validate a physical scene or, with ``"format": "bowler"``, a bowler-language scene
    (:func:`bowlrec.scene_input.parse_scene`: a string ``ball`` is a library reference
    resolved through ``balls``). Raises :class:`~bowlrec.errors.SceneInputError` (a
    :class:`~bowlrec.errors.SpecError`) with field-named lines."""

    return parse_scene(data, balls)


def parse_ball_spec(data: Any) -> Any:
    """A physical ball or a bowler spec sheet (``weight_lb``); :class:`SpecError` if invalid."""

    return checked_ball("spec", data)


# -- cookie sessions -----------------------------------------------------------------------------


class SessionRequest(BaseModel):
    """``POST /session`` body (optional when the bearer header carries the token)."""

    token: str = Field(max_length=4096, description="The server's token.")


class SessionInfo(BaseModel):
    """``POST /session``: the session opened (its cookie is set by the response)."""

    auth: bool = Field(description="False on a server without a token (no session needed).")
    expires_at: str | None = Field(description="When the session ends (UTC, ISO 8601).")


class SessionClosed(BaseModel):
    """``DELETE /session``."""

    closed: bool = Field(description="True when the request's cookie named an open session.")

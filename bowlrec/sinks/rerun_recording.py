"""A finished run as a rerun recording: an ``.rrd`` file or a live stream to a viewer.

Units and frames: everything is SI (m, s, N, N m, rpm for the rev rate; the /summary text gives
the hook in cm and the pocket angle in deg, as the CLI does) in the lane frame of
:mod:`bowlrec.sinks.common` (x from the foul line toward the pins, y from the right gutter
leftward, z up; the ball's geometric center at z = 0, the lane surface at z = -R). Time is the
``sim_time`` duration timeline (simulated seconds, stored as integer nanoseconds).

Entity tree (see :func:`log_run`)::

    /world                       ViewCoordinates RIGHT_HAND_Z_UP (static)
    /world/lane                  Boxes3D slab whose top face lies just below z = -R (static)
    /world/lane/friction         Boxes3D, one flat box per friction cell, colored by mu (static)
    /world/lane/lines            LineStrips3D: foul line and pin-deck line (static)
    /world/path                  LineStrips3D: contact track on the lane, one strip per phase run
    /world/ball                  Transform3D per sample (translation + quaternion xyzw, body->lane)
                                 + Ellipsoids3D wireframe sphere of radius R (static, body frame);
                                 with pins: the kernel's samples before the hand-off, then the
                                 pin engine's (the ball through the deck)
    /world/ball/markings         Points3D on the surface: pin, CG side, mass bias (body frame)
    /world/ball/pin_axis         Arrows3D along the low-RG principal axis (body frame)
    /world/rotation_axis         Arrows3D per sample from the center along omega/|omega| (lane)
    /plots/<series>              Scalars per sample (speed, rev_rate, slip_speed, mu, ...)
    /plots/torque_magnitude/...  |term| per sample of every recorded Eq. (6)/(7) term (N m)
    /plots/torque_components/<term>  x, y, z of that term (N m, lane frame)
    /events                      TextLog, one row per event at its time; with pins also the
                                 hand-off and the leave (at the time pin action ended)
    /summary, /scene             TextDocument (static): summary markdown, the scene as JSON

With pin action (``options.pins``; :mod:`bowlrec.sinks.pin_replay`)::

    /world/deck                  LineStrips3D: the deck's outline at the lane surface (static)
    /world/deck/spots            Points3D: the ten spots, labelled 1..10 (static)
    /world/deck/ball_path        LineStrips3D: the ball's path through the deck (static)
    /world/pins/<n>              Mesh3D of the pin (the revolved profile; static, pin frame: base
                                 centre at the origin, axis +z) moved by a Transform3D per engine
                                 sample (base centre + quaternion xyzw, pin->lane); pins 1..10
    /world/pins/<n>/label        Points3D labelled with the pin's number above its head (static)
    /pins                        TextDocument (static): the leave, pinfall, touched pins, exit board

The pins' samples are on the same ``sim_time`` timeline, at hand-off time + the engine's time;
a pin the engine retired into the pit keeps its last pose in play.

All per-sample data goes through ``send_columns``; rerun stores positions, quaternions and
vectors as float32, so they read back to about 1e-6 relative precision.
"""

from __future__ import annotations

import hashlib
import os
import socket
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import urlsplit

import numpy as np
import pyarrow as pa
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray
from rerun.chunk import RrdReader

from bowlrec.atomic_files import atomic_path
from bowlrec.core.codes import PHASE_NAMES, ROLLING
from bowlrec.errors import ViewerUnavailableError

from .common import friction_cells, markings_body, quaternion_xyzw, series_columns, summary_text
from .pin_replay import PinReplay, deck_outline, pin_mesh, pin_replay

if TYPE_CHECKING:
    from bowlrec.core.trajectory import Trajectory

    from .common import FrictionCell, RunData

__all__ = [
    "APPLICATION_ID",
    "DEFAULT_CONNECT_URL",
    "TIMELINE",
    "ViewerUnavailableError",
    "default_blueprint",
    "log_run",
    "read_rrd_positions",
    "read_rrd_series",
    "recording_id",
    "stream_run",
    "write_rrd",
]

APPLICATION_ID = "bowlrec"
#: the duration timeline all per-sample data is indexed by (simulated time)
TIMELINE = "sim_time"
#: where ``rerun`` (the viewer) listens by default
DEFAULT_CONNECT_URL = "rerun+http://127.0.0.1:9876/proxy"

#: how long the pre-flight check waits for a viewer to accept and answer (s)
_PROBE_TIMEOUT_S = 3.0
_H2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n"
_H2_EMPTY_SETTINGS = bytes([0, 0, 0, 4, 0, 0, 0, 0, 0])  # length 0, type SETTINGS, stream 0
_H2_SETTINGS = 4

Float = NDArray[np.float64]
Rgba = tuple[int, int, int, int]

_LANE_THICKNESS_M = 0.05
_CELL_THICKNESS_M = 0.001
_MAX_LABELLED_CELLS = 24
_OIL_RGBA: Rgba = (70, 130, 220, 235)  # lowest mu of the pattern
_DRY_RGBA: Rgba = (205, 160, 100, 235)  # highest mu of the pattern
_WOOD_RGBA: Rgba = (150, 115, 70, 255)
_BALL_RGBA: Rgba = (30, 45, 160, 255)
_SLIDING_RGBA: Rgba = (230, 60, 50, 255)
_ROLLING_RGBA: Rgba = (40, 170, 70, 255)
_AXIS_RGBA: Rgba = (255, 150, 0, 255)
_DECK_RGBA: Rgba = (60, 60, 60, 255)
_SPOT_RGBA: Rgba = (120, 120, 120, 255)
_DECK_PATH_RGBA: Rgba = (30, 45, 160, 255)
_PIN_LABEL_RGBA: Rgba = (200, 20, 20, 255)
_MARK_RGBA = {
    "pin": (220, 30, 30, 255),
    "cg": (250, 210, 0, 255),
    "mass_bias": (20, 200, 90, 255),
}
_MARK_LABELS = {"pin": "pin (low-RG axis)", "cg": "CG side", "mass_bias": "mass bias (high-RG)"}

#: series_columns name -> (entity under /plots, legend name)
_PLOTS = {
    "speed_mps": ("speed", "speed [m/s]"),
    "rev_rate_rpm": ("rev_rate", "rev rate [rpm]"),
    "slip_speed_mps": ("slip_speed", "slip speed [m/s]"),
    "mu": ("mu", "mu under the ball"),
    "normal_force_N": ("normal_force", "normal force [N]"),
    "friction_force_N": ("friction_force", "friction force [N]"),
    "energy_J": ("energy", "mechanical energy [J]"),
    "phase": ("phase", "phase (0 sliding, 1 rolling)"),
}

_EVENT_TEXT = {
    "slide_to_roll": "slide -> roll",
    "roll_to_slide": "roll -> slide",
    "zone": "friction zone crossed",
    "pins": "reached the pins",
    "gutter": "gutter",
    "stopped": "ball stopped",
    "airborne": "ball left the lane (airborne)",
    "max_time": "time limit reached",
    "slip_reversal": "slip reversal",
}
_EVENT_LEVEL = {
    "gutter": rr.TextLogLevel.WARN,
    "stopped": rr.TextLogLevel.WARN,
    "airborne": rr.TextLogLevel.WARN,
    "max_time": rr.TextLogLevel.WARN,
}


# --------------------------------------------------------------------------------------------
# public API


def recording_id(run: RunData) -> str:
    """The rerun recording id: the archive's run id, else ``<scene name>-<12 hex of the scene>``.

    The fallback is deterministic (a SHA-256 of the scene JSON), so re-logging the same scene
    into an open viewer updates one recording, while different scenes never merge.
    """
    if run.run_id:
        return run.run_id
    digest = hashlib.sha256(run.scene_json().encode()).hexdigest()[:12]
    return f"{run.name}-{digest}"


def default_blueprint(run: RunData) -> rrb.Blueprint:
    """The layout saved with the recording.

    Left: two 3D views of ``/world`` -- "Lane" (the whole lane seen from behind the foul line)
    and "Ball" (a close-up camera that tracks ``/world/ball``, for the markings and the rotation
    axis) -- above the event log and the summary/scene documents. Right: tabs of time-series
    views (motion, contact, energy and phase, and torques when the run recorded them).
    """
    close: rrb.Container | rrb.View = _ball_view(run)
    pins_view = pin_replay(run) is not None
    if pins_view:
        close = rrb.Tabs(_deck_view(run), close, active_tab=0)
    left = rrb.Vertical(
        rrb.Horizontal(_lane_view(run), close, column_shares=[3, 2]),
        rrb.Horizontal(
            rrb.TextLogView(name="Events", origin="/events"),
            rrb.Tabs(
                rrb.TextDocumentView(name="Summary", origin="/summary"),
                rrb.TextDocumentView(name="Scene", origin="/scene"),
                *([rrb.TextDocumentView(name="Pins", origin="/pins")] if pins_view else []),
            ),
        ),
        row_shares=[3, 1],
    )
    tabs: list[rrb.Container | rrb.View] = [
        _plot_column("Motion", ["speed", "rev_rate", "slip_speed"]),
        _plot_column("Contact", ["mu", "normal_force", "friction_force"]),
        _plot_column("Energy & phase", ["energy", "phase"]),
    ]
    if run.trajectory.torques_Nm:
        tabs.append(
            rrb.Vertical(
                rrb.TimeSeriesView(name="|tau terms| [N m]", origin="/plots/torque_magnitude/tau"),
                rrb.TimeSeriesView(
                    name="|I_k alpha terms| [N m]", origin="/plots/torque_magnitude/inertia"
                ),
                rrb.TimeSeriesView(name="term components [N m]", origin="/plots/torque_components"),
                name="Torques",
            )
        )
    right = rrb.Tabs(*tabs, active_tab=0)
    return rrb.Blueprint(rrb.Horizontal(left, right, column_shares=[3, 2]), collapse_panels=True)


def _lane_view(run: RunData) -> rrb.Spatial3DView:
    """The whole lane from 3 m behind the foul line, 1.5 m up, looking at the pins."""
    length, mid = float(run.plan.lane_length_m), 0.5 * float(run.plan.lane_width_m)
    eye = rrb.EyeControls3D(
        position=[-3.0, mid, 1.5], look_target=[length, mid, -float(run.plan.radius_m)]
    )
    return rrb.Spatial3DView(
        name="Lane", origin="/world", eye_controls=eye, line_grid=rrb.LineGrid3D(visible=False)
    )


def _ball_view(run: RunData) -> rrb.Spatial3DView:
    """A close-up that follows the ball (starting behind and left of its release point)."""
    x0, y0 = (float(v) for v in run.plan.position0_m[:2])
    eye = rrb.EyeControls3D(
        position=[x0 - 0.8, y0 + 0.5, 0.4], look_target=[x0, y0, 0.0], tracking_entity="/world/ball"
    )
    return rrb.Spatial3DView(
        name="Ball", origin="/world", eye_controls=eye, line_grid=rrb.LineGrid3D(visible=False)
    )


def _deck_view(run: RunData) -> rrb.Spatial3DView:
    """The pin deck from 2.5 m in front of the head pin, 1.2 m up (a run with pins)."""
    length, mid = float(run.plan.lane_length_m), 0.5 * float(run.plan.lane_width_m)
    eye = rrb.EyeControls3D(
        position=[length - 2.5, mid, 1.2],
        look_target=[length + 0.45, mid, -float(run.plan.radius_m)],
    )
    return rrb.Spatial3DView(
        name="Deck", origin="/world", eye_controls=eye, line_grid=rrb.LineGrid3D(visible=False)
    )


def _plot_column(name: str, entities: list[str]) -> rrb.Vertical:
    """A tab of stacked time-series views, one per ``/plots/<entity>``."""
    legend = {entity: label for entity, label in _PLOTS.values()}
    views = [rrb.TimeSeriesView(name=legend[e], origin=f"/plots/{e}") for e in entities]
    return rrb.Vertical(*views, name=name)


def log_run(rec: rr.RecordingStream, run: RunData) -> None:
    """Log the whole run to ``rec`` (see the module docstring for the entity tree and units).

    Static items (lane, oil cells, ball geometry, markings, path, documents) are logged with
    ``static=True``; every per-sample quantity is sent column-wise on the ``sim_time`` timeline,
    so this never changes ``rec``'s own time cursor.
    """
    run.require_samples("rerun recording")
    traj = run.trajectory
    radius = float(run.plan.radius_m)
    times = _time_column(traj.t_s)
    pins = pin_replay(run)
    rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    _log_lane(rec, run, radius)
    _log_path(rec, traj, radius)
    _log_ball(rec, run, radius, times, pins)
    _log_rotation_axis(rec, traj, radius, times, pins)
    _log_series(rec, traj, times)
    _log_torques(rec, traj, times)
    _log_events(rec, traj)
    if pins is not None:
        _log_pins(rec, run, pins, radius)
    _log_documents(rec, run)


def write_rrd(run: RunData, path: str | os.PathLike[str]) -> Path:
    """Write ``run`` with its default blueprint to the ``.rrd`` file ``path``; return the path.

    The file is written under a temporary name in the same directory (``.<name>.<hex>.part``,
    a dot-file left only by a killed writer), fsynced and moved into place once leaving
    the recording's ``with`` block has written the footer, so ``path`` is never half-written
    and an existing file is replaced only by a complete one. Missing parent directories are
    created. A summary-only run raises :class:`~bowlrec.sinks.SamplesRequiredError` and writes
    nothing.
    """
    run.require_samples("rerun recording")
    target = Path(path)
    with atomic_path(target) as tmp:
        tmp.unlink()  # rerun's file sink creates its file and refuses one that exists
        with rr.RecordingStream(APPLICATION_ID, recording_id=recording_id(run)) as rec:
            rec.save(tmp, default_blueprint=default_blueprint(run))
            rec.send_recording_name(run.name)
            log_run(rec, run)
        rec.disconnect()  # the footer is written; this closes the file sink
    return target


def stream_run(
    run: RunData,
    connect_url: str | None = None,
    spawn: bool = False,
    *,
    timeout_s: float = 60.0,
) -> None:
    """Stream ``run`` live to a viewer and return once the data is delivered.

    ``connect_url`` (e.g. ``"rerun+http://127.0.0.1:9876/proxy"``; default the local viewer at
    :data:`DEFAULT_CONNECT_URL`) names a running viewer or ``rerun --serve-grpc`` proxy. With
    ``spawn=True`` a new viewer is started instead, which needs a display (``DISPLAY`` or
    ``WAYLAND_DISPLAY``). Before anything is sent, :class:`ViewerUnavailableError` is raised
    when there is no display to spawn on, or when no gRPC server answers at the URL.

    ``timeout_s`` (s) bounds the flush of the logged data into the connection; the final
    disconnect then waits until the viewer has received everything. (rerun 0.41 has no time
    limit on that wait, so a viewer that freezes mid-transfer blocks it.)
    """
    run.require_samples("rerun live stream")
    if spawn and connect_url is not None:
        raise ValueError("pass either connect_url or spawn=True, not both")
    if spawn:
        _require_display()
    else:
        connect_url = connect_url or DEFAULT_CONNECT_URL
        _require_listener(connect_url)
    blueprint = default_blueprint(run)
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id(run))
    try:
        if spawn:
            rec.spawn(default_blueprint=blueprint)
        else:
            rec.connect_grpc(connect_url, default_blueprint=blueprint)
        rec.send_recording_name(run.name)
        log_run(rec, run)
        rec.flush(timeout_sec=timeout_s)
    finally:
        rec.disconnect()  # waits until the viewer has everything


def read_rrd_series(
    path: str | os.PathLike[str], entity: str, component: str, timeline: str = TIMELINE
) -> tuple[Float, Float]:
    """Temporal values of ``entity``'s ``component`` (e.g. ``"Transform3D:translation"``).

    Returns ``(t_s (n,), values (n, k))`` sorted by time, ``t_s`` in seconds of ``timeline``.
    Reads headless with :class:`rerun.chunk.RrdReader`; works on files without a footer
    (e.g. saved by a receiving viewer that was killed). Values come back as float64 from the
    stored float32/float64.
    """
    want = entity if entity.startswith("/") else "/" + entity
    t_parts: list[NDArray[np.int64]] = []
    v_parts: list[Float] = []
    for chunk in RrdReader(os.fspath(path)).stream():
        if chunk.entity_path != want or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if component not in batch.schema.names or timeline not in batch.schema.names:
            continue
        t_parts.append(batch.column(timeline).cast(pa.int64()).to_numpy())
        v_parts.append(_flatten_rows(batch.column(component), batch.num_rows))
    if not t_parts:
        raise KeyError(f"{os.fspath(path)}: no temporal {component!r} data for {want!r}")
    t_ns = np.concatenate(t_parts)
    values = np.concatenate(v_parts)
    order = np.argsort(t_ns, kind="stable")
    return t_ns[order] / 1e9, values[order]


def read_rrd_positions(path: str | os.PathLike[str]) -> tuple[Float, Float]:
    """The ball's logged positions: ``(t_s (n,), position_m (n, 3))`` (geometric center)."""
    return read_rrd_series(path, "/world/ball", "Transform3D:translation")


# --------------------------------------------------------------------------------------------
# streams and viewers


def _require_display() -> None:
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ViewerUnavailableError(
            "cannot spawn a rerun viewer: no display (neither DISPLAY nor WAYLAND_DISPLAY is "
            "set); save the run to an .rrd file instead (then `rerun run.rrd` where there is a "
            "display), or pass the URL of a running viewer (e.g. "
            f"{DEFAULT_CONNECT_URL})"
        )


def _require_listener(url: str) -> None:
    """Fail early and clearly unless a gRPC (HTTP/2) server answers at ``url``'s host:port.

    For ``rerun+http`` URLs an HTTP/2 connection preface is sent and the server's SETTINGS
    frame awaited (what any gRPC server sends first); other schemes (TLS) get a TCP check. This
    matters because rerun 0.41 waits without a time limit for a listener that accepts the
    connection but never answers.
    """
    parts = urlsplit(url)
    if parts.scheme not in ("rerun", "rerun+http", "rerun+https") or not parts.hostname:
        raise ValueError(
            f"connect URL {url!r} must look like {DEFAULT_CONNECT_URL!r} "
            "(scheme rerun://, rerun+http:// or rerun+https://, path /proxy)"
        )
    plain = parts.scheme == "rerun+http"
    port = parts.port or (80 if plain else 443)
    try:
        with socket.create_connection((parts.hostname, port), timeout=_PROBE_TIMEOUT_S) as sock:
            if plain:
                sock.settimeout(_PROBE_TIMEOUT_S)
                sock.sendall(_H2_PREFACE + _H2_EMPTY_SETTINGS)
                head = sock.recv(9)
                if len(head) < 4 or head[3] != _H2_SETTINGS:
                    raise ConnectionError("it does not speak gRPC (no HTTP/2 SETTINGS frame)")
    except OSError as exc:
        raise ViewerUnavailableError(
            f"no rerun viewer is listening at {url} ({exc}); start one with `rerun` "
            "(or `rerun --serve-grpc`), or save the run to an .rrd file instead"
        ) from exc


# --------------------------------------------------------------------------------------------
# logging pieces


def _time_column(t_s: Float) -> rr.TimeColumn:
    """``sim_time`` from seconds, rounded to whole nanoseconds (rerun would truncate floats)."""
    t_ns = np.round(np.asarray(t_s, dtype=np.float64) * 1e9).astype(np.int64)
    return rr.TimeColumn(TIMELINE, duration=t_ns.astype("timedelta64[ns]"))


def _log_lane(rec: rr.RecordingStream, run: RunData, radius: float) -> None:
    """The lane slab, the oil pattern (one flat box per friction cell) and the end lines."""
    length, width = float(run.plan.lane_length_m), float(run.plan.lane_width_m)
    top = -radius - _CELL_THICKNESS_M
    rec.log(
        "/world/lane",
        rr.Boxes3D(
            centers=[[length / 2, width / 2, top - _LANE_THICKNESS_M / 2]],
            half_sizes=[[length / 2, width / 2, _LANE_THICKNESS_M / 2]],
            colors=[_WOOD_RGBA],
            fill_mode="solid",
        ),
        static=True,
    )
    cells = friction_cells(run.plan)
    rec.log("/world/lane/friction", _friction_boxes(cells, radius), static=True)
    z = -radius + 0.5 * _CELL_THICKNESS_M
    rec.log(
        "/world/lane/lines",
        rr.LineStrips3D(
            [[[0.0, 0.0, z], [0.0, width, z]], [[length, 0.0, z], [length, width, z]]],
            colors=[(240, 240, 240, 255), (60, 60, 60, 255)],
            radii=0.005,
            labels=["foul line", "pins"],
        ),
        static=True,
    )


def _friction_boxes(cells: list[FrictionCell], radius: float) -> rr.Boxes3D:
    """Flat boxes whose top faces lie at the lane surface z = -R, colored from oil to dry."""
    x0 = np.array([c.x0_m for c in cells])
    x1 = np.array([c.x1_m for c in cells])
    y0 = np.array([c.y0_m for c in cells])
    y1 = np.array([c.y1_m for c in cells])
    mu = np.array([c.mu for c in cells])
    z = np.full(mu.size, -radius - 0.5 * _CELL_THICKNESS_M)
    centers = np.column_stack([(x0 + x1) / 2, (y0 + y1) / 2, z])
    half = np.column_stack([(x1 - x0) / 2, (y1 - y0) / 2, np.full(mu.size, _CELL_THICKNESS_M / 2)])
    return rr.Boxes3D(
        centers=centers,
        half_sizes=half,
        colors=_mu_colors(mu),
        fill_mode="solid",
        labels=[f"mu {m:.3f}" for m in mu],
        show_labels=len(cells) <= _MAX_LABELLED_CELLS,
    )


def _mu_colors(mu: Float) -> NDArray[np.uint8]:
    """RGBA per cell, linear from the oil color (lowest mu) to the dry color (highest mu)."""
    lo, hi = float(mu.min()), float(mu.max())
    frac = (mu - lo) / (hi - lo) if hi > lo else np.ones_like(mu)
    oil, dry = np.array(_OIL_RGBA, dtype=float), np.array(_DRY_RGBA, dtype=float)
    return np.asarray(np.round(oil + frac[:, None] * (dry - oil)), dtype=np.uint8)


def _log_path(rec: rr.RecordingStream, traj: Trajectory, radius: float) -> None:
    """The contact track on the lane (center projected to z = -R), one strip per phase run."""
    track = np.asarray(traj.position_m, dtype=np.float64).copy()
    track[:, 2] = -radius + 0.5 * _CELL_THICKNESS_M
    phase = np.asarray(traj.phase)
    starts = np.concatenate([[0], np.flatnonzero(np.diff(phase)) + 1])
    ends = np.concatenate([starts[1:] + 1, [phase.size]])  # overlap one sample: no gaps
    strips = [track[a:b] for a, b in zip(starts, ends, strict=True)]
    colors = [_ROLLING_RGBA if phase[a] == ROLLING else _SLIDING_RGBA for a in starts]
    labels = [PHASE_NAMES[int(phase[a])] for a in starts]
    rec.log(
        "/world/path",
        rr.LineStrips3D(strips, colors=colors, radii=0.006, labels=labels, show_labels=False),
        static=True,
    )


def _log_ball(
    rec: rr.RecordingStream,
    run: RunData,
    radius: float,
    times: rr.TimeColumn,
    pins: PinReplay | None = None,
) -> None:
    """Wireframe sphere and body-frame markings (static), moved by per-sample transforms (with
    pins: the kernel's samples before the hand-off, then the engine's through the deck)."""
    rec.log(
        "/world/ball",
        rr.Ellipsoids3D(
            half_sizes=[[radius, radius, radius]],
            colors=[_BALL_RGBA],
            fill_mode="majorwireframe",
            line_radii=0.0015,
        ),
        static=True,
    )
    marks = markings_body(run.plan)
    if marks:
        names = list(marks)
        rec.log(
            "/world/ball/markings",
            rr.Points3D(
                [1.02 * radius * marks[n] for n in names],
                radii=0.012,
                colors=[_MARK_RGBA[n] for n in names],
                labels=[_MARK_LABELS[n] for n in names],
            ),
            static=True,
        )
    if "pin" in marks:
        rec.log(
            "/world/ball/pin_axis",
            rr.Arrows3D(
                origins=[-1.4 * radius * marks["pin"]],
                vectors=[2.8 * radius * marks["pin"]],
                colors=[_MARK_RGBA["pin"]],
                radii=0.004,
            ),
            static=True,
        )
    traj = run.trajectory
    if pins is None:
        position, quaternion = traj.position_m, traj.quaternion_wxyz
    else:
        t_s, position, quaternion = pins.ball_track(run)
        times = _time_column(t_s)
    rec.send_columns(
        "/world/ball",
        indexes=[times],
        columns=rr.Transform3D.columns(
            translation=np.asarray(position, dtype=np.float64),
            quaternion=quaternion_xyzw(quaternion),
        ),
    )


def _log_rotation_axis(
    rec: rr.RecordingStream,
    traj: Trajectory,
    radius: float,
    times: rr.TimeColumn,
    pins: PinReplay | None = None,
) -> None:
    """Arrow of length 2.5 R from the center along omega/|omega| (lane frame; zero if still).

    With pins, only the kernel's samples before the hand-off; the arrow is cleared there (the
    pin engine records no angular velocity)."""
    omega = np.asarray(traj.omega_radps, dtype=np.float64)
    position = np.asarray(traj.position_m, dtype=np.float64)
    if pins is not None:
        cut = pins.lane_cut
        omega, position = omega[:cut], position[:cut]
        times = _time_column(np.asarray(traj.t_s, dtype=np.float64)[:cut])
    norm = np.linalg.norm(omega, axis=1, keepdims=True)
    unit = np.divide(omega, norm, out=np.zeros_like(omega), where=norm > 0.0)
    rec.log(
        "/world/rotation_axis",
        rr.Arrows3D.from_fields(colors=[_AXIS_RGBA], radii=0.005, labels=["omega"]),
        static=True,
    )
    rec.send_columns(
        "/world/rotation_axis",
        indexes=[times],
        columns=rr.Arrows3D.columns(origins=position, vectors=2.5 * radius * unit),
    )
    if pins is not None:
        rec.send_columns(
            "/world/rotation_axis",
            indexes=[_time_column(np.array([pins.handoff_t_s]))],
            columns=rr.Clear.columns(is_recursive=[False]),
        )


def _log_pins(rec: rr.RecordingStream, run: RunData, pins: PinReplay, radius: float) -> None:
    """The deck, the spots, the ball's path through the deck, each pin's mesh and poses, the
    hand-off and the leave on ``/events``."""
    from bowlrec.pins.profile import HEIGHT_M

    outline = deck_outline(run)
    z = -radius + 0.5 * _CELL_THICKNESS_M
    rec.log(
        "/world/deck",
        rr.LineStrips3D([outline.corners(z)], colors=[_DECK_RGBA], radii=0.004, labels=["deck"]),
        static=True,
    )
    numbers = sorted(outline.spots_m)
    rec.log(
        "/world/deck/spots",
        rr.Points3D(
            [[*outline.spots_m[p], z] for p in numbers],
            radii=0.0143,  # the spot, 2 1/4 in across
            colors=[_SPOT_RGBA],
            labels=[str(p) for p in numbers],
            show_labels=False,
        ),
        static=True,
    )
    track = pins.ball_position_m.copy()
    track[:, 2] = z
    rec.log(
        "/world/deck/ball_path",
        rr.LineStrips3D([track], colors=[_DECK_PATH_RGBA], radii=0.006, labels=["ball"]),
        static=True,
    )
    verts, tris, normals, colors = pin_mesh()
    mesh = rr.Mesh3D(
        vertex_positions=verts,
        triangle_indices=tris,
        vertex_normals=normals,
        vertex_colors=np.asarray(np.round(255 * colors), dtype=np.uint8),
    )
    times = _time_column(pins.t_s)
    for k, pin in enumerate(pins.pins):
        entity = f"/world/pins/{pin}"
        rec.log(entity, mesh, static=True)
        rec.log(
            f"{entity}/label",
            rr.Points3D(
                [[0.0, 0.0, HEIGHT_M + 0.03]],
                radii=0.003,
                colors=[_PIN_LABEL_RGBA],
                labels=[str(pin)],
            ),
            static=True,
        )
        rec.send_columns(
            entity,
            indexes=[times],
            columns=rr.Transform3D.columns(
                translation=pins.pin_position_m[:, k, :],
                quaternion=quaternion_xyzw(pins.pin_quaternion_wxyz[:, k, :]),
            ),
        )
    outcome = pins.outcome
    rec.send_columns(
        "/events",
        indexes=[_time_column(np.array([pins.handoff_t_s, pins.rest_t_s]))],
        columns=rr.TextLog.columns(
            text=[
                f"pins: the ball reached pin action at x = {pins.ball_position_m[0, 0]:.3f} m",
                f"pins: {outcome.line()}",
            ],
            level=[rr.TextLogLevel.INFO, rr.TextLogLevel.INFO],
        ),
    )
    rec.log(
        "/pins",
        rr.TextDocument(_pins_markdown(pins), media_type=rr.MediaType.MARKDOWN),
        static=True,
    )


def _pins_markdown(pins: PinReplay) -> str:
    """The pins' result as a markdown document (boards from the bowler's own gutter)."""
    o = pins.outcome
    standing = ", ".join(str(p) for p in o.standing) or "none"
    touched = "-".join(str(p) for p in o.touched) or "none"
    rows = [
        ("leave", o.leave),
        ("pinfall", f"{o.pinfall} of {len(o.set_pins)}"),
        ("standing", standing),
        ("touched by the ball", touched),
        ("hand", o.hand),
        ("exit board", "-" if o.exit_board is None else f"{o.exit_board:.1f}"),
        (
            "deflection",
            "-" if o.deflection_boards is None else f"{o.deflection_boards:+.1f} boards",
        ),
        ("hand-off", f"{pins.handoff_t_s:.4f} s"),
        ("pin action ended", f"{pins.rest_t_s:.4f} s"),
    ]
    return "\n".join(
        [f"# {o.leave}", "", o.line(), "", "| quantity | value |", "|---|---|"]
        + [f"| {k} | {v} |" for k, v in rows]
    )


def _send_scalars(
    rec: rr.RecordingStream,
    entity: str,
    names: list[str],
    values: Float,
    times: rr.TimeColumn,
    step: bool = False,
) -> None:
    """One static SeriesLines (legend names) and the (n,) or (n, k) scalar columns."""
    mode = rr.components.InterpolationMode.StepAfter if step else None
    rec.log(entity, rr.SeriesLines(names=names, interpolation_mode=mode), static=True)
    rec.send_columns(entity, indexes=[times], columns=rr.Scalars.columns(scalars=values))


def _log_series(rec: rr.RecordingStream, traj: Trajectory, times: rr.TimeColumn) -> None:
    """The scalar series of :func:`~bowlrec.sinks.common.series_columns` under /plots."""
    for key, (values, _unit) in series_columns(traj).items():
        entity, name = _PLOTS[key]
        _send_scalars(rec, f"/plots/{entity}", [name], values, times, step=key == "phase")


def _log_torques(rec: rr.RecordingStream, traj: Trajectory, times: rr.TimeColumn) -> None:
    """Per-term torques (N m, lane frame) when recorded: magnitudes and x/y/z components.

    ``tau_*`` are the right-hand-side torques of Eqs. (6)/(7); the others are the
    left-hand-side inertia terms I_k alpha, each plotted in its own magnitude view.
    """
    if not traj.torques_Nm:
        return
    groups: dict[str, list[str]] = {"tau": [], "inertia": []}
    for name in traj.torques_Nm:
        groups["tau" if name.startswith("tau_") else "inertia"].append(name)
    for group, names in groups.items():
        if names:
            mags = np.column_stack([np.linalg.norm(traj.torques_Nm[n], axis=1) for n in names])
            _send_scalars(rec, f"/plots/torque_magnitude/{group}", names, mags, times)
    for name, values in traj.torques_Nm.items():
        _send_scalars(
            rec,
            f"/plots/torque_components/{name}",
            [f"{name} {axis}" for axis in "xyz"],
            np.asarray(values, dtype=np.float64),
            times,
        )


def _event_text(kind: str, x_m: float, y_m: float, mu: float, phase: str) -> str:
    what = _EVENT_TEXT.get(kind, kind)
    return f"{what} at x = {x_m:.3f} m, y = {y_m:.3f} m (mu {mu:.3f}, {phase})"


def _log_events(rec: rr.RecordingStream, traj: Trajectory) -> None:
    """One TextLog row per event, at the event's time on ``sim_time``."""
    if not traj.events:
        return
    events = traj.events
    texts = [_event_text(e.kind, e.x_m, e.y_m, e.mu, e.phase) for e in events]
    levels = [_EVENT_LEVEL.get(e.kind, rr.TextLogLevel.INFO) for e in events]
    rec.send_columns(
        "/events",
        indexes=[_time_column(np.array([e.t_s for e in events]))],
        columns=rr.TextLog.columns(text=texts, level=levels),
    )


def _summary_markdown(run: RunData) -> str:
    """The run's summary, the friction legend and the markings as a markdown document.

    Units as in the CLI's summary: slide, positions m; hook cm; pocket angle deg; time s;
    speed m/s; rev rate rpm.
    """
    s = run.trajectory.summary
    rows = [
        ("outcome", f"{s.outcome} ({s.message})"),
        ("slide", "never rolls" if s.slide_m is None else f"{s.slide_m:.3f} m"),
        ("hook", "-" if s.hook_m is None else f"{100 * s.hook_m:.2f} cm"),
        ("pocket angle", "-" if s.pocket_deg is None else f"{s.pocket_deg:.2f} deg"),
        ("time", f"{s.time_s:.4f} s"),
        ("end position", f"x {s.x_end_m:.3f} m, y {s.y_end_m:.3f} m"),
        ("end speed", f"{s.speed_end_mps:.3f} m/s"),
        ("end rev rate", f"{s.rev_rate_end_rpm:.1f} rpm"),
        ("steps / rhs / events", f"{s.n_steps} / {s.n_rhs} / {s.n_events}"),
    ]
    if run.trajectory.pins is not None:
        rows.append(("pins", run.trajectory.pins.line()))
    mus = sorted({c.mu for c in friction_cells(run.plan)})
    legend = (
        f"Oil pattern: blue = lowest mu ({mus[0]:.3f}) ... tan = highest mu ({mus[-1]:.3f}); "
        "each cell is labelled with its mu."
    )
    marks = ", ".join(_MARK_LABELS[n] for n in markings_body(run.plan)) or "none"
    lines = [
        f"# {run.name}",
        "",
        summary_text(run.trajectory),
        "",
        "| quantity | value |",
        "|---|---|",
        *(f"| {k} | {v} |" for k, v in rows),
        "",
        legend,
        "",
        f"Ball markings (body frame): {marks}; orange arrow: rotation axis omega/|omega|; "
        "path: red sliding, green rolling.",
        "",
        f"recording id: `{recording_id(run)}`",
    ]
    return "\n".join(lines)


def _log_documents(rec: rr.RecordingStream, run: RunData) -> None:
    """Static summary (markdown) and the scene as given (JSON) for ``bowlrec replay``."""
    rec.log(
        "/summary",
        rr.TextDocument(_summary_markdown(run), media_type=rr.MediaType.MARKDOWN),
        static=True,
    )
    rec.log("/scene", rr.TextDocument(run.scene_json(), media_type=rr.MediaType.TEXT), static=True)


# --------------------------------------------------------------------------------------------
# reading back


def _flatten_rows(column: pa.Array | pa.ChunkedArray, n_rows: int) -> Float:
    """A ``list<fixed_size_list<k>>`` or ``list<scalar>`` column as an (n_rows, k) float array."""
    inner = column.flatten()
    if pa.types.is_fixed_size_list(inner.type):
        k = inner.type.list_size
        return np.asarray(inner.flatten().to_numpy(zero_copy_only=False), dtype=np.float64).reshape(
            -1, k
        )
    return np.asarray(inner.to_numpy(zero_copy_only=False), dtype=np.float64).reshape(n_rows, -1)

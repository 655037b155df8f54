"""Run a session shot by shot: each shot is simulated on the lane as the shots before left it,
its contact track moves the oil (:mod:`bowlrec.bowling.oil_transfer`), and it lands in the
archive with the oil grid and the session's state after it (:mod:`bowlrec.session.records`).

**Order of play.** Game by game and frame by frame, the bowlers take turns (bowler 1's frame,
then bowler 2's, ...), as a league pair's lane sees them. Pins are not modelled, so a frame's
balls follow from where the first ball enters the pins: a first ball in the session's pocket
window (``SessionSpec.pocket``) is a strike and ends the frame; any other first ball is followed
by a second ball, thrown with the same shot (spare shooting, with its own target and often
another ball, is not modelled). The tenth frame gives two bonus balls after a strike
and none otherwise (a spare cannot be told without pins). This is an assumption about how many
balls cross the lane, stated in docs/sessions.md.

**Each release** is the bowler's shot with a release scatter drawn from the session's seed and
the shot number (``numpy.random.default_rng([seed, shot])``), launched at the angle that puts
the bowler's line over its target at the arrows (a bowler scene given a launch angle instead
aims at the board its line crosses at the arrows on the fresh lane).

**Adjusting.** When ``after_misses`` first balls in a row (default 2) enter outside the
pocket's board window on the same side, a bowler with ``adjust`` moves feet and target toward
the miss (by default the 2-and-1 move: laydown 2 boards, target 1 board; toward higher boards
after high hits) and aims the new line on the lane as it is then (the launch angle that
crosses the new target); a bowler without ``adjust`` keeps the line, and the lane's change
shows as drift of the breakpoint and entry. A move that would leave the lane (laydown or
target beyond boards 1-39) or whose target cannot be reached is not made.

**Run IDs and resuming.** A shot's run ID hashes its Plan, the physics version, the session ID
(:meth:`SessionSpec.session_id`) and the shot number, so the same delivery in another session
or at another point of this one is another run. Running a session again walks its shots in
order: an archived shot is read back (its oil grid and state, from its record groups) instead
of simulated, and play goes on from the first shot that is not archived. New shots are sealed
into the archive :data:`SEAL_EVERY` at a time and when the session ends or fails; a session
killed at any moment resumes from its last sealed shot.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from bowlrec.archive.run_id import RUN_ID_LENGTH, canonical_plan
from bowlrec.bowling.aim import aim
from bowlrec.bowling.oil import OilGrid
from bowlrec.bowling.oil_friction import OilFrictionMapping, grid_friction
from bowlrec.bowling.oil_transfer import (
    TransferLedger,
    absorb_between_shots,
    apply_track,
    session_oil_grid,
)
from bowlrec.bowling.report import bowler_report
from bowlrec.bowling.scene import BowlerScene, Shot
from bowlrec.bowling.variance import ReleaseScatter, draw_releases
from bowlrec.errors import AimError
from bowlrec.sinks.common import RunData
from bowlrec.versions import PHYSICS_VERSION

from .records import ShotState, oil_from_records, shot_records, state_from_records
from .spec import Adjustment, SessionSpec

if TYPE_CHECKING:
    from bowlrec.archive import Archive
    from bowlrec.bowling.drilling import DrilledBall
    from bowlrec.core.plan import Plan
    from bowlrec.core.trajectory import Trajectory
    from bowlrec.sinks.hdf5_run import StoredRun
    from bowlrec.spec import Lane, Scene

__all__ = ["FRAMES", "SEAL_EVERY", "SessionResult", "ShotRow", "run_session", "shot_run_id"]

FRAMES = 10
#: new shots sealed into the archive together (about a second of play)
SEAL_EVERY = 16


@dataclass(frozen=True)
class ShotRow:
    """One shot's result in bowlers' terms and the oil it moved (µL)."""

    shot: int
    game: int
    frame: int
    ball: int
    bowler: str
    run_id: str
    outcome: str
    #: entered the pins in the pocket window (a first ball in the pocket is a strike)
    pocket: bool
    entry_board: float | None
    entry_angle_deg: float | None
    breakpoint_board: float
    breakpoint_ft: float
    #: the bowler's line for this shot: laydown board and target board at the arrows (None for
    #: a line that does not reach the arrows)
    laydown_board: float
    target_board: float | None
    lane_oil_ul: float
    lifted_ul: float
    deposited_ul: float
    absorbed_ul: float
    ball_load_ul: float
    #: False when the shot was read back from the archive (a resumed session)
    simulated: bool

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class SessionResult:
    """A session's shots, its lane before and after, and what running it cost."""

    spec: SessionSpec
    session_id: str
    fresh: OilGrid
    final: OilGrid
    rows: list[ShotRow] = field(default_factory=list)
    #: what aiming on the fresh lane found, by bowler (bowlers with ``aim``)
    aims: dict[str, str] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def simulated(self) -> int:
        return sum(r.simulated for r in self.rows)

    @property
    def resumed(self) -> int:
        return len(self.rows) - self.simulated


def shot_run_id(plan: Plan, session_id: str, shot: int) -> str:
    """The run ID of a session's shot: SHA-256 of the physics version, the canonical Plan, the
    session ID and the shot number (hex, :data:`RUN_ID_LENGTH` digits)."""
    payload = json.dumps(
        {
            "physics_version": PHYSICS_VERSION,
            "plan": canonical_plan(plan),
            "session": {"id": session_id, "shot": shot},
        },
        sort_keys=True,
        separators=(",", ":"),
    )
    return hashlib.sha256(payload.encode()).hexdigest()[:RUN_ID_LENGTH]


@dataclass
class _Bowler:
    """One bowler's fixed parts: the scene on the session's lane, its ball and launch angle."""

    name: str
    scene: BowlerScene
    drilled: DrilledBall | None
    launch_deg: float
    scatter: ReleaseScatter
    adjust: Adjustment | None
    #: sides (+1 high, -1 light) of the first balls in a row that missed since the last move
    misses: list[float] = field(default_factory=list)


class _Session:
    """The running state: the lane's oil and every ball's load."""

    def __init__(self, spec: SessionSpec) -> None:
        self.spec = spec
        self.session_id = spec.session_id()
        pattern = spec.pattern_model()
        #: the lane's pattern label in the archive's index: the preset's name, or the sheet's
        self.pattern_name = spec.pattern if isinstance(spec.pattern, str) else pattern.name
        first = spec.bowlers[0].scene.lane
        self.length_m = first.length_m
        self.width_m = first.width_m
        self.fresh = session_oil_grid(
            pattern,
            cell_ft=spec.grid.cell_ft,
            cell_boards=spec.grid.cell_boards,
            length_ft=first.length_ft,
        )
        self.mapping = spec.oil_friction or OilFrictionMapping()
        self.oil = self.fresh
        self.loads = {b.name: 0.0 for b in spec.bowlers}
        #: what aiming on the fresh lane found, by bowler
        self.aims: dict[str, str] = {}
        self.bowlers = [self._bowler(i) for i in range(len(spec.bowlers))]

    def _bowler(self, i: int) -> _Bowler:
        b = self.spec.bowlers[i]
        own = b.scene
        options = own.options.model_copy(
            update={"record": "rate", "record_dt_s": self.spec.record_dt_s}
        )
        scene = BowlerScene.model_validate(
            {
                **own.model_dump(),
                "pattern": self.spec.pattern
                if isinstance(self.spec.pattern, str)
                else self.spec.pattern.model_dump(),
                "oil_friction": self.mapping.model_dump(),
                "options": options.model_dump(),
            }
        )
        drilled = scene.drilled()
        report = scene.legality(drilled)
        if not report.is_legal and not scene.allow_illegal:
            raise report.error()
        lane = self.lane_for(scene)
        if b.aim:
            found = aim(scene, ("target",), self.spec.pocket, lane=lane)
            scene = found.scene
            self.aims[b.name] = found.message
        shot = Shot(scene, lane=lane, drilled=drilled)
        launch = shot.launch_angle(scene.delivery)
        d = scene.delivery
        if d.target_board_at_arrows is None:  # aimed by its launch angle: its target is where
            board = shot.arrows_board(d, launch)  # that line crosses the arrows, fresh lane
            if board is not None:
                update = {"target_board_at_arrows": board, "launch_angle_deg": None}
                scene = scene.model_copy(update={"delivery": d.model_copy(update=update)})
        return _Bowler(b.name, scene, drilled, launch, b.scatter_model(), b.adjust)

    def adjust(self, bowler: _Bowler, row: ShotRow) -> None:
        """Move ``bowler``'s feet and target after ``row`` (module docstring: Adjusting)."""
        move = bowler.adjust
        pocket = self.spec.pocket
        if move is None or row.ball != 1 or row.entry_board is None:
            return
        if pocket.board_min <= row.entry_board <= pocket.board_max:
            bowler.misses.clear()
            return
        side = 1.0 if row.entry_board > pocket.board_max else -1.0
        if bowler.misses and bowler.misses[-1] != side:
            bowler.misses.clear()
        bowler.misses.append(side)
        if len(bowler.misses) < move.after_misses:
            return
        bowler.misses.clear()
        d = bowler.scene.delivery
        target = d.target_board_at_arrows
        if target is None:  # a line that never reaches the arrows: nothing to move
            return
        laydown = d.laydown_board + side * move.feet_boards
        target = target + side * move.target_boards
        if not (1.0 <= laydown <= 39.0 and 1.0 <= target <= 39.0):
            return
        moved = d.model_copy(
            update={
                "laydown_board": laydown,
                "target_board_at_arrows": target,
                "launch_angle_deg": None,
            }
        )
        scene = bowler.scene.model_copy(update={"delivery": moved})
        shot = Shot(scene, lane=self.lane_for(scene), drilled=bowler.drilled)
        try:
            launch = shot.launch_angle(moved)
        except AimError:
            return
        bowler.scene, bowler.launch_deg = scene, launch

    def lane_for(self, scene: BowlerScene) -> Lane:
        """The physical lane of the current oil for ``scene``'s ball (its cover and surface)."""
        friction = grid_friction(
            self.oil,
            lane_width_m=self.width_m,
            length_m=self.length_m,
            coverstock=scene.ball.coverstock,
            surface=scene.ball.surface,
            mapping=self.mapping,
            name=self.pattern_name,
        )
        return scene.lane.to_physical(friction)

    def shot_scene(self, bowler: _Bowler, shot: int) -> Scene:
        """The physical scene of shot number ``shot`` by ``bowler`` on the current lane."""
        rng = np.random.default_rng([self.spec.seed, shot])
        release = draw_releases(bowler.scene.delivery, bowler.launch_deg, bowler.scatter, rng, 1)[0]
        s = Shot(bowler.scene, lane=self.lane_for(bowler.scene), drilled=bowler.drilled)
        scene = s.physical_scene(release.to_physical(bowler.scene.lane))
        name = f"{self.spec.name} shot {shot} {bowler.name}"
        return scene.model_copy(update={"name": name})


def run_session(
    spec: SessionSpec,
    archive: Archive | None = None,
    *,
    on_shot: Callable[[ShotRow], None] | None = None,
    max_shots: int | None = None,
) -> SessionResult:
    """Play ``spec`` (module docstring), storing every shot in ``archive`` (None: nothing is
    stored, nothing can be resumed); ``on_shot`` is called after each shot; ``max_shots``
    stops after that many shots (the session resumes from there when run again)."""
    t0 = time.perf_counter()
    s = _Session(spec)
    result = SessionResult(spec, s.session_id, s.fresh, s.fresh, aims=dict(s.aims))
    store = _Store(archive)
    try:
        for shot, game, frame, ball, bowler in _order_of_play(s, result, max_shots):
            row = _play(s, store, bowler, shot, game, frame, ball)
            result.rows.append(row)
            s.adjust(bowler, row)
            if on_shot is not None:
                on_shot(row)
    finally:
        store.flush()
    result.final = s.oil
    result.seconds = time.perf_counter() - t0
    return result


def _order_of_play(
    s: _Session, result: SessionResult, max_shots: int | None
) -> Iterator[tuple[int, int, int, int, _Bowler]]:
    """(shot, game, frame, ball, bowler) in order of play (module docstring); a frame's next
    ball depends on the rows played so far (``result.rows``)."""
    shot = 0
    for game in range(1, s.spec.games + 1):
        for frame in range(1, FRAMES + 1):
            for bowler in s.bowlers:
                balls, ball = 2, 1
                while ball <= balls:
                    if max_shots is not None and shot >= max_shots:
                        return
                    shot += 1
                    yield shot, game, frame, ball, bowler
                    if ball == 1 and result.rows[-1].pocket:  # a strike
                        balls = 3 if frame == FRAMES else 1
                    ball += 1


class _Store:
    """The archive side of a session: archived shots are looked up one by one, new shots are
    sealed together, :data:`SEAL_EVERY` at a time and at the end (a kill loses at most the
    shots not yet sealed; the session resumes before them)."""

    def __init__(self, archive: Archive | None) -> None:
        self.archive = archive
        self.pending: Any = None
        if archive is not None:
            archive.recover()  # shots sealed by a session killed before it registered them

    def stored(self, rid: str) -> StoredRun | None:
        a = self.archive
        return a.load(rid) if a is not None and a.has_run(rid) else None

    def add(self, run: RunData, wall_time_s: float, records: dict[str, Any]) -> None:
        from bowlrec.core.arguments import use_closed_form

        a = self.archive
        if a is None:
            return
        if self.pending is None:
            self.pending = a.builder()
        solver = "closed_form" if use_closed_form(run.plan) else "integrator"
        self.pending.append(a.record(run, wall_time_s=wall_time_s, solver=solver, records=records))
        if len(self.pending) >= SEAL_EVERY:
            self.flush()

    def flush(self) -> None:
        if self.archive is not None and self.pending is not None and len(self.pending):
            self.archive.register([self.archive.seal(self.pending)])
        self.pending = None


def _play(
    s: _Session,
    store: _Store,
    bowler: _Bowler,
    shot: int,
    game: int,
    frame: int,
    ball: int,
) -> ShotRow:
    """One shot: read back from the archive when it is there, else simulated and stored."""
    from bowlrec.core.solver import run_plan

    scene = s.shot_scene(bowler, shot)
    plan = scene.resolve()
    rid = shot_run_id(plan, s.session_id, shot)
    stored = store.stored(rid)
    if stored is not None and {"oil", "session"} <= set(stored.records):
        traj = stored.trajectory
        state = state_from_records(stored.records)
        s.oil = oil_from_records(stored.records["oil"])
        s.loads = dict(state.loads_ul)
        return _row(s, bowler, rid, traj, state, simulated=False)
    start = time.perf_counter()
    traj = run_plan(plan)
    wall = time.perf_counter() - start
    x, y = traj.position_m[:, 0], traj.position_m[:, 1]
    oil, load_after, ledger = apply_track(
        s.oil,
        x,
        y,
        lane_width_m=s.width_m,
        model=s.spec.transfer,
        ball_load_ul=s.loads[bowler.name],
    )
    kept, _ = absorb_between_shots(load_after, s.spec.transfer)
    ledger = ledger.with_absorption(s.spec.transfer)
    s.oil = oil
    s.loads[bowler.name] = kept
    state = ShotState(s.session_id, shot, game, frame, ball, bowler.name, dict(s.loads), ledger)
    store.add(RunData(scene, plan, traj, rid), wall, shot_records(oil, state))
    return _row(s, bowler, rid, traj, state, simulated=True)


def _row(
    s: _Session,
    bowler: _Bowler,
    rid: str,
    traj: Trajectory,
    state: ShotState,
    *,
    simulated: bool,
) -> ShotRow:
    hand = bowler.scene.delivery.handedness
    rep = bowler_report(traj, bowler.scene.lane, hand)
    pins = traj.summary.outcome == "pins"
    ledger: TransferLedger = state.ledger
    return ShotRow(
        shot=state.shot,
        game=state.game,
        frame=state.frame,
        ball=state.ball,
        bowler=state.bowler,
        run_id=rid,
        outcome=traj.summary.outcome,
        pocket=bool(pins and s.spec.pocket.contains(rep.entry_board, rep.entry_angle_deg)),
        entry_board=rep.entry_board,
        entry_angle_deg=rep.entry_angle_deg,
        breakpoint_board=rep.breakpoint_board,
        breakpoint_ft=rep.breakpoint_ft,
        laydown_board=bowler.scene.delivery.laydown_board,
        target_board=bowler.scene.delivery.target_board_at_arrows,
        lane_oil_ul=ledger.lane_after_ul,
        lifted_ul=ledger.lifted_ul,
        deposited_ul=ledger.deposited_ul,
        absorbed_ul=ledger.absorbed_ul,
        ball_load_ul=state.loads_ul[state.bowler],
        simulated=simulated,
    )

"""Run a session shot by shot: each shot is simulated on the lane as the shots before left it,
its contact track moves the oil (:mod:`bowlrec.bowling.oil_transfer`), and it lands in the
archive with the oil grid and the session's state after it (:mod:`bowlrec.session.records`).

**The rule.** A session's balls are scored by one of two rules (``SessionSpec.pins``,
:meth:`~bowlrec.session.spec.SessionSpec.rule` says which in words):

* **pins** (the ``bowlrec[pins]`` extra, MuJoCo): every ball runs down the lane and through
  the pins (:func:`bowlrec.api.with_pins`); its pinfall is the pins that fall, and games are
  ten-pin games (:class:`bowlrec.pins.scoring.Game`: a strike scores 10 plus the next two
  balls, a spare 10 plus the next ball; the tenth frame gives two bonus balls after a strike
  and one after a spare). The first ball of a frame is thrown at a full rack with the
  bowler's strike line; a strike ends the frame. Otherwise the second ball is thrown at the
  leave, its pins standing where the first ball left them (the pinsetter sets them back where
  it picked them up: :func:`bowlrec.pins.outcome.standing_offsets_m`, each offset kept within
  the 0.3 m a pin may stand off its spot), with the **3-6-9 cross-lane spare system**
  (:func:`bowlrec.pins.spares.spare_target`): the leave's key pin gives a board at the head
  pin line (60 ft) and a stance move of 3 boards per pin column, away from the key pin; the
  bowler lays the ball down that many boards from the strike line's laydown, and the target
  at the arrows is aimed (:func:`aim`, the target free) so that the ball crosses that board
  at the head pin line on the lane as it is then (same ball, same release scatter as any
  shot; a board the ball cannot reach gets the closest line tried, a line that never reaches
  the arrows the strike line). In the tenth frame a fresh rack is set after each
  strike and after a spare; a ball at a fresh rack is thrown with the strike line. Each ball's
  pins get their own tolerances (weight, centre of gravity, spotting) from the seed
  ``numpy.random.SeedSequence([seed, shot], spawn_key=(1,)).generate_state(1)[0]``; the leave
  is named for the bowler's hand.
* **pocket window** (``pins: false``, or without the extra): pins are not modelled; a first
  ball entering the session's pocket window (``SessionSpec.pocket``) is a strike and ends the
  frame; any other first ball is followed by a second ball, thrown with the same shot; the
  tenth frame gives two bonus balls after a strike and none otherwise (a spare cannot be told
  without pins). No games are scored; the rule sets how many balls cross the lane.

**Order of play.** Game by game and frame by frame, the bowlers take turns (bowler 1's frame,
then bowler 2's, ...), as a league pair's lane sees them; a frame's balls follow from the
rule.

**Each release** is the bowler's shot with a release scatter drawn from the session's seed and
the shot number (``numpy.random.default_rng([seed, shot])``), launched at the angle that puts
the bowler's line over its target at the arrows (a bowler scene given a launch angle instead
aims at the board its line crosses at the arrows on the fresh lane).

**Adjusting** (the strike line). When ``after_misses`` first balls in a row (default 2) enter
outside the pocket's board window on the same side, a bowler with ``adjust`` moves feet and
target toward the miss (by default the 2-and-1 move: laydown 2 boards, target 1 board;
toward higher boards after high hits) and aims the new line on the lane as it is then (the
launch angle that crosses the new target); a bowler without ``adjust`` keeps the line, and
the lane's change shows as drift of the breakpoint and entry. A move that would leave the
lane (laydown or target beyond boards 1-39) or whose target cannot be reached is not made.

**Run IDs and resuming.** A shot's run ID hashes its Plan, the physics version, the session ID
(:meth:`SessionSpec.session_id`) and the shot number, so the same delivery in another session
or at another point of this one is another run (with pins, the Plan holds the pin model, the
pins set and where they stand, so a ball at another leave is another run). Running a session
again walks its shots in order: an archived shot is read back (its oil grid and state, with
the pins' pinfall, standing pins and where they stand, from its record groups) instead of
simulated, its pinfall rolled into the bowler's game as a simulated ball's is, and play goes
on from the first shot that is not archived. New shots are sealed into the archive
:data:`SEAL_EVERY` at a time and when the session ends or fails; a session killed at any moment
resumes from its last sealed shot.
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
from bowlrec.bowling.pocket import Pocket
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
    from bowlrec.pins.outcome import PinOutcome
    from bowlrec.pins.scoring import Game
    from bowlrec.sinks.hdf5_run import StoredRun
    from bowlrec.spec import Lane, Scene
    from bowlrec.spec.pins import PinOptions

__all__ = [
    "FRAMES",
    "MAX_PIN_OFFSET_M",
    "SEAL_EVERY",
    "GameRow",
    "SessionResult",
    "ShotRow",
    "ball_mark",
    "pin_seed",
    "run_session",
    "shot_run_id",
]

FRAMES = 10
#: new shots sealed into the archive together (about a second of play)
SEAL_EVERY = 16
#: how far a standing pin may be set off its spot for the next ball, per axis (m; PinOptions)
MAX_PIN_OFFSET_M = 0.3


@dataclass(frozen=True)
class ShotRow:
    """One shot's result in bowlers' terms and the oil it moved (µL); with pins, what fell and
    the bowler's game after it (None with the pocket-window rule)."""

    shot: int
    game: int
    frame: int
    ball: int
    bowler: str
    run_id: str
    outcome: str
    #: entered the pins in the pocket window (with the pocket-window rule a first ball in the
    #: pocket is a strike)
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
    #: pins knocked down by this ball (count)
    pinfall: int | None = None
    #: the pins standing after the ball in bowlers' words ("strike", "10 pin", "spare", ...)
    leave: str | None = None
    #: the pins standing after the ball (pin numbers, ascending)
    standing: tuple[int, ...] | None = None
    #: the ball on the scoresheet: X strike, / spare, - no pin, else the pinfall (1-9)
    mark: str | None = None
    #: the bowler's game score after the ball (pins and bonuses the balls so far give)
    score: int | None = None
    #: a spare ball: the leave's key pin and the board at the head pin line (60 ft) the ball
    #: was aimed to cross (3-6-9 system); None at a full rack
    key_pin: int | None = None
    spare_board: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class GameRow:
    """One bowler's game scored by the pins: the score, the score sheet's marks (frames
    separated by spaces: ``X``, ``7/``, ``9-``, tenth ``X9/``) and the running score after each
    frame decided so far (a strike or spare waits for its bonus balls); ``finished`` False for
    a game the session stopped in (``max_shots``)."""

    bowler: str
    game: int
    score: int
    marks: str
    frame_scores: tuple[int, ...]
    finished: bool

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class SessionResult:
    """A session's shots, its lane before and after, the rule its balls were scored by, its
    games (with pins) and what running it cost."""

    spec: SessionSpec
    session_id: str
    fresh: OilGrid
    final: OilGrid
    #: the rule in words: "pins (MuJoCo x.y.z)" or "pocket window (...)"
    rule: str = ""
    rows: list[ShotRow] = field(default_factory=list)
    #: every bowler's games, game by game in the bowlers' order (empty without pins)
    games: list[GameRow] = field(default_factory=list)
    #: what aiming on the fresh lane found, by bowler (bowlers with ``aim``)
    aims: dict[str, str] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def simulated(self) -> int:
        return sum(r.simulated for r in self.rows)

    @property
    def resumed(self) -> int:
        return len(self.rows) - self.simulated

    @property
    def pins(self) -> bool:
        """The balls were scored by the pins."""
        return self.rule.startswith("pins")

    def scores(self) -> dict[str, list[int]]:
        """Each bowler's game scores, in game order (games the session stopped in included)."""
        out: dict[str, list[int]] = {b.name: [] for b in self.spec.bowlers}
        for g in self.games:
            out[g.bowler].append(g.score)
        return out


def pin_seed(seed: int, shot: int) -> int:
    """The seed of shot number ``shot``'s pin tolerances in a session seeded ``seed``: a stream
    of its own beside the release scatter's (module docstring)."""
    sequence = np.random.SeedSequence([seed, shot], spawn_key=(1,))
    return int(sequence.generate_state(1)[0])


def ball_mark(pinfall: int, standing: int, *, full_rack: bool) -> str:
    """A ball on the scoresheet: ``X`` all ten down at a full rack, ``/`` the rest down at a
    leave, ``-`` no pin, else the pinfall."""
    if standing == 0:
        return "X" if full_rack else "/"
    return "-" if pinfall == 0 else str(pinfall)


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


@dataclass(frozen=True)
class _Rack:
    """The pins a ball is thrown at when it is not a full rack: those standing (pin numbers)
    and where they stand off their spots (pin -> (dx, dy), m, lane frame)."""

    standing: tuple[int, ...]
    moved: dict[int, tuple[float, float]]


@dataclass(frozen=True)
class _Line:
    """The line a ball is thrown with: the bowler scene (laydown, target), its launch angle
    (deg) and, for a spare, the key pin it is aimed at."""

    scene: BowlerScene
    launch_deg: float
    key_pin: int | None = None
    spare_board: float | None = None


@dataclass
class _Played:
    """A bowler's game being played: the scoring and the balls rolled into it."""

    game: Game
    balls: int = 0


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
        #: the pin model's parameters (None: the pocket-window rule) and the rule in words
        self.pins: PinOptions | None = spec.pin_rule()
        self.rule = spec.rule()
        #: each bowler's games, by (bowler, game number)
        self.games: dict[tuple[str, int], _Played] = {}
        #: the pins each bowler's next ball is thrown at (absent: a full rack)
        self.racks: dict[str, _Rack] = {}
        self.oil = self.fresh
        self.loads = {b.name: 0.0 for b in spec.bowlers}
        #: what aiming on the fresh lane found, by bowler
        self.aims: dict[str, str] = {}
        self.bowlers = [self._bowler(i) for i in range(len(spec.bowlers))]

    def _bowler(self, i: int) -> _Bowler:
        b = self.spec.bowlers[i]
        own = b.scene
        options = own.options.model_copy(  # pins: set per ball by the session's rule
            update={"record": "rate", "record_dt_s": self.spec.record_dt_s, "pins": False}
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

    def shot_scene(self, bowler: _Bowler, shot: int, line: _Line | None = None) -> Scene:
        """The physical scene of shot number ``shot`` by ``bowler`` on the current lane, thrown
        with ``line`` (default the bowler's strike line), with the pins of the bowler's rack
        when the session is scored by the pins."""
        if line is None:
            line = _Line(bowler.scene, bowler.launch_deg)
        rng = np.random.default_rng([self.spec.seed, shot])
        release = draw_releases(line.scene.delivery, line.launch_deg, bowler.scatter, rng, 1)[0]
        s = Shot(line.scene, lane=self.lane_for(line.scene), drilled=bowler.drilled)
        scene = s.physical_scene(release.to_physical(line.scene.lane))
        name = f"{self.spec.name} shot {shot} {bowler.name}"
        update: dict[str, Any] = {"name": name}
        if self.pins is not None:
            pins = self.ball_pins(bowler, shot)
            update["options"] = scene.options.model_copy(update={"pins": pins})
        return scene.model_copy(update=update)

    def ball_pins(self, bowler: _Bowler, shot: int) -> PinOptions:
        """The pin model for shot number ``shot``: the session's parameters, the bowler's rack
        (a full rack, or the leave where it stands), the ball's own tolerances and the
        bowler's hand."""
        from bowlrec.spec.pins import PinOptions

        assert self.pins is not None
        rack = self.racks.get(bowler.name)
        data = self.pins.model_dump()
        data.update(
            seed=pin_seed(self.spec.seed, shot),
            hand=bowler.scene.delivery.handedness,
            standing=list(range(1, 11)) if rack is None else list(rack.standing),
            moved={} if rack is None else rack.moved,
        )
        return PinOptions.model_validate(data)

    def line_for(self, bowler: _Bowler) -> _Line:
        """The line of ``bowler``'s next ball: the strike line at a full rack, else the 3-6-9
        spare line at the leave's key pin (module docstring), aimed on the current lane; the
        strike line when the spare's target cannot be aimed (a line that misses the arrows)."""
        from bowlrec.pins.spares import spare_target

        strike = _Line(bowler.scene, bowler.launch_deg)
        rack = self.racks.get(bowler.name)
        if rack is None:
            return strike
        d = bowler.scene.delivery
        spare = spare_target(rack.standing, d.handedness)
        laydown = min(max(d.laydown_board + spare.stance_move_boards, 1.0), 39.0)
        board = min(max(spare.target_board, 1.0), 39.0)
        moved = d.model_copy(update={"laydown_board": laydown})
        scene = bowler.scene.model_copy(update={"delivery": moved})
        lane = self.lane_for(scene)
        window = Pocket(board=board, board_min=board - 0.5, board_max=board + 0.5)
        try:
            found = aim(scene, ("target",), window, lane=lane).scene
            launch = Shot(found, lane=lane, drilled=bowler.drilled).launch_angle(found.delivery)
        except AimError:  # the strike line, feet and target as they were
            return _Line(strike.scene, strike.launch_deg, spare.key_pin, board)
        return _Line(found, launch, spare.key_pin, board)

    def game_of(self, bowler: _Bowler, game: int) -> _Played:
        """``bowler``'s game number ``game`` (started at its first ball)."""
        from bowlrec.pins.scoring import Game

        key = (bowler.name, game)
        if key not in self.games:
            self.games[key] = _Played(Game())
        return self.games[key]

    def game_rows(self) -> list[GameRow]:
        """The games begun so far, game by game in the bowlers' order."""
        rows = []
        for (name, number), played in sorted(
            self.games.items(), key=lambda kv: (kv[0][1], self._order[kv[0][0]])
        ):
            if played.balls == 0:
                continue
            g = played.game
            rows.append(
                GameRow(
                    bowler=name,
                    game=number,
                    score=int(g.score),
                    marks=str(g.marks()),
                    frame_scores=tuple(int(v) for v in g.frame_scores() if v is not None),
                    finished=bool(g.finished),
                )
            )
        return rows

    @property
    def _order(self) -> dict[str, int]:
        return {b.name: i for i, b in enumerate(self.bowlers)}


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
    result = SessionResult(spec, s.session_id, s.fresh, s.fresh, s.rule, aims=dict(s.aims))
    store = _Store(archive)
    order = _order_of_play if s.pins is None else _order_of_play_pins
    try:
        for shot, game, frame, ball, bowler in order(s, result, max_shots):
            row = _play(s, store, bowler, shot, game, frame, ball)
            result.rows.append(row)
            s.adjust(bowler, row)
            if on_shot is not None:
                on_shot(row)
    finally:
        store.flush()
    result.final = s.oil
    result.games = s.game_rows()
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


def _order_of_play_pins(
    s: _Session, result: SessionResult, max_shots: int | None
) -> Iterator[tuple[int, int, int, int, _Bowler]]:
    """(shot, game, frame, ball, bowler) in order of play with pins: each bowler's balls of a
    frame as long as the bowler's game (rolled by :func:`_play`) stays in that frame."""
    shot = 0
    for game in range(1, s.spec.games + 1):
        for frame in range(1, FRAMES + 1):
            for bowler in s.bowlers:
                g = s.game_of(bowler, game).game
                while not g.finished and g.frame == frame:
                    if max_shots is not None and shot >= max_shots:
                        return
                    shot += 1
                    yield shot, game, frame, g.ball_in_frame, bowler


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
    """One shot: read back from the archive when it is there, else simulated and stored; with
    pins, its pinfall rolled into the bowler's game and the bowler's next rack set."""
    from bowlrec.api import with_pins
    from bowlrec.core.solver import run_plan

    line = _Line(bowler.scene, bowler.launch_deg) if s.pins is None else s.line_for(bowler)
    scene = s.shot_scene(bowler, shot, line)
    plan = scene.resolve()
    rid = shot_run_id(plan, s.session_id, shot)
    stored = store.stored(rid)
    if stored is not None and {"oil", "session"} <= set(stored.records):
        traj = stored.trajectory
        state = state_from_records(stored.records)
        s.oil = oil_from_records(stored.records["oil"])
        s.loads = dict(state.loads_ul)
        if s.pins is not None:
            _roll(s, bowler, game, frame, state)
        return _row(s, line, rid, traj, state, simulated=False)
    start = time.perf_counter()
    traj = with_pins(plan, run_plan(plan))
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
    if traj.pins is not None:
        state = _roll(s, bowler, game, frame, _pins_state(s, bowler, state, traj.pins))
    store.add(RunData(scene, plan, traj, rid), wall, shot_records(oil, state))
    return _row(s, line, rid, traj, state, simulated=True)


def _pins_state(s: _Session, bowler: _Bowler, state: ShotState, out: PinOutcome) -> ShotState:
    """``state`` with what the pins did: the pinfall, the pins standing, where they stand
    (each offset within :data:`MAX_PIN_OFFSET_M`; a ball that never reached the pins leaves
    them where they stood) and the leave."""
    import dataclasses

    from bowlrec.pins.outcome import standing_offsets_m

    if out.action is None:
        before = s.racks.get(bowler.name)
        moved = {} if before is None else before.moved
        offsets = {p: moved[p] for p in out.standing if p in moved}
    else:
        lim = MAX_PIN_OFFSET_M
        offsets = {
            p: (min(max(dx, -lim), lim), min(max(dy, -lim), lim))
            for p, (dx, dy) in standing_offsets_m(out, s.length_m, s.width_m).items()
        }
    return dataclasses.replace(
        state,
        pinfall=int(out.pinfall),
        standing=tuple(out.standing),
        moved=offsets,
        leave=out.leave,
    )


def _roll(s: _Session, bowler: _Bowler, game: int, frame: int, state: ShotState) -> ShotState:
    """Roll the ball of ``state`` into ``bowler``'s game and set the bowler's next rack (a
    full rack when the frame is over, the game is, or no pin stands; else the leave where it
    stands); ``state`` with the game's score after the ball."""
    import dataclasses

    assert state.pinfall is not None and state.standing is not None
    played = s.game_of(bowler, game)
    played.game.roll(state.pinfall)
    played.balls += 1
    g = played.game
    if g.finished or g.frame != frame or not state.standing:
        s.racks.pop(bowler.name, None)
    else:
        s.racks[bowler.name] = _Rack(state.standing, dict(state.moved))
    return dataclasses.replace(state, score=int(g.score))


def _row(
    s: _Session,
    line: _Line,
    rid: str,
    traj: Trajectory,
    state: ShotState,
    *,
    simulated: bool,
) -> ShotRow:
    """The shot's row: ``traj`` reported in bowlers' terms for ``line``'s bowler, with the
    oil and (with pins) the pins of ``state``."""
    d = line.scene.delivery
    rep = bowler_report(traj, line.scene.lane, d.handedness)
    pins = traj.summary.outcome == "pins"
    ledger: TransferLedger = state.ledger
    mark = None
    if state.pinfall is not None and state.standing is not None:
        mark = ball_mark(state.pinfall, len(state.standing), full_rack=line.key_pin is None)
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
        laydown_board=d.laydown_board,
        target_board=d.target_board_at_arrows,
        lane_oil_ul=ledger.lane_after_ul,
        lifted_ul=ledger.lifted_ul,
        deposited_ul=ledger.deposited_ul,
        absorbed_ul=ledger.absorbed_ul,
        ball_load_ul=state.loads_ul[state.bowler],
        simulated=simulated,
        pinfall=state.pinfall,
        leave=state.leave,
        standing=state.standing,
        mark=mark,
        score=state.score,
        key_pin=line.key_pin,
        spare_board=line.spare_board,
    )

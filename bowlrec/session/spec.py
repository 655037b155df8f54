"""A session file (format ``bowlrec-session``): bowlers throwing games on one lane whose oil
changes shot by shot.

::

    format: bowlrec-session
    name: league-night
    pattern: house_shot_approx          # a preset name or an inline pattern sheet
    games: 3
    seed: 7
    bowlers:
      - name: Ann
        scene: ann.yaml                 # a bowler scene: path (relative to this file) or inline
        scatter: pro                    # robot | pro | league | {speed_mph: ..., ...}
      - name: Bo
        scene: {ball: {...}, delivery: {...}}
    pins: true                          # games by pinfall; false: the pocket-window rule
    transfer: {pickup_fraction: 0.5}    # bowlrec.bowling.oil_transfer.TransferModel
    grid: {cell_ft: 1, cell_boards: 1}  # the oil grid the lane evolves on

Each bowler's scene gives the ball, layout, delivery and target; the session's ``pattern``
replaces the scene's own (every bowler bowls on the same lane). The session's friction mapping
(``oil_friction``, default the calibrated mapping of bowler scenes, whose power ramp below a
0.5 um film makes breakdown change the friction) replaces the scenes' own, and the session's
pin rule (``pins``, :meth:`SessionSpec.pin_rule`) replaces the scenes' ``options.pins``.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal, TypeVar

from pydantic import (
    Field,
    ValidationError,
    field_serializer,
    field_validator,
    model_validator,
)

from bowlrec.bowling.oil import KegelPattern, RectanglePattern, preset, preset_names, unknown_preset
from bowlrec.bowling.oil_friction import OilFrictionMapping
from bowlrec.bowling.oil_transfer import TransferModel
from bowlrec.bowling.pocket import POCKET, Pocket
from bowlrec.bowling.scene import BowlerScene
from bowlrec.bowling.variance import PRESETS, ReleaseScatter
from bowlrec.errors import SceneInputError, SpecFileError
from bowlrec.file_kinds import wrong_kind
from bowlrec.scene_input import check_scene_input, prefix_lines
from bowlrec.spec import format_validation_error
from bowlrec.spec._base import NonNegativeFloat, PositiveFloat, SpecModel, spec_error
from bowlrec.spec.loading import read_mapping
from bowlrec.spec.pins import PinOptions

__all__ = [
    "Adjustment",
    "MAX_BOWLERS",
    "MAX_GAMES",
    "SESSION_FORMAT",
    "OilGridSpec",
    "PER_BALL_PIN_FIELDS",
    "SessionBowler",
    "SessionSpec",
    "MAX_SESSIONS",
    "expand_sessions",
    "load_session",
    "load_sessions",
    "parse_session",
    "pins_installed",
]

SESSION_FORMAT = "bowlrec-session"
MAX_BOWLERS = 12
MAX_GAMES = 60
#: sessions one file's sweep may expand to
MAX_SESSIONS = 1000

_T = TypeVar("_T")

#: PinOptions fields a session sets for every ball itself: the pins set (a full rack or the
#: leave), where the leave's pins stand, the pins' tolerances (drawn per ball) and whose names
#: the leave gets (the bowler's hand)
PER_BALL_PIN_FIELDS = ("standing", "moved", "seed", "hand")


class OilGridSpec(SpecModel):
    """The regular grid the lane's oil evolves on (board widths x feet), foul line to pins.

    The default (1 ft x 1 board) is the resolution chosen in docs/oil-transition.md from
    ``benchmarks/results/oil_grid.md``: what each resolution costs the kernel in located
    friction-zone events against how far it moves the entry board."""

    cell_ft: PositiveFloat = Field(
        default=1.0, le=60.0, description="Cell length along the lane (ft), in (0, 60]."
    )
    cell_boards: PositiveFloat = Field(
        default=1.0, le=39.0, description="Cell width across the lane (boards), in (0, 39]."
    )


class Adjustment(SpecModel):
    """A bowler's move when first balls miss the pocket's board window on one side: the laydown
    board by ``feet_boards`` and the target at the arrows by ``target_boards``, both toward the
    side of the miss (toward higher boards when the balls entered above the window, "high";
    lower when they came in "light"), once ``after_misses`` first balls in a row since the last
    move missed on that side. The coaches' 2-and-1 move is the default (Bowling This Month,
    "The fundamentals of target line adjustments"; Ron Clifton: when the ball crosses over,
    move the feet deeper); waiting for two misses that agree (one can be a bad release) is
    bowlrec's assumption (docs/sessions.md)."""

    feet_boards: PositiveFloat = Field(
        default=2.0, le=10.0, description="Boards the feet (laydown) move per miss, in (0, 10]."
    )
    target_boards: NonNegativeFloat = Field(
        default=1.0,
        le=10.0,
        description="Boards the target at the arrows moves per miss, in [0, 10].",
    )
    after_misses: int = Field(
        default=2,
        ge=1,
        le=10,
        description="First balls in a row missing on one side before the bowler moves, in [1, 10].",
    )


class SessionBowler(SpecModel):
    """One bowler: a bowler scene (ball, layout, delivery, target) and a release scatter."""

    name: str = Field(min_length=1, max_length=40, description="The bowler's name.")
    scene: BowlerScene = Field(description="The bowler's shot (a bowler scene).")
    scatter: Literal["robot", "pro", "league"] | ReleaseScatter = Field(
        default="pro",
        description="Release scatter: a preset (robot, pro, league) or one sigma per quantity.",
    )
    aim: bool = Field(
        default=True,
        description=(
            "Find the target at the arrows that enters the pocket on the fresh lane before the "
            "first shot (as a bowler's practice shots do), then keep it; false: the scene's "
            "own target or launch angle."
        ),
    )
    adjust: Adjustment | None = Field(
        default_factory=lambda: Adjustment(),
        description=(
            "How the bowler moves feet and target when first balls miss the pocket's board "
            "window on one side (default: the 2-and-1 move toward the miss after two such "
            "misses); null: the bowler keeps the line all session."
        ),
    )

    def scatter_model(self) -> ReleaseScatter:
        """The scatter as a model (a preset looked up by name)."""
        return PRESETS[self.scatter] if isinstance(self.scatter, str) else self.scatter


class SessionSpec(SpecModel):
    """A session: ``bowlers`` take turns frame by frame for ``games`` games on one lane oiled
    with ``pattern`` (module docstring)."""

    format: Literal["bowlrec-session"] = Field(default="bowlrec-session")
    name: str = Field(default="session", min_length=1, max_length=80)
    description: str = Field(default="")
    pattern: str | KegelPattern | RectanglePattern = Field(
        default="house_shot_approx",
        description="Oil pattern: a preset name (`bowlrec patterns` lists them) or a pattern "
        "sheet.",
    )
    games: int = Field(default=3, ge=1, le=MAX_GAMES, description=f"Games, in [1, {MAX_GAMES}].")
    seed: int = Field(default=0, ge=0, description="Seed of the release scatter, >= 0.")
    bowlers: list[SessionBowler] = Field(
        min_length=1, max_length=MAX_BOWLERS, description=f"1 to {MAX_BOWLERS} bowlers."
    )
    pocket: Pocket = Field(
        default_factory=lambda: POCKET,
        description=(
            "The pocket window: a first ball entering it is a strike (ends the frame), and "
            "aiming bowlers aim at its board."
        ),
    )
    pins: bool | PinOptions | None = Field(
        default=None,
        description=(
            "How a ball's pinfall is found. null (default): the pins when the bowlrec[pins] "
            "extra (MuJoCo) is installed, else the pocket-window rule; true: the pins with the "
            "pin model's defaults; a mapping: the pins with these parameters (options.pins, "
            "without standing, moved, seed and hand, which the session sets per ball); false: "
            "the pocket-window rule (a first ball in the pocket is a strike)."
        ),
    )
    transfer: TransferModel = Field(default_factory=lambda: TransferModel())
    grid: OilGridSpec = Field(default_factory=lambda: OilGridSpec())
    oil_friction: OilFrictionMapping | None = Field(
        default=None,
        description=(
            "Oil film -> friction; default: the calibrated mapping of bowler scenes (its power "
            "ramp makes a film thinned by the shots grip more; docs/calibration.md)."
        ),
    )
    record_dt_s: PositiveFloat = Field(
        default=0.005,
        ge=1e-4,
        le=0.05,
        description="Sampling interval of each shot's recorded path (s), in [1e-4, 0.05].",
    )

    @field_validator("pattern")
    @classmethod
    def _known_pattern(
        cls, pattern: str | KegelPattern | RectanglePattern
    ) -> str | KegelPattern | RectanglePattern:
        if isinstance(pattern, str) and pattern not in preset_names():
            raise spec_error(unknown_preset("pattern", pattern))
        return pattern

    @field_validator("pins")
    @classmethod
    def _no_per_ball_pins(cls, pins: bool | PinOptions | None) -> bool | PinOptions | None:
        if isinstance(pins, PinOptions):
            given = [f for f in PER_BALL_PIN_FIELDS if f in pins.model_fields_set]
            if given:
                raise spec_error(
                    f"{given[0]} is set per ball by the session (the rack or the leave, the "
                    "pins' tolerances from the session's seed, the bowler's hand): leave "
                    f"{', '.join(PER_BALL_PIN_FIELDS)} out"
                )
        return pins

    @field_serializer("pins")
    def _pins_without_per_ball_fields(
        self, pins: bool | PinOptions | None
    ) -> bool | dict[str, Any] | None:
        """The pin model's parameters as the session file gives them: without the fields the
        session sets per ball (a dump reads back)."""
        if isinstance(pins, PinOptions):
            return pins.model_dump(mode="json", exclude=set(PER_BALL_PIN_FIELDS))
        return pins

    @model_validator(mode="after")
    def _distinct_names(self) -> SessionSpec:
        names = [b.name for b in self.bowlers]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise spec_error(f"bowlers: names must differ ({', '.join(dup)} given twice)")
        lane = self.bowlers[0].scene.lane
        for i, b in enumerate(self.bowlers[1:], start=1):
            if b.scene.lane != lane:
                raise spec_error(
                    f"bowlers[{i}].scene.lane = {b.scene.lane.model_dump()} differs from "
                    f"bowlers[0]'s {lane.model_dump()}: a session is one lane"
                )
        return self

    def pattern_model(self) -> KegelPattern | RectanglePattern:
        """The oil pattern as a model (a preset loaded by name)."""
        return preset(self.pattern) if isinstance(self.pattern, str) else self.pattern

    def pin_rule(self) -> PinOptions | None:
        """The pin model's parameters when the session's balls are scored by the pins that
        fall, None for the pocket-window rule (``pins`` false, or null without the
        ``bowlrec[pins]`` extra). MissingExtraError for ``pins`` true or a mapping without
        the extra."""
        if self.pins is False:
            return None
        if self.pins is None and not pins_installed():
            return None
        if self.pins is not None:
            from bowlrec.pins.engine import require_mujoco

            require_mujoco()
        return self.pins if isinstance(self.pins, PinOptions) else PinOptions()

    def rule(self) -> str:
        """The rule in words, as outputs state it: ``pins (MuJoCo 3.3.0)``, ``pocket window
        (pins extra not installed)`` or ``pocket window (pins: false)``."""
        if self.pin_rule() is not None:
            import mujoco

            return f"pins (MuJoCo {mujoco.__version__})"
        if self.pins is False:
            return "pocket window (pins: false)"
        return "pocket window (pins extra not installed)"

    def session_id(self) -> str:
        """SHA-256 (hex, 20 digits) of the session's canonical JSON: what every shot's run ID
        is bound to (a session with any other input has other shots). ``pins`` enters as the
        rule it resolves to (:meth:`pin_rule`): the pin model's full parameters with the pins,
        nothing with the pocket-window rule (such a session's ID is the one it had before
        sessions had pins)."""
        data = self.model_dump(mode="json")
        data.pop("pins", None)
        rule = self.pin_rule()
        if rule is not None:
            data["pins"] = rule.model_dump(mode="json", exclude=set(PER_BALL_PIN_FIELDS))
        text = json.dumps(data, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:20]


def pins_installed() -> bool:
    """The ``bowlrec[pins]`` extra (MuJoCo) can be imported."""
    from bowlrec.errors import MissingExtraError
    from bowlrec.pins.engine import require_mujoco

    try:
        require_mujoco()
    except MissingExtraError:
        return False
    return True


def _bowler_scenes(data: dict[str, Any], base_dir: Path) -> dict[str, Any]:
    """``data`` with every bowler's scene (a path relative to ``base_dir``, or inline) read and
    validated as a bowler scene through the one way in for a scene
    (:func:`bowlrec.scene_input.check_scene_input`); SceneInputError with the intake's lines,
    each prefixed ``bowlers[i].scene:`` (and the file's path for a file), for every bad one."""
    bowlers = data.get("bowlers")
    if not isinstance(bowlers, list):
        return data
    resolved: list[Any] = []
    problems: list[str] = []
    for i, b in enumerate(bowlers):
        entry = b.get("scene") if isinstance(b, dict) else None
        if isinstance(entry, str | dict):
            try:
                entry = check_scene_input(entry, base_dir=base_dir, bowler=True).model
            except SceneInputError as err:
                problems.append(prefix_lines(f"bowlers[{i}].scene", str(err)))
            b = {**b, "scene": entry}
        resolved.append(b)
    if problems:
        raise SceneInputError("\n".join(problems))
    return {**data, "bowlers": resolved}


def expand_sessions(data: object, base_dir: str | Path = ".") -> list[SessionSpec]:
    """The sessions of a session file: the session itself, or with a ``sweep`` (the blocks of a
    job file, :mod:`bowlrec.batch.job`, whose paths address session fields, e.g.
    ``transfer.pickup_fraction`` or ``seed``) one session per point, named ``NAME-1``,
    ``NAME-2``, ... (at most :data:`MAX_SESSIONS`). SceneInputError / JobError naming the
    problem otherwise."""
    if not isinstance(data, dict) or "sweep" not in data:
        return [parse_session(data, base_dir)]
    from pydantic import TypeAdapter

    from bowlrec.batch.job_spec import Sweep
    from bowlrec.batch.paths import apply_override
    from bowlrec.errors import JobError

    rest = {k: v for k, v in data.items() if k != "sweep"}
    base = parse_session(rest, base_dir).model_dump(mode="json")
    try:
        blocks = TypeAdapter(Sweep | list[Sweep]).validate_python(data["sweep"])
    except ValidationError as err:
        raise JobError("sweep: " + format_validation_error(err)) from None
    blocks = blocks if isinstance(blocks, list) else [blocks]
    count = sum(b.count() for b in blocks)
    if count > MAX_SESSIONS:
        raise JobError(f"sweep: {count:,} sessions; at most {MAX_SESSIONS:,} per file")
    specs = []
    points = [p for b in blocks for p in b.points()]
    for i, point in enumerate(points, start=1):
        mapping = json.loads(json.dumps(base))
        for path, value in point.items():
            apply_override(mapping, path, value)
        mapping["name"] = f"{base['name']}-{i}"
        specs.append(parse_session(mapping, base_dir))
    return specs


def parse_session(data: object, base_dir: str | Path = ".") -> SessionSpec:
    """A validated session from a mapping (scene paths relative to ``base_dir``); a
    SceneInputError with one line per problem otherwise."""
    if not isinstance(data, dict):
        raise SceneInputError("a session file holds a mapping (format: bowlrec-session)")
    other = wrong_kind(data, SESSION_FORMAT)
    if other is not None:
        raise SceneInputError(other)
    fmt_ = data.get("format", SESSION_FORMAT)
    if fmt_ != SESSION_FORMAT:
        raise SceneInputError(f"format = {fmt_!r}: a session file has format {SESSION_FORMAT!r}")
    try:
        return SessionSpec.model_validate(_bowler_scenes(data, Path(base_dir)))
    except ValidationError as err:
        raise SceneInputError(format_validation_error(err)) from None


def load_session(path: str | Path) -> SessionSpec:
    """A session file (JSON or YAML) without a sweep, validated (:func:`parse_session`); every
    line of an error starts with the file's path."""
    return _from_file(path, parse_session)


def load_sessions(path: str | Path) -> list[SessionSpec]:
    """The sessions of a session file (JSON or YAML; :func:`expand_sessions`); every line of an
    error starts with the file's path."""
    return _from_file(path, expand_sessions)


def _from_file(path: str | Path, parse: Callable[[Any, Path], _T]) -> _T:
    """``parse(mapping, directory)`` of a session file; SceneInputError or JobError whose lines
    start with the path."""
    from bowlrec.errors import JobError

    p = Path(path)
    try:
        data = read_mapping(p)
    except FileNotFoundError:
        raise SceneInputError(f"{p}: no such file") from None
    except OSError as err:
        raise SceneInputError(f"{p}: {err.strerror or err}") from None
    except SpecFileError as err:
        raise SceneInputError(f"{p}: {err}") from None
    try:
        return parse(data, p.parent)
    except (SceneInputError, JobError) as err:
        raise type(err)(prefix_lines(p, str(err))) from None

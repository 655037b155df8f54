"""The calibration set: published observables of ball motion and bowlrec's value of each.

``data/calibration/observables.json`` holds every published fact the bowlers' layer is held
to, each with its source (publisher, title, address and the line relied on), its number or
range, its kind (measurement, rule of thumb, definition) and how loose it is. A fact that can
be compared with a simulation says how (``compare``): which quantity, on which bowler types
and patterns, and whether the fit of the friction levels may see it (``role: fit``) or not
(``role: held_out``). Facts without ``compare`` are context (definitions, ranges the presets
use).

**The lines.** Bowlers pick a line to suit the pattern; the calibration plays each bowler type
(:mod:`bowlrec.bowling.styles`) on each pattern along the line the sources prescribe: Kegel's
rule of 31 puts the ball's exit from the oil on board L - 31 for a pattern L ft long, with the
breakpoint about a board further out (Bowling This Month: a 38 ft pattern exits on board 7,
"giving you a breakpoint around board 6"). So each case aims for the pocket's entry board
(17.5) with the breakpoint on board L - 32, varying the laydown board and the launch angle
(:func:`~bowlrec.bowling.aim.aim` with ``breakpoint_board``). The quantities compared are what
that line gives: where the breakpoint falls along the lane, the entry angle, where the ball
starts to roll, the board at the end of the pattern, and how the entry board moves when the
same line is thrown 1 mph slower or with 10 % more revs. A comparison may instead give its own
line (laydown board and target at the arrows: Storm's measured test line).

**The score** of a quantity against a fact with range [low, high]: z = (value - centre) /
half-width, so that |z| <= 1 is inside the fact's own looseness; a one-sided fact (only low or
only high) scores 0 on its side and the distance past its bound (in the quantity's units) on
the other. The fit minimises the sum of z^2 over the ``fit`` facts
(``benchmarks/calibration.py``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass
from functools import lru_cache
from importlib.resources import files
from typing import Any, Literal

from .aim import aim, evaluate
from .delivery import BowlerDelivery
from .oil import KegelPattern, RectanglePattern, pattern_statistics, preset
from .oil_friction import OilFrictionMapping
from .pocket import POCKET
from .report import BowlerReport
from .scene import BowlerScene, Shot
from .styles import STYLES

__all__ = [
    "BALL_OVERRIDES",
    "FIT_PATTERNS",
    "LEVELS",
    "HELD_OUT_PATTERNS",
    "OBSERVABLES_FILE",
    "QUANTITIES",
    "Case",
    "CaseResult",
    "Observable",
    "Score",
    "breakpoint_board_for",
    "case_scene",
    "cases_for",
    "comparisons",
    "load_observables",
    "pattern_length_ft",
    "run_case",
    "score",
    "z_score",
]

#: the published facts, inside the package
OBSERVABLES_FILE = "calibration/observables.json"
#: the patterns the fit sees (the library's approximations of house and sport shapes)
FIT_PATTERNS: tuple[str, ...] = (
    "house_shot_approx",
    "sport_short_36ft_approx",
    "sport_medium_41ft_approx",
    "sport_long_45ft_approx",
)
#: published Kegel sheets the fit never sees
HELD_OUT_PATTERNS: tuple[str, ...] = ("kegel_stonehenge", "kegel_chromium_6742", "kegel_big_ben")
#: the ball of every case: the reference cover (reactive solid at 1000 grit, factors 1)
BALL_OVERRIDES: dict[str, Any] = {"coverstock": "reactive_solid", "surface": 1000}
#: the quantities a case reports (CaseResult fields) and what each is
QUANTITIES: dict[str, str] = {
    "breakpoint_ft": "distance of the breakpoint from the foul line (ft)",
    "entry_angle_deg": "entry angle at the head pin line (deg)",
    "roll_ft": "where the ball starts to roll (ft; 60 when it still slides at the pins)",
    "breakpoint_board": "board of the breakpoint",
    "entry_board": "board at the head pin line",
    "exit_board_error": "board at the end of the pattern minus L - 31 (the rule of 31's exit)",
    "launch_angle_deg": "launch angle (deg, negative outward)",
    "speed_loss_mph": "release speed minus the speed at the head pin line (mph)",
    "rolling_angle_deg": "angle the released ball rolls out at, friction aside (deg; below)",
    "slower_entry_shift_boards": "entry board moved by the same line 1 mph slower (boards)",
    "more_revs_entry_shift_boards": "entry board moved by the same line with 10 % more revs",
    "slower_breakpoint_shift_ft": "breakpoint moved along the lane 1 mph slower (ft)",
    "rougher_breakpoint_shift_ft": "breakpoint moved along the lane, cover at 500 grit (ft)",
    "more_tilt_roll_shift_ft": "roll point moved along the lane with 5 deg more tilt (ft)",
}
#: quantities of the friction levels themselves (compared without cases)
LEVELS: dict[str, str] = {
    "mu_oil": "the reference ball's friction on full oil",
    "mu_dry": "the reference ball's friction on the dry lane",
}
#: the lane's length (ft): a ball still sliding there has its roll point there
_LANE_FT = 60.0

Role = Literal["fit", "held_out"]


@dataclass(frozen=True)
class Compare:
    """How a fact is compared: ``quantity`` (a key of :data:`QUANTITIES`) on each case of
    ``styles`` x ``patterns`` against [low, high] (either may be None: one sided), in the fit
    or held out; ``line`` (laydown_board, target_board_at_arrows) throws that line instead of
    the rule-of-31 line."""

    role: Role
    quantity: str
    styles: tuple[str, ...]
    patterns: tuple[str, ...]
    low: float | None
    high: float | None
    line: tuple[tuple[str, float], ...] | None = None
    note: str = ""

    def cases(self) -> list[Case]:
        return [Case(st, p, self.line) for p in self.patterns for st in self.styles]


@dataclass(frozen=True)
class Observable:
    """One published fact (module docstring)."""

    id: str
    topic: str
    quantity: str
    value: float | None
    low: float | None
    high: float | None
    units: str
    kind: str
    looseness: str
    publisher: str
    title: str
    address: str
    quote: str
    compare: tuple[Compare, ...] = ()


_LINE_FIELDS = ("laydown_board", "target_board_at_arrows")


def _compare(data: dict[str, Any]) -> Compare:
    quantity = str(data["quantity"])
    if quantity not in QUANTITIES and quantity not in LEVELS:
        known = ", ".join([*QUANTITIES, *LEVELS])
        raise ValueError(f"compare.quantity = {quantity!r}: not one of {known}")
    role = data["role"]
    if role not in ("fit", "held_out"):
        raise ValueError(f"compare.role = {role!r}: 'fit' or 'held_out'")
    styles = tuple(STYLES if data.get("styles") is None else data["styles"])
    for s in styles:
        if s not in STYLES:
            raise ValueError(f"compare.styles: {s!r} is not a style")
    line = data.get("line")
    if line is not None and set(line) != set(_LINE_FIELDS):
        raise ValueError(f"compare.line = {line!r}: give exactly {', '.join(_LINE_FIELDS)}")
    return Compare(
        role=role,
        quantity=quantity,
        styles=styles,
        patterns=tuple(data["patterns"]),
        low=None if data.get("low") is None else float(data["low"]),
        high=None if data.get("high") is None else float(data["high"]),
        line=None if line is None else tuple((k, float(line[k])) for k in _LINE_FIELDS),
        note=str(data.get("note", "")),
    )


def _number(value: Any) -> float | None:
    return None if value is None else float(value)


@lru_cache(maxsize=1)
def load_observables() -> tuple[Observable, ...]:
    """Every fact of the calibration set, in the file's order."""
    text = files("bowlrec.bowling").joinpath("data", OBSERVABLES_FILE).read_text(encoding="utf-8")
    out = []
    for item in json.loads(text):
        src = item["source"]
        out.append(
            Observable(
                id=item["id"],
                topic=item["topic"],
                quantity=item["quantity"],
                value=_number(item.get("value")),
                low=_number(item.get("low")),
                high=_number(item.get("high")),
                units=item["units"],
                kind=item["kind"],
                looseness=item["looseness"],
                publisher=src["publisher"],
                title=src["title"],
                address=src["address"],
                quote=src["quote"],
                compare=tuple(_compare(c) for c in item.get("compare", ())),
            )
        )
    return tuple(out)


@dataclass(frozen=True)
class Case:
    """One bowler type on one pattern, on the rule-of-31 line or on a given ``line``."""

    style: str
    pattern: str
    line: tuple[tuple[str, float], ...] | None = None

    def label(self) -> str:
        line = "" if self.line is None else " @ " + ", ".join(f"{k} {v:g}" for k, v in self.line)
        return f"{self.style} / {self.pattern}{line}"


def pattern_length_ft(pattern: KegelPattern | RectanglePattern) -> float:
    """A pattern's length (ft): its sheet's oil pattern distance, or its oil's far end
    (:func:`~bowlrec.bowling.oil.pattern_statistics`)."""
    return float(pattern_statistics(pattern).distance_ft)


def breakpoint_board_for(length_ft: float) -> float:
    """The breakpoint board of the rule-of-31 line on a pattern ``length_ft`` long: one board
    outside the exit board L - 31 (module docstring), kept on the lane (boards 1-38)."""
    return min(38.0, max(1.0, length_ft - 32.0))


@dataclass(frozen=True)
class CaseResult:
    """What a case's line gives (see :data:`QUANTITIES`; None where it has no value)."""

    case: Case
    length_ft: float
    found: bool
    laydown_board: float
    launch_angle_deg: float
    arrows_board: float | None
    breakpoint_board: float
    breakpoint_ft: float
    entry_board: float | None
    entry_angle_deg: float | None
    rolling_angle_deg: float
    speed_loss_mph: float | None
    roll_ft: float
    exit_board_error: float | None
    slower_entry_shift_boards: float | None
    more_revs_entry_shift_boards: float | None
    slower_breakpoint_shift_ft: float
    rougher_breakpoint_shift_ft: float
    more_tilt_roll_shift_ft: float
    evaluations: int

    def value(self, quantity: str) -> float | None:
        """The value of a :data:`QUANTITIES` key."""
        v = getattr(self, quantity)
        return None if v is None else float(v)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["case"] = self.case.label()
        return d


def case_scene(case: Case, mapping: OilFrictionMapping) -> BowlerScene:
    """The bowler scene of a case: the default bowler scene's ball with the reference cover
    (:data:`BALL_OVERRIDES`), the style's release, the pattern, the mapping, aimed along the
    case's line (a start for the rule-of-31 line's search)."""
    base = BowlerScene()
    if case.line is None:
        bp = breakpoint_board_for(pattern_length_ft(preset(case.pattern)))
        start: dict[str, Any] = {"laydown_board": bp + 12.0, "launch_angle_deg": -2.0}
    else:
        start = dict(case.line)
    return base.model_copy(
        update={
            "name": f"calibration-{case.style}-{case.pattern}",
            "ball": base.ball.model_copy(update=BALL_OVERRIDES),
            "pattern": case.pattern,
            "oil_friction": mapping,
            "delivery": BowlerDelivery.model_validate({"style": case.style, **start}),
        }
    )


def run_case(case: Case, mapping: OilFrictionMapping) -> CaseResult:
    """The line of ``case`` under ``mapping`` (the rule-of-31 line found by :func:`aim`, or
    the case's own) and its quantities."""
    scene = case_scene(case, mapping)
    length = pattern_length_ft(scene.pattern_model())
    if case.line is None:
        result = aim(
            scene, ("laydown", "launch"), POCKET, breakpoint_board=breakpoint_board_for(length)
        )
        scene, found, evaluations = result.scene, result.found, result.evaluations
    else:
        found, evaluations = True, 1
    shot = Shot(scene)
    delivery = scene.delivery.model_copy(
        update={
            "launch_angle_deg": shot.launch_angle(scene.delivery),
            "target_board_at_arrows": None,
        }
    )
    base = evaluate(shot, delivery)
    report = base.report

    def varied(**update: Any) -> BowlerReport:
        return evaluate(shot, delivery.model_copy(update=update)).report

    slower = varied(speed_mph=delivery.speed_mph - 1.0)
    revs = varied(rev_rate_rpm=delivery.rev_rate_rpm * 1.1)
    tilt = varied(axis_tilt_deg=delivery.axis_tilt_deg + 5.0)
    rough_scene = scene.model_copy(
        update={"ball": scene.ball.model_copy(update={"surface": 500}), "delivery": delivery}
    )
    rough = evaluate(Shot(rough_scene), delivery).report
    exit_board = shot.board_at(delivery, base.launch_angle_deg, scene.lane.ft_to_x_m(length))

    def shift(r: BowlerReport) -> float | None:
        if r.entry_board is None or report.entry_board is None:
            return None
        return float(r.entry_board - report.entry_board)

    return CaseResult(
        case=case,
        length_ft=length,
        found=found,
        laydown_board=delivery.laydown_board,
        launch_angle_deg=base.launch_angle_deg,
        arrows_board=report.arrows_board,
        breakpoint_board=report.breakpoint_board,
        breakpoint_ft=report.breakpoint_ft,
        entry_board=report.entry_board,
        entry_angle_deg=report.entry_angle_deg,
        rolling_angle_deg=rolling_angle_deg(scene, delivery, base.launch_angle_deg),
        speed_loss_mph=None
        if report.entry_speed_mph is None
        else report.launch_speed_mph - report.entry_speed_mph,
        roll_ft=_roll_ft(report),
        exit_board_error=None if exit_board is None else exit_board - (length - 31.0),
        slower_entry_shift_boards=shift(slower),
        more_revs_entry_shift_boards=shift(revs),
        slower_breakpoint_shift_ft=float(slower.breakpoint_ft - report.breakpoint_ft),
        rougher_breakpoint_shift_ft=float(rough.breakpoint_ft - report.breakpoint_ft),
        more_tilt_roll_shift_ft=_roll_ft(tilt) - _roll_ft(report),
        evaluations=evaluations,
    )


def rolling_angle_deg(scene: BowlerScene, delivery: BowlerDelivery, launch_deg: float) -> float:
    """The direction (deg to the boards, positive toward higher boards) the released ball
    rolls out at once it stops sliding, whatever the friction along the way, for a ball with
    isotropic inertia (I = m RG^2) and no mass offset or air drag.

    Friction acts at the contact point, so the horizontal angular momentum about it, L = I w
    + m R z x v, is conserved while the ball slides; once it rolls, v = R w x z. Hence the
    rolling velocity v_f = (v0 + k R w0 x z) / (1 + k) with k = (RG / R)^2: a ball cannot
    enter at more than this angle, however the oil is laid (up to its differential, mass
    offset and drag, which move it by a few hundredths of a degree)."""
    d = delivery.to_physical(scene.lane, launch_deg)
    a = math.radians(d.takeoff_angle_deg)
    vx, vy = d.speed_mps * math.cos(a), d.speed_mps * math.sin(a)
    wx, wy, _ = d.omega_radps
    radius_m = scene.ball.radius_m
    k = (scene.ball.rg_in / scene.ball.radius_in) ** 2
    # w x z = (wy, -wx, 0)
    fx, fy = vx + k * radius_m * wy, vy - k * radius_m * wx
    angle = math.degrees(math.atan2(fy, fx))
    return angle if delivery.handedness == "right" else -angle


def _roll_ft(report: BowlerReport) -> float:
    """Where the ball starts to roll (ft); the lane's length when it still slides there."""
    return _LANE_FT if report.slide_ft is None else float(report.slide_ft)


@dataclass(frozen=True)
class Score:
    """One comparison of a fact with bowlrec: every case's value and z (module docstring),
    the root mean square of the z's, and how many cases are inside the fact's looseness."""

    observable: Observable
    compare: Compare
    values: tuple[tuple[str, float | None], ...]
    zs: tuple[float, ...]

    @property
    def rms_z(self) -> float:
        return math.sqrt(sum(z * z for z in self.zs) / len(self.zs)) if self.zs else math.inf

    @property
    def within(self) -> int:
        return sum(1 for z in self.zs if abs(z) <= 1.0)

    @property
    def missing(self) -> int:
        return sum(1 for _, v in self.values if v is None)

    @property
    def objective(self) -> float:
        """Sum of z^2; a case without a value counts as z = 3."""
        return sum(z * z for z in self.zs) + 9.0 * self.missing


def z_score(value: float, low: float | None, high: float | None) -> float:
    """(value - centre) / half-width of [low, high]; one sided: the distance past the bound
    (in the quantity's units), 0 on the allowed side."""
    if low is not None and high is not None:
        half = 0.5 * (high - low)
        return (value - 0.5 * (low + high)) / half
    if low is not None:
        return min(0.0, value - low)
    if high is not None:
        return max(0.0, value - high)
    return 0.0


def score(
    observable: Observable,
    compare: Compare,
    results: dict[Case, CaseResult],
    mapping: OilFrictionMapping | None = None,
) -> Score:
    """Score one comparison of a fact on the results of its cases (a comparison of a level,
    :data:`LEVELS`, on ``mapping``'s)."""
    values: list[tuple[str, float | None]] = []
    zs: list[float] = []
    if compare.quantity in LEVELS:
        if mapping is None:
            raise ValueError(f"{observable.id}: {compare.quantity} needs the mapping")
        level = float(getattr(mapping, compare.quantity))
        return Score(
            observable,
            compare,
            (("reference ball", level),),
            (z_score(level, compare.low, compare.high),),
        )
    for case in compare.cases():
        v = results[case].value(compare.quantity)
        values.append((case.label(), v))
        if v is not None:
            zs.append(z_score(v, compare.low, compare.high))
    return Score(observable, compare, tuple(values), tuple(zs))


def comparisons(
    observables: Sequence[Observable], role: Role | None = None
) -> list[tuple[Observable, Compare]]:
    """Every (fact, comparison) of ``role`` (or all), in the file's order."""
    return [(o, c) for o in observables for c in o.compare if role is None or c.role == role]


def cases_for(pairs: Iterable[tuple[Observable, Compare]]) -> list[Case]:
    """Every case the comparisons need, once each, in a stable order."""
    seen: dict[Case, None] = {}
    for _, c in pairs:
        for case in c.cases():
            seen.setdefault(case, None)
    return sorted(seen, key=lambda c: (c.pattern, c.style, c.line or ()))

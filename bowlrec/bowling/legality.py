"""USBC ball legality, with the rule set selectable (domain notes Sec. 2; Frohlich 2004 Sec. III A).

Rule sets:

* ``"current"``: weight <= 16 lb; diameter 8.500-8.595 in; RG about every axis in
  2.460-2.800 in (low-RG minimum raised from 2.430 for balls approved from 1 Jul 2010);
  differential <= 0.060 in (from 1 Feb 2005); static weights <= 3 oz top/bottom and <= 3 oz
  side, finger or thumb (from 1 Aug 2018, for balls without a balance hole); balance holes
  banned from 1 Aug 2020; at most 5 gripping holes (one per finger and one for the thumb, all
  usable together) [USBC-GRIP], [GR20].
* ``"paper_era"``: the ABC/WIBC rules Frohlich (2004) quotes: weight <= 16 lb; diameter
  8.500-8.595 in; RG 2.43-2.80 in; differential <= 0.080 in; static weights <= 3 oz top/bottom
  and <= 1 oz side, finger or thumb; one balance hole allowed, at most 1 1/4 in in diameter,
  beside at most 5 gripping holes (the pre-2020 USBC wording [USBC-GRIP]).

Static-weight limits apply to balls heavier than 10 lb (the sources give no limits for lighter
balls, so none are checked). Rules the spec sheet cannot show (hardness, surface roughness Ra,
oil absorption, component density, marking tolerances) are not checked. [USBC-GRIP]:
https://bowl.com/news/usbc-explains-specification-related-to-new-gripping-layouts (USBC,
"USBC explains specification related to new gripping layouts"); [GR20]:
https://grgrusbc.org/new-balance-hole-rules-now-in-effect. Comparisons allow
``LIMIT_SLACK_IN`` / ``LIMIT_SLACK_OZ`` of floating-point rounding (e.g. 2.74 + 0.06 in
evaluates to 2.8000000000000003 in and is legal).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

from bowlrec.errors import IllegalBallError

from .ball import BowlerBall, StaticWeights

__all__ = [
    "LIMIT_SLACK_IN",
    "LIMIT_SLACK_OZ",
    "RULE_SETS",
    "IllegalBallError",
    "LegalityReport",
    "RuleSet",
    "RuleSetName",
    "Violation",
    "check_legality",
    "ensure_legal",
]

RuleSetName = Literal["current", "paper_era"]

#: rounding allowance of the inch limits (in); far below the 0.001 in resolution of the rules
LIMIT_SLACK_IN = 1e-9
#: rounding allowance of the ounce limits (oz)
LIMIT_SLACK_OZ = 1e-9
#: balls above this weight are subject to the static-weight limits (lb)
_STATIC_WEIGHT_MIN_LB = 10.0


@dataclass(frozen=True)
class RuleSet:
    """One set of USBC (or ABC/WIBC) limits."""

    name: RuleSetName
    description: str
    weight_max_lb: float
    diameter_min_in: float
    diameter_max_in: float
    rg_min_in: float
    rg_max_in: float
    differential_max_in: float
    top_bottom_max_oz: float
    side_max_oz: float
    finger_thumb_max_oz: float
    balance_hole_allowed: bool
    #: holes for gripping (fingers and thumb)
    gripping_holes_max: int = 5
    #: balance (weight) holes
    balance_holes_max: int = 0
    #: diameter of a balance hole where one is allowed (in)
    balance_hole_diameter_max_in: float = 1.25


RULE_SETS: dict[RuleSetName, RuleSet] = {
    "current": RuleSet(
        name="current",
        description=(
            "USBC current: RG 2.460-2.800 in (from 1 Jul 2010), diff <= 0.060 in (from 1 Feb "
            "2005), static weights 3 oz top/bottom and 3 oz side/finger/thumb (from 1 Aug 2018), "
            "no balance hole (from 1 Aug 2020)"
        ),
        weight_max_lb=16.0,
        diameter_min_in=8.500,
        diameter_max_in=8.595,
        rg_min_in=2.460,
        rg_max_in=2.800,
        differential_max_in=0.060,
        top_bottom_max_oz=3.0,
        side_max_oz=3.0,
        finger_thumb_max_oz=3.0,
        balance_hole_allowed=False,
    ),
    "paper_era": RuleSet(
        name="paper_era",
        description=(
            "ABC/WIBC rules as quoted by Frohlich (2004): RG 2.43-2.80 in, diff <= 0.08 in, "
            "static weights 3 oz top/bottom and 1 oz side/finger/thumb, balance holes allowed"
        ),
        weight_max_lb=16.0,
        diameter_min_in=8.500,
        diameter_max_in=8.595,
        rg_min_in=2.430,
        rg_max_in=2.800,
        differential_max_in=0.080,
        top_bottom_max_oz=3.0,
        side_max_oz=1.0,
        finger_thumb_max_oz=1.0,
        balance_hole_allowed=True,
        balance_holes_max=1,
    ),
}


@dataclass(frozen=True)
class Violation:
    """One broken rule: which rule, the ball's value, the limit, the rule set."""

    rule: str
    value: float
    limit: float
    unit: str
    rule_set: RuleSetName

    def __str__(self) -> str:
        return (
            f"{self.rule}: {self.value:.6g} {self.unit} (limit {self.limit:.6g} {self.unit}, "
            f"rule set '{self.rule_set}')"
        )


@dataclass(frozen=True)
class LegalityReport:
    """The result of a legality check: the ball, the rule set, and every violation found."""

    ball_name: str
    rule_set: RuleSetName
    violations: tuple[Violation, ...]

    @property
    def is_legal(self) -> bool:
        """True when no rule is violated."""
        return not self.violations

    @property
    def rules_violated(self) -> tuple[str, ...]:
        """The names of the violated rules."""
        return tuple(v.rule for v in self.violations)

    def error(self) -> IllegalBallError:
        """The error an illegal ball raises where it was not explicitly allowed: the ball, the
        rule set and one ``"rule value unit (limit L unit)"`` line per violation."""
        lines = [
            f"{v.rule} {v.value:.6g} {v.unit} (limit {v.limit:.6g} {v.unit})"
            for v in self.violations
        ]
        return IllegalBallError(self.ball_name, self.rule_set, lines)

    def __str__(self) -> str:
        head = f"ball {self.ball_name!r} under rule set '{self.rule_set}'"
        if self.is_legal:
            return f"{head}: legal"
        return f"{head}: ILLEGAL\n" + "\n".join(f"  - {v}" for v in self.violations)


def _rule_set(rules: RuleSetName | RuleSet) -> RuleSet:
    if isinstance(rules, RuleSet):
        return rules
    try:
        return RULE_SETS[rules]
    except KeyError:
        raise ValueError(
            f"rules = {rules!r} must be one of {sorted(RULE_SETS)} or a RuleSet"
        ) from None


def _max_rule(
    rule: str, value: float, limit: float, unit: str, slack: float, rs: RuleSet
) -> Iterator[Violation]:
    if value > limit + slack:
        yield Violation(rule, value, limit, unit, rs.name)


def _min_rule(
    rule: str, value: float, limit: float, unit: str, slack: float, rs: RuleSet
) -> Iterator[Violation]:
    if value < limit - slack:
        yield Violation(rule, value, limit, unit, rs.name)


def _ball_violations(ball: BowlerBall, rs: RuleSet) -> Iterator[Violation]:
    s = LIMIT_SLACK_IN
    yield from _max_rule("weight_max", ball.weight_lb, rs.weight_max_lb, "lb", 0.0, rs)
    yield from _min_rule("diameter_min", ball.diameter_in, rs.diameter_min_in, "in", s, rs)
    yield from _max_rule("diameter_max", ball.diameter_in, rs.diameter_max_in, "in", s, rs)
    yield from _min_rule("rg_min", ball.rg_min_in, rs.rg_min_in, "in", s, rs)
    yield from _max_rule("rg_max", ball.rg_max_in, rs.rg_max_in, "in", s, rs)
    yield from _max_rule(
        "differential_max", ball.differential_in, rs.differential_max_in, "in", s, rs
    )


def _hole_violations(
    gripping: int | None, balance_diameters: tuple[float, ...], balance_hole: bool, rs: RuleSet
) -> Iterator[Violation]:
    if gripping is not None:
        yield from _max_rule("gripping_holes", gripping, rs.gripping_holes_max, "holes", 0.0, rs)
    count = max(len(balance_diameters), 1 if balance_hole else 0)
    allowed = rs.balance_holes_max if rs.balance_hole_allowed else 0
    yield from _max_rule("balance_hole", count, allowed, "holes", 0.0, rs)
    if allowed:
        for d in balance_diameters:
            yield from _max_rule(
                "balance_hole_diameter",
                d,
                rs.balance_hole_diameter_max_in,
                "in",
                LIMIT_SLACK_IN,
                rs,
            )


def _static_violations(
    ball: BowlerBall, weights: StaticWeights, rs: RuleSet
) -> Iterator[Violation]:
    if not ball.weight_lb > _STATIC_WEIGHT_MIN_LB:
        return
    s = LIMIT_SLACK_OZ
    yield from _max_rule(
        "top_bottom_weight", abs(weights.top_oz), rs.top_bottom_max_oz, "oz", s, rs
    )
    yield from _max_rule("side_weight", abs(weights.side_oz), rs.side_max_oz, "oz", s, rs)
    yield from _max_rule(
        "finger_thumb_weight", abs(weights.finger_oz), rs.finger_thumb_max_oz, "oz", s, rs
    )


def check_legality(
    ball: BowlerBall,
    rules: RuleSetName | RuleSet = "current",
    *,
    static_weights: StaticWeights | None = None,
    balance_hole: bool = False,
    gripping_holes: int | None = None,
    balance_hole_diameters_in: tuple[float, ...] = (),
) -> LegalityReport:
    """Check ``ball`` (and its static weights and holes after drilling, if given) against a
    rule set. ``balance_hole``: the ball has (at least) one balance hole;
    ``balance_hole_diameters_in``: the diameter of each balance hole (in); ``gripping_holes``:
    the number of finger and thumb holes (none: not checked).

    Rules (names as reported): weight_max, diameter_min, diameter_max, rg_min (low RG),
    rg_max (high RG = RG + diff), differential_max, gripping_holes, balance_hole (count),
    balance_hole_diameter, top_bottom_weight, side_weight, finger_thumb_weight (the last three
    on |reading|, balls > 10 lb only).
    """
    rs = _rule_set(rules)
    found = list(_ball_violations(ball, rs))
    found += _hole_violations(gripping_holes, tuple(balance_hole_diameters_in), balance_hole, rs)
    if static_weights is not None:
        found += _static_violations(ball, static_weights, rs)
    return LegalityReport(ball_name=ball.name, rule_set=rs.name, violations=tuple(found))


def ensure_legal(
    ball: BowlerBall,
    rules: RuleSetName | RuleSet = "current",
    *,
    static_weights: StaticWeights | None = None,
    balance_hole: bool = False,
    allow_illegal: bool = False,
    gripping_holes: int | None = None,
    balance_hole_diameters_in: tuple[float, ...] = (),
) -> LegalityReport:
    """The legality report (:func:`check_legality`); raises :class:`IllegalBallError` for an
    illegal ball unless ``allow_illegal`` is True (then the report, with its violations, is
    returned)."""
    report = check_legality(
        ball,
        rules,
        static_weights=static_weights,
        balance_hole=balance_hole,
        gripping_holes=gripping_holes,
        balance_hole_diameters_in=balance_hole_diameters_in,
    )
    if not report.is_legal and not allow_illegal:
        raise report.error()
    return report

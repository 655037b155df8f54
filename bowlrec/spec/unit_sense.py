"""Values that look typed in another unit: warnings, never refusals.

A scene's fields have hard limits (:mod:`bowlrec.spec.limits`) far outside anything bowled, so
a value typed in the wrong unit (17 for a speed in m/s meant as mph) is valid and simulates
something no bowler throws. :func:`unit_warnings` names such a value when it lies outside the
range bowlers throw and, read in a unit people mix up with the field's, lands inside it:
``delivery.speed_mps = 17: above the 3.5-12 m/s bowlers throw; did you mean 17 mph (7.6 m/s)?``

The ranges: USBC's EARL robot covers 10-24 mph and 50-900 rpm, PBA League 2020 tracking
averages are 17.8-18.6 mph and 297-436 rpm; a ball weighs at most 16 lb (7.26 kg, USBC) and
house balls start near 6 lb. The speed range is widened to
8-27 mph (3.5-12 m/s) so that children's and the fastest deliveries pass without a word.

A scene silences the warnings with ``options.unit_warnings: false`` (a stress test or a
deliberately unusual delivery). The check reads the validated model's fields by name, so it
serves the physical :class:`~bowlrec.spec.Scene` and the bowlers' scene alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = ["RULES", "UnitRule", "unit_warnings"]

MPH_MPS = 0.44704
KMH_MPS = 1.0 / 3.6
LB_KG = 0.45359237
RPM_RADPS = math.pi / 30.0


@dataclass(frozen=True)
class UnitRule:
    """A field (``section.name``; ``norm``: the length of a vector field), its unit, the range
    bowlers throw in that unit, and the units it is mixed up with: (name, one of them in the
    field's unit)."""

    path: str
    unit: str
    low: float
    high: float
    others: tuple[tuple[str, float], ...]
    norm: bool = False
    what: str = "bowlers throw"

    def check(self, value: float) -> str | None:
        """The warning for ``value``, or None when it lies in the range bowlers throw."""
        if self.low <= value <= self.high:
            return None
        side = "below" if value < self.low else "above"
        line = (
            f"{self.path}{' (magnitude)' if self.norm else ''} = {value:g}: {side} the "
            f"{self.low:g}-{self.high:g} {self.unit} {self.what}"
        )
        meant = [
            f"{value:g} {name} ({value * factor:.3g} {self.unit})"
            for name, factor in self.others
            if self.low <= value * factor <= self.high
        ]
        if meant:
            line += f"; did you mean {' or '.join(meant)}?"
        return line


#: the checked fields of both scene kinds (a field a scene does not have is skipped)
RULES: tuple[UnitRule, ...] = (
    UnitRule("delivery.speed_mps", "m/s", 3.5, 12.0, (("mph", MPH_MPS), ("km/h", KMH_MPS))),
    UnitRule("delivery.omega_radps", "rad/s", 0.0, 95.0, (("rpm", RPM_RADPS),), norm=True),
    UnitRule("ball.mass_kg", "kg", 2.5, 7.3, (("lb", LB_KG),), what="a bowling ball weighs"),
    UnitRule(
        "delivery.speed_mph", "mph", 8.0, 27.0, (("m/s", 1 / MPH_MPS), ("km/h", KMH_MPS / MPH_MPS))
    ),
    UnitRule(
        "delivery.rev_rate_rpm", "rpm", 50.0, 900.0, (("rad/s", 1 / RPM_RADPS), ("rev/s", 60.0))
    ),
    UnitRule("ball.weight_lb", "lb", 5.5, 16.0, (("kg", 1 / LB_KG),), what="a bowling ball weighs"),
)


def _field(model: Any, path: str) -> Any:
    """The value of the model field at ``path`` (None when the model has no such field: a
    derived property of the same name does not count)."""
    node = model
    for name in path.split("."):
        if name not in getattr(type(node), "model_fields", {}):
            return None
        node = getattr(node, name)
    return node


def unit_warnings(model: Any) -> list[str]:
    """One line per value of ``model`` (a validated scene of either kind) that looks typed in
    another unit (module docstring); none when its ``options.unit_warnings`` is false."""
    options = getattr(model, "options", None)
    if options is not None and not getattr(options, "unit_warnings", True):
        return []
    out = []
    for rule in RULES:
        value = _field(model, rule.path)
        if value is None or isinstance(value, str | bool):
            continue
        if rule.norm:
            value = math.sqrt(sum(float(v) ** 2 for v in value))
        elif not isinstance(value, int | float):
            continue
        warning = rule.check(float(value))
        if warning is not None:
            out.append(f"{warning} (options.unit_warnings: false silences this)")
    return out

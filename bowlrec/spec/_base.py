"""Shared building blocks of the scene models: the base class, constrained float types, errors.

All quantities are SI (m, s, kg, rad) unless a field name says otherwise (``_deg``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field
from pydantic_core import PydanticCustomError

__all__ = [
    "FiniteFloat",
    "NonNegativeFloat",
    "PositiveFloat",
    "PositiveVec3",
    "Quat",
    "SpecModel",
    "Vec2",
    "Vec3",
    "fmt",
    "fmt_vec",
    "norm",
    "spec_error",
]

#: any finite float (nan and +-inf are rejected with "Input should be a finite number")
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
#: a finite float > 0
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
#: a finite float >= 0
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
#: a 3-vector of finite floats (lane frame unless documented otherwise)
Vec3 = tuple[FiniteFloat, FiniteFloat, FiniteFloat]
#: a 3-vector of finite floats, each > 0
PositiveVec3 = tuple[PositiveFloat, PositiveFloat, PositiveFloat]
#: a point or vector in the lane plane (x, y)
Vec2 = tuple[FiniteFloat, FiniteFloat]
#: a quaternion (w, x, y, z)
Quat = tuple[FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat]


class SpecModel(BaseModel):
    """Base of every scene model: unknown fields are rejected, floats must be finite, and
    instances are immutable (build a new one, or use ``model_copy(update=...)`` knowing that it
    skips validation)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


def spec_error(message: str) -> PydanticCustomError:
    """An error that Pydantic reports as-is (no "Value error, " prefix), type ``invalid_spec``."""
    return PydanticCustomError("invalid_spec", "{message}", {"message": message})


def fmt(x: float) -> str:
    """Shortest round-tripping text of a float (``repr``), e.g. ``0.1085``."""
    return repr(float(x))


def fmt_vec(v: Iterable[float]) -> str:
    """Text of a vector, e.g. ``(0.0, 30.0, 0.0)``."""
    return "(" + ", ".join(fmt(x) for x in v) + ")"


def norm(v: Iterable[float]) -> float:
    """Euclidean length of a vector (no NumPy needed; ``math.hypot``, which does not overflow
    for components near the float64 range)."""
    return math.hypot(*(float(x) for x in v))

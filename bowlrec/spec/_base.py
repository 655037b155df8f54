"""Shared building blocks of the scene models: the base class, constrained float types, errors.

All quantities are SI (m, s, kg, rad) unless a field name says otherwise (``_deg``).
"""

from __future__ import annotations

import functools
import math
import types
import typing
from collections.abc import Iterable
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator
from pydantic_core import InitErrorDetails, PydanticCustomError

__all__ = [
    "FiniteFloat",
    "NumbersModel",
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


@functools.cache
def _numbers_only(annotation: Any) -> bool:
    """Whether a field of this type holds numbers (``float``, ``int``, tuples or lists of them,
    optionally None) and no ``bool``: where ``true`` must not pass as 1."""
    origin = typing.get_origin(annotation)
    if annotation in (float, int):
        return True
    if origin is Annotated:
        return _numbers_only(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        arms = [a for a in typing.get_args(annotation) if a is not type(None)]
        return bool(arms) and all(_numbers_only(a) for a in arms)
    if origin in (tuple, list):
        args = [a for a in typing.get_args(annotation) if a is not Ellipsis]
        return bool(args) and all(_numbers_only(a) for a in args)
    return False


def _holds_bool(value: Any) -> bool:
    if isinstance(value, bool):
        return True
    return isinstance(value, list | tuple) and any(isinstance(v, bool) for v in value)


class NumbersModel(BaseModel):
    """A model whose number fields take numbers only: ``"speed_mps": true`` is an error naming
    the field, not 1 m/s (Pydantic's lax mode would read a boolean as 0 or 1)."""

    @model_validator(mode="before")
    @classmethod
    def _no_bool_for_numbers(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        for name, value in data.items():
            field = cls.model_fields.get(name) if _holds_bool(value) else None
            if field is not None and _numbers_only(typing.cast(Any, field.annotation)):
                # raised as the field's own error, so that the message names its path
                error = PydanticCustomError(
                    "number_type", "Input should be a number, not a boolean"
                )
                raise ValidationError.from_exception_data(
                    cls.__name__, [InitErrorDetails(type=error, loc=(name,), input=value)]
                )
        return data


class SpecModel(NumbersModel):
    """Base of every scene model: unknown fields are rejected, floats must be finite, a
    boolean is not a number, and instances are immutable (build a new one, or use
    ``model_copy(update=...)`` knowing that it skips validation)."""

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

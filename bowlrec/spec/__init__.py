"""Scene specification: Pydantic models of a delivery in SI units, validation, file loading and
resolution to the plain-number :class:`~bowlrec.core.plan.Plan`.

Imports only Pydantic, NumPy and (lazily, for .yaml files) PyYAML; never numba.
"""

from .air import Air
from .ball import Ball
from .delivery import Delivery
from .errors import format_validation_error
from .friction import ConstantFriction, Friction, TypicalFriction, Zone, ZoneFriction
from .lane import Lane, Topography
from .loading import dump_scene_json, load_scene
from .options import Options
from .scene import Scene

__all__ = [
    "Air",
    "Ball",
    "ConstantFriction",
    "Delivery",
    "Friction",
    "Lane",
    "Options",
    "Scene",
    "Topography",
    "TypicalFriction",
    "Zone",
    "ZoneFriction",
    "dump_scene_json",
    "format_validation_error",
    "load_scene",
]

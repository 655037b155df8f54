"""Scene specification: Pydantic models of a delivery in SI units, validation, the spec-file
reader and resolution to the plain-number :class:`~bowlrec.core.plan.Plan`.

The bottom of the scene stack: imports only Pydantic, NumPy and (lazily, for .yaml files)
PyYAML, never numba, and nothing of bowlrec above the numerics. A scene as a user gives it (a
file, a mapping, a bowler scene) comes in through :mod:`bowlrec.scene_input`.
"""

from .air import Air
from .ball import Ball
from .delivery import Delivery
from .errors import format_validation_error
from .friction import ConstantFriction, Friction, TypicalFriction, Zone, ZoneFriction
from .lane import Lane, Topography
from .loading import dump_scene_json
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
]

"""bowlrec: bowling-ball motion simulator (Frohlich 2004, exact equations of motion).

``import bowlrec`` is light: the compiled kernels (numba) load on the first simulation.

>>> import bowlrec
>>> traj = bowlrec.simulate("examples/paper/case16.json")  # doctest: +SKIP
>>> traj.summary.hook_m  # doctest: +SKIP
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"
#: version of the physics model and its numerics; part of every run's provenance
PHYSICS_VERSION = "frohlich2004-dp54-1"

if TYPE_CHECKING:
    from .api import simulate

__all__ = ["PHYSICS_VERSION", "__version__", "simulate"]


def __getattr__(name: str) -> Any:
    if name == "simulate":
        from .api import simulate

        return simulate
    raise AttributeError(f"module 'bowlrec' has no attribute {name!r}")

"""bowlrec: bowling-ball motion simulator (Frohlich 2004, exact equations of motion).

``import bowlrec`` is light: the compiled kernels (numba) load on the first simulation.

>>> import bowlrec
>>> traj = bowlrec.simulate("examples/paper/case16.json")  # doctest: +SKIP
>>> traj.summary.hook_m  # doctest: +SKIP
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .versions import BOWLER_LAYER_VERSION, PHYSICS_VERSION, __version__

if TYPE_CHECKING:
    from .api import simulate
    from .batch.many import simulate_many

__all__ = ["BOWLER_LAYER_VERSION", "PHYSICS_VERSION", "__version__", "simulate", "simulate_many"]


def __getattr__(name: str) -> Any:
    if name == "simulate":
        from .api import simulate

        return simulate
    if name == "simulate_many":
        from .batch.many import simulate_many

        return simulate_many
    raise AttributeError(f"module 'bowlrec' has no attribute {name!r}")

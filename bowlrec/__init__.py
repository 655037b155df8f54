"""bowlrec: bowling-ball motion simulator (Frohlich 2004, exact equations of motion).

``import bowlrec`` is light: the compiled kernels (numba) load on the first simulation.

>>> import bowlrec
>>> traj = bowlrec.simulate("examples/paper/case16.json")  # doctest: +SKIP
>>> traj.summary.hook_m  # doctest: +SKIP
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"
#: version of the physics model and its numerics; part of every run's provenance and run ID.
#: 2: radial slip layer, steps aimed at the layer, error-checked step to events, orientation
#: gain 10 (summary-only runs), Hairer's starting step after phase changes. At the default
#: rtol 1e-9 results moved by < 1e-6 m; at rtol 1e-6 slide distances by up to 6 mm.
#: 3: the state at an event from the dense output (no redone step), no step growth right after
#: a rejection and cuts at the observed order, full orientation weight (gain 1000). Over the
#: 218 benchmark deliveries results moved by < 7e-8 m at rtol 1e-9 and < 0.15 mm at 1e-6.
PHYSICS_VERSION = "frohlich2004-dp54-3"
#: version of the bowlers' layer (spec sheet, layout and PAP, delivery -> physical scene); part
#: of every run's provenance. 2: the PAP at +omega_hat for a right-hander, the grip facing the
#: bowler at release. Runs without it (or with 1) placed the PAP at the other end of the axis,
#: so their layout and side-weight labels describe the mirror-side ball.
BOWLER_LAYER_VERSION = 2

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

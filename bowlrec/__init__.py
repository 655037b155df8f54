"""bowlrec: bowling-ball motion simulator (Frohlich 2004, exact equations of motion).

``import bowlrec`` is light: the compiled kernels (numba) load on the first simulation.

>>> import bowlrec
>>> traj = bowlrec.simulate("examples/paper/case16.json")  # doctest: +SKIP
>>> traj.summary.hook_m  # doctest: +SKIP
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"
#: version of the physics model and its numerics; part of every run's provenance and run ID. It
#: changes whenever results change beyond rounding (CHANGELOG.md says what each version changed).
PHYSICS_VERSION = "frohlich2004-dp54-3"
#: version of the bowlers' layer (spec sheet, layout and PAP, delivery -> physical scene); part
#: of every run's provenance. Version 2 places the PAP at +omega_hat for a right-hander, grip
#: facing the bowler at release; in runs stored with 1 or without the field the PAP is at the
#: other end of the axis, so their layout and side-weight labels describe the mirror-side ball
#: (archive.provenance.bowler_layer_warning).
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

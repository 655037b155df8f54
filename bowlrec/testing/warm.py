"""Every compiled kernel, the paper's RK4 scheme included: for the tests and CI.

    python -m bowlrec.testing.warm [NAME ...] [--jobs N]

:func:`warm_up_all` is :func:`bowlrec.core.warm.warm_up` of ``all`` plus the kernels of
:mod:`bowlrec.testing.rk4` (when scipy is installed: numba links their ``np.linalg.solve`` from
scipy's LAPACK), which ``bowlrec.core`` may not import. The command does the same and prints one
line (seconds, kernels compiled, kernels loaded from numba's cache): run it before pytest-xdist's
workers start, so they load the kernels instead of each compiling them.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable

from bowlrec.core.warm import WarmUp, main, offset_plan, warm_up

__all__ = ["EXTRA", "warm_up_all"]


def _rk4() -> None:
    from bowlrec.testing.rk4 import paper_scheme

    paper_scheme(offset_plan(), dt=1e-2)


#: the kernels of bowlrec.testing by name (none without scipy)
EXTRA: dict[str, Callable[[], object]] = (
    {"rk4": _rk4} if importlib.util.find_spec("scipy") is not None else {}
)


def warm_up_all(jobs: int = 1) -> WarmUp:
    """Load or compile every kernel variant (:func:`bowlrec.core.warm.warm_up` of ``all``) and
    the paper's RK4 scheme; ``jobs`` > 1: in that many processes at once."""
    return warm_up("all", extra=EXTRA, jobs=jobs, module=__name__)


if __name__ == "__main__":
    raise SystemExit(main(extra=EXTRA, module=__spec__.name))

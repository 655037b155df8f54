"""Reference deliveries and reference solvers for tests and benchmarks (like ``numpy.testing``).

* :mod:`bowlrec.testing.scenes`: deterministic reference deliveries: the 18 Table III cases as
  written (:func:`~bowlrec.testing.scenes.table3_plans`) and fixed-seed random but realistic
  deliveries (:func:`~bowlrec.testing.scenes.random_plans`, and the scene dictionaries behind
  them, :func:`~bowlrec.testing.scenes.random_scene_dicts`);
* :mod:`bowlrec.testing.rk4`: the paper's scheme, fixed-step classical RK4 with the 1 cm/s
  slide -> roll rule on bowlrec's right-hand side (:func:`~bowlrec.testing.rk4.paper_scheme`;
  needs scipy).

``import bowlrec`` never imports this package, and importing it loads neither numba nor the
kernels: each name below loads its module on first access.

>>> from bowlrec.testing import paper_scheme, table3_plans
>>> paper_scheme(table3_plans()[0][1], dt=1e-3)["outcome"]  # doctest: +SKIP
'pins'
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .rk4 import paper_scheme
    from .scenes import random_plans, random_scene_dicts, table3_plans

__all__ = ["paper_scheme", "random_plans", "random_scene_dicts", "table3_plans"]

_MODULES = {
    "paper_scheme": "rk4",
    "random_plans": "scenes",
    "random_scene_dicts": "scenes",
    "table3_plans": "scenes",
}


def __getattr__(name: str) -> Any:
    module = _MODULES.get(name)
    if module is None:
        raise AttributeError(f"module 'bowlrec.testing' has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)

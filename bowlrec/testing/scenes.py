"""Reference deliveries as :class:`~bowlrec.core.plan.Plan` objects (summary-only recording).

* :func:`table3_plans`: the 18 Table III cases of Frohlich (2004) as written;
* :func:`random_plans`: fixed-seed random but realistic deliveries (non-scalar inertia with random
  principal axes, center-of-mass offsets, tilted spin, two kinds of lane);
* :func:`random_scene_dicts`: the scene dictionaries behind :func:`random_plans`.

The generator is deterministic (NumPy's ``default_rng`` with a fixed seed, draws in a fixed
order): the same arguments give the same scenes to the last bit, which the tests and the
benchmarks' stored results rely on. Changing a draw changes every scene after it.
"""

from __future__ import annotations

import math

import numpy as np

from bowlrec.core.plan import Plan
from bowlrec.paper import TABLE_III, paper_scene
from bowlrec.spec import Scene

__all__ = ["random_plans", "random_scene_dicts", "table3_plans"]

LANE_LENGTH_M = 18.288
LANE_WIDTH_M = 1.0668


def table3_plans() -> list[tuple[str, Plan]]:
    """The 18 Table III cases as written (oil to 40 ft, release on the lane center)."""
    out = []
    for c in TABLE_III:
        scene = paper_scene(c.case, "as_written")
        options = scene.options.model_copy(update={"record": "summary"})
        scene = scene.model_copy(update={"options": options})
        out.append((f"case{c.case:02d}", scene.resolve()))
    return out


def _unit(rng: np.random.Generator) -> np.ndarray:
    """A direction uniformly distributed on the unit sphere."""
    while True:
        v = rng.normal(size=3)
        n = float(np.linalg.norm(v))
        if n > 1e-6:
            return v / n


def _frame(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Two perpendicular unit vectors of a uniformly random orthonormal frame (Haar, via QR)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))  # makes the distribution uniform
    return q[:, 0].copy(), q[:, 1].copy()


def random_scene_dicts(n: int = 200, seed: int = 20261121) -> list[dict]:  # type: ignore[type-arg]
    """The scene dictionaries behind :func:`random_plans` (deterministic given ``seed``).

    Per delivery:

    * ball: low RG uniform in [6.2, 7.1] cm, RG differential (high - low) uniform in [0, 0.2] cm,
      intermediate differential (between the two high RGs) uniform in [0, half the
      differential]; principal axes of a uniformly random orthonormal frame; center-of-mass
      offset of length uniform in [0, 1] mm in a uniformly random direction;
    * delivery: x = 0, y uniform over the middle 60 % of the width; speed uniform in [6, 10] m/s;
      take-off angle uniform in [-3, +1] deg; |omega| uniform in [10, 60] rad/s. 80 % are
      bowling-like: the spin axis is turned from +y (forward roll) toward -x (to the rear of
      left, the hook of a right-hander) by an angle uniform in [-10, 80] deg and tilted by an
      angle uniform in [-20, 40] deg above the horizontal (so omega_y > 0); the other 20 % spin
      about a uniformly random direction;
    * lane: exactly half (a random half) the paper's typical pattern, the others a constant mu
      uniform in [0.04, 0.2].
    """
    rng = np.random.default_rng(seed)
    typical = np.zeros(n, dtype=bool)
    typical[rng.permutation(n)[: n // 2]] = True
    scenes = []
    for i in range(n):
        rg_low = rng.uniform(0.062, 0.071)
        diff = rng.uniform(0.0, 0.002)
        idiff = rng.uniform(0.0, 0.5 * diff)
        rg = (rg_low, rg_low + diff, rg_low + diff - idiff)
        a1, a2 = _frame(rng)
        offset = _unit(rng) * rng.uniform(0.0, 0.001)
        speed = rng.uniform(6.0, 10.0)
        toa = rng.uniform(-3.0, 1.0)
        y0 = rng.uniform(0.2 * LANE_WIDTH_M, 0.8 * LANE_WIDTH_M)
        w = rng.uniform(10.0, 60.0)
        bowling_like = rng.uniform() < 0.8
        turn = math.radians(rng.uniform(-10.0, 80.0))
        tilt = math.radians(rng.uniform(-20.0, 40.0))
        random_dir = _unit(rng)
        if bowling_like:
            d = np.array(
                [-math.sin(turn) * math.cos(tilt), math.cos(turn) * math.cos(tilt), math.sin(tilt)]
            )
        else:
            d = random_dir
        omega = w * d
        mu_const = rng.uniform(0.04, 0.2)
        friction = {"kind": "typical"} if typical[i] else {"kind": "constant", "mu": mu_const}
        scenes.append(
            {
                "name": f"random{i:03d}",
                "description": (
                    f"benchmark random delivery {i} (seed {seed}); "
                    + ("bowling-like spin" if bowling_like else "spin about a random axis")
                ),
                "ball": {
                    "mass_kg": 6.8,
                    "radius_m": 0.1085,
                    "rg_m": [float(v) for v in rg],
                    "axis_1": [float(v) for v in a1],
                    "axis_2": [float(v) for v in a2],
                    "com_offset_m": [float(v) for v in offset],
                },
                "lane": {"length_m": LANE_LENGTH_M, "width_m": LANE_WIDTH_M, "friction": friction},
                "delivery": {
                    "position_m": [0.0, float(y0)],
                    "speed_mps": float(speed),
                    "takeoff_angle_deg": float(toa),
                    "omega_radps": [float(v) for v in omega],
                },
                "options": {"record": "summary"},
            }
        )
    return scenes


def random_plans(n: int = 200, seed: int = 20261121) -> list[tuple[str, Plan]]:
    """``n`` random deliveries (see :func:`random_scene_dicts`) as (name, Plan), summary only."""
    return [(d["name"], Scene.model_validate(d).resolve()) for d in random_scene_dicts(n, seed)]

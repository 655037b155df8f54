"""Scene dictionaries for tests: a uniform-ish ball on a constant-friction lane by default,
every field overridable (SI units: m, m/s, rad/s, degrees for the take-off angle); the service
tests' summary-only and sampled scenes; a recorded grid job."""

from __future__ import annotations

from typing import Any


def scene(
    *,
    mu: float | dict[str, Any] = 0.12,
    omega: tuple[float, float, float] = (0.0, 30.0, 0.0),
    speed: float = 8.0,
    angle: float = 0.0,
    position: tuple[float, float] | None = None,
    rg: tuple[float, float, float] = (0.067, 0.067, 0.067),
    axis_1: tuple[float, float, float] = (1.0, 0.0, 0.0),
    axis_2: tuple[float, float, float] | None = None,
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
    lane: dict[str, Any] | None = None,
    **options: Any,
) -> dict[str, Any]:
    friction = {"kind": "constant", "mu": mu} if isinstance(mu, float) else mu
    return {
        "ball": {
            "rg_m": list(rg),
            "axis_1": list(axis_1),
            "axis_2": None if axis_2 is None else list(axis_2),
            "com_offset_m": list(offset),
        },
        "lane": {"friction": friction, **(lane or {})},
        "delivery": {
            "speed_mps": speed,
            "takeoff_angle_deg": angle,
            "omega_radps": list(omega),
            "position_m": None if position is None else list(position),
        },
        "options": options,
    }


def summary_scene(i: int, name: str = "svc") -> dict[str, Any]:
    """A distinct summary-only scene per ``i`` (closed-form solver: ~1 ms to simulate)."""
    return {
        "name": name,
        "delivery": {"speed_mps": round(6.0 + 0.001 * i, 6)},
        "options": {"record": "summary"},
    }


def sampled_scene() -> dict[str, Any]:
    """A spinning delivery recorded every 10 ms (the integrator), replayable as MCAP/RRD."""
    return {
        "name": "sampled",
        "delivery": {"speed_mps": 8.0, "omega_radps": [-16.62, 23.74, 7.765]},
        "options": {"record": "rate", "record_dt_s": 0.01},
    }


def recorded_speed_job(n: int, record_dt_s: float) -> dict[str, Any]:
    """A job of ``n`` default deliveries at speeds 7-8 m/s, each recorded every
    ``record_dt_s`` s and archived with its samples."""
    return {
        "base": {"options": {"record": "rate", "record_dt_s": record_dt_s}},
        "sweep": {
            "kind": "grid",
            "axes": {"delivery.speed_mps": {"start": 7.0, "stop": 8.0, "num": n}},
        },
        "record": "trajectory",
    }

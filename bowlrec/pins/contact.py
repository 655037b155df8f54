"""Restitution and friction per pair of surfaces, mapped to MuJoCo's soft contacts.

MuJoCo's contacts are soft: a contact acts as a spring and damper on the penetration, set by
``solref = (time constant, damping ratio)``, and it has no restitution setting. With a constant
impedance (``SOLIMP`` of :mod:`.model`) the contact's reference dynamics are those of a linear
oscillator whose damping ratio is the one given, so restitution falls as the damping ratio
rises and does not depend on the masses or the impact speed; for an ideal oscillator released
when its force vanishes, e = exp(-zeta pi / sqrt(1 - zeta^2)). MuJoCo's discrete solver departs
from that ideal, so the damping ratio for a wanted restitution is found by measurement:
:func:`dampratio_for` bisects on the damping ratio, measuring the restitution of a sphere
meeting a fixed box head on (gravity and friction off) in MuJoCo with the run's time step and
time constant, until it matches to :data:`RESTITUTION_TOL`. The tests measure the restitution
then achieved in the real pairs (ball-pin, pin-pin, pin-deck) and ``docs/pins.md`` reports it.

MuJoCo's contact still gives back a little energy when critically damped (e = 0.13 at the
default time step), so low restitutions need an over-damped contact (damping ratio above 1);
the asked restitution must lie in [:data:`MIN_RESTITUTION`, :data:`MAX_RESTITUTION`].
"""

from __future__ import annotations

import math
from functools import cache

__all__ = [
    "MAX_RESTITUTION",
    "MIN_RESTITUTION",
    "RESTITUTION_TOL",
    "dampratio_for",
    "measured_restitution",
]

#: the range of restitution a pair may ask for
MIN_RESTITUTION = 0.001
MAX_RESTITUTION = 0.95
#: how closely the calibration meets the asked restitution (absolute)
RESTITUTION_TOL = 1e-4
_SPEED_MPS = 3.0


def _oscillator_dampratio(e: float) -> float:
    """The damping ratio of an ideal linear oscillator with restitution ``e`` (0 < e < 1)."""
    log_e = math.log(e)
    return -log_e / math.sqrt(math.pi**2 + log_e**2)


@cache
def _probe(timestep_s: float, timeconst_s: float) -> tuple[object, object]:
    import mujoco

    xml = f"""<mujoco>
  <option timestep="{timestep_s!r}" gravity="0 0 0" integrator="implicitfast"/>
  <worldbody>
    <geom name="wall" type="box" pos="0 0 0" size="0.05 1 1" priority="1"
          friction="0 0 0" solref="{timeconst_s!r} 1.0" solimp="0.99 0.99 0.001 0.5 2"/>
    <body name="probe" pos="0.2 0 0">
      <freejoint/>
      <geom type="sphere" size="0.1" mass="1" friction="0 0 0"/>
    </body>
  </worldbody>
</mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def measured_restitution(dampratio: float, timestep_s: float, timeconst_s: float) -> float:
    """The restitution MuJoCo gives a sphere meeting a fixed box head on at 3 m/s with this
    damping ratio, time step (s) and time constant (s): the speed after it leaves the box over
    the speed before."""
    import mujoco

    model, data = _probe(timestep_s, timeconst_s)
    assert isinstance(model, mujoco.MjModel) and isinstance(data, mujoco.MjData)
    model.geom_solref[0] = (timeconst_s, dampratio)
    mujoco.mj_resetData(model, data)
    data.qpos[0] = 0.05 + 0.1 + 0.002  # 2 mm from the wall
    data.qvel[0] = -_SPEED_MPS
    steps = int(math.ceil(20.0 * timeconst_s / timestep_s)) + 50
    for _ in range(steps):
        mujoco.mj_step(model, data)
        if data.ncon == 0 and data.qvel[0] > 0.0:
            break
    return float(data.qvel[0]) / _SPEED_MPS


@cache
def dampratio_for(restitution: float, timestep_s: float, timeconst_s: float) -> float:
    """The damping ratio that gives ``restitution`` at this time step and time constant,
    measured (see the module's docstring); ValueError outside [MIN_RESTITUTION,
    MAX_RESTITUTION] or when the time step cannot reach it."""
    if not MIN_RESTITUTION <= restitution <= MAX_RESTITUTION:
        raise ValueError(
            f"restitution = {restitution} must be in [{MIN_RESTITUTION}, {MAX_RESTITUTION}]"
        )
    lo, hi = 1e-3, 100.0  # measured restitution falls from lo to hi
    if measured_restitution(lo, timestep_s, timeconst_s) < restitution:
        raise ValueError(
            f"restitution = {restitution} is out of reach at time step {timestep_s} s and "
            f"time constant {timeconst_s} s"
        )
    guess = _oscillator_dampratio(restitution) if restitution < 1.0 else math.nan
    for _ in range(80):
        # the ideal oscillator's value first, then bisection (geometric: the range spans 1e5)
        mid = guess if lo < guess < hi else math.sqrt(lo * hi)
        guess = math.nan
        e = measured_restitution(mid, timestep_s, timeconst_s)
        if abs(e - restitution) <= RESTITUTION_TOL:
            return mid
        if e > restitution:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi)

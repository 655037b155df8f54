"""The resolved, unit-free description of one delivery that the compiled kernels consume.

Everything here is SI (m, s, kg, rad) and plain floats / NumPy arrays. ``bowlrec.spec`` builds a
:class:`Plan` from a validated :class:`~bowlrec.spec.Scene`; nothing in ``bowlrec.core`` knows
about Pydantic, units or files.

Conventions (the paper's, Frohlich 2004):

* lane frame: x from the foul line toward the pins, y from the right gutter toward the left,
  z up; the ball's geometric center moves in the plane z = 0 and the lane surface is z = -R;
* body frame: the ball's principal axes; ``q0`` (w, x, y, z) rotates body vectors into the lane
  frame at release;
* ``r_delta_body``: the paper's r_Delta, the vector FROM the center of mass TO the geometric
  center, in the body frame (so a center of mass displaced toward +a has r_Delta along -a);
* the delivery's velocity is that of the geometric center.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .codes import LIFT_NONE, RECORD_STEPS, SLIDE_TO_ROLL_EXACT

#: Plan fields of the optional external terms: a Plan at their defaults is a flat lane in still
#: air without rolling resistance, and its run ID and stored resolved fields leave them out
#: (:func:`external_field_at_default`), so a scene that does not use them keeps the run ID
#: archived runs of the same scene have
EXTERNAL_FIELDS = (
    "drag_coefficient",
    "air_density_kg_m3",
    "lift_model",
    "rolling_resistance",
    "cross_slope",
    "profile_y_m",
    "profile_z_m",
)


@dataclass(frozen=True)
class PinPlan:
    """Pin action after the lane (``bowlrec.pins``): the pin model's version and parameters.

    Restitution (dimensionless, the normal speed after an impact over the speed before) and
    Coulomb friction (dimensionless) for each pair of surfaces; the ball's friction on the
    deck is the lane's under the ball where the pins take over. ``seed``: None sets nominal
    pins on their spots' centres; an integer draws each pin's mass, centre of gravity and
    spotting within USBC's tolerances. ``standing``: the pins set before the ball (1-10).
    """

    model_version: str
    ball_pin_restitution: float
    ball_pin_friction: float
    pin_pin_restitution: float
    pin_pin_friction: float
    pin_deck_restitution: float
    pin_deck_friction: float
    pin_kickback_restitution: float
    pin_kickback_friction: float
    #: the engine's time step (s) and the soft contacts' time constant (s)
    timestep_s: float = 1e-4
    contact_timeconst_s: float = 2e-3
    #: pin action stops when everything is at rest or at this time after the hand-off (s)
    max_time_s: float = 4.0
    #: sampling interval of the pins' and the ball's recorded motion (s)
    record_dt_s: float = 0.005
    seed: int | None = None
    standing: tuple[int, ...] = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10)
    #: standing pins off their spots: (pin, dx, dy), the base centre's offset from the spot (m)
    moved: tuple[tuple[int, float, float], ...] = ()
    #: whose names the leave gets: "right", "left" or "auto" (a ball moving left at the pins
    #: is a right-hander's)
    hand: str = "auto"


@dataclass(frozen=True)
class Plan:
    """One delivery in plain SI numbers.

    Attributes are documented with their units; arrays are float64.
    """

    mass_kg: float
    radius_m: float
    #: principal moments of inertia per unit mass, k_i**2 (m^2), about body axes 1, 2, 3
    inertia_per_mass_m2: NDArray[np.float64]
    #: r_Delta in the body frame (m): from the center of mass to the geometric center
    r_delta_body_m: NDArray[np.float64]
    #: orientation at release, unit quaternion (w, x, y, z), body -> lane frame
    q0: NDArray[np.float64]
    #: initial position of the geometric center in the lane plane (m)
    position0_m: NDArray[np.float64]
    #: initial velocity of the geometric center in the lane plane (m/s)
    velocity0_mps: NDArray[np.float64]
    #: initial angular velocity in the lane frame (rad/s)
    omega0_radps: NDArray[np.float64]
    lane_length_m: float
    lane_width_m: float
    #: friction grid: sorted x break points (m); cell i spans [x_edges[i-1], x_edges[i])
    friction_x_edges_m: NDArray[np.float64]
    #: friction grid: sorted y break points (m)
    friction_y_edges_m: NDArray[np.float64]
    #: friction coefficient per cell, shape (len(x_edges) + 1, len(y_edges) + 1)
    friction_mu: NDArray[np.float64]
    g_mps2: float = 9.81
    #: relative tolerance of the integrator (dimensionless)
    rtol: float = 1e-9
    record_mode: int = RECORD_STEPS
    #: sampling interval for RECORD_RATE (s)
    record_dt_s: float = 1e-3
    #: whether per-term torques are derived for every sample
    record_terms: bool = False
    slide_to_roll: int = SLIDE_TO_ROLL_EXACT
    #: slip speed below which the paper's rule declares rolling (m/s)
    slip_threshold_mps: float = 0.01
    #: slip speed below which sliding friction acts along the slaved direction (m/s); None picks
    #: a value from the tolerance (see ``bowlrec.core.arguments.slip_layer``)
    slip_layer_mps: float | None = None
    #: hard limit on simulated time (s)
    max_time_s: float = 60.0
    #: hard limit on accepted integrator steps
    max_steps: int = 2_000_000
    #: free-form labels carried to the result (not used by the physics)
    labels: dict[str, str] = field(default_factory=dict)
    #: pin action after the lane; None: the run ends at the pins (and its run ID leaves it out)
    pins: PinPlan | None = None
    # ---- optional external terms (none in the paper; all off by default; see
    # bowlrec.core.dynamics.external_accel and docs/lane-and-air.md) ----
    #: air drag coefficient C_D (dimensionless); 0: no drag
    drag_coefficient: float = 0.0
    #: density of the air (kg/m^3), for drag and lift
    air_density_kg_m3: float = 1.204
    #: Magnus lift model (LIFT_* code of bowlrec.core.codes); LIFT_NONE: no lift
    lift_model: int = LIFT_NONE
    #: rolling-resistance coefficient C_rr (dimensionless): a force C_rr M g against the motion
    rolling_resistance: float = 0.0
    #: lane height's slope across the lane dz/dy (dimensionless; > 0: the left side is higher)
    cross_slope: float = 0.0
    #: height profile across the lane: knots y (m, strictly ascending) ...
    profile_y_m: NDArray[np.float64] | None = None
    #: ... and the lane's heights there (m), joined by a natural cubic spline
    profile_z_m: NDArray[np.float64] | None = None

    @property
    def scalar_inertia(self) -> bool:
        """True when all three principal moments are equal (I_dev is exactly zero)."""
        k = self.inertia_per_mass_m2
        return bool(k[0] == k[1] == k[2])

    @property
    def has_offset(self) -> bool:
        """True when the center of mass is not at the geometric center."""
        return bool(np.any(self.r_delta_body_m != 0.0))

    @property
    def external_terms(self) -> bool:
        """True when any optional external term is on (drag, rolling resistance, lift, cross
        slope, height profile): the closed form and other flat-lane shortcuts do not apply."""
        return bool(
            self.drag_coefficient != 0.0
            or self.lift_model != LIFT_NONE
            or self.rolling_resistance != 0.0
            or self.cross_slope != 0.0
            or self.profile_y_m is not None
        )

    @property
    def constant_friction(self) -> bool:
        """True when the friction map has a single value (no zone events can happen)."""
        return bool(np.all(self.friction_mu == self.friction_mu.flat[0]))


@functools.cache
def _defaults() -> dict[str, Any]:
    """Each Plan field's default (``dataclasses.MISSING`` where it has none)."""
    return {f.name: f.default for f in fields(Plan)}


def external_field_at_default(plan: Plan, name: str) -> bool:
    """True when ``name`` is one of :data:`EXTERNAL_FIELDS` and ``plan`` has its default."""
    if name not in EXTERNAL_FIELDS:
        return False
    default = _defaults()[name]
    value = getattr(plan, name)
    if value is None or default is None:
        return value is None and default is None
    return bool(value == default)

"""The delivery as tracking systems report it (mph, rpm, degrees, boards, ft), for either hand,
and its exact conversion to and from the physical :class:`~bowlrec.spec.Delivery`.

Conventions (lane frame: x toward the pins, y from the RIGHT gutter toward the left, z up):

* **Speed** ``speed_mph``: speed of the ball's geometric center **at release** (not at the pins),
  the physical ``speed_mps = speed_mph * 0.44704``.
* **Rev rate** ``rev_rate_rpm``: |omega| at release, ``|omega| = rpm * 2 pi / 60`` rad/s.
* **Launch angle** ``launch_angle_deg``: angle of the release velocity to the boards (the x
  axis), **positive toward higher board numbers** of the bowler's own count (toward the lane's
  far side: to the left for a right-hander, to the right for a left-hander). A right-hander who
  swings the ball out toward the right gutter has a negative launch angle (USBC's EARL robot:
  -2.0 to -1.0 deg). Physical take-off angle (positive toward +y): ``+launch`` for a
  right-hander, ``-launch`` for a left-hander.
* **Target at the arrows** ``target_board_at_arrows``: the (fractional) board the center
  crosses 15 ft past the foul line. The ball curves on its way there, so a bowler scene solves
  the launch angle for which the simulated path crosses the target
  (:class:`~bowlrec.bowling.scene.Shot`); the straight line from the laydown point,
  ``tan(launch) = (target - laydown) * board_width / (15 ft - laydown_ft)``, is the sighting
  line the solver starts from (:meth:`BowlerDelivery.launch_angle_on`).
* **Laydown** ``laydown_board`` (bowler's own count, see :mod:`bowlrec.bowling.lane`) and
  ``laydown_ft`` (distance of the release point past the foul line): the initial position of the
  center.
* **Axis of rotation** (unit vector ``a`` along omega, expressed in the *travel frame*: t along
  the release velocity, n = z x t to the left of the travel, z up), for a right-hander::

      omega = |omega| (-sin(rot) cos(tilt) t + cos(rot) cos(tilt) n + sin(tilt) z)

  - ``axis_rotation_deg`` (rot): 0 = end over end (forward roll: omega points to the left of the
    travel, the contact point is at rest when v = |omega| R), 90 = side roll. **Positive makes
    the ball hook toward higher boards**: for a right-hander omega gains a component along -t
    (the ball turns counter-clockwise seen from behind), the contact point slides toward the right
    gutter and friction pushes the ball to the left.
  - ``axis_tilt_deg`` (tilt): angle of the rotation axis to the lane plane, **positive when a
    right-hander's ball spins counter-clockwise seen from above** (omega_z > 0; a left-hander's
    clockwise): the fingers leave the ball on its bowling-hand side and turn that side forward
    (fingers at the right side moving toward +x give omega along +z), which is the spin of the
    paper's Table III combination case (omega 15 deg above horizontal, hooking left). The
    positive axis point (PAP, +omega for a right-hander: to the ball's left and back toward
    the bowler) is then the raised end of the axis, and the track, the ring of contact points
    of the rolling ball, is the small circle 90 + tilt deg from the PAP: more tilt gives a
    smaller, lower track (:mod:`bowlrec.bowling.layout`).
  - A left-hander is the exact mirror image through the x-z plane: rotation, tilt, launch angle
    and boards keep their numbers and meaning, and the physical state is mirrored
    (:func:`mirror_delivery`).
* **Mirroring an angular velocity.** The reflection S = diag(1, -1, 1) (y -> -y) maps polar
  vectors by S and axial vectors (omega) by det(S) S = -S, so omega = (a, b, c) -> (-a, b, -c):
  forward roll (along +y) is kept, side roll (x) and spin (z) change sign.

Round trips ``BowlerDelivery -> Delivery -> BowlerDelivery`` and back are exact to rounding
(about 1e-15 relative) away from the axis singularity at tilt = +-90 deg (pure spin), where the
axis rotation is undefined and reported as 0.
"""

from __future__ import annotations

import math

from pydantic import Field, model_validator

from bowlrec.spec import Delivery
from bowlrec.spec._base import (
    FiniteFloat,
    NonNegativeFloat,
    PositiveFloat,
    SpecModel,
    fmt,
    spec_error,
)
from bowlrec.units import ARROWS_FT, BOARDS, FT_M, MPH_MPS, RPM_RADPS

from .lane import BowlerLane, Handedness
from .styles import STYLE_NAMES, STYLES, Style

__all__ = [
    "BowlerDelivery",
    "Vec3",
    "axis_angles_deg",
    "hooking_delivery",
    "mirror_delivery",
    "mirror_omega",
    "omega_from_axis",
]

#: a 3-vector of floats (lane frame)
Vec3 = tuple[float, float, float]
#: lowest / highest fractional board a ball's center can be on: the lane's edges
_BOARD_MIN = 0.5
_BOARD_MAX = BOARDS + 0.5


def mirror_omega(omega: Vec3) -> Vec3:
    """Mirror image of an angular velocity (axial vector) through the x-z plane:
    (a, b, c) -> (-a, b, -c)."""
    a, b, c = omega
    return (-a, b, -c)


def _rotate_z(v: Vec3, angle_rad: float) -> Vec3:
    """``v`` rotated by ``angle_rad`` about +z (counter-clockwise seen from above)."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1], v[2])


def omega_from_axis(
    rev_rate_rpm: float,
    axis_rotation_deg: float,
    axis_tilt_deg: float,
    heading_deg: float,
    handedness: Handedness,
) -> Vec3:
    """Lane-frame angular velocity (rad/s) of a ball traveling at ``heading_deg`` (angle of the
    velocity to +x, positive toward +y) with the given rev rate and axis angles (module doc)."""
    w = rev_rate_rpm * RPM_RADPS
    rot, tilt = math.radians(axis_rotation_deg), math.radians(axis_tilt_deg)
    travel: Vec3 = (
        -w * math.sin(rot) * math.cos(tilt),
        w * math.cos(rot) * math.cos(tilt),
        w * math.sin(tilt),
    )
    if handedness == "left":
        travel = mirror_omega(travel)
    return _rotate_z(travel, math.radians(heading_deg))


def axis_angles_deg(omega: Vec3, heading_deg: float, handedness: Handedness) -> tuple[float, float]:
    """(axis rotation, axis tilt) in degrees of a lane-frame angular velocity for a ball
    traveling at ``heading_deg`` (inverse of :func:`omega_from_axis`).

    Rotation is in (-180, 180], tilt in [-90, 90]. Where the axis rotation is undefined (a pure
    spin, tilt = +-90 deg) it is 0; for omega = 0 both angles are 0."""
    a, b, c = _rotate_z(omega, -math.radians(heading_deg))
    if handedness == "left":
        a, b, c = mirror_omega((a, b, c))
    rotation = math.degrees(math.atan2(-a, b))
    tilt = math.degrees(math.atan2(c, math.hypot(a, b)))
    return rotation + 0.0, tilt + 0.0  # + 0.0 turns -0.0 into 0.0


def mirror_delivery(delivery: Delivery, lane: BowlerLane) -> Delivery:
    """The mirror image of a physical delivery through the lane's center line: y -> width - y,
    take-off angle -> -take-off angle, omega (a, b, c) -> (-a, b, -c). A release position of
    None (the lane center) stays None."""
    position = delivery.position_m
    mirrored = None if position is None else (position[0], lane.mirror_y_m(position[1]))
    return Delivery(
        position_m=mirrored,
        speed_mps=delivery.speed_mps,
        takeoff_angle_deg=-delivery.takeoff_angle_deg,
        omega_radps=mirror_omega(delivery.omega_radps),
    )


#: the physical limits (bowlrec.spec.limits) in bowlers' units, rounded down
MAX_SPEED_MPH = 220.0
MAX_REV_RATE_RPM = 9500.0


class BowlerDelivery(SpecModel):
    """A delivery in tracking-system terms (mph, rpm, degrees, boards, ft); see the module doc
    for every zero and sign. Give the direction either as ``launch_angle_deg`` or as
    ``target_board_at_arrows`` (not both; neither means launch angle 0). With ``style``, the
    release quantities not given take that bowler type's typical values
    (:mod:`bowlrec.bowling.styles`)."""

    style: Style | None = Field(
        default=None,
        description=(
            f"Bowler type ({' | '.join(STYLE_NAMES)}): speed_mph, rev_rate_rpm, "
            "axis_rotation_deg and axis_tilt_deg not given take the type's typical values "
            "(docs/calibration.md); null: the fields' own defaults."
        ),
    )
    handedness: Handedness = Field(
        default="right",
        description="Bowling hand: 'right' or 'left'. Boards are counted from this hand's gutter.",
    )
    speed_mph: PositiveFloat = Field(
        default=17.0,
        le=MAX_SPEED_MPH,
        description=(
            f"Speed of the ball's center at release (mph), in (0, {MAX_SPEED_MPH:g}]; "
            "1 mph = 0.44704 m/s."
        ),
    )
    rev_rate_rpm: NonNegativeFloat = Field(
        default=300.0,
        le=MAX_REV_RATE_RPM,
        description=(
            f"Rev rate |omega| at release (revolutions per minute), in [0, "
            f"{MAX_REV_RATE_RPM:g}]; a bowler scene needs > 0 (its layout is placed by the "
            "spin axis)."
        ),
    )
    axis_rotation_deg: FiniteFloat = Field(
        default=45.0,
        ge=-180.0,
        le=180.0,
        description=(
            "Axis rotation (deg) in [-180, 180]: 0 = end over end, 90 = side roll; positive "
            "hooks toward higher boards (left for a right-hander)."
        ),
    )
    axis_tilt_deg: FiniteFloat = Field(
        default=0.0,
        ge=-90.0,
        le=90.0,
        description=(
            "Axis tilt (deg) in [-90, 90]: angle of the rotation axis to the lane plane, "
            "positive when the ball spins counter-clockwise seen from above for a right-hander "
            "(clockwise for a left-hander), as a bowler's fingers turn it."
        ),
    )
    laydown_board: FiniteFloat = Field(
        default=20.0,
        ge=_BOARD_MIN,
        le=_BOARD_MAX,
        description=(
            "Board of the release point (fractional; integer = board center), counted from the "
            "bowling hand's gutter, in [0.5, 39.5] (the lane's edges)."
        ),
    )
    laydown_ft: NonNegativeFloat = Field(
        default=0.0,
        description="Distance of the release point past the foul line (ft), >= 0.",
    )
    launch_angle_deg: FiniteFloat | None = Field(
        default=None,
        gt=-90.0,
        lt=90.0,
        description=(
            "Angle of the release velocity to the boards (deg) in (-90, 90), positive toward "
            "higher boards (negative = outward, toward the bowling hand's gutter). null: solved "
            "from target_board_at_arrows, or 0 if that is null too."
        ),
    )
    target_board_at_arrows: FiniteFloat | None = Field(
        default=None,
        ge=_BOARD_MIN,
        le=_BOARD_MAX,
        description=(
            "Board (fractional) the ball's center crosses at the arrows, 15 ft past the foul "
            "line, in [0.5, 39.5]; a bowler scene solves the launch angle that makes its path "
            "cross it (to 1e-6 board)."
        ),
    )

    @model_validator(mode="before")
    @classmethod
    def _style_fills_release(cls, data: object) -> object:
        """A style gives the release quantities the delivery does not give itself."""
        if isinstance(data, dict) and isinstance(data.get("style"), str):
            preset = STYLES.get(data["style"])
            if preset is not None:
                return {**preset.typical(), **data}
        return data

    @model_validator(mode="after")
    def _target_needs_laydown_before_arrows(self) -> BowlerDelivery:
        """A target at the arrows needs a release point short of the arrows, and no launch
        angle beside it (the target decides the angle)."""
        if self.target_board_at_arrows is not None and self.launch_angle_deg is not None:
            raise spec_error(
                f"launch_angle_deg = {fmt(self.launch_angle_deg)} and target_board_at_arrows = "
                f"{fmt(self.target_board_at_arrows)}: give only one (the launch angle is solved "
                "from the target)"
            )
        if self.target_board_at_arrows is not None and not self.laydown_ft < ARROWS_FT:
            raise spec_error(
                f"laydown_ft = {fmt(self.laydown_ft)} must be < {fmt(ARROWS_FT)} (the arrows) "
                f"when target_board_at_arrows = {fmt(self.target_board_at_arrows)} is given"
            )
        return self

    # --- derived quantities --------------------------------------------------------------

    @property
    def speed_mps(self) -> float:
        """Release speed (m/s)."""
        return self.speed_mph * MPH_MPS

    @property
    def rev_rate_radps(self) -> float:
        """Rev rate |omega| (rad/s)."""
        return self.rev_rate_rpm * RPM_RADPS

    def launch_angle_on(self, lane: BowlerLane) -> float:
        """The launch angle (deg, positive toward higher boards) on ``lane``: the explicit one,
        or, with a target at the arrows, the sighting line from the laydown point straight to
        it (where a bowler scene's aim solver starts), or 0."""
        if self.target_board_at_arrows is None:
            return 0.0 if self.launch_angle_deg is None else self.launch_angle_deg
        return _angle_to_target_deg(
            lane, self.laydown_board, self.laydown_ft, self.target_board_at_arrows
        )

    def takeoff_angle_on(self, lane: BowlerLane, launch_angle_deg: float | None = None) -> float:
        """Physical take-off angle (deg, positive toward +y, the left) on ``lane`` of the
        launch angle ``launch_angle_deg`` (None: :meth:`launch_angle_on`)."""
        launch = self.launch_angle_on(lane) if launch_angle_deg is None else launch_angle_deg
        return launch if self.handedness == "right" else -launch

    def mirrored(self) -> BowlerDelivery:
        """The same delivery by the other hand (every number kept; the physics mirrors)."""
        other: Handedness = "left" if self.handedness == "right" else "right"
        return BowlerDelivery.model_validate({**self.model_dump(), "handedness": other})

    # --- conversions ---------------------------------------------------------------------

    def to_physical(self, lane: BowlerLane, launch_angle_deg: float | None = None) -> Delivery:
        """The physical :class:`~bowlrec.spec.Delivery` (SI, lane frame) on ``lane``, launched
        at ``launch_angle_deg`` (deg, toward higher boards; None: :meth:`launch_angle_on`, the
        sighting line for a target at the arrows: a bowler scene passes the solved angle).

        Raises ValueError if the release point is not on the lane (laydown_ft >= length)."""
        x = lane.ft_to_x_m(self.laydown_ft)
        if not x < lane.length_m:
            raise ValueError(
                f"laydown_ft = {fmt(self.laydown_ft)} must be < the lane length "
                f"{fmt(lane.length_ft)} ft"
            )
        takeoff = self.takeoff_angle_on(lane, launch_angle_deg)
        return Delivery(
            position_m=(x, lane.board_to_y_m(self.laydown_board, self.handedness)),
            speed_mps=self.speed_mps,
            takeoff_angle_deg=takeoff,
            omega_radps=omega_from_axis(
                self.rev_rate_rpm,
                self.axis_rotation_deg,
                self.axis_tilt_deg,
                takeoff,
                self.handedness,
            ),
        )

    @classmethod
    def from_physical(
        cls,
        delivery: Delivery,
        lane: BowlerLane,
        handedness: Handedness = "right",
    ) -> BowlerDelivery:
        """The bowler's description of a physical delivery on ``lane`` by ``handedness``, its
        direction as ``launch_angle_deg`` (the board crossed at the arrows depends on the ball
        and the oil: :func:`bowlrec.bowling.report.bowler_report` reports it). A release
        position of None is the lane center on the foul line, as in the physical model."""
        x, y = delivery.position_m or (0.0, lane.width_m / 2.0)
        takeoff = delivery.takeoff_angle_deg
        launch = takeoff if handedness == "right" else -takeoff
        rotation, tilt = axis_angles_deg(delivery.omega_radps, takeoff, handedness)
        laydown_board = lane.y_to_board(y, handedness)
        laydown_ft = lane.x_m_to_ft(x)
        fields: dict[str, object] = {
            "handedness": handedness,
            "speed_mph": delivery.speed_mps / MPH_MPS,
            "rev_rate_rpm": math.sqrt(sum(w * w for w in delivery.omega_radps)) / RPM_RADPS,
            "axis_rotation_deg": rotation,
            "axis_tilt_deg": tilt,
            "laydown_board": laydown_board,
            "laydown_ft": laydown_ft,
            "launch_angle_deg": launch,
        }
        return cls.model_validate(fields)


def hooking_delivery() -> BowlerDelivery:
    """A right-hander's typical hooking delivery: 17 mph, 300 rpm, 45 deg axis rotation and
    10 deg tilt, laid down on board 15 and over board 10 at the arrows (the second arrow).
    The default of a bowler scene and the examples' and tests' reference delivery."""
    return BowlerDelivery(
        speed_mph=17.0,
        rev_rate_rpm=300.0,
        axis_rotation_deg=45.0,
        axis_tilt_deg=10.0,
        laydown_board=15.0,
        target_board_at_arrows=10.0,
    )


def _angle_to_target_deg(
    lane: BowlerLane, laydown_board: float, laydown_ft: float, target_board: float
) -> float:
    """Launch angle (deg, toward higher boards) from the laydown point to the target board at
    the arrows."""
    across = (target_board - laydown_board) * lane.board_width_m
    along = (ARROWS_FT - laydown_ft) * FT_M
    return math.degrees(math.atan2(across, along))

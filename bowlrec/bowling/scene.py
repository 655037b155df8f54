"""A scene in bowlers' language and the shot it makes.

:class:`BowlerScene`: ball spec sheet + layout + PAP + static weights, lane and oil pattern,
delivery as a tracking system reports it. :meth:`BowlerScene.to_scene` resolves it to the
physical :class:`~bowlrec.spec.Scene` (SI, lane frame); the kernel never sees these units.
A scene mapping is a bowler scene when its top level has ``"format": "bowler"``
(:mod:`bowlrec.scene_input`, the one way in for a scene, takes both kinds).

:class:`Shot`: a bowler scene's fixed parts (ball, layout, lane and oil) ready to run many
releases fast, and the launch angle that sends the ball over its target board at the arrows.
Aiming, the pocket search and release scatter run the same ball on the same lane hundreds of
times with different releases. A shot resolves the lane's friction grid once and, per release,
only what the release changes (the ball's orientation, which follows the spin axis, and the
initial state: :func:`bowlrec.spec.resolve.release_state`), so its plans are identical to those
of :meth:`BowlerScene.to_scene` for the same release, at a fraction of the cost.

**Crossing the target at the arrows.** On its way to the arrows the ball already curves (it
slides on oil with a side component of friction), so the straight sighting line from the
laydown point misses the target by about a board. The launch angle is solved so that the
simulated path crosses ``target_board_at_arrows`` at 15 ft: the secant method on the board
crossed there, observed by the kernel without restarting it (:mod:`bowlrec.core.observe`),
to ``TARGET_TOLERANCE_BOARDS``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from bowlrec.core.codes import RECORD_SUMMARY
from bowlrec.core.plan import Plan
from bowlrec.core.trajectory import Trajectory
from bowlrec.errors import AimError
from bowlrec.spec import Ball, Delivery, Lane, Options, Scene
from bowlrec.spec._base import FiniteFloat, SpecModel, fmt, spec_error
from bowlrec.spec.resolve import release_state
from bowlrec.units import ARROWS_FT, FT_M

from .ball import BowlerBall, CenterOfMassMark, StaticWeights
from .delivery import BowlerDelivery, hooking_delivery
from .drilling import DrilledBall, GripDrilling, drill_ball
from .lane import BowlerLane
from .layout import PAP, DualAngle, Layout, resolve_ball
from .legality import LegalityReport, RuleSetName, check_legality
from .oil import KegelPattern, RectanglePattern, preset, preset_names, unknown_preset
from .oil_friction import OilFrictionMapping, pattern_friction
from .surface import check_surface

__all__ = ["TARGET_TOLERANCE_BOARDS", "BowlerScene", "Shot", "heading"]

#: how closely the solved path crosses the target board at the arrows (boards)
TARGET_TOLERANCE_BOARDS = 1e-6
#: secant iterations before the arrows target is declared out of reach
_MAX_ITERATIONS = 12
#: the largest change of the launch angle in one iteration (deg)
_MAX_STEP_DEG = 3.0


def _default_ball() -> BowlerBall:
    return BowlerBall(
        name="example 15 lb symmetric",
        weight_lb=15.0,
        rg_in=2.50,
        differential_in=0.050,
        core_type="symmetric",
        coverstock="reactive_pearl",
        surface=1500,
    )


def _named_levels_schema(schema: dict[str, Any]) -> None:
    """The JSON Schema of ``oil_friction``: a mapping or one of the two named level sets."""
    mapping = {k: v for k, v in schema.items() if k not in ("description", "title")}
    for k in mapping:
        del schema[k]
    schema["anyOf"] = [mapping, {"type": "string", "enum": ["paper", "calibrated"]}]


class BowlerScene(SpecModel):
    """One delivery described as bowlers, drillers and coaches write it (lb, in, oz, mph, rpm,
    boards, ft, deg). Every field has a default: ``BowlerScene()`` is a right-hander's 17 mph,
    300 rpm, 45 deg rotation delivery of a 15 lb symmetric pearl ball drilled 45 x 4.5 x 30 on
    the paper's typical pattern."""

    format: Literal["bowler"] = Field(
        default="bowler", description="Marks a bowler-language scene file; always 'bowler'."
    )
    name: str = Field(
        default="bowler-scene",
        max_length=200,
        description="Short identifier (at most 200 characters).",
    )
    description: str = Field(default="", description="Free text.")
    ball: BowlerBall = Field(default_factory=_default_ball, description="The spec sheet.")
    layout: Layout = Field(
        default_factory=lambda: DualAngle(
            drilling_angle_deg=45.0, pin_to_pap_in=4.5, val_angle_deg=30.0
        ),
        description="Where the pin and PSA sit relative to the PAP (dual_angle | vls | ...).",
    )
    pap: PAP = Field(
        default_factory=lambda: PAP(over_in=5.0, up_in=0.5),
        description="The bowler's positive axis point from the center of grip (in), hand.",
    )
    balance: StaticWeights | CenterOfMassMark | None = Field(
        default=None,
        description="Static weights measured after drilling (oz) or a center-of-mass mark; "
        "measured values win over those computed from drilled holes; none: computed from "
        "drilling if given, else balanced.",
    )
    drilling: GripDrilling | None = Field(
        default=None,
        description="The grip drilled into the ball (finger, thumb and extra holes); its mass "
        "properties replace the spec sheet's (bowlrec drill). None: the spec sheet's ball.",
    )
    undrilled_cg: CenterOfMassMark | None = Field(
        default=None,
        description="With drilling: the undrilled ball's CG mark (over / up from the center of "
        "grip, in) with its top weight (oz) as static_oz, from the spec sheet; none: balanced.",
    )
    roll_about_pap_deg: FiniteFloat = Field(
        default=0.0,
        description="Rotation of the ball about the PAP at release (deg); 0 turns the center "
        "of grip toward the bowler (thumb above the fingers), as at release.",
    )
    lane: BowlerLane = Field(default_factory=BowlerLane, description="Lane geometry (ft, in).")
    pattern: str | KegelPattern | RectanglePattern = Field(
        default="paper_typical",
        description="Oil pattern: a preset name (`bowlrec patterns` lists them) or a pattern "
        "sheet.",
    )
    oil_friction: OilFrictionMapping = Field(
        default_factory=OilFrictionMapping,
        description="Oil depth -> friction mapping, or 'paper' (Frohlich's 0.04 oiled / 0.20 "
        "dry) or 'calibrated' (the default: levels fitted to published ball motion, "
        "docs/calibration.md).",
        json_schema_extra=_named_levels_schema,
    )
    delivery: BowlerDelivery = Field(
        default_factory=hooking_delivery,
        description="The delivery as a tracking system reports it.",
    )
    options: Options = Field(default_factory=Options, description="Solver and recording.")
    rules: RuleSetName = Field(
        default="current", description="USBC rule set the ball is checked against."
    )
    balance_hole: bool = Field(default=False, description="The ball has a balance hole.")
    allow_illegal: bool = Field(
        default=False, description="Simulate a ball that fails the rule set (reported)."
    )

    @field_validator("oil_friction", mode="before")
    @classmethod
    def _named_mapping(cls, value: object) -> object:
        """'paper' and 'calibrated' name the two sets of friction levels."""
        if value == "paper":
            return OilFrictionMapping.paper()
        if value == "calibrated":
            return OilFrictionMapping()
        if isinstance(value, str):
            raise spec_error(
                f"oil_friction = {value!r}: give 'paper', 'calibrated' or a mapping "
                "(mu_oil, mu_dry, ...)"
            )
        return value

    @field_validator("pattern")
    @classmethod
    def _known_pattern(
        cls, pattern: str | KegelPattern | RectanglePattern
    ) -> str | KegelPattern | RectanglePattern:
        """A name is one of the bundled presets (checked at the field, so a job checks every
        listed name before its first run)."""
        if isinstance(pattern, str) and pattern not in preset_names():
            raise spec_error(unknown_preset("pattern", pattern))
        return pattern

    @field_validator("delivery")
    @classmethod
    def _spinning(cls, delivery: BowlerDelivery) -> BowlerDelivery:
        """The layout is placed by the spin axis, which a ball without spin does not have."""
        if not delivery.rev_rate_rpm > 0.0:
            raise spec_error(
                f"rev_rate_rpm = {fmt(delivery.rev_rate_rpm)}: a bowler scene needs a spinning "
                "ball (rev_rate_rpm > 0), because its layout (PAP) is placed by the spin axis; "
                "for a ball without spin, write a physical scene"
            )
        return delivery

    @model_validator(mode="after")
    def _consistent(self) -> BowlerScene:
        if self.pap.handedness != self.delivery.handedness:
            raise spec_error(
                f"pap.handedness = {self.pap.handedness!r} must equal delivery.handedness = "
                f"{self.delivery.handedness!r} (one bowler throws the ball)"
            )
        if self.oil_friction.cover_model == "ranked":
            try:
                check_surface(self.ball.surface, "ball.surface")
            except ValueError as err:
                raise spec_error(str(err)) from None
        return self

    def pattern_model(self) -> KegelPattern | RectanglePattern:
        """The oil pattern as a model (a preset loaded by name)."""
        return preset(self.pattern) if isinstance(self.pattern, str) else self.pattern

    def drilled(self) -> DrilledBall | None:
        """The ball with :attr:`drilling` drilled into it (None without drilling)."""
        if self.drilling is None:
            return None
        return drill_ball(
            self.ball, self.layout, self.pap, self.drilling, undrilled_cg=self.undrilled_cg
        )

    def measured_weights(self, mass_kg: float) -> StaticWeights | None:
        """:attr:`balance` as static weights (oz) of a ball of ``mass_kg`` (None: not given)."""
        if isinstance(self.balance, CenterOfMassMark):
            return self.balance.as_static_weights(mass_kg, self.ball.radius_in, self.pap.handedness)
        return self.balance

    def legality(self, drilled: DrilledBall | None = None) -> LegalityReport:
        """The ball checked against :attr:`rules`: the drilled ball (its holes, and the
        measured static weights where given, else the computed ones) with drilling, else the
        spec sheet with the static weights when given. ``drilled``: :meth:`drilled`, when the
        caller has it."""
        drilled = self.drilled() if drilled is None and self.drilling is not None else drilled
        if drilled is not None:
            return check_legality(
                drilled.drilled_spec(),
                self.rules,
                static_weights=drilled.static_weights(self.measured_weights(drilled.mass_kg)),
                gripping_holes=drilled.gripping_holes,
                balance_hole_diameters_in=drilled.balance_hole_diameters_in,
                balance_hole=self.balance_hole,
            )
        weights = self.balance if isinstance(self.balance, StaticWeights) else None
        return check_legality(
            self.ball, self.rules, static_weights=weights, balance_hole=self.balance_hole
        )

    def physical_lane(self) -> Lane:
        """The physical lane with the pattern's friction for this ball's cover."""
        friction = pattern_friction(
            self.pattern_model(),
            lane_width_m=self.lane.width_m,
            length_m=self.lane.length_m,
            coverstock=self.ball.coverstock,
            surface=self.ball.surface,
            mapping=self.oil_friction,
        )
        if isinstance(self.pattern, str):  # index runs by the preset's name
            friction = friction.model_copy(update={"pattern": self.pattern})
        return self.lane.to_physical(friction)

    def to_scene(self) -> Scene:
        """The physical scene. With a target at the arrows the launch angle is solved so that
        the path crosses it (:class:`Shot`). Raises IllegalBallError for
        an illegal ball unless ``allow_illegal``, AimError for a target out of reach."""
        drilled = self.drilled()
        report = self.legality(drilled)
        if not report.is_legal and not self.allow_illegal:
            raise report.error()
        shot = Shot(self, drilled=drilled)
        launch = shot.launch_angle(self.delivery)
        return shot.physical_scene(self.delivery.to_physical(self.lane, launch))


def heading(takeoff_angle_deg: float) -> tuple[float, float, float]:
    """Unit lane-frame direction of a release at ``takeoff_angle_deg`` (positive toward +y)."""
    a = math.radians(takeoff_angle_deg)
    return (math.cos(a), math.sin(a), 0.0)


class Shot:
    """One bowler scene's ball and lane, run for many releases (module docstring).

    ``lane`` is the scene's physical lane and ``drilled`` its drilled ball (with drilling)
    when the caller has them already."""

    def __init__(
        self, scene: BowlerScene, lane: Lane | None = None, drilled: DrilledBall | None = None
    ) -> None:
        self.scene = scene
        self.lane = scene.physical_lane() if lane is None else lane
        self.drilled = (
            scene.drilled() if drilled is None and scene.drilling is not None else drilled
        )
        self._plan = self.physical_scene(scene.delivery.to_physical(scene.lane)).resolve()
        self.arrows_x_m = scene.lane.ft_to_x_m(ARROWS_FT)

    # --- one release ---------------------------------------------------------------------

    def physical_scene(self, delivery: Delivery) -> Scene:
        """The physical scene of ``delivery`` with this shot's ball, lane and options (pin
        action, when asked for with ``hand`` left at auto, names the leave for the bowler's
        hand)."""
        s = self.scene
        options = s.options
        pins = options.pin_options
        if pins is not None and pins.hand == "auto":
            hand = s.delivery.handedness
            options = options.model_copy(update={"pins": pins.model_copy(update={"hand": hand})})
        return Scene(
            name=s.name,
            description=s.description,
            ball=self.ball(delivery),
            lane=self.lane,
            delivery=delivery,
            options=options,
        )

    def ball(self, delivery: Delivery) -> Ball:
        """The physical ball laid out for ``delivery``'s spin axis and direction: the drilled
        ball (measured static weights win over computed ones) with drilling, else the spec
        sheet's."""
        s = self.scene
        if self.drilled is not None:
            return self.drilled.to_ball(
                s.pap,
                delivery.omega_radps,
                roll_about_pap_deg=s.roll_about_pap_deg,
                measured=s.measured_weights(self.drilled.mass_kg),
                travel_dir_lane=heading(delivery.takeoff_angle_deg),
            )
        return resolve_ball(
            s.ball,
            s.layout,
            s.pap,
            delivery.omega_radps,
            roll_about_pap_deg=s.roll_about_pap_deg,
            balance=s.balance,
            travel_dir_lane=heading(delivery.takeoff_angle_deg),
        )

    def plan(self, delivery: Delivery, *, summary_only: bool = True) -> Plan:
        """The Plan of ``delivery`` (physical) with this shot's ball and lane; summary only
        unless ``summary_only`` is False (then the scene's own recording options)."""
        plan = replace(
            self._plan, **release_state(self.ball(delivery), delivery, self.lane.width_m)
        )
        return replace(plan, record_mode=RECORD_SUMMARY) if summary_only else plan

    def run(
        self, delivery: Delivery, stations_m: Sequence[float] = (), turns: bool = False
    ) -> Trajectory:
        """Summary-only run of ``delivery`` observing ``stations_m`` (x, m) and ``turns``."""
        from bowlrec.core.solver import run_plan

        return run_plan(self.plan(delivery), "auto", stations_m, turns)

    def arrows_board(self, delivery: BowlerDelivery, launch_angle_deg: float) -> float | None:
        """The board the center crosses at the arrows when ``delivery`` is launched at
        ``launch_angle_deg`` (deg, toward higher boards); None if it never gets there."""
        return self.board_at(delivery, launch_angle_deg, self.arrows_x_m)

    def board_at(
        self, delivery: BowlerDelivery, launch_angle_deg: float, x_m: float
    ) -> float | None:
        """The board the center crosses at ``x_m`` (m from the foul line) when ``delivery`` is
        launched at ``launch_angle_deg``; None if it never gets there."""
        traj = self.run(delivery.to_physical(self.scene.lane, launch_angle_deg), [x_m])
        for ob in traj.observations:
            if ob.station == 0:
                return self.scene.lane.y_to_board(ob.position_m[1], delivery.handedness)
        return None

    # --- the launch angle through the target ---------------------------------------------

    def launch_angle(self, delivery: BowlerDelivery) -> float:
        """The launch angle (deg, toward higher boards) of ``delivery``: its explicit one, or
        the one whose path crosses its target at the arrows (module docstring). Raises
        :class:`AimError` when the target cannot be reached."""
        target = delivery.target_board_at_arrows
        if target is None:
            return delivery.launch_angle_on(self.scene.lane)
        return self._solve_target(delivery, target)

    def _solve_target(self, delivery: BowlerDelivery, target: float) -> float:
        lane = self.scene.lane
        # d(board at the arrows) / d(launch angle) along a straight line, boards per degree
        along = (ARROWS_FT - delivery.laydown_ft) * FT_M
        slope = along / lane.board_width_m * math.pi / 180.0
        a0 = delivery.launch_angle_on(lane)
        b0 = self.arrows_board(delivery, a0)
        if b0 is None:
            raise AimError(
                f"target_board_at_arrows = {fmt(target)}: launched at the sighting line "
                f"({a0:.4f} deg) from board {fmt(delivery.laydown_board)} the ball does not "
                "reach the arrows"
            )
        best = (abs(b0 - target), a0, b0)
        a1 = a0 - (b0 - target) / slope
        for _ in range(_MAX_ITERATIONS):
            # at most _MAX_STEP_DEG from the last angle that reached the arrows
            a1 = max(a0 - _MAX_STEP_DEG, min(a0 + _MAX_STEP_DEG, a1))
            b1 = self.arrows_board(delivery, a1)
            if b1 is None:  # it does not get there (the gutter first): half the step
                a1 = 0.5 * (a0 + a1)
                continue
            if abs(b1 - target) <= TARGET_TOLERANCE_BOARDS:
                return a1
            best = min(best, (abs(b1 - target), a1, b1))
            if b1 == b0:
                break
            a0, a1, b0 = a1, a1 - (b1 - target) * (a1 - a0) / (b1 - b0), b1
        raise AimError(
            f"target_board_at_arrows = {fmt(target)}: no launch angle found that makes the "
            f"ball cross it at the arrows from board {fmt(delivery.laydown_board)} (closest: "
            f"board {best[2]:.3f} at {best[1]:.4f} deg); the board crossed there need not "
            "change steadily with the angle where the ball starts on dry boards"
        )

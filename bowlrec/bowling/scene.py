"""A scene in bowlers' language: ball spec sheet + layout + PAP + static weights, lane and oil
pattern, delivery as a tracking system reports it. :meth:`BowlerScene.to_scene` resolves it to
the physical :class:`~bowlrec.spec.Scene` (SI, lane frame); the kernel never sees these units.

A file is read as a bowler scene when its top level has ``"format": "bowler"``
(:func:`bowlrec.spec.load_scene` and every CLI command that takes a scene accept both).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator, model_validator

from bowlrec.errors import IllegalBallError
from bowlrec.spec import Lane, Options, Scene
from bowlrec.spec._base import FiniteFloat, SpecModel, fmt, spec_error

from .ball import BowlerBall, CenterOfMassMark, StaticWeights
from .delivery import BowlerDelivery, hooking_delivery
from .drilling import DrilledBall, GripDrilling, drill_ball
from .lane import BowlerLane
from .layout import PAP, DualAngle, Layout
from .legality import LegalityReport, RuleSetName, check_legality
from .oil import KegelPattern, RectanglePattern, preset, preset_names
from .oil_friction import OilFrictionMapping, pattern_friction
from .shot import Shot
from .surface import check_surface

__all__ = ["BowlerScene"]


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


class BowlerScene(SpecModel):
    """One delivery described as bowlers, drillers and coaches write it (lb, in, oz, mph, rpm,
    boards, ft, deg). Every field has a default: ``BowlerScene()`` is a right-hander's 17 mph,
    300 rpm, 45 deg rotation delivery of a 15 lb symmetric pearl ball drilled 45 x 4.5 x 30 on
    the paper's typical pattern."""

    format: Literal["bowler"] = Field(
        default="bowler", description="Marks a bowler-language scene file; always 'bowler'."
    )
    name: str = Field(default="bowler-scene", description="Short identifier.")
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
        description="Oil pattern: a preset name (bowlrec patterns list) or a pattern sheet.",
    )
    oil_friction: OilFrictionMapping = Field(
        default_factory=OilFrictionMapping,
        description="Oil depth -> friction mapping (default: the paper's 0.04 oiled / 0.20 dry).",
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
        if isinstance(self.pattern, str) and self.pattern not in preset_names():
            raise spec_error(
                f"pattern = {self.pattern!r} is not a preset; presets: {', '.join(preset_names())}"
            )
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
        the path crosses it (:class:`~bowlrec.bowling.shot.Shot`). Raises IllegalBallError for
        an illegal ball unless ``allow_illegal``, AimError for a target out of reach."""
        drilled = self.drilled()
        report = self.legality(drilled)
        if not report.is_legal and not self.allow_illegal:
            raise IllegalBallError(report)
        shot = Shot(self, drilled=drilled)
        launch = shot.launch_angle(self.delivery)
        return shot.physical_scene(self.delivery.to_physical(self.lane, launch))

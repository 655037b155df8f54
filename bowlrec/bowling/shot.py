"""A bowler scene's fixed parts (ball, layout, lane and oil) ready to run many releases fast,
and the launch angle that sends the ball over its target board at the arrows.

Aiming, the pocket search and release scatter run the same ball on the same lane hundreds of
times with different releases. :class:`Shot` resolves the lane's friction grid once and, per
release, only what the release changes (the ball's orientation, which follows the spin axis, and
the initial state: :func:`bowlrec.spec.resolve.release_state`), so its plans are identical to
those of :meth:`BowlerScene.to_scene` for the same release, at a fraction of the cost.

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
from typing import TYPE_CHECKING

from bowlrec.core.codes import RECORD_SUMMARY
from bowlrec.core.plan import Plan
from bowlrec.core.trajectory import Trajectory
from bowlrec.errors import AimError
from bowlrec.spec import Ball, Delivery, Lane, Scene
from bowlrec.spec._base import fmt
from bowlrec.spec.resolve import release_state
from bowlrec.units import ARROWS_FT, FT_M

from .delivery import BowlerDelivery
from .drilling import DrilledBall
from .layout import resolve_ball

if TYPE_CHECKING:
    from .scene import BowlerScene

__all__ = ["TARGET_TOLERANCE_BOARDS", "Shot", "heading"]

#: how closely the solved path crosses the target board at the arrows (boards)
TARGET_TOLERANCE_BOARDS = 1e-6
#: secant iterations before the arrows target is declared out of reach
_MAX_ITERATIONS = 12
#: the largest change of the launch angle in one iteration (deg)
_MAX_STEP_DEG = 3.0


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
        """The physical scene of ``delivery`` with this shot's ball, lane and options."""
        s = self.scene
        return Scene(
            name=s.name,
            description=s.description,
            ball=self.ball(delivery),
            lane=self.lane,
            delivery=delivery,
            options=s.options,
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
        traj = self.run(delivery.to_physical(self.scene.lane, launch_angle_deg), [self.arrows_x_m])
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

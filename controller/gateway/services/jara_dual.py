"""JARA_ARM_DUAL service: both arms together, transport-independent (mm, deg, %).

Both arms start and stop together (one time law); speeds are the slower of the two arms'
JARA_ARM settings. Hands: servoOFFHand keeps the grippers where they are and refuses gripper
commands (STATUS_ERR) until servoONHand; the grippers share the drives' power with the arms,
so servo power itself is switched by servoONArm/servoOFFArm. getRelativePosition (ruling):
the left control point in the right control-point frame.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from controller.conversions import se3_to_hg
from controller.errors import ArgumentError, Refused
from controller.gateway.planning.jara_arm import CarPos
from controller.gateway.services.arguments import finite_values
from controller.gateway.services.jara_arm import JaraArmService
from controller.vocabulary import FrameType, ReturnCode, RightLeft

_NAMES = {RightLeft.RIGHT: "rArm", RightLeft.LEFT: "lArm"}


class JaraDualService:
    def __init__(self, arms: JaraArmService):
        self.arms = arms
        self.ctx = arms.ctx

    def require_dual(self) -> None:
        if set(self.arms.arms) != {RightLeft.RIGHT, RightLeft.LEFT}:
            raise Refused(
                ReturnCode.VALUE_ERR, "this robot has one arm: the dual-arm interface needs two"
            )

    # ------------------------------------------------------------------ power
    def servo_arms(self, on: bool) -> None:
        self.require_dual()
        self.ctx.call("servo_on" if on else "servo_off")

    def servo_hands(self, on: bool) -> None:
        self.require_dual()
        if on and not self.ctx.snapshot().servo_on:
            raise Refused(ReturnCode.STATUS_ERR, "the arms are servo off: call servoONArm first")
        self.arms.hands_on = on

    # ------------------------------------------------------------------ grippers
    def grippers(self, ratios: dict[RightLeft, float | None]) -> None:
        """Grippers to ``ratios`` (0 closed .. 1 open; None: leave that side)."""
        self.require_dual()
        if not self.arms.hands_on:
            raise Refused(ReturnCode.STATUS_ERR, "the hands are servo off: call servoONHand first")
        for side, ratio in ratios.items():
            if ratio is not None and not self.arms.has_gripper(side):
                raise ArgumentError(f"the {side.name} arm has no gripper")
        for side, ratio in ratios.items():
            if ratio is not None:
                self.ctx.call("gripper", side=side, ratio=ratio)

    # ------------------------------------------------------------------ moves
    def move_linear(self, targets: dict[RightLeft, CarPos], relative: bool) -> str | None:
        self.require_dual()
        return self.arms.dual_linear(targets, relative)

    def move_ptp_cartesian(self, targets: dict[RightLeft, CarPos], relative: bool) -> str | None:
        self.require_dual()
        return self.arms.dual_ptp_cartesian(targets, relative)

    def move_ptp_joint(
        self, values: dict[RightLeft, Sequence[float]], relative: bool
    ) -> str | None:
        """Both arms' joints [deg], one value per joint and arm."""
        self.require_dual()
        checked = {}
        for side, vals in values.items():
            n = len(self.arms.arms[side].joint_names)
            name = _NAMES[side]
            if len(vals) != n:
                raise ArgumentError(f"{name}: expected {n} joint values, got {len(vals)}")
            checked[side] = finite_values(vals, name)
        return self.arms.dual_ptp_joint(checked, relative)

    # ------------------------------------------------------------------ queries
    def relative_position(self) -> np.ndarray:
        """The left control point in the right control-point frame: HgMatrix (3 x 4, [mm])."""
        self.require_dual()
        with self.ctx.view.at(self.ctx.snapshot()) as kin:
            right = kin.pose(RightLeft.RIGHT, FrameType.CURRENT_FRAME)
            left = kin.pose(RightLeft.LEFT, FrameType.CURRENT_FRAME)
            return se3_to_hg(right.actInv(left))

"""Cartesian soft limits (JARA_ARM ``setSoftLimitCartesian``), supervised every cycle.

A control point that leaves its box while the robot moves raises alarm 0x5
(CARTESIAN_SOFT_LIMIT); the alarm stops motion.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from controller.contract.motion_specs import CartesianBox
from controller.control.core import MotionCore
from controller.model.alarms import AlarmCode
from controller.vocabulary import FrameType, RightLeft


class CartesianSoftLimits:
    """One box per arm; checked against the measured control-point pose."""

    def __init__(self, core: MotionCore):
        self.core = core
        self.boxes: dict[RightLeft, CartesianBox] = {}

    def __bool__(self) -> bool:
        return bool(self.boxes)

    def set(self, side: RightLeft, box: CartesianBox | None) -> None:
        """Set ``side``'s box, or remove it (``None``)."""
        if box is None:
            self.boxes.pop(side, None)
        else:
            self.boxes[side] = box

    def check(self) -> None:
        """Raise CARTESIAN_SOFT_LIMIT for the first control point outside its box."""
        for side, box in self.boxes.items():
            pose = self.core.kin.pose(side, FrameType.CURRENT_FRAME)
            p = pin.SE3(box.base_offset).actInv(pose).translation
            if np.any(p < box.lower) or np.any(p > box.upper):
                mm = ", ".join(f"{1e3 * x:.1f}" for x in p)
                self.core.raise_alarm(
                    AlarmCode.CARTESIAN_SOFT_LIMIT,
                    f"{side.name.lower()}_arm",
                    f"{side.name} control point at ({mm}) mm left the Cartesian soft limit",
                )
                return

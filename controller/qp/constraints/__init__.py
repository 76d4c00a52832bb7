"""The QP's constraints: the protocol (:mod:`.protocol`) and the robot's own limits.

* :class:`JointBox`: velocity, acceleration, braking distance, frozen joints (the box);
  both levels, hard.
* :class:`AxisLimit`: held redundant axes and axis ranges; both levels, relaxed to
  "no further", then dropped.
* :class:`DifferentialDrive`: no sideways base motion; both levels, hard.

How to add one: docs/qp.md.
"""

from controller.qp.constraints.axes import AxisLimit, AxisRows
from controller.qp.constraints.braking import BRAKING_SHARE, braking_speed
from controller.qp.constraints.drive import DifferentialDrive
from controller.qp.constraints.joint_box import JointBox
from controller.qp.constraints.protocol import (
    INF,
    BoxConstraint,
    Constraint,
    ConstraintSetup,
    CycleState,
    Level,
    Relaxation,
    RowBlock,
)

__all__ = [
    "BRAKING_SHARE",
    "INF",
    "AxisLimit",
    "AxisRows",
    "BoxConstraint",
    "Constraint",
    "ConstraintSetup",
    "CycleState",
    "DifferentialDrive",
    "JointBox",
    "Level",
    "Relaxation",
    "RowBlock",
    "braking_speed",
]

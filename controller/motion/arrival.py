"""When a motion has arrived: every task of the IK within its tolerance of its target.

The motion core ends a motion only once its time law has ended, the robot is at rest and
:func:`off_target` finds nothing off (see ``MotionCore._finish_motion`` in
:mod:`controller.control.core`).
Tolerances are well above what the closed loop reaches on perfect drives (~1e-7) and well
below what a client can see; regularisation (level-0 posture) tasks do not count.
"""

from __future__ import annotations

import math

import numpy as np

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis
from controller.qp.tasks import ROTATION_SCALE, AxisTask, ControlPointTask, PostureTask, Task

#: Control point: position [m] and orientation [rad].
POSITION_TOL = 2e-4
ANGLE_TOL = math.radians(0.1)
#: Joint tracking (PTP, streams): [rad or m].
JOINT_TOL = 2e-4
#: Redundant axes: linear [m], angular [rad].
AXIS_TOL = (2e-4, math.radians(0.1))
#: An elbow task counts only while its weight is at least this share of its base weight
#: (it fades out as the arm stretches and the angle loses meaning).
ELBOW_WEIGHT_SHARE = 0.25

_LINEAR = (RedundantAxis.VEHICLE_X, RedundantAxis.VEHICLE_Y)


def hold_posture(kin: Kinematics, tasks: list[Task]) -> None:
    """Once a motion's time law has ended: the regularisation (level-0 posture) tasks keep
    the posture the robot has now instead of pulling on toward the one it started from.

    Pulling all joints toward the start posture trades some joints' errors for others' along
    the tasks' null space (SmartPal V's two lumbar joints against both held arms after a
    waist bend): a drift of a few mrad/s that decays over seconds, on target all along but
    never at rest. What the regularisation is for (a tame redundancy on the way) is over
    once the targets stop moving.
    """
    for task in tasks:
        if isinstance(task, PostureTask) and task.level == 0:
            task.reference[task.joints] = kin.q[task.joints]


def off_target(kin: Kinematics, tasks: list[Task]) -> str | None:
    """None when every task is within tolerance at ``kin``'s last update; else what is off
    (a short text in interface units)."""
    for task in tasks:
        if isinstance(task, ControlPointTask):
            err = task.error(kin)
            pos, ang = float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:]))
            if pos > POSITION_TOL or ang > ANGLE_TOL:
                return (
                    f"{task.side.name} control point {pos * 1e3:.2f} mm and "
                    f"{math.degrees(ang):.2f} deg from its target"
                )
        elif isinstance(task, AxisTask):
            if task.axis.is_elbow and task.weight[0] < ELBOW_WEIGHT_SHARE * task.base_weight:
                continue
            off = abs(task.error(kin))
            linear = task.axis in _LINEAR
            if off > AXIS_TOL[0 if linear else 1]:
                shown = f"{off * 1e3:.2f} mm" if linear else f"{math.degrees(off):.2f} deg"
                return f"{task.axis.value} {shown} from its target"
        elif isinstance(task, PostureTask) and task.level >= 1:
            gap = np.abs(task.reference[task.joints] - kin.q[task.joints])
            if gap.size and float(gap.max()) > JOINT_TOL:
                k = int(np.argmax(gap))
                name = kin.joint_names[int(task.joints[k])]
                off = float(gap[k])
                revolute = kin.robot.joints[name].kind == "revolute"
                shown = f"{math.degrees(off):.3f} deg" if revolute else f"{off * 1e3:.2f} mm"
                return f"{name} {shown} from its target"
    return None


def tracking_error(kin: Kinematics, tasks: list[Task]) -> float:
    """The largest distance [m] between a task's target and the measured state at ``kin``'s
    last update: control points as position plus ``ROTATION_SCALE`` × angle, angular axes and
    joints as ``ROTATION_SCALE`` × angle (regularisation tasks and faded elbows left out)."""
    worst = 0.0
    for task in tasks:
        if isinstance(task, ControlPointTask):
            err = task.error(kin)
            off = float(np.linalg.norm(err[:3])) + ROTATION_SCALE * float(np.linalg.norm(err[3:]))
        elif isinstance(task, AxisTask):
            if task.axis.is_elbow and task.weight[0] < ELBOW_WEIGHT_SHARE * task.base_weight:
                continue
            off = abs(task.error(kin)) * (1.0 if task.axis in _LINEAR else ROTATION_SCALE)
        elif isinstance(task, PostureTask) and task.level >= 1 and len(task.joints):
            gap = np.abs(task.reference[task.joints] - kin.q[task.joints])
            off = ROTATION_SCALE * float(gap.max())
        else:
            continue
        worst = max(worst, off)
    return worst

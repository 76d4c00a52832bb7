"""How far an arm can reach and how fast its control point can go: cheap bounds from the
kinematic chain, checked before any path is sampled.

For a chain of revolute joints the distance between two consecutive joint origins does not
depend on the configuration (each origin lies on its joint's axis), and neither does the
distance from the last one to the control point. Their sum bounds how far the control point
can get from the first joint that may move: a target beyond it is refused in microseconds
instead of by sampling a path to it (a 1e9 mm target once took the gateway to 23 GB). When
the vehicle may move, the chain's anchor may go anywhere in the vehicle workspace.

The same sums bound the control point's speed: each joint moves it at most by its speed
times its distance from the control point along the chain.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis
from controller.vocabulary import RightLeft

#: Slack on the reach bound [m] (rounding, the IK's position tolerance).
REACH_SLACK = 1e-3


def _chain(kin: Kinematics, side: RightLeft, with_lumbar: bool) -> tuple[np.ndarray, list[str]]:
    """Control point and the origins of the joints that may move, from the control point up
    (original frame [m]), with the joints' names."""
    model, data = kin.model, kin.data
    robot = kin.robot
    names = set(robot.unit_joints(f"{side.name}_ARM"))
    if with_lumbar:
        names |= set(robot.unit_joints("LUMBER"))
    arm = robot.profile.arms[side.name]  # type: ignore[index]
    flange = model.frames[model.getFrameId(arm.flange, pin.BODY)]
    original = kin.original_frame
    points = [kin.pose(side).translation.copy()]
    joints: list[str] = []
    jid = flange.parentJoint
    while jid > 0:
        if model.names[jid] in names:
            points.append(original.actInv(data.oMi[jid]).translation.copy())
            joints.append(model.names[jid])
        jid = model.parents[jid]
    return np.array(points), joints


def reach(kin: Kinematics, side: RightLeft, with_lumbar: bool) -> tuple[float, np.ndarray]:
    """Largest distance [m] of ``side``'s control point from the anchor (the origin of the
    topmost joint that may move, original frame [m]), whatever the joints do."""
    points, _ = _chain(kin, side, with_lumbar)
    radius = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
    return radius, points[-1]


def out_of_reach(
    kin: Kinematics,
    side: RightLeft,
    target: pin.SE3,
    allowed: dict[RedundantAxis, bool],
    workspace: tuple[np.ndarray, np.ndarray] | None,
) -> str | None:
    """Why ``target`` (original frame) is beyond any reach of ``side``, or None.

    ``allowed``: the redundant axes the move may use (the waist joins the chain when a lumbar
    axis is allowed, the vehicle lets the chain's anchor roam its ``workspace``)."""
    lumbar = any(use and axis.is_lumbar for axis, use in allowed.items())
    vehicle = any(use and axis.is_vehicle for axis, use in allowed.items())
    radius, anchor = reach(kin, side, lumbar)
    p = target.translation
    if vehicle and workspace is not None and kin.has_vehicle:
        lo, hi = workspace
        body = kin.original_frame.actInv(kin.body_pose()).translation
        swing = float(np.hypot(*(anchor - body)[:2]))  # the anchor turns about the body
        dx = max(lo[0] - p[0], 0.0, p[0] - hi[0])
        dy = max(lo[1] - p[1], 0.0, p[1] - hi[1])
        distance = math.hypot(max(math.hypot(dx, dy) - swing, 0.0), p[2] - anchor[2])
        where = "anywhere the vehicle may take it"
    else:
        distance = float(np.linalg.norm(p - anchor))
        where = "from where it is"
    if distance <= radius + REACH_SLACK:
        return None
    return (
        f"the target is {1e3 * distance:.0f} mm from the {side.name} arm's base {where}, "
        f"beyond its reach ({1e3 * radius:.0f} mm)"
    )


def speed_limit(kin: Kinematics, side: RightLeft) -> tuple[float, float]:
    """Fastest the control point of ``side`` can go with only its arm moving, every joint
    at its speed limit: translation [m/s], rotation [rad/s] (upper bounds)."""
    points, joints = _chain(kin, side, with_lumbar=False)
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    along = np.cumsum(lengths)  # distance from joint k to the control point along the chain
    speeds = np.array([kin.robot.joints[n].velocity for n in joints])
    return float(speeds @ along), float(speeds.sum())

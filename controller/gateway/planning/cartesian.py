"""Spec A Cartesian moves: linear (straight line, the redundant axes under the mask) and
PTP (joint interpolation to the IK solution), absolute or relative. SI in, a checked spec
out, or Refused(CANNOT_REACH_TARGET_ERR) / ArgumentError."""

from __future__ import annotations

import pinocchio as pin

from controller.contract.motion_specs import MotionSpec
from controller.contract.snapshot import Snapshot
from controller.errors import ArgumentError, Refused
from controller.gateway.planning.limits import require_pose_duration
from controller.gateway.planning.planner import Planner
from controller.gateway.planning.redundancy import Range
from controller.gateway.planning.relative import relative_pose
from controller.model.redundant_axes import RedundantAxis
from controller.vocabulary import ReturnCode, RightLeft


def plan_linear(
    planner: Planner,
    snap: Snapshot,
    side: RightLeft,
    goal: pin.SE3,
    speed: tuple[float, float],
    accel: tuple[float, float],
    tool_frame: bool | None,
    allowed: dict[RedundantAxis, bool],
    ranges: dict[RedundantAxis, Range | None],
    hold_other: bool,
    target_name: str,
) -> MotionSpec:
    """A straight-line move of ``side``'s control point to ``goal`` (original frame; with
    ``tool_frame`` False/True, relative to where it is in the original / control-point frame)
    at ``speed`` [m/s, rad/s] and ``accel`` [m/s², rad/s²]."""
    q0 = planner.base_q(snap, queued=False)
    with planner.view.at(snap, q0) as kin:
        start = kin.pose(side)
    if tool_frame is not None:
        goal = relative_pose(start, goal, tool_frame=tool_frame)
    require_pose_duration(start, goal, speed, accel)
    try:
        spec, _ = planner.cartesian(
            snap,
            q0,
            side,
            goal,
            speed,
            accel,
            allowed,
            ranges,
            hold_other,
            label=f"{side.name} linear move",
        )
    except ArgumentError:
        raise
    except ValueError as exc:  # a finite but absurd target no time law can cover
        raise Refused(
            ReturnCode.CANNOT_REACH_TARGET_ERR, f"{target_name}: no path to it: {exc}"
        ) from None
    return spec


def plan_ptp(
    planner: Planner,
    snap: Snapshot,
    side: RightLeft,
    goal: pin.SE3,
    duration: float,
    allowed: dict[RedundantAxis, bool],
    ranges: dict[RedundantAxis, Range | None],
    hold_other: bool,
    relative: bool,
) -> MotionSpec:
    """A joint-space move taking ``duration`` [s] to the IK solution of ``goal`` (original
    frame; ``relative``: a change in the original frame's axes)."""
    q0 = planner.base_q(snap, queued=False)
    if relative:
        with planner.view.at(snap, q0) as kin:
            goal = relative_pose(kin.pose(side), goal, tool_frame=False)
    spec, _ = planner.ptp_cartesian(
        snap,
        q0,
        side,
        goal,
        allowed,
        ranges,
        hold_other,
        duration,
        label=f"{side.name} PTP move",
    )
    return spec

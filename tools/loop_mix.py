"""The motion mix of tools/bench_loop.py and tools/bench_hil.py (issues 13, 14).

Segments, repeated in this order where the robot has what they need: hand line out and back,
elbow swing with the hand held, joint PTP out and back, waist bend with the hands held,
vehicle out and back, both hands towards each other and back ("arms close": each hand to a
quarter of its distance from the point between them, close enough for the collision rows
between the two arms).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from controller.control.core import MotionCore
from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import axis_value, elbow_axis
from controller.motion.motions import (
    CartesianMotion,
    CPHoldMotion,
    DualCartesianMotion,
    JointMotion,
    Motion,
    VehicleMotion,
    arm_joints,
)
from controller.motion.paths import LinePath
from controller.motion.reachability import ReachabilityChecker
from controller.vocabulary import RightLeft, UnitType

RIGHT = RightLeft.RIGHT
Factory = Callable[[MotionCore], Motion | None]
#: The segment of the mix with the two arms close together.
ARMS_CLOSE = "arms close"
#: In "arms close", each hand goes to this share of its distance from the point between them.
CLOSE_SHARE = 0.25


def segments(core: MotionCore) -> list[tuple[str, Factory]]:
    """The motion mix for this robot: (segment name, factory building the motion on the
    planning copy)."""
    kin, dt = core.planning_kinematics(), core.dt
    checker = ReachabilityChecker(kin)

    def line(sign: float) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            start = kin.pose(RIGHT)
            end = pin.SE3(start.rotation, start.translation + sign * np.array([0.05, 0, 0.05]))
            m = CartesianMotion(kin, dt, RIGHT, LinePath(start, end), (0.2, 1.0), (0.5, 2.0), {})
            return m if checker.check(kin, RIGHT, m.path, m.setup()) is None else None

        return make

    def hold(axis_of: Callable[[], object], delta: float, held: tuple[RightLeft, ...]) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            axis = axis_of()
            goal = axis_value(kin, axis) + delta  # type: ignore[arg-type]
            speed = np.array([math.radians(20)])
            return CPHoldMotion(kin, dt, held, {axis: goal}, speed, 2 * speed)  # type: ignore[dict-item]

        return make

    def ptp(delta: float) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            joints = kin.unit_indices(UnitType.RIGHT_ARM)
            box = c.ik.box
            return JointMotion(
                kin,
                dt,
                joints,
                c.q_cmd[joints] + delta,
                0.5 * box.v_max[joints],
                0.5 * box.a_max[joints],
            )

        return make

    def drive(x: float) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            pose = kin.vehicle_pose()
            return VehicleMotion(kin, dt, np.array([x, pose[1], pose[2]]), (0.2, 0.5), (0.4, 1.0))

        return make

    home: dict[RightLeft, pin.SE3] = {}

    def arms(close: bool) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            poses = {side: kin.pose(side) for side in kin.arms}
            if close:
                home.update(poses)
                mid = sum(p.translation for p in poses.values()) / len(poses)
                goals = {
                    side: pin.SE3(p.rotation, mid + CLOSE_SHARE * (p.translation - mid))
                    for side, p in poses.items()
                }
            else:
                goals = dict(home)
            paths = {side: LinePath(poses[side], goals[side]) for side in poses}
            return DualCartesianMotion(kin, dt, paths, (0.2, 1.0), (0.5, 2.0))

        return make

    mix: list[tuple[str, Factory]] = [("hand line", line(1.0)), ("hand line", line(-1.0))]
    if kin.has_elbow(RIGHT):
        mix += [
            ("elbow swing", hold(lambda: elbow_axis(RIGHT), math.radians(10), (RIGHT,))),
            ("elbow swing", hold(lambda: elbow_axis(RIGHT), -math.radians(10), (RIGHT,))),
        ]
    mix += [("joint ptp", ptp(0.2)), ("joint ptp", ptp(-0.2))]
    lumbar = [a for a in core.ik.axes if a.is_lumbar]
    if lumbar:
        both = tuple(kin.arms)
        mix += [
            ("waist bend", hold(lambda: lumbar[0], math.radians(5), both)),
            ("waist bend", hold(lambda: lumbar[0], -math.radians(5), both)),
        ]
    if kin.has_vehicle:
        mix += [("vehicle", drive(0.2)), ("vehicle", drive(0.0))]
    if len(kin.arms) == 2:
        mix += [(ARMS_CLOSE, arms(True)), (ARMS_CLOSE, arms(False))]
    return mix


def arm_pairs(kin: Kinematics, pair_links: list[tuple[str, str]]) -> np.ndarray:
    """Per checked pair: True when its two links are moved by different arms."""
    model = kin.model
    columns = {side: set(arm_joints(kin, side).tolist()) for side in kin.arms}

    def arm_of(link: str) -> RightLeft | None:
        if not model.existFrame(link):
            return None  # an obstacle
        joint = model.frames[model.getFrameId(link)].parentJoint
        moved_by = {model.joints[j].idx_v for j in model.supports[joint] if j}
        return next((side for side, cols in columns.items() if moved_by & cols), None)

    sides = [(arm_of(a), arm_of(b)) for a, b in pair_links]
    return np.array([a is not None and b is not None and a != b for a, b in sides], dtype=bool)


def script(core: MotionCore) -> list[Factory]:
    """The factories of :func:`segments`, in order."""
    return [make for _, make in segments(core)]

"""The motion mix of tools/bench_loop.py and tools/bench_hil.py (issues 13, 14).

Segments, repeated in this order where the robot has what they need: hand line out and back,
elbow swing with the hand held, joint PTP out and back, waist bend with the hands held,
vehicle out and back, both hands towards each other and back ("arms close": each hand to a
quarter of its distance from the point between them, close enough for the collision rows
between the two arms).
"""

from __future__ import annotations

import math
import multiprocessing
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pinocchio as pin

from controller.control.core import MotionCore
from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import axis_value, elbow_axis
from controller.model.robot import load_robot
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
#: The hand line's reachability check: ``check(q [rad], sign) -> reachable``.
LineCheck = Callable[[np.ndarray, float], bool]
#: The segment of the mix with the two arms close together.
ARMS_CLOSE = "arms close"
#: In "arms close", each hand goes to this share of its distance from the point between them.
CLOSE_SHARE = 0.25


def _line(kin: Kinematics, dt: float, sign: float) -> CartesianMotion:
    """The right hand's line of the mix from where ``kin`` is: 50 mm out in x and z."""
    start = kin.pose(RIGHT)
    end = pin.SE3(start.rotation, start.translation + sign * np.array([0.05, 0, 0.05]))
    return CartesianMotion(kin, dt, RIGHT, LinePath(start, end), (0.2, 1.0), (0.5, 2.0), {})


def _reachable(kin: Kinematics, checker: ReachabilityChecker, dt: float, sign: float) -> bool:
    m = _line(kin, dt, sign)
    return checker.check(kin, RIGHT, m.path, m.setup()) is None


_worker: dict[str, object] = {}


def _start_worker(robot_id: str, dt: float) -> None:
    kin = Kinematics(load_robot(robot_id))
    _worker.update(kin=kin, checker=ReachabilityChecker(kin), dt=dt)


def _ready() -> bool:
    return "kin" in _worker


def _check_in_worker(q: np.ndarray, sign: float) -> bool:
    kin = _worker["kin"]
    assert isinstance(kin, Kinematics)
    kin.update(q)
    return _reachable(kin, _worker["checker"], _worker["dt"], sign)  # type: ignore[arg-type]


class WorkerLineCheck:
    """The hand line's reachability check in a worker process.

    In the daemon the gateway plans in its own process: the control process never runs a
    check, and its loop shares the GIL with no planner. A benchmark planning in a thread of
    the loop's process would add what the daemon does not have: the loop waiting for the GIL
    while the planner thread, preempted by other processes on a busy machine, holds it.
    """

    def __init__(self, robot_id: str, dt: float):
        self._pool = ProcessPoolExecutor(
            1,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_start_worker,
            initargs=(robot_id, dt),
        )
        self._pool.submit(_ready).result()  # started and loaded before the first cycle

    def __call__(self, q: np.ndarray, sign: float) -> bool:
        return bool(self._pool.submit(_check_in_worker, q, sign).result())

    def close(self) -> None:
        self._pool.shutdown()


def segments(core: MotionCore, line_check: LineCheck | None = None) -> list[tuple[str, Factory]]:
    """The motion mix for this robot: (segment name, factory building the motion on the
    planning copy). ``line_check`` replaces the hand line's reachability check in this
    thread (e.g. :class:`WorkerLineCheck`)."""
    kin, dt = core.planning_kinematics(), core.dt
    checker = ReachabilityChecker(kin)

    def line(sign: float) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            if line_check is not None:
                ok = line_check(kin.q.copy(), sign)
            else:
                ok = _reachable(kin, checker, dt, sign)
            return _line(kin, dt, sign) if ok else None

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

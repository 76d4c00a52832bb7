"""The motion mix of tools/bench_loop.py and tools/bench_hil.py (issues 13, 14).

Segments, repeated in this order where the robot has what they need: hand line out and back,
elbow swing with the hand held, joint PTP out and back, waist bend with the hands held,
vehicle out and back, both hands towards each other and back ("arms close": each hand to a
quarter of its distance from the point between them, close enough for the collision rows
between the two arms).

The hand line and "arms close" are planned as the daemon's gateway plans them (the gateway's
:class:`~controller.gateway.planning.planner.Planner`: reachability along the path, the
checked joint path, path-rate limits, clearance) and built as its control process builds
them (``MotionSpec.build_as_planned``): the loop runs the daemon's motions, the line's null
space following the checked joint path (:mod:`controller.motion.posture`), not the start
posture. A move the planning refuses is skipped.
"""

from __future__ import annotations

import math
import multiprocessing
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Protocol

import numpy as np
import pinocchio as pin

from controller.contract.motion_specs import (
    CartesianMoveSpec,
    CPHoldSpec,
    DualCartesianSpec,
    JointMoveSpec,
    MotionSpec,
    VehicleMoveSpec,
)
from controller.contract.snapshot import Snapshot
from controller.control.core import MotionCore
from controller.errors import Refused
from controller.gateway.planning.clearance import combine
from controller.gateway.planning.planner import Planner
from controller.gateway.planning.robot_view import RobotView
from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import axis_value, elbow_axis
from controller.model.robot import load_robot
from controller.motion.motions import Motion, arm_joints
from controller.vocabulary import CoreState, RightLeft, UnitType
from hal.interface import HardwareState

RIGHT = RightLeft.RIGHT
#: Makes a segment's motion; None: skipped.
Factory = Callable[[MotionCore], Motion | None]
#: Plans a segment's motion (the spec the gateway would send); None: skipped.
SpecFactory = Callable[[MotionCore], MotionSpec | None]
#: A snapshot's frames (:func:`frames_of`).
Frames = tuple[np.ndarray, float, np.ndarray]
#: The segment of the mix with the two arms close together.
ARMS_CLOSE = "arms close"
#: In "arms close", each hand goes to this share of its distance from the point between them.
CLOSE_SHARE = 0.25
#: Speed and acceleration of the mix's lines (translation [m/s, m/s²], rotation [rad/s,
#: rad/s²]).
LINE_SPEED, LINE_ACCEL = (0.2, 1.0), (0.5, 2.0)


class Planning(Protocol):
    """Plans the mix's Cartesian moves: :class:`MixPlanner` or :class:`WorkerLineCheck`."""

    def line(
        self, q: np.ndarray, frames: Frames, sign: float
    ) -> tuple[MotionSpec | None, str | None]: ...

    def arms(
        self, q: np.ndarray, frames: Frames, goals: dict[RightLeft, np.ndarray]
    ) -> tuple[MotionSpec | None, str | None]: ...


def frames_of(kin: Kinematics) -> Frames:
    """What a snapshot carries of ``kin``'s frames: original frame (3x4), its θ [rad], the
    control-point offsets (2 x 3x4, RIGHT then LEFT)."""
    offsets = np.zeros((2, 3, 4))
    for k, side in enumerate((RightLeft.RIGHT, RightLeft.LEFT)):
        if side in kin.arms:
            offsets[k] = kin.control_point_offset(side).homogeneous[:3]
    return kin.original_frame.homogeneous[:3].copy(), float(kin.original_theta), offsets


class MixPlanner:
    """The gateway's planning (:class:`~controller.gateway.planning.planner.Planner`) for
    the mix's Cartesian moves, as the daemon plans them: the hand line as
    ``Planner.cartesian`` (reachability along the path, the checked joint path the loop's
    null space follows, path-rate limits, clearance) and "arms close" as the dual linear
    move of the JARA service (each arm checked, the combined paths' clearance). Returns the
    specs the control process would get, or why the daemon would refuse the move."""

    def __init__(self, robot_id: str, dt: float):
        robot = load_robot(robot_id)
        self.view = RobotView(robot, None, list(Kinematics(robot).joint_names))  # type: ignore[arg-type]
        self.planner = Planner(self.view, dt)

    def line(
        self, q: np.ndarray, frames: Frames, sign: float
    ) -> tuple[CartesianMoveSpec | None, str | None]:
        """The right hand's line of the mix from ``q``: 50 mm out (``sign`` 1) or back in x
        and z; (spec, None) or (None, why refused)."""
        snap = _snapshot(q, frames)
        with self.view.at(snap, q) as kin:
            start = kin.pose(RIGHT)
        end = pin.SE3(start.rotation, start.translation + sign * np.array([0.05, 0, 0.05]))
        try:
            spec, _ = self.planner.cartesian(
                snap, q, RIGHT, end, LINE_SPEED, LINE_ACCEL, {}, {}, False, label="hand line"
            )
        except Refused as exc:
            return None, exc.comment
        return spec, None

    def arms(
        self, q: np.ndarray, frames: Frames, goals: dict[RightLeft, np.ndarray]
    ) -> tuple[DualCartesianSpec | None, str | None]:
        """Both hands on straight lines to ``goals`` (4x4, original frame), together."""
        snap = _snapshot(q, frames)
        planner = self.planner
        limits, paths = [], []
        try:
            with planner.lock:
                for side, goal in goals.items():
                    spec, _ = planner.cartesian(
                        snap, q, side, pin.SE3(goal), LINE_SPEED, LINE_ACCEL, {}, {}, False,
                        clearance=False,
                    )  # fmt: skip
                    if spec.path_limits is not None:
                        limits.append(spec.path_limits)
                    paths.append((arm_joints(self.view.kin, side), *planner.last_path))
                planner.require_clearance(*combine(q, paths))
        except Refused as exc:
            return None, exc.comment
        dual = DualCartesianSpec(
            targets={side: np.array(goal) for side, goal in goals.items()},
            speed=LINE_SPEED,
            accel=LINE_ACCEL,
            path_limits=(
                (min(p[0] for p in limits), min(p[1] for p in limits)) if limits else None
            ),
            planned_from=q.copy(),
            label=ARMS_CLOSE,
        )
        return dual, None


def _snapshot(q: np.ndarray, frames: Frames) -> Snapshot:
    """A published state at kinematic configuration ``q`` with ``frames`` (the planner
    reads the frames and, through :class:`RobotView`, nothing else)."""
    original, theta, offsets = frames
    return Snapshot(
        cycle=0, core_state=CoreState.READY, hw_state=HardwareState.ACTIVE, flags=0,
        queue=0, queue_depth=0, started=0, finished=0, overruns=0, pid=0, stamp=0.0,
        compute_us=np.zeros(3), wake_us=np.zeros(3), q=q, q_cmd=q, original=original,
        original_theta=theta, offsets=offsets, alarms=[],
    )  # fmt: skip


_worker: dict[str, MixPlanner] = {}


def _start_worker(robot_id: str, dt: float) -> None:
    _worker["planner"] = MixPlanner(robot_id, dt)


def _ready() -> bool:
    return "planner" in _worker


def _plan_in_worker(what: str, *args: Any) -> tuple[MotionSpec | None, str | None]:
    result: tuple[MotionSpec | None, str | None] = getattr(_worker["planner"], what)(*args)
    return result


class WorkerLineCheck:
    """:class:`MixPlanner` in a worker process (the hand line's check, and arms close).

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

    def line(
        self, q: np.ndarray, frames: Frames, sign: float
    ) -> tuple[MotionSpec | None, str | None]:
        return self._pool.submit(_plan_in_worker, "line", q, frames, sign).result()

    def arms(
        self, q: np.ndarray, frames: Frames, goals: dict[RightLeft, np.ndarray]
    ) -> tuple[MotionSpec | None, str | None]:
        return self._pool.submit(_plan_in_worker, "arms", q, frames, goals).result()

    def close(self) -> None:
        self._pool.shutdown()


def segments(
    core: MotionCore, line_check: Planning | None = None, refused: list[str] | None = None
) -> list[tuple[str, Factory]]:
    """The motion mix for this robot: (segment name, factory building the motion on the
    planning copy): :func:`planned_segments`' specs, each built as the control process
    builds it (:meth:`~controller.contract.motion_specs.MotionSpec.build_as_planned`)."""
    kin, dt = core.planning_kinematics(), core.dt

    def building(plan: SpecFactory) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            spec = plan(c)
            return None if spec is None else spec.build_as_planned(kin, dt)

        return make

    return [(name, building(plan)) for name, plan in planned_segments(core, line_check, refused)]


def planned_segments(
    core: MotionCore, line_check: Planning | None = None, refused: list[str] | None = None
) -> list[tuple[str, SpecFactory]]:
    """The motion mix for this robot: (segment name, factory planning the motion on the
    planning copy, as the daemon's gateway would: the spec it sends the control process,
    with the configuration it was planned from). The hand line and "arms close" are planned
    as the daemon plans them (:class:`MixPlanner`, in this thread; ``line_check`` elsewhere,
    e.g. :class:`WorkerLineCheck`); a move the daemon would refuse is skipped (its factory
    returns None) and why goes to ``refused``."""
    kin, dt = core.planning_kinematics(), core.dt
    planning: Planning = line_check if line_check is not None else MixPlanner(core.robot.id, dt)

    def built(segment: str, planned: tuple[MotionSpec | None, str | None]) -> MotionSpec | None:
        spec, why = planned
        if spec is None:
            if refused is not None:
                refused.append(f"{segment}: {why}")
        return spec

    def line(sign: float) -> SpecFactory:
        def make(c: MotionCore) -> MotionSpec | None:
            return built("hand line", planning.line(kin.q.copy(), frames_of(kin), sign))

        return make

    def hold(
        axis_of: Callable[[], object], delta: float, held: tuple[RightLeft, ...]
    ) -> SpecFactory:
        def make(c: MotionCore) -> MotionSpec | None:
            axis = axis_of()
            goal = axis_value(kin, axis) + delta  # type: ignore[arg-type]
            speed = np.array([math.radians(20)])
            targets = {axis: goal}
            planned_from = kin.q.copy()
            return CPHoldSpec(held, targets, speed, 2 * speed, planned_from=planned_from)  # type: ignore[arg-type]

        return make

    def ptp(delta: float) -> SpecFactory:
        def make(c: MotionCore) -> MotionSpec | None:
            joints = kin.unit_indices(UnitType.RIGHT_ARM)
            box = c.ik.box
            return JointMoveSpec(
                joints,
                c.q_cmd[joints] + delta,
                0.5 * box.v_max[joints],
                0.5 * box.a_max[joints],
                planned_from=kin.q.copy(),
            )

        return make

    def drive(x: float) -> SpecFactory:
        def make(c: MotionCore) -> MotionSpec | None:
            pose = kin.vehicle_pose()
            target = np.array([x, pose[1], pose[2]])
            return VehicleMoveSpec(target, (0.2, 0.5), (0.4, 1.0), planned_from=kin.q.copy())

        return make

    home: dict[RightLeft, np.ndarray] = {}

    def arms(close: bool) -> SpecFactory:
        def make(c: MotionCore) -> MotionSpec | None:
            poses = {side: kin.pose(side) for side in kin.arms}
            if close:
                home.update((side, p.homogeneous.copy()) for side, p in poses.items())
                mid = sum(p.translation for p in poses.values()) / len(poses)
                goals = {
                    side: pin.SE3(p.rotation, mid + CLOSE_SHARE * (p.translation - mid)).homogeneous
                    for side, p in poses.items()
                }
            else:
                goals = dict(home)
            return built(ARMS_CLOSE, planning.arms(kin.q.copy(), frames_of(kin), goals))

        return make

    mix: list[tuple[str, SpecFactory]] = [("hand line", line(1.0)), ("hand line", line(-1.0))]
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

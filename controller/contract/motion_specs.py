"""Motion requests as plain data: what the gateway plans and the control loop builds.

The gateway validates a command, converts it to SI, resolves relative targets and checks
reachability; it sends one of these (picklable) specs to the control process, whose loop
thread turns it into a :class:`controller.motion.motions.Motion` against the live
kinematics when the motion starts (at once, or when it leaves the JARA queue). Building is
cheap (paths and a Ruckig time law); everything expensive happened in the gateway.

Poses are 4x4 homogeneous matrices in the original frame [m]; angles [rad].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis
from controller.motion.motions import (
    CartesianMotion,
    CPHoldMotion,
    DualCartesianMotion,
    JointMotion,
    Motion,
    VehicleMotion,
)
from controller.motion.paths import ArcPath, LinePath
from controller.motion.posture import PosturePath
from controller.motion.stream import JointStreamMotion
from controller.vocabulary import RightLeft

Range = tuple[float, float]


@dataclass
class MotionSpec:
    #: Kinematic configuration the gateway planned from; a motion started "now" is refused
    #: if the robot has since moved (another client got there first).
    planned_from: np.ndarray | None = field(default=None, kw_only=True)
    #: Human-readable summary for logs.
    label: str = field(default="motion", kw_only=True)

    def build(self, kin: Kinematics, dt: float) -> Motion:
        raise NotImplementedError

    def build_as_planned(self, kin: Kinematics, dt: float) -> Motion:
        """The motion the gateway checked: built at the configuration it was planned from
        (:attr:`planned_from`), so its path and time law are the checked ones, not a re-plan
        from where the robot happens to be; ``kin`` is back at its measured state after.
        The motion is prepared (:meth:`~controller.motion.motions.Motion.prepare`)."""
        if self.planned_from is None:
            motion = self.build(kin, dt)
        else:
            measured = kin.q.copy()
            kin.update(self.planned_from)
            try:
                motion = self.build(kin, dt)
            finally:
                kin.update(measured)
        motion.prepare()  # its set-up that does not depend on the state at the start
        return motion


@dataclass
class JointMoveSpec(MotionSpec):
    """Joint-space PTP of the kinematic joints ``joints`` (indices into q) to ``target``."""

    joints: np.ndarray
    target: np.ndarray
    speed: np.ndarray  #: per joint [rad/s, m/s]
    accel: np.ndarray  #: per joint [rad/s², m/s²]
    duration: float | None = None  #: all joints start and stop together in this time [s]
    hold: tuple[RightLeft, ...] = ()  #: arms whose control points stay put

    def build(self, kin: Kinematics, dt: float) -> Motion:
        return JointMotion(
            kin, dt, self.joints, self.target, self.speed, self.accel, self.duration, self.hold
        )


@dataclass
class CartesianMoveSpec(MotionSpec):
    """Control point of ``side`` along a line (or an arc through ``via``) to ``target``."""

    side: RightLeft
    target: np.ndarray  #: 4x4, original frame
    speed: tuple[float, float]  #: translation [m/s], rotation [rad/s]
    accel: tuple[float, float]
    allowed: dict[RedundantAxis, bool] = field(default_factory=dict)
    ranges: dict[RedundantAxis, Range | None] = field(default_factory=dict)
    hold_other: bool = False
    elbow: float | None = None  #: target elbow angle [rad]
    via: np.ndarray | None = None  #: 4x4 via point of an arc
    duration: float | None = None
    #: Path-parameter rate [1/s] and acceleration [1/s²] the joints allow (from planning).
    path_limits: tuple[float, float] | None = None
    #: The checked joint path (path parameters, one configuration per row [rad, m]): the
    #: null space follows it (:mod:`controller.motion.posture`); None: the start posture.
    posture: tuple[np.ndarray, np.ndarray] | None = None

    def build(self, kin: Kinematics, dt: float) -> Motion:
        start = kin.pose(self.side)
        end = pin.SE3(self.target)
        path: LinePath | ArcPath
        if self.via is None:
            path = LinePath(start, end)
        else:
            path = ArcPath(start, pin.SE3(self.via), end)
        return CartesianMotion(
            kin,
            dt,
            self.side,
            path,
            self.speed,
            self.accel,
            self.allowed,
            self.ranges,
            self.hold_other,
            self.elbow,
            self.duration,
            self.path_limits,
            None if self.posture is None else PosturePath(*self.posture),
        )


@dataclass
class DualCartesianSpec(MotionSpec):
    """Both control points along straight lines to ``targets``, together."""

    targets: dict[RightLeft, np.ndarray]  #: 4x4 per arm, original frame
    speed: tuple[float, float]
    accel: tuple[float, float]
    elbows: dict[RightLeft, float | None] = field(default_factory=dict)
    duration: float | None = None
    path_limits: tuple[float, float] | None = None

    def build(self, kin: Kinematics, dt: float) -> Motion:
        paths = {side: LinePath(kin.pose(side), pin.SE3(t)) for side, t in self.targets.items()}
        return DualCartesianMotion(
            kin, dt, paths, self.speed, self.accel, self.elbows, self.duration, self.path_limits
        )


@dataclass
class CPHoldSpec(MotionSpec):
    """Redundant axes to ``targets`` with the control points of ``held`` fixed."""

    held: tuple[RightLeft, ...]
    targets: dict[RedundantAxis, float]
    speed: np.ndarray  #: per target, in ``targets`` order
    accel: np.ndarray
    #: Let the held arms' elbows move (else every axis without a target is held).
    free_elbows: bool = False

    def build(self, kin: Kinematics, dt: float) -> Motion:
        return CPHoldMotion(
            kin, dt, self.held, self.targets, self.speed, self.accel, self.free_elbows
        )


@dataclass
class VehicleMoveSpec(MotionSpec):
    """Vehicle to (x [m], y [m], θ [rad]) in the original frame."""

    target: np.ndarray
    speed: tuple[float, float]  #: translation [m/s], rotation [rad/s]
    accel: tuple[float, float]

    def build(self, kin: Kinematics, dt: float) -> Motion:
        return VehicleMotion(kin, dt, self.target, self.speed, self.accel)


@dataclass
class JointStreamSpec(MotionSpec):
    """A streamed joint set-point (JARA ``...CmdCycle``): starts a stream, or extends the
    running stream with the same ``key`` and joints (see controller/motion/stream.py)."""

    joints: np.ndarray
    target: np.ndarray
    v_max: np.ndarray  #: per joint [rad/s, m/s]
    a_max: np.ndarray
    period: float  #: command cycle [s]
    key: str = ""

    def build(self, kin: Kinematics, dt: float) -> Motion:
        return JointStreamMotion(
            kin, dt, self.joints, self.target, self.v_max, self.a_max, self.period, self.key
        )

    def extends(self, motion: Motion | None) -> bool:
        """True when ``motion`` is a stream this set-point continues."""
        return (
            isinstance(motion, JointStreamMotion)
            and motion.key == self.key
            and np.array_equal(motion.joints, self.joints)
            and not motion.finished
        )


@dataclass
class CartesianBox:
    """JARA soft limit: the control point must stay in [lower, upper] (arm frame) [m]."""

    lower: np.ndarray
    upper: np.ndarray
    base_offset: np.ndarray  #: 4x4, arm frame in the robot (current) frame

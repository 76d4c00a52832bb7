"""JARA_ARM state and planning, shared by the single-arm and the dual-arm servicers.

Per arm: base offset, speed settings, acceleration times, soft limits, home, grasp force.
JARA poses are in the *arm frame*: the robot (current) frame moved by the base offset
(identity by default). JARA moves use the arm's own joints only (waist and vehicle stay
put, the other arm is frozen); a 7-axis arm's elbow follows the CarPosWithElbow angle.

Queueing (interfaces.md ruling): a move given while Busy or Paused is queued (depth from
the configuration) and planned from where the queued moves will leave the arm; a full queue
is FULL_MOTION_QUEUE_ERR; stop/abort empty it.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from controller.contract.motion_specs import DualCartesianSpec, JointStreamSpec, MotionSpec
from controller.contract.snapshot import Snapshot
from controller.conversions import ArgumentError
from controller.errors import Refused
from controller.gateway.grpc.base import Context, finite_arg, hg_arg
from controller.gateway.grpc.spec_a import relative_pose
from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, elbow_axis
from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import CoreState, FrameType, ReturnCode, RightLeft, UnitType

Box = tuple[np.ndarray, np.ndarray]  # lower, upper [mm] in the arm frame
#: getSoftLimitCartesian before any setSoftLimitCartesian: no limit, shown as ±10 m.
NO_BOX_MM = 10000.0


@dataclass
class ArmSettings:
    """One arm's JARA_ARM settings (spec units: mm, deg, s, %)."""

    joint_names: tuple[str, ...]
    hw_speed: np.ndarray  #: joint speed limits [deg/s]
    hw_accel: np.ndarray  #: joint acceleration limits [deg/s²]
    hw_lower: np.ndarray  #: hardware joint limits [deg]
    hw_upper: np.ndarray
    speed_ratio_cartesian: int
    speed_ratio_joint: int
    max_speed_cartesian: tuple[float, float]  #: [mm/s, deg/s]
    min_accel_time_cartesian: float  #: [s]
    min_accel_time_joint: float
    max_speed_joint: np.ndarray = field(init=False)
    accel_time_cartesian: float = field(init=False)
    accel_time_joint: float = field(init=False)
    soft_lower: np.ndarray = field(init=False)  #: [deg]
    soft_upper: np.ndarray = field(init=False)
    base_offset: pin.SE3 = field(default_factory=pin.SE3.Identity)
    soft_box: Box | None = None
    home: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: [deg]
    grasp_force: int = 50

    def __post_init__(self) -> None:
        self.max_speed_joint = self.hw_speed.copy()
        self.accel_time_cartesian = self.min_accel_time_cartesian
        self.accel_time_joint = self.min_accel_time_joint
        self.soft_lower = self.hw_lower.copy()
        self.soft_upper = self.hw_upper.copy()

    @property
    def hw_min_accel_time_joint(self) -> float:
        """Shortest joint acceleration time the drives allow at full speed [s]."""
        return float(np.max(self.hw_speed / self.hw_accel))

    def joint_speed(self, ratio: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Joint speed and acceleration for the current ratio [rad/s, rad/s²]."""
        share = (self.speed_ratio_joint if ratio is None else ratio) / 100.0
        v = np.radians(self.max_speed_joint) * share
        return v, v / self.accel_time_joint

    def cartesian_speed(
        self, ratio: float | None = None
    ) -> tuple[tuple[float, float], tuple[float, float]]:
        """Cartesian speed and acceleration [m/s, rad/s], [m/s², rad/s²]."""
        share = (self.speed_ratio_cartesian if ratio is None else ratio) / 100.0
        v = (
            self.max_speed_cartesian[0] / 1e3 * share,
            math.radians(self.max_speed_cartesian[1]) * share,
        )
        t = self.accel_time_cartesian
        return v, (v[0] / t, v[1] / t)


@dataclass
class CarPos:
    """A checked CarPosWithElbow: pose [m] and elbow [rad]."""

    pose: pin.SE3
    elbow: float


def car_pos_arg(msg: pb.CarPosWithElbow, name: str) -> CarPos:
    pose = hg_arg(msg.car_pos, f"{name}.carPos")
    return CarPos(pose, math.radians(finite_arg(msg.elbow, f"{name}.elbow")))


@contextmanager
def unreachable_is_value_err() -> Iterator[None]:
    """JARA_ARM has no CANNOT_REACH_TARGET_ERR (its -6 means NOT_IMPLEMENTED): an unreachable
    target is an invalid argument there."""
    try:
        yield
    except Refused as exc:
        if exc.code == ReturnCode.CANNOT_REACH_TARGET_ERR:
            raise Refused(ReturnCode.VALUE_ERR, exc.comment) from None
        raise


class JaraArms:
    def __init__(self, ctx: Context):
        self.ctx = ctx
        self.view = ctx.view
        self.lock = threading.RLock()
        self.hands_on = True  #: JARA_ARM_DUAL servoONHand / servoOFFHand
        cfg = ctx.config.jara
        robot = ctx.robot
        self.arms: dict[RightLeft, ArmSettings] = {}
        for side in self.view.arms:
            names = robot.unit_joints(f"{side.name}_ARM")
            specs = [robot.joints[n] for n in names]
            settings = ArmSettings(
                joint_names=names,
                hw_speed=np.degrees([s.velocity for s in specs]),
                hw_accel=np.degrees([s.acceleration for s in specs]),
                hw_lower=np.degrees([s.lower for s in specs]),
                hw_upper=np.degrees([s.upper for s in specs]),
                speed_ratio_cartesian=robot.profile.speed_ratio,
                speed_ratio_joint=robot.profile.speed_ratio,
                max_speed_cartesian=cfg.max_speed_cartesian,
                min_accel_time_cartesian=cfg.min_accel_time_cartesian,
                min_accel_time_joint=cfg.min_accel_time_joint,
            )
            hw_min = settings.hw_min_accel_time_joint
            if settings.min_accel_time_joint < hw_min:
                settings.min_accel_time_joint = settings.accel_time_joint = hw_min
            home = robot.home()
            settings.home = np.array(
                [specs[i].from_si(home.get(n, 0.0)) for i, n in enumerate(names)]
            )
            self.arms[side] = settings
        self.cmd_cycle = cfg.cmd_cycle_ms / 1000.0

    # ------------------------------------------------------------------ lookups
    def arm(self, value: int, name: str = "arm") -> tuple[RightLeft, ArmSettings]:
        try:
            side = RightLeft(value)
        except ValueError:
            raise ArgumentError(f"{name}: {value} is not RIGHT (0) or LEFT (1)") from None
        if side not in self.arms:
            raise ArgumentError(f"{name}: this robot has no {side.name} arm")
        return side, self.arms[side]

    def joints(self, side: RightLeft) -> np.ndarray:
        return self.ctx.planner.view.kin.unit_indices(UnitType[f"{side.name}_ARM"])

    def has_gripper(self, side: RightLeft) -> bool:
        return side.name in self.ctx.robot.profile.grippers

    # ------------------------------------------------------------------ frames
    def to_arm_frame(self, kin: Kinematics, side: RightLeft, settings: ArmSettings) -> pin.SE3:
        """Control-point pose in the arm frame [m]."""
        return settings.base_offset.actInv(kin.pose(side, FrameType.CURRENT_FRAME))

    def to_original(self, kin: Kinematics, settings: ArmSettings, pose: pin.SE3) -> pin.SE3:
        """Arm-frame pose → original frame."""
        return kin.original_frame.actInv(kin.body_pose() * settings.base_offset * pose)

    def feedback(self, snap: Snapshot, side: RightLeft) -> tuple[pin.SE3, float]:
        settings = self.arms[side]
        with self.view.at(snap) as kin:
            pose = self.to_arm_frame(kin, side, settings)
            elbow = kin.elbow_angle(side) if kin.has_elbow(side) else 0.0
        return pose, elbow

    # ------------------------------------------------------------------ state
    @staticmethod
    def require_motion_state(snap: Snapshot) -> None:
        if snap.core_state == CoreState.ALARM:
            raise Refused(ReturnCode.STATUS_ERR, "alarms are active: clearAlarms, then servoON")
        if snap.core_state == CoreState.SERVO_OFF:
            raise Refused(ReturnCode.NOT_SV_ON_ERR, "the servos are off: call servoON first")

    def submit(
        self, spec: MotionSpec, q_end: np.ndarray, poses: dict[RightLeft, pin.SE3] | None = None
    ) -> dict[str, str]:
        """Start or queue ``spec``; remember where it leaves the robot (configuration, and
        the commanded poses of Cartesian moves, original frame)."""
        result = self.ctx.call("start", spec=spec, queued=True)
        planner = self.ctx.planner
        if poses is None:
            planner.tail_poses.clear()
        planner.remember(q_end, poses)
        if result == "queued":
            return {"comment": "OK (queued behind the running motion)"}
        if result == "extended":
            return {"comment": "OK (set-point joined the running stream)"}
        return {}

    def check_box(self, settings: ArmSettings, pose_arm: pin.SE3, name: str) -> None:
        if settings.soft_box is None:
            return
        lo, hi = settings.soft_box
        p = pose_arm.translation * 1e3
        if np.any(p < lo - 1e-6) or np.any(p > hi + 1e-6):
            shown = ", ".join(f"{x:.1f}" for x in p)
            raise ArgumentError(f"{name}: target ({shown}) mm is outside the Cartesian soft limit")

    # ------------------------------------------------------------------ planning
    def _start_state(self) -> tuple[Snapshot, np.ndarray]:
        snap = self.ctx.snapshot()
        self.require_motion_state(snap)
        return snap, self.ctx.planner.base_q(snap, queued=True)

    def _target(
        self,
        kin: Kinematics,
        side: RightLeft,
        settings: ArmSettings,
        target: CarPos,
        relative: bool,
        name: str,
    ) -> tuple[pin.SE3, float | None]:
        """Target pose (original frame) and elbow [rad] (None for a 6-axis arm)."""
        current = self.to_arm_frame(kin, side, settings)
        queued_end = self.ctx.planner.tail_pose(side)
        if queued_end is not None:  # build on the queued move's commanded end pose
            current = settings.base_offset.actInv(
                kin.body_pose().actInv(kin.original_frame * queued_end)
            )
        goal = relative_pose(current, target.pose, tool_frame=False) if relative else target.pose
        self.check_box(settings, goal, name)
        elbow = None
        if kin.has_elbow(side):
            elbow = kin.elbow_angle(side) + target.elbow if relative else target.elbow
        return self.to_original(kin, settings, goal), elbow

    def linear(
        self,
        side: RightLeft,
        target: CarPos,
        relative: bool,
        name: str,
        via: CarPos | None = None,
    ) -> dict[str, str]:
        settings = self.arms[side]
        snap, q0 = self._start_state()
        planner = self.ctx.planner
        with planner.view.at(snap, q0) as kin:
            goal, elbow = self._target(kin, side, settings, target, relative, name)
            via_pose = None
            if via is not None:
                via_pose, _ = self._target(kin, side, settings, via, relative, "car_point_r")
        speed, accel = settings.cartesian_speed()
        allowed = {elbow_axis(side): True} if elbow is not None else {}
        with unreachable_is_value_err():
            spec, q_end = planner.cartesian(
                snap,
                q0,
                side,
                goal,
                speed,
                accel,
                allowed,
                {},
                False,
                elbow=elbow,
                via=via_pose,
                label=f"{side.name} {'arc' if via else 'linear'} move",
            )
        return self.submit(spec, q_end, {side: goal})

    def ptp_cartesian(
        self,
        side: RightLeft,
        target: CarPos,
        relative: bool,
        name: str,
    ) -> dict[str, str]:
        settings = self.arms[side]
        snap, q0 = self._start_state()
        q_goal, goal = self.ptp_goal(snap, q0, side, target, relative, name)
        joints = self.joints(side)
        v, a = settings.joint_speed()
        spec = self.ctx.planner.joint(
            q0, joints, q_goal[joints], v, a, label=f"{side.name} PTP move", absolute=True
        )
        return self.submit(spec, q_goal, {side: goal})

    def ptp_joint(
        self,
        side: RightLeft,
        values_deg: np.ndarray,
        relative: bool,
        label: str = "PTP joint move",
    ) -> dict[str, str]:
        settings = self.arms[side]
        _, q0 = self._start_state()
        joints = self.joints(side)
        target = self.joint_target(side, values_deg, q0, relative, "jointPoints")
        v, a = settings.joint_speed()
        spec = self.ctx.planner.joint(
            q0, joints, target, v, a, label=f"{side.name} {label}", absolute=True
        )
        q_end = q0.copy()
        q_end[joints] = target
        return self.submit(spec, q_end)

    # ------------------------------------------------------------------ streams
    def _stream(
        self,
        side: RightLeft,
        q_goal: np.ndarray,
        q0: np.ndarray,
        poses: dict[RightLeft, pin.SE3] | None = None,
    ) -> dict[str, str]:
        """A ...CmdCycle set-point: joins the arm's running stream or starts one."""
        settings = self.arms[side]
        joints = self.joints(side)
        spec = JointStreamSpec(
            joints=joints,
            target=q_goal[joints].copy(),
            v_max=np.radians(settings.max_speed_joint),
            a_max=np.radians(settings.hw_accel),
            period=self.cmd_cycle,
            key=side.name,
            planned_from=q0.copy(),
            label=f"{side.name} streamed set-point",
        )
        q_end = q0.copy()
        q_end[joints] = q_goal[joints]
        return self.submit(spec, q_end, poses)

    def stream_joint(self, side: RightLeft, values_deg: np.ndarray, relative: bool):
        _, q0 = self._start_state()
        target = self.joint_target(side, values_deg, q0, relative, "jointPoints")
        q_goal = q0.copy()
        q_goal[self.joints(side)] = target
        return self._stream(side, q_goal, q0)

    def stream_cartesian(self, side: RightLeft, target: CarPos, relative: bool, name: str):
        snap, q0 = self._start_state()
        q_goal, goal = self.ptp_goal(snap, q0, side, target, relative, name)
        return self._stream(side, q_goal, q0, {side: goal})

    def joint_target(
        self, side: RightLeft, values_deg: np.ndarray, q0: np.ndarray, relative: bool, name: str
    ) -> np.ndarray:
        """An arm's joint target [rad] from JointPos values [deg]; VALUE_ERR outside the
        soft limits."""
        settings = self.arms[side]
        joints = self.joints(side)
        target = np.radians(values_deg) + (q0[joints] if relative else 0.0)
        lo, hi = np.radians(settings.soft_lower), np.radians(settings.soft_upper)
        for i, joint in enumerate(settings.joint_names):
            if not lo[i] - 1e-9 <= target[i] <= hi[i] + 1e-9:
                raise ArgumentError(
                    f"{name}[{i}] ({joint}): {math.degrees(target[i]):.3f} deg is outside "
                    f"the soft limit {settings.soft_lower[i]:g}..{settings.soft_upper[i]:g} deg"
                )
        return target

    def dual_linear(self, targets: dict[RightLeft, CarPos], relative: bool) -> dict[str, str]:
        """Both arms along straight lines, starting and stopping together."""
        snap, q0 = self._start_state()
        planner = self.ctx.planner
        goals: dict[RightLeft, np.ndarray] = {}
        elbows: dict[RightLeft, float | None] = {}
        q_end = q0.copy()
        speeds, accels = [], []
        path_limits: list[tuple[float, float]] = []
        for side, target in targets.items():
            settings = self.arms[side]
            with planner.view.at(snap, q0) as kin:
                goal, elbow = self._target(kin, side, settings, target, relative, f"{side.name}")
            speed, accel = settings.cartesian_speed()
            speeds.append(speed)
            accels.append(accel)
            allowed = {elbow_axis(side): True} if elbow is not None else {}
            with unreachable_is_value_err():
                arm_spec, q_side = planner.cartesian(
                    snap, q0, side, goal, speed, accel, allowed, {}, False, elbow=elbow
                )
            if arm_spec.path_limits is not None:
                path_limits.append(arm_spec.path_limits)
            joints = self.joints(side)
            q_end[joints] = q_side[joints]
            goals[side] = goal.homogeneous.copy()
            elbows[side] = elbow
        spec = DualCartesianSpec(
            targets=goals,
            speed=(min(s[0] for s in speeds), min(s[1] for s in speeds)),
            accel=(min(a[0] for a in accels), min(a[1] for a in accels)),
            elbows=elbows,
            path_limits=(
                (min(p[0] for p in path_limits), min(p[1] for p in path_limits))
                if path_limits
                else None
            ),
            planned_from=q0.copy(),
            label="dual linear move",
        )
        poses = {side: pin.SE3(goal) for side, goal in goals.items()}
        return self.submit(spec, q_end, poses)

    def dual_ptp(self, goals_q: dict[RightLeft, np.ndarray], snap: Snapshot, q0: np.ndarray):
        """Both arms' joints to ``goals_q`` (kinematic configurations), together."""
        joints = np.concatenate([self.joints(side) for side in goals_q])
        target = np.concatenate([goals_q[side][self.joints(side)] for side in goals_q])
        v = np.concatenate([self.arms[side].joint_speed()[0] for side in goals_q])
        a = np.concatenate([self.arms[side].joint_speed()[1] for side in goals_q])
        spec = self.ctx.planner.joint(
            q0, joints, target, v, a, label="dual PTP move", absolute=True
        )
        q_end = q0.copy()
        q_end[joints] = target
        return self.submit(spec, q_end)

    def ptp_goal(
        self,
        snap: Snapshot,
        q0: np.ndarray,
        side: RightLeft,
        target: CarPos,
        relative: bool,
        name: str,
    ) -> tuple[np.ndarray, pin.SE3]:
        """IK solution (kinematic configuration) of a JARA Cartesian target, and the target
        pose (original frame)."""
        settings = self.arms[side]
        planner = self.ctx.planner
        with planner.view.at(snap, q0) as kin:
            goal, _ = self._target(kin, side, settings, target, relative, name)
        allowed: dict[RedundantAxis, bool] = (
            {elbow_axis(side): True} if planner.view.kin.has_elbow(side) else {}
        )
        with unreachable_is_value_err():
            q_goal, _, _ = planner.pose_goal(snap, q0, side, goal, allowed, {}, False)
        return q_goal, goal

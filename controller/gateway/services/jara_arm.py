"""JARA_ARM service: the per-arm settings and every motion of ManipulatorCommon/Middle and
JARA_ARM_DUAL, transport-independent (spec units in: mm, deg, s, %).

Queueing (interfaces.md ruling): a move given while Busy or Paused is queued (depth from
the configuration) and planned from where the queued moves will leave the arm; a full queue
is FULL_MOTION_QUEUE_ERR; stop/abort empty it (and relative moves then build on the measured
state again). JARA_ARM has no CANNOT_REACH_TARGET_ERR (its -6 means NOT_IMPLEMENTED): an
unreachable target is VALUE_ERR there.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

import numpy as np
import pinocchio as pin

from controller.contract.motion_specs import DualCartesianSpec, JointStreamSpec, MotionSpec
from controller.contract.snapshot import Snapshot
from controller.conversions import deg_to_rad, finite_array, hg_to_se3
from controller.errors import ArgumentError, Refused
from controller.gateway.planning.clearance import combine
from controller.gateway.planning.jara_arm import (
    ArmSettings,
    CarPos,
    cartesian_target,
    joint_target,
    to_arm_frame,
)
from controller.gateway.planning.limits import require_arc
from controller.gateway.services.context import Context
from controller.model.redundant_axes import RedundantAxis, elbow_axis
from controller.vocabulary import CoreState, ReturnCode, RightLeft, UnitType


@contextmanager
def unreachable_is_value_err() -> Iterator[None]:
    """JARA_ARM has no CANNOT_REACH_TARGET_ERR: an unreachable target is an invalid argument."""
    try:
        yield
    except Refused as exc:
        if exc.code == ReturnCode.CANNOT_REACH_TARGET_ERR:
            raise Refused(ReturnCode.VALUE_ERR, exc.comment) from None
        raise


def car_pos(hg_mm: np.ndarray | Sequence[float], elbow_deg: float, name: str) -> CarPos:
    """A CarPosWithElbow from an HgMatrix (3 x 4 or 12 numbers, row-major, [mm]) and an elbow
    angle [deg]."""
    values = finite_array(hg_mm, f"{name}.carPos")
    if values.size != 12:
        raise ArgumentError(
            f"{name}.carPos: expected 12 numbers (3x4 row-major [R | p]), got {values.size}"
        )
    pose = hg_to_se3(values.reshape(3, 4), f"{name}.carPos")
    return CarPos(pose, float(deg_to_rad(elbow_deg, f"{name}.elbow")))


class JaraArmService:
    """Per-arm JARA settings and the JARA motions of both interfaces (one per daemon)."""

    def __init__(self, ctx: Context):
        self.ctx = ctx
        self.view = ctx.view
        self.lock = threading.RLock()
        self.hands_on = True  #: JARA_ARM_DUAL servoONHand / servoOFFHand
        cfg = ctx.config.jara
        self.arms: dict[RightLeft, ArmSettings] = {
            side: ArmSettings.for_arm(
                ctx.robot,
                side,
                cfg.max_speed_cartesian,
                cfg.min_accel_time_cartesian,
                cfg.min_accel_time_joint,
            )
            for side in self.view.arms
        }
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

    def feedback(self, snap: Snapshot, side: RightLeft) -> tuple[pin.SE3, float]:
        """Control-point pose in the arm frame [m] and elbow [rad]."""
        settings = self.arms[side]
        with self.view.at(snap) as kin:
            pose = to_arm_frame(kin, side, settings)
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
    ) -> str | None:
        """Start or queue ``spec``; remember where it leaves the robot (configuration, and
        the commanded poses of Cartesian moves, original frame). Returns the answer's comment
        (None: plain OK)."""
        result = self.ctx.call("start", spec=spec, queued=True)
        planner = self.ctx.planner
        if poses is None:
            planner.tail_poses.clear()
        planner.remember(q_end, poses)
        if result == "queued":
            return "OK (queued behind the running motion)"
        if result == "extended":
            return "OK (set-point joined the running stream)"
        return None

    def _start_state(self) -> tuple[Snapshot, np.ndarray]:
        snap = self.ctx.snapshot()
        self.require_motion_state(snap)
        return snap, self.ctx.planner.base_q(snap, queued=True)

    # ------------------------------------------------------------------ moves
    def linear(
        self,
        side: RightLeft,
        target: CarPos,
        relative: bool,
        name: str,
        via: CarPos | None = None,
    ) -> str | None:
        settings = self.arms[side]
        if via is not None and relative:  # relative to the start: the start is the origin
            require_arc(np.zeros(3), via.pose.translation, target.pose.translation)
        snap, q0 = self._start_state()
        planner = self.ctx.planner
        with planner.lock:
            with planner.view.at(snap, q0) as kin:
                goal, elbow = cartesian_target(planner, kin, side, settings, target, relative, name)
                via_pose = None
                if via is not None:
                    via_pose, _ = cartesian_target(
                        planner, kin, side, settings, via, relative, "carPointR"
                    )
                    start = planner.tail_pose(side)
                    start = kin.pose(side) if start is None else start
                    require_arc(start.translation, via_pose.translation, goal.translation)
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

    def ptp_cartesian(self, side: RightLeft, target: CarPos, relative: bool, name: str):
        settings = self.arms[side]
        snap, q0 = self._start_state()
        with self.ctx.planner.lock:
            q_goal, goal = self.ptp_goal(snap, q0, side, target, relative, name)
            joints = self.joints(side)
            v, a = settings.joint_speed()
            spec = self.ctx.planner.joint(
                q0, joints, q_goal[joints], v, a, label=f"{side.name} PTP move", absolute=True
            )
            return self.submit(spec, q_goal, {side: goal})

    def joint_target(
        self, side: RightLeft, values_deg: np.ndarray, q0: np.ndarray, relative: bool, name: str
    ) -> np.ndarray:
        """An arm's joint target [rad] from joint values [deg]; VALUE_ERR outside the soft
        limits."""
        values = deg_to_rad(values_deg, name)
        return joint_target(self.arms[side], self.joints(side), values, q0, relative, name)

    def ptp_joint(
        self, side: RightLeft, values_deg: np.ndarray, relative: bool, label: str = "PTP joint move"
    ) -> str | None:
        settings = self.arms[side]
        _, q0 = self._start_state()
        with self.ctx.planner.lock:
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
    ) -> str | None:
        """A ...CmdCycle set-point: joins the arm's running stream or starts one."""
        settings = self.arms[side]
        joints = self.joints(side)
        spec = JointStreamSpec(
            joints=joints,
            target=q_goal[joints].copy(),
            v_max=deg_to_rad(settings.max_speed_joint),
            a_max=deg_to_rad(settings.hw_accel),
            period=self.cmd_cycle,
            key=side.name,
            planned_from=q0.copy(),
            label=f"{side.name} streamed set-point",
        )
        q_end = q0.copy()
        q_end[joints] = q_goal[joints]
        return self.submit(spec, q_end, poses)

    def stream_joint(self, side: RightLeft, values_deg: np.ndarray, relative: bool) -> str | None:
        _, q0 = self._start_state()
        with self.ctx.planner.lock:
            target = self.joint_target(side, values_deg, q0, relative, "jointPoints")
            q_goal = q0.copy()
            q_goal[self.joints(side)] = target
            return self._stream(side, q_goal, q0)

    def stream_cartesian(
        self, side: RightLeft, target: CarPos, relative: bool, name: str
    ) -> str | None:
        snap, q0 = self._start_state()
        with self.ctx.planner.lock:
            q_goal, goal = self.ptp_goal(snap, q0, side, target, relative, name)
            return self._stream(side, q_goal, q0, {side: goal})

    def ptp_goal(
        self,
        snap: Snapshot,
        q0: np.ndarray,
        side: RightLeft,
        target: CarPos,
        relative: bool,
        name: str,
        clearance: bool = True,
    ) -> tuple[np.ndarray, pin.SE3]:
        """IK solution (kinematic configuration) of a JARA Cartesian target, and the target
        pose (original frame). ``clearance``: check the joint-space line there (a dual move
        checks both arms' lines together instead)."""
        settings = self.arms[side]
        planner = self.ctx.planner
        with planner.view.at(snap, q0) as kin:
            goal, _ = cartesian_target(planner, kin, side, settings, target, relative, name)
        allowed: dict[RedundantAxis, bool] = (
            {elbow_axis(side): True} if planner.view.kin.has_elbow(side) else {}
        )
        with unreachable_is_value_err():
            q_goal, _, _ = planner.pose_goal(
                snap, q0, side, goal, allowed, {}, False, clearance=clearance
            )
        return q_goal, goal

    # ------------------------------------------------------------------ both arms
    def dual_linear(self, targets: dict[RightLeft, CarPos], relative: bool) -> str | None:
        """Both arms along straight lines, starting and stopping together."""
        snap, q0 = self._start_state()
        planner = self.ctx.planner
        goals: dict[RightLeft, np.ndarray] = {}
        elbows: dict[RightLeft, float | None] = {}
        q_end = q0.copy()
        speeds, accels = [], []
        path_limits: list[tuple[float, float]] = []
        paths = []
        with planner.lock:
            for side, target in targets.items():
                settings = self.arms[side]
                with planner.view.at(snap, q0) as kin:
                    goal, elbow = cartesian_target(
                        planner, kin, side, settings, target, relative, side.name
                    )
                speed, accel = settings.cartesian_speed()
                speeds.append(speed)
                accels.append(accel)
                allowed = {elbow_axis(side): True} if elbow is not None else {}
                with unreachable_is_value_err():
                    arm_spec, q_side = planner.cartesian(
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
                        clearance=False,
                    )
                if arm_spec.path_limits is not None:
                    path_limits.append(arm_spec.path_limits)
                joints = self.joints(side)
                paths.append((joints, *planner.last_path))
                q_end[joints] = q_side[joints]
                goals[side] = goal.homogeneous.copy()
                elbows[side] = elbow
            with unreachable_is_value_err():  # both arms along their paths, together
                planner.require_clearance(*combine(q0, paths))
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

    def dual_ptp_cartesian(self, targets: dict[RightLeft, CarPos], relative: bool) -> str | None:
        """Both arms' joints to the IK solutions of their targets, together."""
        snap, q0 = self._start_state()
        with self.ctx.planner.lock:
            goals = {
                side: self.ptp_goal(snap, q0, side, target, relative, name, clearance=False)[0]
                for (side, target), name in zip(targets.items(), ("rArm", "lArm"), strict=True)
            }
            q_end = q0.copy()
            for side, q_side in goals.items():
                q_end[self.joints(side)] = q_side[self.joints(side)]
            with unreachable_is_value_err():  # both arms' joint lines at once
                self.ctx.planner.require_joint_line_clearance(q0, q_end)
            return self._dual_ptp(goals, q0)

    def dual_ptp_joint(self, values_deg: dict[RightLeft, np.ndarray], relative: bool) -> str | None:
        """Both arms' joints to (or by) ``values_deg``, together."""
        _, q0 = self._start_state()
        names = {RightLeft.RIGHT: "rArm", RightLeft.LEFT: "lArm"}
        with self.ctx.planner.lock:
            goals = {}
            for side, deg in values_deg.items():
                q = q0.copy()
                q[self.joints(side)] = self.joint_target(side, deg, q0, relative, names[side])
                goals[side] = q
            return self._dual_ptp(goals, q0)

    def _dual_ptp(self, goals_q: dict[RightLeft, np.ndarray], q0: np.ndarray) -> str | None:
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

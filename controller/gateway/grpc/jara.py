"""JARA_ARM: ManipulatorCommon (9) and ManipulatorMiddle (45) servicers, one per daemon.

Every request names its ``arm`` (RIGHT default; LEFT on a one-arm robot is VALUE_ERR). Servo
power, alarms, pause/resume/stop act on the whole robot (one power chain): the arm field of
those requests is checked but they do not act on one arm alone. Units: mm, deg, s, %.
Queueing and frames: see :mod:`controller.gateway.services.jara_arm`.
"""

from __future__ import annotations

import math

import grpc
import numpy as np

from controller.contract.motion_specs import CartesianBox
from controller.conversions import ArgumentError
from controller.errors import Refused
from controller.gateway.grpc.base import (
    alarm_msgs,
    car_pos_arg,
    car_pos_msg,
    finite_arg,
    hg_arg,
    hg_msg,
    positive_arg,
    ratio_arg,
    rpc,
    seq_arg,
)
from controller.gateway.grpc.replies import jara_state
from controller.gateway.planning.jara_arm import NO_BOX_MM
from controller.gateway.services.context import Context
from controller.gateway.services.jara_arm import JaraArmService
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import CoreState, ReturnCode, RightLeft, UnitType

C = "ManipulatorCommon"
M = "ManipulatorMiddle"


def _r(service: str, name: str) -> type:
    return getattr(pb, f"{service}{name}Response")


class ManipulatorCommonServicer(pb_grpc.ManipulatorCommonServicer):
    def __init__(self, ctx: Context, arms: JaraArmService):
        self.ctx = ctx
        self.arms = arms

    @rpc(_r(C, "ClearAlarms"))
    def ClearAlarms(self, request):
        self.arms.arm(request.arm)
        self.ctx.call("clear_alarms")

    @rpc(_r(C, "GetActiveAlarm"))
    def GetActiveAlarm(self, request):
        self.arms.arm(request.arm)
        return {"alarms": alarm_msgs(self.ctx.snapshot(), with_module=False)}

    @rpc(_r(C, "GetFeedbackPosJoint"))
    def GetFeedbackPosJoint(self, request):
        side, _ = self.arms.arm(request.arm)
        return {"pos": self._joint_pos(side)}

    def _joint_pos(self, side: RightLeft) -> list[float]:
        snap = self.ctx.snapshot()
        view = self.ctx.view
        unit = view.unit_positions(snap, UnitType[f"{side.name}_ARM"])
        values = unit.tolist()
        grippers = self.ctx.robot.profile.grippers
        if side.name in grippers:
            joint = grippers[side.name].joints[0]
            spec = self.ctx.robot.joints[joint]
            q = snap.q[view.hw_joints.index(joint)]
            values.append(math.degrees(q) if spec.kind == "revolute" else 1e3 * q)
        return values

    @rpc(_r(C, "GetManipInfo"))
    def GetManipInfo(self, request):
        side, settings = self.arms.arm(request.arm)
        profile = self.ctx.robot.profile
        info = pb.ManipInfo(
            manufactur=profile.manufacturer,
            type=f"{profile.name} {side.name.lower()} arm",
            axis_num=len(settings.joint_names),
            cmd_cycle=self.ctx.config.jara.cmd_cycle_ms,
            is_gripper=self.arms.has_gripper(side),
        )
        return {"m_info": info}

    @rpc(_r(C, "GetSoftLimitJoint"))
    def GetSoftLimitJoint(self, request):
        _, s = self.arms.arm(request.arm)
        limits = [
            pb.LimitValue(upper=float(hi), lower=float(lo))
            for lo, hi in zip(s.soft_lower, s.soft_upper, strict=True)
        ]
        return {"soft_limit": limits}

    @rpc(_r(C, "GetState"))
    def GetState(self, request):
        self.arms.arm(request.arm)
        return {"state": jara_state(self.ctx.snapshot())}

    @rpc(_r(C, "ServoOFF"))
    def ServoOFF(self, request):
        self.arms.arm(request.arm)
        self.ctx.call("servo_off")

    @rpc(_r(C, "ServoON"))
    def ServoON(self, request):
        self.arms.arm(request.arm)
        self.ctx.call("servo_on")

    @rpc(_r(C, "SetSoftLimitJoint"))
    def SetSoftLimitJoint(self, request):
        side, s = self.arms.arm(request.arm)
        n = len(s.joint_names)
        if len(request.soft_limit) != n:
            raise ArgumentError(
                f"soft_limit: expected {n} limits (one per joint), got {len(request.soft_limit)}"
            )
        lower, upper = np.empty(n), np.empty(n)
        for i, lv in enumerate(request.soft_limit):
            name = f"soft_limit[{i}] ({s.joint_names[i]})"
            upper[i] = finite_arg(lv.upper, f"{name}.upper")
            lower[i] = finite_arg(lv.lower, f"{name}.lower")
            if upper[i] < lower[i]:
                raise ArgumentError(f"{name}: upper {upper[i]:g} is below lower {lower[i]:g}")
            if lower[i] < s.hw_lower[i] - 1e-9 or upper[i] > s.hw_upper[i] + 1e-9:
                raise ArgumentError(
                    f"{name}: {lower[i]:g}..{upper[i]:g} deg is wider than the hardware limits "
                    f"{s.hw_lower[i]:g}..{s.hw_upper[i]:g} deg"
                )
        snap = self.ctx.snapshot()
        if snap.core_state == CoreState.ALARM:
            raise Refused(ReturnCode.STATUS_ERR, "not in alarm: clearAlarms first")
        if snap.moving or snap.queue:
            raise Refused(ReturnCode.STATUS_ERR, "not while the robot moves")
        joints = self.arms.joints(side)
        with self.arms.lock:
            self.ctx.call(
                "set_joint_limits", indices=joints, lower=np.radians(lower), upper=np.radians(upper)
            )
            self.ctx.planner.set_joint_limits(joints, np.radians(lower), np.radians(upper))
            s.soft_lower, s.soft_upper = lower, upper


class ManipulatorMiddleServicer(pb_grpc.ManipulatorMiddleServicer):
    def __init__(self, ctx: Context, arms: JaraArmService):
        self.ctx = ctx
        self.arms = arms

    # ------------------------------------------------------------------ grippers
    def _gripper(self, arm: int, ratio: float) -> None:
        side, _ = self.arms.arm(arm)
        if not self.arms.has_gripper(side):
            raise ArgumentError(f"arm: the {side.name} arm has no gripper")
        if not self.arms.hands_on:
            raise Refused(ReturnCode.STATUS_ERR, "the hands are servo off: call servoONHand first")
        self.ctx.call("gripper", side=side, ratio=ratio)

    @rpc(_r(M, "CloseGripper"))
    def CloseGripper(self, request):
        self._gripper(request.arm, 0.0)

    @rpc(_r(M, "OpenGripper"))
    def OpenGripper(self, request):
        self._gripper(request.arm, 1.0)

    @rpc(_r(M, "MoveGripper"))
    def MoveGripper(self, request):
        self._gripper(request.arm, ratio_arg(request.angle_ratio, "angle_ratio"))

    @rpc(_r(M, "SetGraspForce"))
    def SetGraspForce(self, request):
        side, s = self.arms.arm(request.arm)
        ratio_arg(request.force_ratio, "force_ratio")
        if not self.arms.has_gripper(side):
            raise ArgumentError(f"arm: the {side.name} arm has no gripper")
        s.grasp_force = int(request.force_ratio)

    @rpc(_r(M, "GetGraspForce"))
    def GetGraspForce(self, request):
        _, s = self.arms.arm(request.arm)
        return {"force_ratio": s.grasp_force}

    # ------------------------------------------------------------------ frames
    @rpc(_r(M, "GetBaseOffset"))
    def GetBaseOffset(self, request):
        _, s = self.arms.arm(request.arm)
        return {"offset": hg_msg(s.base_offset)}

    @rpc(_r(M, "SetBaseOffset"))
    def SetBaseOffset(self, request):
        side, s = self.arms.arm(request.arm)
        offset = hg_arg(request.offset, "offset")
        snap = self.ctx.snapshot()
        if snap.moving or snap.queue:
            raise Refused(ReturnCode.STATUS_ERR, "not while the robot moves")
        with self.arms.lock:
            s.base_offset = offset
            self._push_box(side)

    @rpc(_r(M, "SetControlPointOffset"))
    def SetControlPointOffset(self, request):
        side, _ = self.arms.arm(request.arm)
        offset = hg_arg(request.offset, "offset")
        self.ctx.call("set_control_point_offset", side=side, offset=offset.homogeneous)

    @rpc(_r(M, "GetFeedbackPosCartesian"))
    def GetFeedbackPosCartesian(self, request):
        side, _ = self.arms.arm(request.arm)
        pose, elbow = self.arms.feedback(self.ctx.snapshot(), side)
        return {"pos": car_pos_msg(pose, elbow)}

    # ------------------------------------------------------------------ speeds
    @rpc(_r(M, "GetMaxSpeedCartesian"))
    def GetMaxSpeedCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        t, r = s.max_speed_cartesian
        return {"speed": pb.CartesianSpeed(translation=t, rotation=r)}

    @rpc(_r(M, "SetMaxSpeedCartesian"))
    def SetMaxSpeedCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        t = positive_arg(request.speed.translation, "speed.translation", "mm/s")
        r = positive_arg(request.speed.rotation, "speed.rotation", "deg/s")
        s.max_speed_cartesian = (t, r)

    @rpc(_r(M, "GetMaxSpeedJoint"))
    def GetMaxSpeedJoint(self, request):
        _, s = self.arms.arm(request.arm)
        return {"speed": s.max_speed_joint.tolist()}

    @rpc(_r(M, "SetMaxSpeedJoint"))
    def SetMaxSpeedJoint(self, request):
        _, s = self.arms.arm(request.arm)
        speed = seq_arg(request.speed, len(s.joint_names), "speed", "speeds (one per joint)")
        for i, v in enumerate(speed):
            positive_arg(float(v), f"speed[{i}]", "deg/s")
            if v > s.hw_speed[i] * (1 + 1e-9):
                raise ArgumentError(
                    f"speed[{i}] ({s.joint_names[i]}): {v:g} deg/s exceeds the hardware limit "
                    f"{s.hw_speed[i]:g} deg/s"
                )
        s.max_speed_joint = speed

    @rpc(_r(M, "GetMinAccelTimeCartesian"))
    def GetMinAccelTimeCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        return {"acl_time": s.min_accel_time_cartesian}

    @rpc(_r(M, "SetMinAccelTimeCartesian"))
    def SetMinAccelTimeCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        s.min_accel_time_cartesian = positive_arg(request.acl_time, "acl_time", "s")
        s.accel_time_cartesian = max(s.accel_time_cartesian, s.min_accel_time_cartesian)

    @rpc(_r(M, "GetMinAccelTimeJoint"))
    def GetMinAccelTimeJoint(self, request):
        _, s = self.arms.arm(request.arm)
        return {"acl_time": s.min_accel_time_joint}

    @rpc(_r(M, "SetMinAccelTimeJoint"))
    def SetMinAccelTimeJoint(self, request):
        _, s = self.arms.arm(request.arm)
        t = positive_arg(request.acl_time, "acl_time", "s")
        hw = s.hw_min_accel_time_joint
        if t < hw - 1e-9:
            raise ArgumentError(
                f"acl_time: {t:g} s is shorter than the drives allow at full speed ({hw:.3f} s)"
            )
        s.min_accel_time_joint = t
        s.accel_time_joint = max(s.accel_time_joint, t)

    @rpc(_r(M, "SetAccelTimeCartesian"))
    def SetAccelTimeCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        t = positive_arg(request.acl_time, "acl_time", "s")
        if t < s.min_accel_time_cartesian - 1e-12:
            raise ArgumentError(
                f"acl_time: {t:g} s is below the minimum {s.min_accel_time_cartesian:g} s"
            )
        s.accel_time_cartesian = t

    @rpc(_r(M, "SetAccelTimeJoint"))
    def SetAccelTimeJoint(self, request):
        _, s = self.arms.arm(request.arm)
        t = positive_arg(request.acl_time, "acl_time", "s")
        if t < s.min_accel_time_joint - 1e-12:
            raise ArgumentError(
                f"acl_time: {t:g} s is below the minimum {s.min_accel_time_joint:g} s"
            )
        s.accel_time_joint = t

    @staticmethod
    def _ratio(value: int) -> int:
        if not 1 <= value <= 100:
            raise ArgumentError(f"spd_ratio: {value} % is outside 1..100 % (0 would never move)")
        return int(value)

    @rpc(_r(M, "SetSpeedCartesian"))
    def SetSpeedCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        s.speed_ratio_cartesian = self._ratio(request.spd_ratio)

    @rpc(_r(M, "SetSpeedJoint"))
    def SetSpeedJoint(self, request):
        _, s = self.arms.arm(request.arm)
        s.speed_ratio_joint = self._ratio(request.spd_ratio)

    @rpc(_r(M, "GetSpeedCartesian"))
    def GetSpeedCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        return {"spd_ratio": s.speed_ratio_cartesian}

    @rpc(_r(M, "GetSpeedJoint"))
    def GetSpeedJoint(self, request):
        _, s = self.arms.arm(request.arm)
        return {"spd_ratio": s.speed_ratio_joint}

    # ------------------------------------------------------------------ soft limits
    @rpc(_r(M, "GetSoftLimitCartesian"))
    def GetSoftLimitCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        if s.soft_box is None:
            lo, hi = np.full(3, -NO_BOX_MM), np.full(3, NO_BOX_MM)
        else:
            lo, hi = s.soft_box
        names = ("x_limit", "y_limit", "z_limit")
        return {
            n: pb.LimitValue(upper=float(hi[i]), lower=float(lo[i])) for i, n in enumerate(names)
        }

    @rpc(_r(M, "SetSoftLimitCartesian"))
    def SetSoftLimitCartesian(self, request):
        side, s = self.arms.arm(request.arm)
        lo, hi = np.empty(3), np.empty(3)
        for i, n in enumerate(("x_limit", "y_limit", "z_limit")):
            lv = getattr(request, n)
            hi[i] = finite_arg(lv.upper, f"{n}.upper")
            lo[i] = finite_arg(lv.lower, f"{n}.lower")
            if hi[i] < lo[i]:
                raise ArgumentError(f"{n}: upper {hi[i]:g} is below lower {lo[i]:g} mm")
        snap = self.ctx.snapshot()
        pose, _ = self.arms.feedback(snap, side)
        p = pose.translation * 1e3
        if np.any(p < lo) or np.any(p > hi):
            shown = ", ".join(f"{x:.1f}" for x in p)
            raise ArgumentError(
                f"the control point ({shown}) mm is outside the new limits: move it inside first"
            )
        if snap.moving or snap.queue:
            raise Refused(ReturnCode.STATUS_ERR, "not while the robot moves")
        with self.arms.lock:
            s.soft_box = (lo, hi)
            self._push_box(side)

    def _push_box(self, side: RightLeft) -> None:
        s = self.arms.arms[side]
        box = None
        if s.soft_box is not None:
            box = CartesianBox(s.soft_box[0] / 1e3, s.soft_box[1] / 1e3, s.base_offset.homogeneous)
        self.ctx.call("set_cartesian_box", side=side, box=box)

    # ------------------------------------------------------------------ home
    @rpc(_r(M, "SetHome"))
    def SetHome(self, request):
        _, s = self.arms.arm(request.arm)
        home = seq_arg(request.joint_point, len(s.joint_names), "jointPoint", "joint values")
        for i, v in enumerate(home):
            if not s.soft_lower[i] - 1e-9 <= v <= s.soft_upper[i] + 1e-9:
                raise ArgumentError(
                    f"jointPoint[{i}] ({s.joint_names[i]}): {v:g} deg is outside "
                    f"{s.soft_lower[i]:g}..{s.soft_upper[i]:g} deg"
                )
        s.home = home

    @rpc(_r(M, "GetHome"))
    def GetHome(self, request):
        _, s = self.arms.arm(request.arm)
        return {"joint_point": s.home.tolist()}

    @rpc(_r(M, "GoHome"))
    def GoHome(self, request):
        side, s = self.arms.arm(request.arm)
        return self.arms.ptp_joint(side, s.home, relative=False, label="go home")

    # ------------------------------------------------------------------ flow
    @rpc(_r(M, "Pause"))
    def Pause(self, request):
        self.arms.arm(request.arm)
        self.ctx.call("pause")

    @rpc(_r(M, "Resume"))
    def Resume(self, request):
        self.arms.arm(request.arm)
        self.ctx.call("resume")

    @rpc(_r(M, "Stop"))
    def Stop(self, request):
        self.arms.arm(request.arm)
        self.ctx.call("stop")

    # ------------------------------------------------------------------ moves
    def _joints_arg(
        self, side, values, name: str = "jointPoints"
    ) -> tuple[np.ndarray, float | None]:
        """Arm joint values [deg]; an extra last value moves the gripper (same unit as
        getFeedbackPosJoint reports it)."""
        s = self.arms.arms[side]
        n = len(s.joint_names)
        vals = list(values)
        extra = None
        if len(vals) == n + 1 and self.arms.has_gripper(side):
            extra = finite_arg(float(vals.pop()), f"{name}[{n}] (gripper)")
        arr = seq_arg(
            vals,
            n,
            name,
            f"joint values ({n} joints{' + 1 gripper' if self.arms.has_gripper(side) else ''})",
        )
        return arr, extra

    def _gripper_ratio(self, side, value: float) -> float:
        """Opening 0..1 of a gripper value (getFeedbackPosJoint's unit: deg or mm)."""
        g = self.ctx.robot.profile.grippers[side.name]
        spec = self.ctx.robot.joints[g.joints[0]]
        si = math.radians(value) if spec.kind == "revolute" else value / 1e3
        lo, hi = spec.to_si(g.closed[0]), spec.to_si(g.open[0])
        ratio = (si - lo) / (hi - lo)
        if not -1e-6 <= ratio <= 1 + 1e-6:
            raise ArgumentError(f"jointPoints: gripper value {value:g} is outside its range")
        return float(np.clip(ratio, 0.0, 1.0))

    def _ptp_joint(self, request, relative: bool, stream: bool = False):
        side, _ = self.arms.arm(request.arm)
        values, gripper = self._joints_arg(side, request.joint_points)
        # every argument checked before anything moves (a refused command leaves no trace)
        ratio = None if gripper is None else self._gripper_ratio(side, gripper)
        if stream:
            result = self.arms.stream_joint(side, values, relative)
        else:
            result = self.arms.ptp_joint(side, values, relative)
        if ratio is not None:
            self.ctx.call("gripper", side=side, ratio=ratio)
        return result

    @rpc(_r(M, "MovePTPJointAbs"))
    def MovePTPJointAbs(self, request):
        return self._ptp_joint(request, relative=False)

    @rpc(_r(M, "MovePTPJointRel"))
    def MovePTPJointRel(self, request):
        return self._ptp_joint(request, relative=True)

    @rpc(_r(M, "MovePTPJointAbsCmdCycle"))
    def MovePTPJointAbsCmdCycle(self, request):
        return self._ptp_joint(request, relative=False, stream=True)

    @rpc(_r(M, "MovePTPJointRelCmdCycle"))
    def MovePTPJointRelCmdCycle(self, request):
        return self._ptp_joint(request, relative=True, stream=True)

    def _linear(self, request, relative: bool, stream: bool = False):
        side, _ = self.arms.arm(request.arm)
        target = car_pos_arg(request.car_point, "carPoint")
        if stream:  # one command cycle apart: the joint stream through the IK solutions
            return self.arms.stream_cartesian(side, target, relative, "carPoint")
        return self.arms.linear(side, target, relative, "carPoint")

    @rpc(_r(M, "MoveLinearCartesianAbs"))
    def MoveLinearCartesianAbs(self, request):
        return self._linear(request, relative=False)

    @rpc(_r(M, "MoveLinearCartesianRel"))
    def MoveLinearCartesianRel(self, request):
        return self._linear(request, relative=True)

    @rpc(_r(M, "MoveLinearCartesianAbsCmdCycle"))
    def MoveLinearCartesianAbsCmdCycle(self, request):
        return self._linear(request, relative=False, stream=True)

    @rpc(_r(M, "MoveLinearCartesianRelCmdCycle"))
    def MoveLinearCartesianRelCmdCycle(self, request):
        return self._linear(request, relative=True, stream=True)

    def _ptp_cart(self, request, relative: bool, stream: bool = False):
        side, _ = self.arms.arm(request.arm)
        target = car_pos_arg(request.car_point, "carPoint")
        if stream:
            return self.arms.stream_cartesian(side, target, relative, "carPoint")
        return self.arms.ptp_cartesian(side, target, relative, "carPoint")

    @rpc(_r(M, "MovePTPCartesianAbs"))
    def MovePTPCartesianAbs(self, request):
        return self._ptp_cart(request, relative=False)

    @rpc(_r(M, "MovePTPCartesianRel"))
    def MovePTPCartesianRel(self, request):
        return self._ptp_cart(request, relative=True)

    @rpc(_r(M, "MovePTPCartesianAbsCmdCycle"))
    def MovePTPCartesianAbsCmdCycle(self, request):
        return self._ptp_cart(request, relative=False, stream=True)

    @rpc(_r(M, "MovePTPCartesianRelCmdCycle"))
    def MovePTPCartesianRelCmdCycle(self, request):
        return self._ptp_cart(request, relative=True, stream=True)

    def _circular(self, request, relative: bool):
        side, _ = self.arms.arm(request.arm)
        via = car_pos_arg(request.car_point_r, "carPointR")
        target = car_pos_arg(request.car_point_t, "carPointT")
        if np.linalg.norm(via.pose.translation - target.pose.translation) < 1e-6:
            raise ArgumentError("carPointR: the via point coincides with the target")
        return self.arms.linear(side, target, relative, "carPointT", via=via)

    @rpc(_r(M, "MoveCircularCartesianAbs"))
    def MoveCircularCartesianAbs(self, request):
        return self._circular(request, relative=False)

    @rpc(_r(M, "MoveCircularCartesianRel"))
    def MoveCircularCartesianRel(self, request):
        return self._circular(request, relative=True)


def add_jara_servicers(server: grpc.Server, ctx: Context) -> JaraArmService:
    from controller.gateway.grpc.dual import add_dual_servicers

    arms = JaraArmService(ctx)
    pb_grpc.add_ManipulatorCommonServicer_to_server(ManipulatorCommonServicer(ctx, arms), server)
    pb_grpc.add_ManipulatorMiddleServicer_to_server(ManipulatorMiddleServicer(ctx, arms), server)
    add_dual_servicers(server, ctx, arms)
    return arms

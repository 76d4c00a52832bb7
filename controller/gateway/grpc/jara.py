"""JARA_ARM over gRPC: ManipulatorCommon (9) and ManipulatorMiddle (45) servicers, one per
daemon. Messages to spec-unit values, a call of the JARA services
(:mod:`controller.gateway.services.jara_arm` for motions,
:mod:`controller.gateway.services.jara_settings` for settings), the reply.

Every request names its ``arm`` (RIGHT default; LEFT on a one-arm robot is VALUE_ERR). Servo
power, alarms, pause/resume/stop act on the whole robot (one power chain): the arm field of
those requests is checked but they do not act on one arm alone. Units: mm, deg, s, %.
"""

from __future__ import annotations

import grpc
import numpy as np

from controller.conversions import ArgumentError
from controller.gateway.grpc.base import (
    alarm_msgs,
    car_pos_arg,
    ratio_arg,
    rpc,
)
from controller.gateway.grpc.registrar import Registrar
from controller.gateway.services.context import Context
from controller.gateway.services.jara_arm import JaraArmService
from controller.gateway.services.jara_settings import JaraSettingsService
from controller.gateway.services.registry import Services
from controller.gateway.services.states import jara_state
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc

C = "ManipulatorCommon"
M = "ManipulatorMiddle"
_XYZ = ("x_limit", "y_limit", "z_limit")


def _r(service: str, name: str) -> type:
    return getattr(pb, f"{service}{name}Response")


def hg_list(msg: pb.HgMatrix) -> list[float]:
    return list(msg.m)


def hg_reply(hg_mm: np.ndarray) -> pb.HgMatrix:
    return pb.HgMatrix(m=np.asarray(hg_mm).ravel().tolist())


def limit_msgs(limits: list[tuple[float, float]]) -> list[pb.LimitValue]:
    return [pb.LimitValue(upper=hi, lower=lo) for lo, hi in limits]


class ManipulatorCommonServicer(pb_grpc.ManipulatorCommonServicer):
    def __init__(self, ctx: Context, arms: JaraArmService, settings: JaraSettingsService):
        self.ctx = ctx
        self.arms = arms
        self.settings = settings

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
        return {"pos": self.settings.joint_positions(side)}

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
        side, _ = self.arms.arm(request.arm)
        return {"soft_limit": limit_msgs(self.settings.soft_limit_joint(side))}

    @rpc(_r(C, "GetState"))
    def GetState(self, request):
        self.arms.arm(request.arm)
        return {"state": jara_state(self.ctx.state())}

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
        side, _ = self.arms.arm(request.arm)
        limits = [(lv.lower, lv.upper) for lv in request.soft_limit]
        self.settings.set_soft_limit_joint(side, limits)


class ManipulatorMiddleServicer(pb_grpc.ManipulatorMiddleServicer):
    def __init__(self, ctx: Context, arms: JaraArmService, settings: JaraSettingsService):
        self.ctx = ctx
        self.arms = arms
        self.settings = settings

    # ------------------------------------------------------------------ grippers
    @rpc(_r(M, "CloseGripper"))
    def CloseGripper(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.gripper(side, 0.0)

    @rpc(_r(M, "OpenGripper"))
    def OpenGripper(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.gripper(side, 1.0)

    @rpc(_r(M, "MoveGripper"))
    def MoveGripper(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.gripper(side, ratio_arg(request.angle_ratio, "angle_ratio"))

    @rpc(_r(M, "SetGraspForce"))
    def SetGraspForce(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_grasp_force(side, request.force_ratio)

    @rpc(_r(M, "GetGraspForce"))
    def GetGraspForce(self, request):
        _, s = self.arms.arm(request.arm)
        return {"force_ratio": s.grasp_force}

    # ------------------------------------------------------------------ frames
    @rpc(_r(M, "GetBaseOffset"))
    def GetBaseOffset(self, request):
        side, _ = self.arms.arm(request.arm)
        return {"offset": hg_reply(self.settings.base_offset(side))}

    @rpc(_r(M, "SetBaseOffset"))
    def SetBaseOffset(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_base_offset(side, hg_list(request.offset))

    @rpc(_r(M, "SetControlPointOffset"))
    def SetControlPointOffset(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_control_point_offset(side, hg_list(request.offset))

    @rpc(_r(M, "GetFeedbackPosCartesian"))
    def GetFeedbackPosCartesian(self, request):
        side, _ = self.arms.arm(request.arm)
        hg_mm, elbow = self.settings.feedback_cartesian(side)
        return {"pos": pb.CarPosWithElbow(car_pos=hg_reply(hg_mm), elbow=elbow, struct_flag=0)}

    # ------------------------------------------------------------------ speeds
    @rpc(_r(M, "GetMaxSpeedCartesian"))
    def GetMaxSpeedCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        t, r = s.max_speed_cartesian
        return {"speed": pb.CartesianSpeed(translation=t, rotation=r)}

    @rpc(_r(M, "SetMaxSpeedCartesian"))
    def SetMaxSpeedCartesian(self, request):
        side, _ = self.arms.arm(request.arm)
        speed = request.speed
        self.settings.set_max_speed_cartesian(side, speed.translation, speed.rotation)

    @rpc(_r(M, "GetMaxSpeedJoint"))
    def GetMaxSpeedJoint(self, request):
        _, s = self.arms.arm(request.arm)
        return {"speed": s.max_speed_joint.tolist()}

    @rpc(_r(M, "SetMaxSpeedJoint"))
    def SetMaxSpeedJoint(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_max_speed_joint(side, list(request.speed))

    @rpc(_r(M, "GetMinAccelTimeCartesian"))
    def GetMinAccelTimeCartesian(self, request):
        _, s = self.arms.arm(request.arm)
        return {"acl_time": s.min_accel_time_cartesian}

    @rpc(_r(M, "SetMinAccelTimeCartesian"))
    def SetMinAccelTimeCartesian(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_min_accel_time_cartesian(side, request.acl_time)

    @rpc(_r(M, "GetMinAccelTimeJoint"))
    def GetMinAccelTimeJoint(self, request):
        _, s = self.arms.arm(request.arm)
        return {"acl_time": s.min_accel_time_joint}

    @rpc(_r(M, "SetMinAccelTimeJoint"))
    def SetMinAccelTimeJoint(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_min_accel_time_joint(side, request.acl_time)

    @rpc(_r(M, "SetAccelTimeCartesian"))
    def SetAccelTimeCartesian(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_accel_time_cartesian(side, request.acl_time)

    @rpc(_r(M, "SetAccelTimeJoint"))
    def SetAccelTimeJoint(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_accel_time_joint(side, request.acl_time)

    @rpc(_r(M, "SetSpeedCartesian"))
    def SetSpeedCartesian(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_speed_cartesian(side, request.spd_ratio)

    @rpc(_r(M, "SetSpeedJoint"))
    def SetSpeedJoint(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_speed_joint(side, request.spd_ratio)

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
        side, _ = self.arms.arm(request.arm)
        limits = limit_msgs(self.settings.soft_limit_cartesian(side))
        return dict(zip(_XYZ, limits, strict=True))

    @rpc(_r(M, "SetSoftLimitCartesian"))
    def SetSoftLimitCartesian(self, request):
        side, _ = self.arms.arm(request.arm)
        limits = [(getattr(request, n).lower, getattr(request, n).upper) for n in _XYZ]
        self.settings.set_soft_limit_cartesian(side, limits)

    # ------------------------------------------------------------------ home
    @rpc(_r(M, "SetHome"))
    def SetHome(self, request):
        side, _ = self.arms.arm(request.arm)
        self.settings.set_home(side, list(request.joint_point))

    @rpc(_r(M, "GetHome"))
    def GetHome(self, request):
        _, s = self.arms.arm(request.arm)
        return {"joint_point": s.home.tolist()}

    @rpc(_r(M, "GoHome"))
    def GoHome(self, request):
        side, _ = self.arms.arm(request.arm)
        return self.settings.go_home(side)

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
    def _ptp_joint(self, request, relative: bool, stream: bool = False):
        side, _ = self.arms.arm(request.arm)
        return self.settings.move_joints(side, list(request.joint_points), relative, stream)

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


def add_jara_servicers(server: grpc.Server | Registrar, services: Services) -> None:
    from controller.gateway.grpc.dual import add_dual_servicers

    ctx, arms, settings = services.ctx, services.arms, services.settings
    pb_grpc.add_ManipulatorCommonServicer_to_server(
        ManipulatorCommonServicer(ctx, arms, settings), server
    )
    pb_grpc.add_ManipulatorMiddleServicer_to_server(
        ManipulatorMiddleServicer(ctx, arms, settings), server
    )
    add_dual_servicers(server, services.dual)

"""JARA_ARM_DUAL: DualManipulatorCommon (4) and DualManipulatorMiddle (10) servicers.

Both arms move together: they start and stop together (one time law). Speeds are the
slower of the two arms' JARA_ARM settings. Hands: servoOFFHand keeps the grippers where they
are and refuses gripper commands (STATUS_ERR) until servoONHand; the grippers share the
drives' power with the arms, so servo power itself is switched by servoONArm/servoOFFArm.
getRelativePosition (ruling): the left control point in the right control-point frame.
"""

from __future__ import annotations

import grpc

from controller.conversions import ArgumentError
from controller.errors import Refused
from controller.gateway.grpc.base import car_pos_arg, hg_msg, ratio_arg, rpc, seq_arg
from controller.gateway.services.context import Context
from controller.gateway.services.jara_arm import JaraArmService
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import FrameType, ReturnCode, RightLeft

C = "DualManipulatorCommon"
M = "DualManipulatorMiddle"


def _r(service: str, name: str) -> type:
    return getattr(pb, f"{service}{name}Response")


def _require_dual(arms: JaraArmService) -> None:
    if set(arms.arms) != {RightLeft.RIGHT, RightLeft.LEFT}:
        raise Refused(
            ReturnCode.VALUE_ERR, "this robot has one arm: the dual-arm interface needs two"
        )


class DualManipulatorCommonServicer(pb_grpc.DualManipulatorCommonServicer):
    def __init__(self, ctx: Context, arms: JaraArmService):
        self.ctx = ctx
        self.arms = arms

    @rpc(_r(C, "ServoONArm"))
    def ServoONArm(self, request):
        _require_dual(self.arms)
        self.ctx.call("servo_on")

    @rpc(_r(C, "ServoOFFArm"))
    def ServoOFFArm(self, request):
        _require_dual(self.arms)
        self.ctx.call("servo_off")

    @rpc(_r(C, "ServoONHand"))
    def ServoONHand(self, request):
        _require_dual(self.arms)
        if not self.ctx.snapshot().servo_on:
            raise Refused(ReturnCode.STATUS_ERR, "the arms are servo off: call servoONArm first")
        self.arms.hands_on = True

    @rpc(_r(C, "ServoOFFHand"))
    def ServoOFFHand(self, request):
        _require_dual(self.arms)
        self.arms.hands_on = False


class DualManipulatorMiddleServicer(pb_grpc.DualManipulatorMiddleServicer):
    def __init__(self, ctx: Context, arms: JaraArmService):
        self.ctx = ctx
        self.arms = arms

    def _grippers(self, ratios: dict[RightLeft, float | None]) -> None:
        _require_dual(self.arms)
        if not self.arms.hands_on:
            raise Refused(ReturnCode.STATUS_ERR, "the hands are servo off: call servoONHand first")
        for side, ratio in ratios.items():
            if ratio is not None and not self.arms.has_gripper(side):
                raise ArgumentError(f"the {side.name} arm has no gripper")
        for side, ratio in ratios.items():
            if ratio is not None:
                self.ctx.call("gripper", side=side, ratio=ratio)

    @staticmethod
    def _flag(value: int, name: str) -> bool:
        if value not in (0, 1):
            raise ArgumentError(f"{name}: {value} must be 1 (act on that side) or 0 (leave it)")
        return value == 1

    @rpc(_r(M, "CloseGripper"))
    def CloseGripper(self, request):
        r, l_ = self._flag(request.r_arm, "rArm"), self._flag(request.l_arm, "lArm")
        self._grippers({RightLeft.RIGHT: 0.0 if r else None, RightLeft.LEFT: 0.0 if l_ else None})

    @rpc(_r(M, "OpenGripper"))
    def OpenGripper(self, request):
        r, l_ = self._flag(request.r_arm, "rArm"), self._flag(request.l_arm, "lArm")
        self._grippers({RightLeft.RIGHT: 1.0 if r else None, RightLeft.LEFT: 1.0 if l_ else None})

    @rpc(_r(M, "MoveGripper"))
    def MoveGripper(self, request):
        self._grippers(
            {
                RightLeft.RIGHT: ratio_arg(request.r_arm, "rArm"),
                RightLeft.LEFT: ratio_arg(request.l_arm, "lArm"),
            }
        )

    def _linear(self, request, relative: bool):
        _require_dual(self.arms)
        targets = {
            RightLeft.RIGHT: car_pos_arg(request.r_arm, "rArm"),
            RightLeft.LEFT: car_pos_arg(request.l_arm, "lArm"),
        }
        return self.arms.dual_linear(targets, relative)

    @rpc(_r(M, "MoveLinearCartesianAbs"))
    def MoveLinearCartesianAbs(self, request):
        return self._linear(request, relative=False)

    @rpc(_r(M, "MoveLinearCartesianRel"))
    def MoveLinearCartesianRel(self, request):
        return self._linear(request, relative=True)

    def _ptp_cartesian(self, request, relative: bool):
        _require_dual(self.arms)
        targets = {
            RightLeft.RIGHT: car_pos_arg(request.r_arm, "rArm"),
            RightLeft.LEFT: car_pos_arg(request.l_arm, "lArm"),
        }
        return self.arms.dual_ptp_cartesian(targets, relative)

    @rpc(_r(M, "MovePTPCartesianAbs"))
    def MovePTPCartesianAbs(self, request):
        return self._ptp_cartesian(request, relative=False)

    @rpc(_r(M, "MovePTPCartesianRel"))
    def MovePTPCartesianRel(self, request):
        return self._ptp_cartesian(request, relative=True)

    def _ptp_joint(self, request, relative: bool):
        _require_dual(self.arms)
        values = {}
        for side, msg, name in (
            (RightLeft.RIGHT, request.r_arm, "rArm"),
            (RightLeft.LEFT, request.l_arm, "lArm"),
        ):
            n = len(self.arms.arms[side].joint_names)
            values[side] = seq_arg(msg, n, name, "joint values")
        return self.arms.dual_ptp_joint(values, relative)

    @rpc(_r(M, "MovePTPJointAbs"))
    def MovePTPJointAbs(self, request):
        return self._ptp_joint(request, relative=False)

    @rpc(_r(M, "MovePTPJointRel"))
    def MovePTPJointRel(self, request):
        return self._ptp_joint(request, relative=True)

    @rpc(_r(M, "GetRelativePosition"))
    def GetRelativePosition(self, request):
        _require_dual(self.arms)
        snap = self.ctx.snapshot()
        with self.ctx.view.at(snap) as kin:
            right = kin.pose(RightLeft.RIGHT, FrameType.CURRENT_FRAME)
            left = kin.pose(RightLeft.LEFT, FrameType.CURRENT_FRAME)
            rel = right.actInv(left)
        return {"rel_pos": hg_msg(rel)}


def add_dual_servicers(server: grpc.Server, ctx: Context, arms: JaraArmService) -> None:
    pb_grpc.add_DualManipulatorCommonServicer_to_server(
        DualManipulatorCommonServicer(ctx, arms), server
    )
    pb_grpc.add_DualManipulatorMiddleServicer_to_server(
        DualManipulatorMiddleServicer(ctx, arms), server
    )

"""JARA_ARM_DUAL over gRPC: DualManipulatorCommon (4) and DualManipulatorMiddle (10)
servicers; the rules are :mod:`controller.gateway.services.jara_dual`'s."""

from __future__ import annotations

import grpc

from controller.conversions import ArgumentError
from controller.gateway.grpc.base import car_pos_arg, ratio_arg, rpc
from controller.gateway.grpc.registrar import Registrar
from controller.gateway.services.jara_dual import JaraDualService
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import RightLeft

C = "DualManipulatorCommon"
M = "DualManipulatorMiddle"


def _r(service: str, name: str) -> type:
    return getattr(pb, f"{service}{name}Response")


def _flag(value: int, name: str) -> bool:
    if value not in (0, 1):
        raise ArgumentError(f"{name}: {value} must be 1 (act on that side) or 0 (leave it)")
    return value == 1


class DualManipulatorCommonServicer(pb_grpc.DualManipulatorCommonServicer):
    def __init__(self, dual: JaraDualService):
        self.dual = dual

    @rpc(_r(C, "ServoONArm"))
    def ServoONArm(self, request):
        self.dual.servo_arms(True)

    @rpc(_r(C, "ServoOFFArm"))
    def ServoOFFArm(self, request):
        self.dual.servo_arms(False)

    @rpc(_r(C, "ServoONHand"))
    def ServoONHand(self, request):
        self.dual.servo_hands(True)

    @rpc(_r(C, "ServoOFFHand"))
    def ServoOFFHand(self, request):
        self.dual.servo_hands(False)


class DualManipulatorMiddleServicer(pb_grpc.DualManipulatorMiddleServicer):
    def __init__(self, dual: JaraDualService):
        self.dual = dual

    def _both(self, request, ratio: float) -> None:
        r, l_ = _flag(request.r_arm, "rArm"), _flag(request.l_arm, "lArm")
        self.dual.grippers(
            {RightLeft.RIGHT: ratio if r else None, RightLeft.LEFT: ratio if l_ else None}
        )

    @rpc(_r(M, "CloseGripper"))
    def CloseGripper(self, request):
        self._both(request, 0.0)

    @rpc(_r(M, "OpenGripper"))
    def OpenGripper(self, request):
        self._both(request, 1.0)

    @rpc(_r(M, "MoveGripper"))
    def MoveGripper(self, request):
        self.dual.grippers(
            {
                RightLeft.RIGHT: ratio_arg(request.r_arm, "rArm"),
                RightLeft.LEFT: ratio_arg(request.l_arm, "lArm"),
            }
        )

    @staticmethod
    def _targets(request):
        return {
            RightLeft.RIGHT: car_pos_arg(request.r_arm, "rArm"),
            RightLeft.LEFT: car_pos_arg(request.l_arm, "lArm"),
        }

    @rpc(_r(M, "MoveLinearCartesianAbs"))
    def MoveLinearCartesianAbs(self, request):
        self.dual.require_dual()
        return self.dual.move_linear(self._targets(request), relative=False)

    @rpc(_r(M, "MoveLinearCartesianRel"))
    def MoveLinearCartesianRel(self, request):
        self.dual.require_dual()
        return self.dual.move_linear(self._targets(request), relative=True)

    @rpc(_r(M, "MovePTPCartesianAbs"))
    def MovePTPCartesianAbs(self, request):
        self.dual.require_dual()
        return self.dual.move_ptp_cartesian(self._targets(request), relative=False)

    @rpc(_r(M, "MovePTPCartesianRel"))
    def MovePTPCartesianRel(self, request):
        self.dual.require_dual()
        return self.dual.move_ptp_cartesian(self._targets(request), relative=True)

    @staticmethod
    def _joints(request):
        return {RightLeft.RIGHT: list(request.r_arm), RightLeft.LEFT: list(request.l_arm)}

    @rpc(_r(M, "MovePTPJointAbs"))
    def MovePTPJointAbs(self, request):
        return self.dual.move_ptp_joint(self._joints(request), relative=False)

    @rpc(_r(M, "MovePTPJointRel"))
    def MovePTPJointRel(self, request):
        return self.dual.move_ptp_joint(self._joints(request), relative=True)

    @rpc(_r(M, "GetRelativePosition"))
    def GetRelativePosition(self, request):
        return {"rel_pos": pb.HgMatrix(m=self.dual.relative_position().ravel().tolist())}


def add_dual_servicers(server: grpc.Server | Registrar, dual: JaraDualService) -> None:
    pb_grpc.add_DualManipulatorCommonServicer_to_server(DualManipulatorCommonServicer(dual), server)
    pb_grpc.add_DualManipulatorMiddleServicer_to_server(DualManipulatorMiddleServicer(dual), server)

"""JARA_ARM_DUAL over CORBA: DualManipulatorCommonInterface Common (4) and Middle (10),
calling the same :class:`~controller.gateway.services.jara_dual.JaraDualService` as the gRPC
servicers. Served only on robots with two arms.

getRelativePosition keeps the original ``in HgMatrix`` signature, so the pose cannot travel
back as an out parameter: the answer is OK with the pose in the comment (HgMatrix row-major,
in the family's units), and the ``in`` argument is ignored (docs/corba.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from controller.bounds import ANGLE
from controller.corba.stubs import JARA_ARM_DUAL, JARA_ARM_DUAL__POA
from controller.errors import ArgumentError
from controller.gateway.corba.guard import lenient_ops, op
from controller.gateway.corba.values import Units
from controller.gateway.services.arguments import ratio_arg
from controller.gateway.services.jara_arm import CarPos, car_pos
from controller.gateway.services.registry import Services
from controller.vocabulary import RightLeft

_FAMILY = "JARA_ARM_DUAL"


def _flag(value: int, name: str) -> bool:
    if value not in (0, 1):
        raise ArgumentError(f"{name}: {value} must be 1 (act on that side) or 0 (leave it)")
    return value == 1


class DualCommonServant(JARA_ARM_DUAL__POA.DualManipulatorCommonInterface_Common):
    _family = f"{_FAMILY}.DualManipulatorCommonInterface_Common"
    _return_id = JARA_ARM_DUAL.RETURN_ID
    _omni_op_d = lenient_ops(JARA_ARM_DUAL__POA.DualManipulatorCommonInterface_Common._omni_op_d)

    def __init__(self, services: Services):
        self.dual = services.dual

    @op
    def servoONArm(self) -> None:
        self.dual.servo_arms(True)

    @op
    def servoOFFArm(self) -> None:
        self.dual.servo_arms(False)

    @op
    def servoONHand(self) -> None:
        self.dual.servo_hands(True)

    @op
    def servoOFFHand(self) -> None:
        self.dual.servo_hands(False)


class DualMiddleServant(JARA_ARM_DUAL__POA.DualManipulatorCommonInterface_Middle):
    _family = f"{_FAMILY}.DualManipulatorCommonInterface_Middle"
    _return_id = JARA_ARM_DUAL.RETURN_ID
    _omni_op_d = lenient_ops(JARA_ARM_DUAL__POA.DualManipulatorCommonInterface_Middle._omni_op_d)

    def __init__(self, services: Services, si: bool):
        self.dual = services.dual
        self.arms = services.arms
        self.units = Units(si)

    def _both(self, r_arm: int, l_arm: int, ratio: float) -> None:
        r, l_ = _flag(r_arm, "rArm"), _flag(l_arm, "lArm")
        self.dual.grippers(
            {RightLeft.RIGHT: ratio if r else None, RightLeft.LEFT: ratio if l_ else None}
        )

    @op
    def closeGripper(self, r_arm: int, l_arm: int) -> None:
        self._both(r_arm, l_arm, 0.0)

    @op
    def openGripper(self, r_arm: int, l_arm: int) -> None:
        self._both(r_arm, l_arm, 1.0)

    @op
    def moveGripper(self, r_arm: int, l_arm: int) -> None:
        self.dual.grippers(
            {RightLeft.RIGHT: ratio_arg(r_arm, "rArm"), RightLeft.LEFT: ratio_arg(l_arm, "lArm")}
        )

    def _car_pos(self, cp: Any, name: str) -> CarPos:
        hg = self.units.hg_in(cp.carPos, f"{name}.carPos")
        return car_pos(hg, self.units.scalar_in(cp.elbow, ANGLE, f"{name}.elbow"), name)

    def _targets(self, r_arm: Any, l_arm: Any) -> dict[RightLeft, CarPos]:
        return {
            RightLeft.RIGHT: self._car_pos(r_arm, "rArm"),
            RightLeft.LEFT: self._car_pos(l_arm, "lArm"),
        }

    @op
    def moveLinearCartesianAbs(self, r_arm: Any, l_arm: Any) -> str | None:
        self.dual.require_dual()
        return self.dual.move_linear(self._targets(r_arm, l_arm), relative=False)

    @op
    def moveLinearCartesianRel(self, r_arm: Any, l_arm: Any) -> str | None:
        self.dual.require_dual()
        return self.dual.move_linear(self._targets(r_arm, l_arm), relative=True)

    @op
    def movePTPCartesianAbs(self, r_arm: Any, l_arm: Any) -> str | None:
        self.dual.require_dual()
        return self.dual.move_ptp_cartesian(self._targets(r_arm, l_arm), relative=False)

    @op
    def movePTPCartesianRel(self, r_arm: Any, l_arm: Any) -> str | None:
        self.dual.require_dual()
        return self.dual.move_ptp_cartesian(self._targets(r_arm, l_arm), relative=True)

    def _joints(self, r_arm: Any, l_arm: Any) -> dict[RightLeft, Sequence[float]]:
        return {
            RightLeft.RIGHT: self.units.seq_in(r_arm, ANGLE, "rArm"),
            RightLeft.LEFT: self.units.seq_in(l_arm, ANGLE, "lArm"),
        }

    @op
    def movePTPJointAbs(self, r_arm: Any, l_arm: Any) -> str | None:
        return self.dual.move_ptp_joint(self._joints(r_arm, l_arm), relative=False)

    @op
    def movePTPJointRel(self, r_arm: Any, l_arm: Any) -> str | None:
        return self.dual.move_ptp_joint(self._joints(r_arm, l_arm), relative=True)

    @op
    def getRelativePosition(self, rel_pos: Any) -> str:
        """The ``in`` argument is ignored (the original's signature cannot return the
        pose); the comment carries it: ``OK relPos=[[r00, r01, r02, x], [...], [...]]``."""
        hg = self.units.hg_out(self.dual.relative_position())
        unit = "m" if self.units.si else "mm"
        rows = ", ".join("[" + ", ".join(f"{v:.9g}" for v in row) + "]" for row in hg)
        return (
            f"OK relPos=[{rows}] (left control point in the right control-point frame, "
            f"HgMatrix [R | p], p in {unit}; the in parameter cannot return it)"
        )

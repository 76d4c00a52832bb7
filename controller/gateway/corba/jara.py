"""JARA_ARM (right arm) and JARA_ARM_LEFT (left arm) over CORBA: ManipulatorCommonInterface
Common (9) and Middle (45), one implementation parametrised by the arm and its stub module,
calling the same JARA services as the gRPC servicers (shared settings, one queue).

Units: mm, deg (default) or SI (``corba.units.jara_arm: si``: m, rad, m/s, rad/s),
converted in :class:`~controller.gateway.corba.values.Units`. Servo power, alarms and
pause/resume/stop act on the whole robot (one power chain), as over gRPC.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from controller.bounds import (
    ACCEL_TIME,
    ANGLE,
    ANGULAR_SPEED,
    LENGTH,
    LINEAR_SPEED,
    MAX_REPEATED,
    bounded,
)
from controller.corba.stubs import JARA_ARM, JARA_ARM__POA, JARA_ARM_LEFT, JARA_ARM_LEFT__POA
from controller.errors import ArgumentError
from controller.gateway.corba.guard import Reply, lenient_ops, op
from controller.gateway.corba.values import Units
from controller.gateway.services.arguments import ratio_arg
from controller.gateway.services.jara_arm import CarPos, car_pos
from controller.gateway.services.registry import Services
from controller.gateway.services.states import jara_state
from controller.vocabulary import RightLeft


@dataclass(frozen=True)
class JaraFamily:
    """One of the two single-arm modules: its stubs and interface names."""

    module: Any  #: JARA_ARM or JARA_ARM_LEFT
    poa: Any  #: JARA_ARM__POA or JARA_ARM_LEFT__POA
    prefix: str  #: "" or "Left"

    @property
    def name(self) -> str:
        return str(self.module.__name__.rsplit(".", 1)[-1])

    @property
    def common_type(self) -> str:
        return f"{self.name}::{self.prefix}ManipulatorCommonInterface_Common"

    @property
    def middle_type(self) -> str:
        return f"{self.name}::{self.prefix}ManipulatorCommonInterface_Middle"

    def skeleton(self, level: str) -> Any:
        return getattr(self.poa, f"{self.prefix}ManipulatorCommonInterface_{level}")


JARA_RIGHT = JaraFamily(JARA_ARM, JARA_ARM__POA, "")
JARA_LEFT = JaraFamily(JARA_ARM_LEFT, JARA_ARM_LEFT__POA, "Left")


class _Arm:
    """What both servants of one arm share: the arm, its units, its stub module."""

    _family: str
    _return_id: Any
    _omni_op_d: dict[str, Any]
    idl: Any

    def __init__(self, services: Services, side: RightLeft, si: bool):
        self.ctx = services.ctx
        self.arms = services.arms
        self.settings = services.settings
        self.side = side
        self.units = Units(si)
        self.arm_value = int(side)

    def _arm(self) -> Any:
        """The arm's settings; VALUE_ERR if this robot lost the arm (never: checked at start)."""
        return self.arms.arm(self.arm_value)[1]

    def _gripper_is_angle(self) -> bool:
        g = self.ctx.robot.profile.grippers[self.side.name]  # type: ignore[index]
        return bool(self.ctx.robot.joints[g.joints[0]].kind == "revolute")

    def joints_out(self, values: list[float]) -> list[float]:
        """Arm joints [deg] (+ a gripper value [deg or mm]) in wire units."""
        n = len(self._arm().joint_names)
        out = self.units.angles_out(values[:n])
        for v in values[n:]:
            out.append(
                self.units.angle_out(v) if self._gripper_is_angle() else self.units.length_out(v)
            )
        return out

    def joints_in(self, values: Any, name: str) -> list[float]:
        """Arm joints (+ an optional gripper value) in spec units, bounded."""
        vals = list(values)
        if len(vals) > MAX_REPEATED:
            raise ArgumentError(f"{name}: {len(vals)} values is too many (at most {MAX_REPEATED})")
        n = len(self._arm().joint_names)
        out = []
        for i, v in enumerate(vals):
            if i >= n and self.units.si and not self._gripper_is_angle():
                out.append(self.units.scalar_in(v, LENGTH, f"{name}[{i}]"))
            else:
                out.append(self.units.scalar_in(v, ANGLE, f"{name}[{i}]"))
        return out

    def car_pos_in(self, cp: Any, name: str) -> CarPos:
        hg = self.units.hg_in(cp.carPos, f"{name}.carPos")
        return car_pos(hg, self.units.scalar_in(cp.elbow, ANGLE, f"{name}.elbow"), name)

    def limit(self, lower: float, upper: float, length: bool) -> Any:
        f = self.units.length_out if length else self.units.angle_out
        return self.idl.LimitValue(f(upper), f(lower))


class CommonMixin(_Arm):
    """ManipulatorCommonInterface_Common (9 operations)."""

    @op
    def clearAlarms(self) -> None:
        self.ctx.call("clear_alarms")

    @op
    def getActiveAlarm(self) -> Reply:
        alarms = [
            self.idl.Alarm(a["code"], self.idl.AlarmType._items[a["type"]], a["description"])
            for a in self.ctx.snapshot().alarms
        ]
        return Reply(alarms)

    @op
    def getFeedbackPosJoint(self) -> Reply:
        return Reply(self.joints_out(self.settings.joint_positions(self.side)))

    @op
    def getManipInfo(self) -> Reply:
        profile = self.ctx.robot.profile
        info = self.idl.ManipInfo(
            profile.manufacturer,
            f"{profile.name} {self.side.name.lower()} arm",
            len(self._arm().joint_names),
            self.ctx.config.jara.cmd_cycle_ms,
            self.arms.has_gripper(self.side),
        )
        return Reply(info)

    @op
    def getSoftLimitJoint(self) -> Reply:
        limits = self.settings.soft_limit_joint(self.side)
        return Reply([self.limit(lo, hi, length=False) for lo, hi in limits])

    @op
    def getState(self) -> Reply:
        return Reply(int(jara_state(self.ctx.snapshot())))

    @op
    def servoOFF(self) -> None:
        self.ctx.call("servo_off")

    @op
    def servoON(self) -> None:
        self.ctx.call("servo_on")

    @op
    def setSoftLimitJoint(self, soft_limit: Any) -> None:
        limits = self.units.limits_in(soft_limit, ANGLE, "soft_limit")
        self.settings.set_soft_limit_joint(self.side, limits)


class MiddleMixin(_Arm):
    """ManipulatorCommonInterface_Middle (45 operations: JARA's 35 + SEED-Noid's 10)."""

    # ------------------------------------------------------------------ grippers
    @op
    def closeGripper(self) -> None:
        self.settings.gripper(self.side, 0.0)

    @op
    def openGripper(self) -> None:
        self.settings.gripper(self.side, 1.0)

    @op
    def moveGripper(self, angle_ratio: int) -> None:
        self.settings.gripper(self.side, ratio_arg(angle_ratio, "angle_ratio"))

    @op
    def setGraspForce(self, force_ratio: int) -> None:
        self.settings.set_grasp_force(self.side, force_ratio)

    @op
    def getGraspForce(self) -> Reply:
        return Reply(int(self._arm().grasp_force))

    # ------------------------------------------------------------------ frames
    @op
    def getBaseOffset(self) -> Reply:
        return Reply(self.units.hg_out(self.settings.base_offset(self.side)))

    @op
    def setBaseOffset(self, offset: Any) -> None:
        self.settings.set_base_offset(self.side, self.units.hg_in(offset, "offset"))

    @op
    def setControlPointOffset(self, offset: Any) -> None:
        self.settings.set_control_point_offset(self.side, self.units.hg_in(offset, "offset"))

    @op
    def getFeedbackPosCartesian(self) -> Reply:
        hg_mm, elbow = self.settings.feedback_cartesian(self.side)
        return Reply(
            self.idl.CarPosWithElbow(self.units.hg_out(hg_mm), self.units.angle_out(elbow), 0)
        )

    # ------------------------------------------------------------------ speeds
    @op
    def getMaxSpeedCartesian(self) -> Reply:
        t, r = self._arm().max_speed_cartesian
        return Reply(self.idl.CartesianSpeed(self.units.length_out(t), self.units.angle_out(r)))

    @op
    def setMaxSpeedCartesian(self, speed: Any) -> None:
        self.settings.set_max_speed_cartesian(
            self.side,
            self.units.scalar_in(speed.translation, LINEAR_SPEED, "speed.translation"),
            self.units.scalar_in(speed.rotation, ANGULAR_SPEED, "speed.rotation"),
        )

    @op
    def getMaxSpeedJoint(self) -> Reply:
        return Reply(self.units.angles_out(np.asarray(self._arm().max_speed_joint).tolist()))

    @op
    def setMaxSpeedJoint(self, speed: Any) -> None:
        self.settings.set_max_speed_joint(
            self.side, self.units.seq_in(speed, ANGULAR_SPEED, "speed")
        )

    @op
    def getMinAccelTimeCartesian(self) -> Reply:
        return Reply(float(self._arm().min_accel_time_cartesian))

    @op
    def setMinAccelTimeCartesian(self, acl_time: float) -> None:
        self.settings.set_min_accel_time_cartesian(self.side, _accel_time(acl_time))

    @op
    def getMinAccelTimeJoint(self) -> Reply:
        return Reply(float(self._arm().min_accel_time_joint))

    @op
    def setMinAccelTimeJoint(self, acl_time: float) -> None:
        self.settings.set_min_accel_time_joint(self.side, _accel_time(acl_time))

    @op
    def setAccelTimeCartesian(self, acl_time: float) -> None:
        self.settings.set_accel_time_cartesian(self.side, _accel_time(acl_time))

    @op
    def setAccelTimeJoint(self, acl_time: float) -> None:
        self.settings.set_accel_time_joint(self.side, _accel_time(acl_time))

    @op
    def setSpeedCartesian(self, spd_ratio: int) -> None:
        self.settings.set_speed_cartesian(self.side, spd_ratio)

    @op
    def setSpeedJoint(self, spd_ratio: int) -> None:
        self.settings.set_speed_joint(self.side, spd_ratio)

    @op
    def getSpeedCartesian(self) -> Reply:
        return Reply(int(self._arm().speed_ratio_cartesian))

    @op
    def getSpeedJoint(self) -> Reply:
        return Reply(int(self._arm().speed_ratio_joint))

    # ------------------------------------------------------------------ soft limits
    @op
    def getSoftLimitCartesian(self) -> Reply:
        limits = self.settings.soft_limit_cartesian(self.side)
        return Reply(*(self.limit(lo, hi, length=True) for lo, hi in limits))

    @op
    def setSoftLimitCartesian(self, x_limit: Any, y_limit: Any, z_limit: Any) -> None:
        limits = [
            self.units.limit_in(lv, LENGTH, name)
            for lv, name in ((x_limit, "x_limit"), (y_limit, "y_limit"), (z_limit, "z_limit"))
        ]
        self.settings.set_soft_limit_cartesian(self.side, limits)

    # ------------------------------------------------------------------ home
    @op
    def setHome(self, joint_point: Any) -> None:
        self.settings.set_home(self.side, self.joints_in(joint_point, "jointPoint"))

    @op
    def getHome(self) -> Reply:
        return Reply(self.units.angles_out(np.asarray(self._arm().home).tolist()))

    @op
    def goHome(self) -> str | None:
        return self.settings.go_home(self.side)

    # ------------------------------------------------------------------ flow
    @op
    def pause(self) -> None:
        self.ctx.call("pause")

    @op
    def resume(self) -> None:
        self.ctx.call("resume")

    @op
    def stop(self) -> None:
        self.ctx.call("stop")

    # ------------------------------------------------------------------ moves
    def _joints(self, points: Any, relative: bool, stream: bool = False) -> str | None:
        values = self.joints_in(points, "jointPoints")
        return self.settings.move_joints(self.side, values, relative, stream)

    @op
    def movePTPJointAbs(self, joint_points: Any) -> str | None:
        return self._joints(joint_points, relative=False)

    @op
    def movePTPJointRel(self, joint_points: Any) -> str | None:
        return self._joints(joint_points, relative=True)

    @op
    def movePTPJointAbsCmdCycle(self, joint_points: Any) -> str | None:
        return self._joints(joint_points, relative=False, stream=True)

    @op
    def movePTPJointRelCmdCycle(self, joint_points: Any) -> str | None:
        return self._joints(joint_points, relative=True, stream=True)

    def _linear(self, cp: Any, relative: bool, stream: bool = False) -> str | None:
        target = self.car_pos_in(cp, "carPoint")
        if stream:
            return self.arms.stream_cartesian(self.side, target, relative, "carPoint")
        return self.arms.linear(self.side, target, relative, "carPoint")

    @op
    def moveLinearCartesianAbs(self, car_point: Any) -> str | None:
        return self._linear(car_point, relative=False)

    @op
    def moveLinearCartesianRel(self, car_point: Any) -> str | None:
        return self._linear(car_point, relative=True)

    @op
    def moveLinearCartesianAbsCmdCycle(self, car_point: Any) -> str | None:
        return self._linear(car_point, relative=False, stream=True)

    @op
    def moveLinearCartesianRelCmdCycle(self, car_point: Any) -> str | None:
        return self._linear(car_point, relative=True, stream=True)

    def _ptp(self, cp: Any, relative: bool, stream: bool = False) -> str | None:
        target = self.car_pos_in(cp, "carPoint")
        if stream:
            return self.arms.stream_cartesian(self.side, target, relative, "carPoint")
        return self.arms.ptp_cartesian(self.side, target, relative, "carPoint")

    @op
    def movePTPCartesianAbs(self, car_point: Any) -> str | None:
        return self._ptp(car_point, relative=False)

    @op
    def movePTPCartesianRel(self, car_point: Any) -> str | None:
        return self._ptp(car_point, relative=True)

    @op
    def movePTPCartesianAbsCmdCycle(self, car_point: Any) -> str | None:
        return self._ptp(car_point, relative=False, stream=True)

    @op
    def movePTPCartesianRelCmdCycle(self, car_point: Any) -> str | None:
        return self._ptp(car_point, relative=True, stream=True)

    def _circular(self, via_cp: Any, target_cp: Any, relative: bool) -> str | None:
        via = self.car_pos_in(via_cp, "carPointR")
        target = self.car_pos_in(target_cp, "carPointT")
        if np.linalg.norm(via.pose.translation - target.pose.translation) < 1e-6:
            raise ArgumentError("carPointR: the via point coincides with the target")
        return self.arms.linear(self.side, target, relative, "carPointT", via=via)

    @op
    def moveCircularCartesianAbs(self, car_point_r: Any, car_point_t: Any) -> str | None:
        return self._circular(car_point_r, car_point_t, relative=False)

    @op
    def moveCircularCartesianRel(self, car_point_r: Any, car_point_t: Any) -> str | None:
        return self._circular(car_point_r, car_point_t, relative=True)


def _accel_time(value: float) -> float:
    return bounded(float(value), ACCEL_TIME, "acl_time")


def _servant_class(family: JaraFamily, level: str, mixin: type) -> type:
    skeleton = family.skeleton(level)
    return type(
        f"{family.prefix}ManipulatorCommonInterface_{level}Servant",
        (mixin, skeleton),
        {
            "_family": f"{family.name}.{family.prefix}ManipulatorCommonInterface_{level}",
            "_return_id": family.module.RETURN_ID,
            "_omni_op_d": lenient_ops(skeleton._omni_op_d),
            "idl": family.module,
        },
    )


_CLASSES = {
    (fam.name, level): _servant_class(fam, level, mixin)
    for fam in (JARA_RIGHT, JARA_LEFT)
    for level, mixin in (("Common", CommonMixin), ("Middle", MiddleMixin))
}


def common_servant(family: JaraFamily, services: Services, side: RightLeft, si: bool) -> Any:
    return _CLASSES[(family.name, "Common")](services, side, si)


def middle_servant(family: JaraFamily, services: Services, side: RightLeft, si: bool) -> Any:
    return _CLASSES[(family.name, "Middle")](services, side, si)

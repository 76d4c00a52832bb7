"""Spec A over CORBA: ``IDL:IntegratedMotionInterface:1.0`` (29 operations), calling the
same :class:`~controller.gateway.services.spec_a.SpecAService` as the gRPC servicer. Units
mm, deg, s, % (Spec A has no SI edition). ``isMoving`` / ``isServoOn`` answer a bare
boolean, as in the original IDL."""

from __future__ import annotations

from typing import Any

from controller.bounds import (
    ANGLE,
    ANGULAR_ACCEL,
    ANGULAR_SPEED,
    LENGTH,
    LINEAR_ACCEL,
    LINEAR_SPEED,
    MAX_REPEATED,
    TIME,
    bounded,
)
from controller.corba.stubs import _GlobalIDL as idl
from controller.corba.stubs import _GlobalIDL__POA as idl_poa
from controller.errors import ArgumentError
from controller.gateway.corba.guard import Reply, boolean_op, enum_value, lenient_ops, op
from controller.gateway.corba.values import Units
from controller.gateway.services.arguments import ratio_arg, side_arg, unit_arg
from controller.gateway.services.spec_a import AXIS_FIELDS, POS_FIELDS, RATE_FIELDS, SpecAService
from controller.gateway.services.states import spec_a_state
from controller.vocabulary import RightLeft, UnitType

#: IDL field names of RedundantPos / Speed / Accel / AxesMask / Limit by the services' names.
_IDL = {
    "elbow": "elbow",
    "lumbar_rx": "lumbarRx",
    "lumbar_ry": "lumbarRy",
    "lumbar_rz": "lumbarRz",
    "vehicle_x": "vehicleX",
    "vehicle_y": "vehicleY",
    "vehicle_theta": "vehicleTheta",
    "vehicle_translation": "vehicleTranslation",
    "vehicle_rotation": "vehicleRotation",
    "right_elbow": "rightElbow",
    "left_elbow": "leftElbow",
}
_POS_Q = {f: (LENGTH if f in ("vehicle_x", "vehicle_y") else ANGLE) for f in POS_FIELDS}
_LIMIT_Q = {
    f: (LENGTH if f in ("vehicle_x", "vehicle_y") else ANGLE) for _, f in AXIS_FIELDS.values()
}
_VEHICLE = (
    (LENGTH, LENGTH, ANGLE),  # x, y, theta
    (LINEAR_SPEED, ANGULAR_SPEED),
    (LINEAR_ACCEL, ANGULAR_ACCEL),
)


class SpecAServant(idl_poa.IntegratedMotionInterface):
    _family = "IntegratedMotionInterface"
    _return_id = idl.ReturnID
    _omni_op_d = lenient_ops(idl_poa.IntegratedMotionInterface._omni_op_d)

    def __init__(self, service: SpecAService):
        self.service = service
        self.ctx = service.ctx
        self.units = Units(si=False)

    # ------------------------------------------------------------------ always OK
    @op
    def abort(self) -> None:
        self.ctx.call("abort")

    @op
    def clearAlarms(self) -> None:
        self.ctx.call("clear_alarms")

    @op
    def pause(self) -> None:
        self.ctx.call("pause")

    @op
    def resume(self) -> None:
        self.ctx.call("resume")

    @op
    def stop(self) -> None:
        self.ctx.call("stop")

    @op
    def getActiveAlarm(self) -> Reply:
        alarms = [
            idl.Alarm(a["code"], idl.AlarmType._items[a["type"]], a["description"], a["module"])
            for a in self.ctx.snapshot().alarms
        ]
        return Reply(alarms)

    @op
    def getState(self) -> Reply:
        state, text = spec_a_state(self.ctx.state())
        return Reply(int(state), text)

    @op
    def getVersion(self) -> Reply:
        return Reply(self.service.version())

    @boolean_op
    def isMoving(self) -> bool:
        return self.service.is_moving()

    @boolean_op
    def isServoOn(self) -> bool:
        return self.service.is_servo_on()

    # ------------------------------------------------------------------ servo
    @op
    def servoOn(self) -> None:
        self.ctx.call("servo_on")

    @op
    def servoOff(self) -> None:
        self.ctx.call("servo_off")

    # ------------------------------------------------------------------ feedback
    @op
    def getFeedbackPosCartesian(self, side: Any, frame: Any) -> Reply:
        hg_mm, elbow = self.service.feedback_cartesian(enum_value(side), enum_value(frame))
        return Reply(idl.CarPosWithElbow(self.units.hg_out(hg_mm), elbow, 0))

    @op
    def getFeedbackPosJoint(self, unit: Any) -> Reply:
        u = unit_arg(self.ctx.view, enum_value(unit), "type")
        return Reply(self.ctx.view.unit_positions(self.ctx.snapshot(), u).tolist())

    @op
    def getGripperPos(self, side: Any) -> Reply:
        return Reply(self.service.gripper_pos(enum_value(side)))

    # ------------------------------------------------------------------ grippers
    @op
    def closeGripper(self, side: Any) -> None:
        self.service.gripper(enum_value(side), 0.0)

    @op
    def openGripper(self, side: Any) -> None:
        self.service.gripper(enum_value(side), 1.0)

    @op
    def moveGripper(self, side: Any, angle_ratio: int) -> None:
        self.service.gripper(enum_value(side), ratio_arg(angle_ratio, "angle_ratio"))

    # ------------------------------------------------------------------ settings
    @op
    def resetOriginalFrame(self) -> None:
        self.ctx.call("reset_original_frame")

    @op
    def setControlPointOffset(self, side: Any, offset: Any) -> None:
        hg = self.units.hg_in(offset, "offset")
        self.service.set_control_point_offset(self._side(side), hg)

    @op
    def selectRedundantAxes(self, redundancy: Any, limit: Any) -> str | None:
        mask = {f: bool(getattr(redundancy, _IDL[f])) for f, _ in AXIS_FIELDS.values()}
        limits = {
            f: self.units.limit_in(getattr(limit, _IDL[f]), _LIMIT_Q[f], f"limit.{_IDL[f]}")
            for _, f in AXIS_FIELDS.values()
        }
        return self.service.select_redundant_axes(mask, limits)

    # ------------------------------------------------------------------ unit moves
    def _unit_move(self, unit: Any, pos: Any, speed: Any, accel: Any, relative: bool) -> None:
        u = unit_arg(self.ctx.view, enum_value(unit))
        pos_name = "rel_pos" if relative else "abs_pos"
        vehicle = u == UnitType.VEHICLE
        args = []
        for values, name, joint_q, vehicle_q in (
            (pos, pos_name, ANGLE, _VEHICLE[0]),
            (speed, "speed", ANGULAR_SPEED, _VEHICLE[1]),
            (accel, "accel", ANGULAR_ACCEL, _VEHICLE[2]),
        ):
            vals = list(values)
            if len(vals) > MAX_REPEATED:
                raise ArgumentError(
                    f"{name}: {len(vals)} values is too many (at most {MAX_REPEATED})"
                )
            args.append(
                [
                    bounded(
                        float(v),
                        vehicle_q[i] if vehicle and i < len(vehicle_q) else joint_q,
                        f"{name}[{i}]",
                    )
                    for i, v in enumerate(vals)
                ]
            )
        self.service.move_unit(u, args[0], args[1], args[2], relative)

    @op
    def moveUnitAbs(self, unit: Any, abs_pos: Any, speed: Any, accel: Any) -> None:
        self._unit_move(unit, abs_pos, speed, accel, relative=False)

    @op
    def moveUnitRel(self, unit: Any, rel_pos: Any, speed: Any, accel: Any) -> None:
        self._unit_move(unit, rel_pos, speed, accel, relative=True)

    # ------------------------------------------------------------------ CP hold
    def _cp_hold(self, side: Any, pos: Any, speed: Any, accel: Any, relative: bool) -> str | None:
        pos_name = "rel_pos" if relative else "abs_pos"
        u = self.units
        rate_q = {
            f: (
                (LINEAR_SPEED, LINEAR_ACCEL)
                if f == "vehicle_translation"
                else (ANGULAR_SPEED, ANGULAR_ACCEL)
            )
            for f in RATE_FIELDS
        }
        return self.service.move_cp_hold(
            self._side(side),
            {
                f: u.scalar_in(getattr(pos, _IDL[f]), _POS_Q[f], f"{pos_name}.{f}")
                for f in POS_FIELDS
            },
            {
                f: u.scalar_in(getattr(speed, _IDL[f]), rate_q[f][0], f"speed.{f}")
                for f in RATE_FIELDS
            },
            {
                f: u.scalar_in(getattr(accel, _IDL[f]), rate_q[f][1], f"accel.{f}")
                for f in RATE_FIELDS
            },
            relative,
        )

    @op
    def moveCPHoldAbs(self, side: Any, abs_pos: Any, speed: Any, accel: Any) -> str | None:
        return self._cp_hold(side, abs_pos, speed, accel, relative=False)

    @op
    def moveCPHoldRel(self, side: Any, rel_pos: Any, speed: Any, accel: Any) -> str | None:
        return self._cp_hold(side, rel_pos, speed, accel, relative=True)

    # ------------------------------------------------------------------ Cartesian
    def _linear(
        self, side: Any, frame: int | None, hg: Any, speed: Any, accel: Any, hold: bool, target: str
    ) -> None:
        s = self._side(side)
        if frame is not None and frame not in (0, 1):
            raise ArgumentError(f"frame_type: {frame} is not BASE_FRAME (0) or TOOL_FRAME (1)")
        u = self.units
        self.service.move_linear(
            s,
            u.hg_in(hg, target),
            (
                u.scalar_in(speed.translation, LINEAR_SPEED, "speed.translation"),
                u.scalar_in(speed.rotation, ANGULAR_SPEED, "speed.rotation"),
            ),
            (
                u.scalar_in(accel.translation, LINEAR_ACCEL, "accel.translation"),
                u.scalar_in(accel.rotation, ANGULAR_ACCEL, "accel.rotation"),
            ),
            bool(hold),
            None if frame is None else frame == 1,
            target,
        )

    @op
    def moveLinearCartesianAbs(
        self, side: Any, abs_hg_mat: Any, speed: Any, accel: Any, is_hold_other_arm: bool
    ) -> None:
        self._linear(side, None, abs_hg_mat, speed, accel, is_hold_other_arm, "abs_hg_mat")

    @op
    def moveLinearCartesianRel(
        self,
        side: Any,
        frame_type: Any,
        rel_hg_mat: Any,
        speed: Any,
        accel: Any,
        is_hold_other_arm: bool,
    ) -> None:
        frame = enum_value(frame_type)
        self._linear(side, frame, rel_hg_mat, speed, accel, is_hold_other_arm, "rel_hg_mat")

    def _ptp(
        self, side: Any, hg: Any, time: float, hold: bool, relative: bool, target: str
    ) -> None:
        s = self._side(side)
        self.service.move_ptp(
            s,
            self.units.hg_in(hg, target),
            bounded(float(time), TIME, "time"),
            bool(hold),
            relative,
            target,
        )

    @op
    def movePTPCartesianAbs(
        self, side: Any, abs_hg_mat: Any, time: float, is_hold_other_arm: bool
    ) -> None:
        self._ptp(side, abs_hg_mat, time, is_hold_other_arm, False, "abs_hg_mat")

    @op
    def movePTPCartesianRel(
        self, side: Any, rel_hg_mat: Any, time: float, is_hold_other_arm: bool
    ) -> None:
        self._ptp(side, rel_hg_mat, time, is_hold_other_arm, True, "rel_hg_mat")

    # ------------------------------------------------------------------ helpers
    def _side(self, value: Any) -> RightLeft:
        return side_arg(self.ctx.view, enum_value(value))

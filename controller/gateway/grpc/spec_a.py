"""Spec A, IntegratedMotion: whole-body motion with redundant axes (29 operations).

Motion commands are accepted only in Ready (Spec A never queues: Busy/Pause → STATUS_ERR);
with the servos off they answer NOT_SV_ON_ERR where the original lists it (grippers,
movePTPCartesian*) and STATUS_ERR otherwise. Arguments are checked first (VALUE_ERR says
which and why), then the state, then reachability (CANNOT_REACH_TARGET_ERR), and only then
does anything move. Units: mm, deg, s at this edge; SI inside.
"""

from __future__ import annotations

import math
import threading

import numpy as np
import pinocchio as pin

from controller import __version__
from controller.contract.motion_specs import MotionSpec
from controller.contract.snapshot import Snapshot
from controller.conversions import ArgumentError
from controller.errors import Refused
from controller.gateway.grpc.base import (
    Context,
    alarm_msgs,
    car_pos_msg,
    finite_arg,
    hg_arg,
    positive_arg,
    ratio_arg,
    require_gripper,
    rpc,
    side_arg,
    unit_arg,
)
from controller.gateway.grpc.replies import spec_a_state
from controller.model.redundant_axes import RedundantAxis, available_axes, axis_value, elbow_axis
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import FrameType, ReturnCode, RightLeft, SpecAState, UnitType

Range = tuple[float, float]

#: Longest movePTPCartesian time [s] (the time law fails on much longer ones).
MAX_PTP_TIME = 3600.0

_LUMBAR = {
    RedundantAxis.LUMBAR_RX: "lumbar_rx",
    RedundantAxis.LUMBAR_RY: "lumbar_ry",
    RedundantAxis.LUMBAR_RZ: "lumbar_rz",
}
_VEHICLE = {
    RedundantAxis.VEHICLE_X: "vehicle_x",
    RedundantAxis.VEHICLE_Y: "vehicle_y",
    RedundantAxis.VEHICLE_THETA: "vehicle_theta",
}


def require_ready(snap: Snapshot, sv_on_code: bool) -> None:
    """Spec A: motion only from Ready."""
    state, _ = spec_a_state(snap)
    if state in (SpecAState.UNPOWERED, SpecAState.SERVO_OFF):
        code = ReturnCode.NOT_SV_ON_ERR if sv_on_code else ReturnCode.STATUS_ERR
        raise Refused(code, "the servos are off: call servoOn first")
    if state == SpecAState.ALARM:
        raise Refused(ReturnCode.STATUS_ERR, "alarms are active: clearAlarms, then servoOn")
    if state in (SpecAState.BUSY, SpecAState.PAUSE):
        raise Refused(
            ReturnCode.STATUS_ERR,
            f"the robot is {'paused' if state == SpecAState.PAUSE else 'busy'}: this "
            "interface does not queue; wait for the motion to end, or stop it",
        )


def relative_pose(current: pin.SE3, rel: pin.SE3, tool_frame: bool) -> pin.SE3:
    """Target of a relative move: in the control-point frame (TOOL) or in the original
    frame (BASE: translation added, rotation applied about the original axes)."""
    if tool_frame:
        return current * rel
    return pin.SE3(rel.rotation @ current.rotation, current.translation + rel.translation)


class IntegratedMotionServicer(pb_grpc.IntegratedMotionServicer):
    def __init__(self, ctx: Context):
        self.ctx = ctx
        self.view = ctx.view
        axes = available_axes(ctx.planner.view.kin)
        self.axes = axes
        #: selectRedundantAxes state: which axes Cartesian moves may use, and their ranges.
        self.allowed: dict[RedundantAxis, bool] = {a: a.is_elbow for a in axes}
        self.ranges: dict[RedundantAxis, Range | None] = {}
        self._settings = threading.Lock()

    # ------------------------------------------------------------------ always OK
    @rpc(pb.AbortResponse)
    def Abort(self, request):
        self.ctx.call("abort")

    @rpc(pb.ClearAlarmsResponse)
    def ClearAlarms(self, request):
        self.ctx.call("clear_alarms")

    @rpc(pb.PauseResponse)
    def Pause(self, request):
        self.ctx.call("pause")

    @rpc(pb.ResumeResponse)
    def Resume(self, request):
        self.ctx.call("resume")

    @rpc(pb.StopResponse)
    def Stop(self, request):
        self.ctx.call("stop")

    @rpc(pb.GetActiveAlarmResponse)
    def GetActiveAlarm(self, request):
        return {"alarms": alarm_msgs(self.ctx.snapshot())}

    @rpc(pb.GetStateResponse)
    def GetState(self, request):
        state, text = spec_a_state(self.ctx.snapshot())
        return {"status_id": int(state), "message": text}

    @rpc(pb.GetVersionResponse)
    def GetVersion(self, request):
        cfg = self.ctx.config
        return {"version": f"imotion {__version__} (robot {cfg.robot}, hal {cfg.hal})"}

    @rpc(pb.IsMovingResponse)
    def IsMoving(self, request):
        snap = self.ctx.snapshot()
        return {"is_moving": snap.moving or snap.queue > 0}

    @rpc(pb.IsServoOnResponse)
    def IsServoOn(self, request):
        return {"is_servo_on": self.ctx.snapshot().servo_on}

    # ------------------------------------------------------------------ servo
    @rpc(pb.ServoOnResponse)
    def ServoOn(self, request):
        self.ctx.call("servo_on")

    @rpc(pb.ServoOffResponse)
    def ServoOff(self, request):
        self.ctx.call("servo_off")

    # ------------------------------------------------------------------ feedback
    @rpc(pb.GetFeedbackPosCartesianResponse)
    def GetFeedbackPosCartesian(self, request):
        side = side_arg(self.view, request.type)
        if request.frame_type not in (0, 1):
            raise ArgumentError(f"frame_type: {request.frame_type} is not a FrameType (0, 1)")
        pose, elbow = self.view.pose(self.ctx.snapshot(), side, FrameType(request.frame_type))
        return {"pos": car_pos_msg(pose, elbow)}

    @rpc(pb.GetFeedbackPosJointResponse)
    def GetFeedbackPosJoint(self, request):
        unit = unit_arg(self.view, request.type, "type")
        return {"position": self.view.unit_positions(self.ctx.snapshot(), unit).tolist()}

    @rpc(pb.GetGripperPosResponse)
    def GetGripperPos(self, request):
        side = side_arg(self.view, request.type)
        require_gripper(self.view, side)
        ratio = self.view.gripper_ratio(self.ctx.snapshot(), side)
        return {"angle_ratio": round(100.0 * (ratio or 0.0))}

    # ------------------------------------------------------------------ grippers
    def _gripper(self, side_value: int, ratio: float) -> None:
        side = side_arg(self.view, side_value)
        require_gripper(self.view, side)
        self.ctx.call("gripper", side=side, ratio=ratio)

    @rpc(pb.CloseGripperResponse)
    def CloseGripper(self, request):
        self._gripper(request.type, 0.0)

    @rpc(pb.OpenGripperResponse)
    def OpenGripper(self, request):
        self._gripper(request.type, 1.0)

    @rpc(pb.MoveGripperResponse)
    def MoveGripper(self, request):
        self._gripper(request.type, ratio_arg(request.angle_ratio, "angle_ratio"))

    # ------------------------------------------------------------------ settings
    @rpc(pb.ResetOriginalFrameResponse)
    def ResetOriginalFrame(self, request):
        self.ctx.call("reset_original_frame")

    @rpc(pb.SetControlPointOffsetResponse)
    def SetControlPointOffset(self, request):
        side = side_arg(self.view, request.type)
        offset = hg_arg(request.offset, "offset")
        if np.linalg.norm(offset.translation) > 2.0:
            raise ArgumentError(
                f"offset: {1e3 * np.linalg.norm(offset.translation):.0f} mm from the flange "
                "is not a plausible tool (limit 2000 mm)"
            )
        self.ctx.call("set_control_point_offset", side=side, offset=offset.homogeneous)

    @rpc(pb.SelectRedundantAxesResponse)
    def SelectRedundantAxes(self, request):
        mask, limit = request.redundancy, request.limit
        allowed: dict[RedundantAxis, bool] = {}
        ranges: dict[RedundantAxis, Range | None] = {}
        ignored = []
        fields = {
            RedundantAxis.RIGHT_ELBOW: ("elbow", "right_elbow"),
            RedundantAxis.LEFT_ELBOW: ("elbow", "left_elbow"),
            RedundantAxis.LUMBAR_RX: ("lumbar_rx", "lumbar_rx"),
            RedundantAxis.LUMBAR_RY: ("lumbar_ry", "lumbar_ry"),
            RedundantAxis.LUMBAR_RZ: ("lumbar_rz", "lumbar_rz"),
            RedundantAxis.VEHICLE_X: ("vehicle_x", "vehicle_x"),
            RedundantAxis.VEHICLE_Y: ("vehicle_y", "vehicle_y"),
            RedundantAxis.VEHICLE_THETA: ("vehicle_theta", "vehicle_theta"),
        }
        for axis, (mask_field, limit_field) in fields.items():
            use = bool(getattr(mask, mask_field))
            lv = getattr(limit, limit_field)
            name = f"limit.{limit_field}"
            upper = finite_arg(lv.upper, f"{name}.upper")
            lower = finite_arg(lv.lower, f"{name}.lower")
            if axis not in self.axes:
                # one mask bit for both elbows: a one-arm robot's missing left elbow is no news
                lone_arm = axis.is_elbow and any(a.is_elbow for a in self.axes)
                if use and not lone_arm and axis.value not in ignored:
                    ignored.append(axis.value)
                continue
            allowed[axis] = use
            if upper == 0.0 and lower == 0.0:
                ranges[axis] = None  # no range given: the hardware's
                continue
            if upper < lower:
                raise ArgumentError(f"{name}: upper {upper:g} is below lower {lower:g}")
            ranges[axis] = self._range_si(axis, lower, upper, name)
        snap = self.ctx.snapshot()
        state, _ = spec_a_state(snap)
        if state in (SpecAState.BUSY, SpecAState.PAUSE):
            raise Refused(ReturnCode.STATUS_ERR, "not while a motion runs: stop it or wait")
        with self._settings:
            self.allowed, self.ranges = allowed, ranges
        if ignored:
            return {"comment": f"OK (this robot has no {', '.join(ignored)}: ignored)"}
        return None

    def _range_si(self, axis: RedundantAxis, lower: float, upper: float, name: str) -> Range:
        if axis in (RedundantAxis.VEHICLE_X, RedundantAxis.VEHICLE_Y):
            return lower / 1e3, upper / 1e3
        lo, hi = math.radians(lower), math.radians(upper)
        if axis.is_elbow:
            if lo < -math.pi - 1e-9 or hi > math.pi + 1e-9:
                raise ArgumentError(f"{name}: elbow ranges lie within -180..180 deg")
        elif axis.is_lumbar:
            hw_lo, hw_hi = self._lumbar_range(axis)
            if lo < hw_lo - 1e-9 or hi > hw_hi + 1e-9:
                raise ArgumentError(
                    f"{name}: {lower:g}..{upper:g} deg is wider than the waist allows "
                    f"({math.degrees(hw_lo):.1f}..{math.degrees(hw_hi):.1f} deg)"
                )
        return lo, hi

    def _lumbar_range(self, axis: RedundantAxis) -> Range:
        weights = self.ctx.robot.profile.redundant_axes.lumbar[axis.lumbar.value]
        lo = hi = 0.0
        for joint, w in weights.items():
            spec = self.ctx.robot.joints[joint]
            a, b = w * spec.lower, w * spec.upper
            lo += min(a, b)
            hi += max(a, b)
        return lo, hi

    def _mask(self) -> tuple[dict[RedundantAxis, bool], dict[RedundantAxis, Range | None]]:
        with self._settings:
            return dict(self.allowed), dict(self.ranges)

    # ------------------------------------------------------------------ unit moves
    def _unit_move(self, request, relative: bool) -> dict | None:
        view = self.view
        unit = unit_arg(view, request.unit)
        pos_name = "rel_pos" if relative else "abs_pos"
        pos = np.array(list(getattr(request, pos_name)), dtype=float)
        names = view.unit_joint_names(unit)
        n = 3 if unit == UnitType.VEHICLE else len(names)
        if pos.size != n:
            raise ArgumentError(f"{pos_name}: {unit.value} takes {n} values, got {pos.size}")
        for i, x in enumerate(pos):
            finite_arg(float(x), f"{pos_name}[{i}]")
        snap = self.ctx.snapshot()
        planner = self.ctx.planner
        if unit == UnitType.VEHICLE:
            speed = self._pair(request.speed, "speed", "mm/s, deg/s")
            accel = self._pair(request.accel, "accel", "mm/s², deg/s²")
            x_spec = self.ctx.robot.joints[names[0]]
            t_spec = self.ctx.robot.joints[names[2]]
            self._within(speed[0] / 1e3, x_spec.velocity, "speed[0]", 1e3, "mm/s")
            self._within(math.radians(speed[1]), t_spec.velocity, "speed[1]", None, "deg/s")
            self._within(accel[0] / 1e3, x_spec.acceleration, "accel[0]", 1e3, "mm/s²")
            self._within(math.radians(accel[1]), t_spec.acceleration, "accel[1]", None, "deg/s²")
            require_ready(snap, sv_on_code=False)
            target = np.array([pos[0] / 1e3, pos[1] / 1e3, math.radians(pos[2])])
            q0 = planner.base_q(snap, queued=False)
            if relative:
                with planner.view.at(snap, q0) as kin:
                    target = target + kin.vehicle_pose()
            spec: MotionSpec = planner.vehicle(
                q0,
                target,
                (speed[0] / 1e3, math.radians(speed[1])),
                (accel[0] / 1e3, math.radians(accel[1])),
            )
        else:
            specs = [self.ctx.robot.joints[j] for j in names]
            j_speed = self._per_joint(request.speed, n, "speed")
            j_accel = self._per_joint(request.accel, n, "accel")
            si_speed = np.array([s.to_si(v) for s, v in zip(specs, j_speed, strict=True)])
            si_accel = np.array([s.to_si(a) for s, a in zip(specs, j_accel, strict=True)])
            for i, s in enumerate(specs):
                self._within(si_speed[i], s.velocity, f"speed[{i}]", None, "deg/s", s.name)
                self._within(si_accel[i], s.acceleration, f"accel[{i}]", None, "deg/s²", s.name)
            require_ready(snap, sv_on_code=False)
            joints = np.array([planner.view.kin.index(j) for j in names])
            q0 = planner.base_q(snap, queued=False)
            target = np.array([s.to_si(x) for s, x in zip(specs, pos, strict=True)])
            if relative:
                target = target + q0[joints]
            spec = planner.joint(
                q0, joints, target, si_speed, si_accel, label=f"{unit.value} move", absolute=True
            )
        self.ctx.call("start", sv_on_code=False, spec=spec)
        return None

    @staticmethod
    def _within(
        value: float,
        limit: float,
        name: str,
        scale: float | None,
        unit: str,
        joint: str | None = None,
    ) -> None:
        if value > limit * (1 + 1e-9):
            shown = limit * scale if scale else math.degrees(limit)
            mine = value * scale if scale else math.degrees(value)
            who = f" of {joint}" if joint else ""
            raise ArgumentError(
                f"{name}: {mine:g} {unit} exceeds the hardware limit{who} ({shown:g} {unit})"
            )

    @staticmethod
    def _pair(values, name: str, unit: str) -> tuple[float, float]:
        vals = list(values)
        if len(vals) != 2:
            raise ArgumentError(f"{name}: VEHICLE takes 2 values (translation, rotation) [{unit}]")
        return (
            positive_arg(float(vals[0]), f"{name}[0]"),
            positive_arg(float(vals[1]), f"{name}[1]"),
        )

    @staticmethod
    def _per_joint(values, n: int, name: str) -> np.ndarray:
        vals = [float(v) for v in values]
        if len(vals) == 1:
            vals = vals * n
        if len(vals) != n:
            raise ArgumentError(
                f"{name}: expected {n} values (one per joint) or 1, got {len(vals)}"
            )
        for i, v in enumerate(vals):
            positive_arg(v, f"{name}[{i}]")
        return np.array(vals)

    @rpc(pb.MoveUnitAbsResponse)
    def MoveUnitAbs(self, request):
        return self._unit_move(request, relative=False)

    @rpc(pb.MoveUnitRelResponse)
    def MoveUnitRel(self, request):
        return self._unit_move(request, relative=True)

    # ------------------------------------------------------------------ CP hold
    def _cp_hold(self, request, relative: bool) -> dict[str, str] | None:
        side = side_arg(self.view, request.type)
        pos = request.rel_pos if relative else request.abs_pos
        pos_name = "rel_pos" if relative else "abs_pos"
        speed, accel = request.speed, request.accel
        snap = self.ctx.snapshot()
        planner = self.ctx.planner
        axes: dict[RedundantAxis, tuple[float, float, float, str]] = {}  # value, v, a, name
        kin_axes = self.axes
        own_elbow = elbow_axis(side)
        if own_elbow in kin_axes:
            axes[own_elbow] = (
                math.radians(finite_arg(pos.elbow, f"{pos_name}.elbow")),
                math.radians(speed.elbow),
                math.radians(accel.elbow),
                "elbow",
            )
        for axis, field in _LUMBAR.items():
            if axis in kin_axes:
                axes[axis] = (
                    math.radians(finite_arg(getattr(pos, field), f"{pos_name}.{field}")),
                    math.radians(getattr(speed, field)),
                    math.radians(getattr(accel, field)),
                    field,
                )
        if RedundantAxis.VEHICLE_X in kin_axes:
            vt, at = speed.vehicle_translation / 1e3, accel.vehicle_translation / 1e3
            vr, ar = math.radians(speed.vehicle_rotation), math.radians(accel.vehicle_rotation)
            for axis, field in _VEHICLE.items():
                value = finite_arg(getattr(pos, field), f"{pos_name}.{field}")
                rot = axis == RedundantAxis.VEHICLE_THETA
                si = math.radians(value) if rot else value / 1e3
                axes[axis] = (
                    si,
                    vr if rot else vt,
                    ar if rot else at,
                    "vehicle_rotation" if rot else "vehicle_translation",
                )
        for _axis, (_, v, a, name) in axes.items():
            finite_arg(v, f"speed.{name}")
            finite_arg(a, f"accel.{name}")
        q0 = planner.base_q(snap, queued=False)
        targets: dict[RedundantAxis, float] = {}
        speeds, accels = [], []
        vehicle_moves = False
        with planner.view.at(snap, q0) as kin:
            for axis, (value, v, a, name) in axes.items():
                current = axis_value(kin, axis)
                goal = current + value if relative else value
                delta = goal - current
                if axis.is_elbow:
                    delta = math.remainder(delta, math.tau)
                if abs(delta) > 1e-9:
                    positive_arg(v, f"speed.{name}")
                    positive_arg(a, f"accel.{name}")
                if abs(delta) <= 1e-9 and not axis.is_vehicle:
                    continue  # not moving: held (its joints are frozen)
                vehicle_moves = vehicle_moves or (axis.is_vehicle and abs(delta) > 1e-9)
                targets[axis] = goal
                speeds.append(v if v > 0 else 1.0)
                accels.append(a if a > 0 else 1.0)
                if axis.is_lumbar:
                    lo, hi = self._lumbar_range(axis)
                    if not lo - 1e-9 <= goal <= hi + 1e-9:
                        raise ArgumentError(
                            f"{pos_name}.{name}: {math.degrees(goal):.2f} deg is outside the "
                            f"waist's range {math.degrees(lo):.1f}..{math.degrees(hi):.1f} deg"
                        )
        if not vehicle_moves:  # the vehicle's three axes go together: hold them all
            for axis in [a for a in targets if a.is_vehicle]:
                k = list(targets).index(axis)
                del targets[axis], speeds[k], accels[k]
        require_ready(snap, sv_on_code=False)
        if not targets:
            return {"comment": "OK (every redundant axis is already at its target)"}
        held: tuple[RightLeft, ...] = (side,)
        other = RightLeft.LEFT if side == RightLeft.RIGHT else RightLeft.RIGHT
        body_moves = any(a.is_lumbar or a.is_vehicle for a in targets)
        if body_moves and other in self.view.arms and elbow_axis(other) not in targets:
            held = (side, other)  # the body moves under both hands: hold both
        spec = planner.cp_hold(
            q0, held, targets, np.array(speeds), np.array(accels), label="CP-hold move"
        )
        reason = planner.dry_run(snap, q0, spec)
        comment = None
        held_elbows = [elbow_axis(s) for s in held if elbow_axis(s) in kin_axes]
        if reason is not None and held_elbows and not any(a in targets for a in held_elbows):
            # Axes without a target stay put, unless a held hand cannot follow the body
            # with its elbow held: then the elbow moves, and the answer says so.
            spec.free_elbows = True
            if planner.dry_run(snap, q0, spec) is None:
                names = ", ".join(a.value for a in held_elbows)
                comment = (
                    f"OK ({names} left free to keep the held hand(s): with the elbow held, "
                    f"{reason})"
                )
                reason = None
        if reason is not None:
            raise Refused(ReturnCode.CANNOT_REACH_TARGET_ERR, reason)
        self.ctx.call("start", sv_on_code=False, spec=spec)
        return None if comment is None else {"comment": comment}

    @rpc(pb.MoveCPHoldAbsResponse)
    def MoveCPHoldAbs(self, request):
        return self._cp_hold(request, relative=False)

    @rpc(pb.MoveCPHoldRelResponse)
    def MoveCPHoldRel(self, request):
        return self._cp_hold(request, relative=True)

    # ------------------------------------------------------------------ Cartesian
    def _linear(self, request, target_field: str, frame: int | None) -> None:
        side = side_arg(self.view, request.type)
        goal = hg_arg(getattr(request, target_field), target_field)
        speed = (
            positive_arg(request.speed.translation, "speed.translation", "mm/s") / 1e3,
            math.radians(positive_arg(request.speed.rotation, "speed.rotation", "deg/s")),
        )
        accel = (
            positive_arg(request.accel.translation, "accel.translation", "mm/s²") / 1e3,
            math.radians(positive_arg(request.accel.rotation, "accel.rotation", "deg/s²")),
        )
        if frame is not None and frame not in (0, 1):
            raise ArgumentError(f"frame_type: {frame} is not BASE_FRAME (0) or TOOL_FRAME (1)")
        snap = self.ctx.snapshot()
        require_ready(snap, sv_on_code=False)
        planner = self.ctx.planner
        q0 = planner.base_q(snap, queued=False)
        if frame is not None:
            with planner.view.at(snap, q0) as kin:
                goal = relative_pose(kin.pose(side), goal, tool_frame=frame == 1)
        allowed, ranges = self._mask()
        try:
            spec, _ = planner.cartesian(
                snap,
                q0,
                side,
                goal,
                speed,
                accel,
                allowed,
                ranges,
                request.is_hold_other_arm,
                label=f"{side.name} linear move",
            )
        except ArgumentError:
            raise
        except ValueError as exc:  # a finite but absurd target no time law can cover
            raise Refused(
                ReturnCode.CANNOT_REACH_TARGET_ERR, f"{target_field}: no path to it: {exc}"
            ) from None
        self.ctx.call("start", sv_on_code=False, spec=spec)

    @rpc(pb.MoveLinearCartesianAbsResponse)
    def MoveLinearCartesianAbs(self, request):
        self._linear(request, "abs_hg_mat", None)

    @rpc(pb.MoveLinearCartesianRelResponse)
    def MoveLinearCartesianRel(self, request):
        self._linear(request, "rel_hg_mat", request.frame_type)

    def _ptp(self, request, target_field: str, relative: bool) -> None:
        side = side_arg(self.view, request.type)
        goal = hg_arg(getattr(request, target_field), target_field)
        duration = positive_arg(request.time, "time", "s")
        if duration > MAX_PTP_TIME:
            raise ArgumentError(f"time: {duration:g} s is longer than {MAX_PTP_TIME:g} s")
        snap = self.ctx.snapshot()
        require_ready(snap, sv_on_code=True)
        planner = self.ctx.planner
        q0 = planner.base_q(snap, queued=False)
        if relative:
            with planner.view.at(snap, q0) as kin:
                goal = relative_pose(kin.pose(side), goal, tool_frame=False)
        allowed, ranges = self._mask()
        spec, _ = planner.ptp_cartesian(
            snap,
            q0,
            side,
            goal,
            allowed,
            ranges,
            request.is_hold_other_arm,
            duration,
            label=f"{side.name} PTP move",
        )
        self.ctx.call("start", sv_on_code=True, spec=spec)

    @rpc(pb.MovePTPCartesianAbsResponse)
    def MovePTPCartesianAbs(self, request):
        self._ptp(request, "abs_hg_mat", relative=False)

    @rpc(pb.MovePTPCartesianRelResponse)
    def MovePTPCartesianRel(self, request):
        self._ptp(request, "rel_hg_mat", relative=True)

"""Spec A, IntegratedMotion over gRPC (29 operations): messages to spec-unit Python values,
a call of :class:`controller.gateway.services.spec_a.SpecAService` (or a control command),
the reply. The rules (state, order of checks, units) are the service's.
"""

from __future__ import annotations

from controller.conversions import ArgumentError
from controller.gateway.grpc.base import (
    Replies,
    alarm_msgs,
    ratio_arg,
    rpc,
    side_arg,
    unit_arg,
)
from controller.gateway.planning.robot_view import pose_inputs
from controller.gateway.services.context import Context
from controller.gateway.services.spec_a import (
    AXIS_FIELDS,
    POS_FIELDS,
    RATE_FIELDS,
    SpecAService,
)
from controller.gateway.services.states import spec_a_state
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc


class IntegratedMotionServicer(pb_grpc.IntegratedMotionServicer):
    def __init__(self, ctx: Context, service: SpecAService | None = None):
        self.ctx = ctx
        self.view = ctx.view
        self.service = service or SpecAService(ctx)
        self._states = Replies(pb.GetStateResponse)  #: getState's answers
        #: getFeedbackPosCartesian's answers, by request and snapshot (pose_inputs)
        self._poses = Replies(pb.GetFeedbackPosCartesianResponse, limit=16)

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
        s = self.ctx.state()  # the snapshot's header: no joints, no alarms

        def fields() -> dict:
            state, text = spec_a_state(s)
            return {"status_id": int(state), "message": text}

        return self._states.get((s.core_state, s.hw_state, s.queue), fields)

    @rpc(pb.GetVersionResponse)
    def GetVersion(self, request):
        return {"version": self.service.version()}

    @rpc(pb.IsMovingResponse)
    def IsMoving(self, request):
        return {"is_moving": self.service.is_moving()}

    @rpc(pb.IsServoOnResponse)
    def IsServoOn(self, request):
        return {"is_servo_on": self.service.is_servo_on()}

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
        snap = self.ctx.snapshot()
        side, frame = request.type, request.frame_type

        def fields() -> dict:
            hg_mm, elbow = self.service.feedback_cartesian(side, frame, snap)
            pos = pb.CarPosWithElbow(car_pos=pb.HgMatrix(m=hg_mm.ravel().tolist()), elbow=elbow)
            return {"pos": pos}

        # Readers of one snapshot share one answer; any new joint value or frame is a new key.
        return self._poses.get((side, frame, *pose_inputs(snap)), fields)

    @rpc(pb.GetFeedbackPosJointResponse)
    def GetFeedbackPosJoint(self, request):
        unit = unit_arg(self.view, request.type, "type")
        return {"position": self.view.unit_positions(self.ctx.snapshot(), unit).tolist()}

    @rpc(pb.GetGripperPosResponse)
    def GetGripperPos(self, request):
        return {"angle_ratio": self.service.gripper_pos(request.type)}

    # ------------------------------------------------------------------ grippers
    def _gripper(self, side_value: int, ratio: float) -> None:
        self.service.gripper(side_value, ratio)

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
        self.service.set_control_point_offset(side, list(request.offset.m))

    @rpc(pb.SelectRedundantAxesResponse)
    def SelectRedundantAxes(self, request):
        mask = {f: getattr(request.redundancy, f) for f, _ in AXIS_FIELDS.values()}
        limits = {
            f: (getattr(request.limit, f).lower, getattr(request.limit, f).upper)
            for _, f in AXIS_FIELDS.values()
        }
        return self.service.select_redundant_axes(mask, limits)

    # ------------------------------------------------------------------ unit moves
    def _unit_move(self, request, relative: bool) -> None:
        unit = unit_arg(self.view, request.unit)
        pos = request.rel_pos if relative else request.abs_pos
        self.service.move_unit(unit, list(pos), list(request.speed), list(request.accel), relative)

    @rpc(pb.MoveUnitAbsResponse)
    def MoveUnitAbs(self, request):
        self._unit_move(request, relative=False)

    @rpc(pb.MoveUnitRelResponse)
    def MoveUnitRel(self, request):
        self._unit_move(request, relative=True)

    # ------------------------------------------------------------------ CP hold
    def _cp_hold(self, request, relative: bool) -> str | None:
        side = side_arg(self.view, request.type)
        pos = request.rel_pos if relative else request.abs_pos
        return self.service.move_cp_hold(
            side,
            {f: getattr(pos, f) for f in POS_FIELDS},
            {f: getattr(request.speed, f) for f in RATE_FIELDS},
            {f: getattr(request.accel, f) for f in RATE_FIELDS},
            relative,
        )

    @rpc(pb.MoveCPHoldAbsResponse)
    def MoveCPHoldAbs(self, request):
        return self._cp_hold(request, relative=False)

    @rpc(pb.MoveCPHoldRelResponse)
    def MoveCPHoldRel(self, request):
        return self._cp_hold(request, relative=True)

    # ------------------------------------------------------------------ Cartesian
    def _linear(self, request, target_field: str, frame: int | None) -> None:
        side = side_arg(self.view, request.type)
        if frame is not None and frame not in (0, 1):
            raise ArgumentError(f"frame_type: {frame} is not BASE_FRAME (0) or TOOL_FRAME (1)")
        self.service.move_linear(
            side,
            list(getattr(request, target_field).m),
            (request.speed.translation, request.speed.rotation),
            (request.accel.translation, request.accel.rotation),
            request.is_hold_other_arm,
            None if frame is None else frame == 1,
            target_field,
        )

    @rpc(pb.MoveLinearCartesianAbsResponse)
    def MoveLinearCartesianAbs(self, request):
        self._linear(request, "abs_hg_mat", None)

    @rpc(pb.MoveLinearCartesianRelResponse)
    def MoveLinearCartesianRel(self, request):
        self._linear(request, "rel_hg_mat", request.frame_type)

    def _ptp(self, request, target_field: str, relative: bool) -> None:
        side = side_arg(self.view, request.type)
        self.service.move_ptp(
            side,
            list(getattr(request, target_field).m),
            request.time,
            request.is_hold_other_arm,
            relative,
            target_field,
        )

    @rpc(pb.MovePTPCartesianAbsResponse)
    def MovePTPCartesianAbs(self, request):
        self._ptp(request, "abs_hg_mat", relative=False)

    @rpc(pb.MovePTPCartesianRelResponse)
    def MovePTPCartesianRel(self, request):
        self._ptp(request, "rel_hg_mat", relative=True)

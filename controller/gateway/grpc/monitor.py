"""Monitor.StreamState: state, joints, control points, alarms and loop statistics at a rate.

Samples come from the shared-memory snapshot, so any number of streams costs the control
loop nothing. ``rate_hz`` 0 means the configured default; negative or non-finite is
INVALID_ARGUMENT; rates above the loop rate are clamped to it, rates below
:data:`MIN_RATE_HZ` raised to it. A cancelled stream frees its slot at once, however slow.
"""

from __future__ import annotations

import math
import threading
import time

import grpc

from controller.contract.snapshot import F_MOTION
from controller.gateway.grpc.base import alarm_msgs, car_pos_msg
from controller.gateway.services.context import Context
from controller.gateway.services.states import spec_a_state
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import FrameType, UnitType

#: Names of the vehicle's StreamState values (its pose, not joints).
_VEHICLE_NAMES = ("x", "y", "theta")
#: Slowest stream rate [Hz] (slower requests get this).
MIN_RATE_HZ = 0.01


class MonitorServicer(pb_grpc.MonitorServicer):
    def __init__(self, ctx: Context):
        self.ctx = ctx
        self._streams = threading.BoundedSemaphore(ctx.config.monitor.max_streams)

    def sample(self, sequence: int) -> pb.StateSample:
        view = self.ctx.view
        snap = view.snapshot()
        state, text = spec_a_state(snap)
        joints = [
            pb.UnitJointPositions(
                unit=unit.name,
                position=view.unit_positions(snap, unit).tolist(),
                commanded=view.unit_positions(snap, unit, commanded=True).tolist(),
                names=_VEHICLE_NAMES if unit == UnitType.VEHICLE else view.unit_joint_names(unit),
                limits=[pb.LimitValue(upper=u, lower=lo) for u, lo in view.unit_limits(unit)],
            )
            for unit in UnitType
            if view.has_unit(unit)
        ]
        points = []
        for side in view.arms:
            pose, elbow = view.pose(snap, side, FrameType.ORIGINAL_FRAME)
            points.append(pb.ControlPointPose(arm=side.name, pose=car_pos_msg(pose, elbow)))
        loop = pb.LoopStats(
            cycles=snap.cycle,
            overruns=snap.overruns,
            compute=pb.LatencyStats(
                p50_us=snap.compute_us[0], p99_us=snap.compute_us[1], max_us=snap.compute_us[2]
            ),
            wake_latency=pb.LatencyStats(
                p50_us=snap.wake_us[0], p99_us=snap.wake_us[1], max_us=snap.wake_us[2]
            ),
        )
        return pb.StateSample(
            sequence=sequence,
            stamp_s=snap.stamp,
            status_id=int(state),
            status_message=text,
            joints=joints,
            control_points=points,
            alarms=alarm_msgs(snap),
            loop=loop,
            wall_time_s=time.time(),
            motion=pb.MotionStatus(
                active=bool(snap.flags & F_MOTION),
                queued=snap.queue,
                queue_depth=snap.queue_depth,
                started=snap.started,
                finished=snap.finished,
            ),
        )

    def StreamState(self, request, context):
        rate = request.rate_hz
        if not math.isfinite(rate) or rate < 0:
            context.abort(grpc.StatusCode.INVALID_ARGUMENT, f"rate_hz: {rate} must be >= 0")
        if rate == 0:
            rate = self.ctx.config.monitor.default_rate_hz
        rate = min(max(rate, MIN_RATE_HZ), self.ctx.config.loop.rate_hz)
        if not self._streams.acquire(blocking=False):
            context.abort(
                grpc.StatusCode.RESOURCE_EXHAUSTED,
                f"at most {self.ctx.config.monitor.max_streams} StreamState streams at once",
            )
        ended = threading.Event()  # set when the client cancels or the call ends
        if not context.add_callback(ended.set):
            ended.set()
        try:
            period = 1.0 / rate
            next_t = time.monotonic()
            sequence = 0
            while context.is_active() and not ended.is_set():
                yield self.sample(sequence)
                sequence += 1
                next_t += period
                delay = next_t - time.monotonic()
                if delay > 0:
                    ended.wait(delay)
                else:
                    next_t = time.monotonic()
        finally:
            self._streams.release()

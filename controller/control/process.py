"""The control process: the fixed-rate loop, the motion core, the JARA queue, the snapshot.

Everything that touches the motion core runs in the loop thread. Commands arrive from the
gateway over a Unix socket (:mod:`controller.contract.channel`); the channel thread only hands
them to the loop (a lock-free queue) and waits for the answer, which the loop gives at the
start of its next cycle. So a command never races a cycle and the loop never waits for a
lock held by a slow request.

Per cycle::

    commands → MotionCore.cycle() → queue / soft-limit supervision → snapshot

Commands answer with a value or raise :class:`Refused` carrying a generic code name
(``STATUS_ERR``, ``NOT_SV_ON_ERR``, ``FULL_MOTION_QUEUE_ERR``, ``VALUE_ERR``, ``NG``) that
the service maps onto its family's codes.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from controller.contract import snapshot as snap
from controller.contract.motion_specs import CartesianBox, JointStreamSpec, MotionSpec
from controller.control.core import CoreError, MotionCore
from controller.control.loop import FixedRateLoop
from controller.errors import Refused
from controller.model.alarms import AlarmCode
from controller.model.robot import Robot
from controller.vocabulary import CoreState, FrameType, ReturnCode, RightLeft
from hal.interface import HardwareInterface, HardwareState

_log = logging.getLogger("imotiond.control")

#: A motion started "now" is refused when the robot moved more than this since planning
#: [rad, m].
PLAN_TOLERANCE = 2e-3
#: Loop statistics are refreshed in the snapshot this often [s].
STATS_PERIOD = 0.2


@dataclass
class Request:
    name: str
    args: dict[str, Any]
    done: threading.Event = field(default_factory=threading.Event)
    ok: bool = False
    value: Any = None
    code: ReturnCode = ReturnCode.NG
    message: str = ""
    #: Set when the caller stopped waiting; the loop then drops the request unexecuted.
    cancelled: bool = False


class Controller:
    """The loop-side half of the daemon (see the module docstring)."""

    def __init__(
        self,
        robot: Robot,
        hardware: HardwareInterface,
        rate_hz: float,
        snapshot_path: Path,
        queue_depth: int = 8,
        solver: str = "daqp",
    ):
        self.robot = robot
        self.hw = hardware
        self.dt = 1.0 / rate_hz
        self.core = MotionCore(robot, hardware, self.dt, solver)
        # Statistics over the last second: cheap enough to summarise from the loop thread.
        self.loop = FixedRateLoop(
            rate_hz, self._step, realtime=False, stats_capacity=max(1, round(rate_hz))
        )
        self.queue: deque[MotionSpec] = deque()
        self.queue_depth = queue_depth
        self.inbox: queue.SimpleQueue[Request] = queue.SimpleQueue()
        self.writer = snap.SnapshotWriter(snapshot_path, len(hardware.joint_names), queue_depth)
        self.boxes: dict[RightLeft, CartesianBox] = {}
        self.started = 0
        self.finished = 0
        self._running_motion: object = None
        self._stats_every = max(1, round(STATS_PERIOD * rate_hz))
        #: The original frame or a control-point offset changed since the last publish.
        self._frames_changed = True
        #: Set by a signal handler: decelerate, servo off, leave the loop.
        self.shutdown_requested = threading.Event()
        self._shutdown_deadline: float | None = None
        self.stop_timeout = 1.2
        self._handlers: dict[str, Callable[..., Any]] = {
            name.removeprefix("cmd_"): getattr(self, name)
            for name in dir(self)
            if name.startswith("cmd_")
        }
        self.publish()

    # ------------------------------------------------------------------ loop side
    def _step(self, cycle: int, t: float) -> bool:
        executed = []
        try:
            while True:
                try:
                    request = self.inbox.get_nowait()
                except queue.Empty:
                    break
                self._execute(request)
                executed.append(request)
            self.core.cycle()
            self._after_cycle()
            self.publish()
        finally:
            # Answer only once the snapshot shows the command's effect: a client that reads
            # isMoving/getState right after an OK sees the motion it started.
            for request in executed:
                request.done.set()
        return not self._shutdown_step()

    def run(self) -> None:
        """Run the loop in the calling thread until shutdown."""
        self.loop.run()

    def _execute(self, request: Request) -> None:
        if request.cancelled:  # its caller gave up waiting: never act on it late
            return
        handler = self._handlers.get(request.name)
        try:
            if handler is None:
                raise Refused(ReturnCode.NG, f"unknown command {request.name!r}")
            request.value = handler(**request.args)
            request.ok = True
        except Refused as exc:
            request.code, request.message = exc.code, exc.comment
        except CoreError as exc:
            request.code, request.message = exc.code, exc.comment
        except Exception as exc:  # a command must never take the loop down
            _log.exception("command %s failed", request.name)
            request.code, request.message = ReturnCode.NG, f"{request.name} failed: {exc}"

    def submit(self, name: str, timeout: float = 5.0, **args: Any) -> Request:
        """Hand a command to the loop and wait for its answer (any thread but the loop's)."""
        request = Request(name, args)
        self.inbox.put(request)
        if not request.done.wait(timeout):
            request.cancelled = True
            request.code, request.message = ReturnCode.NG, "the control loop did not answer in time"
        return request

    def _after_cycle(self) -> None:
        core = self.core
        if core.motion is not self._running_motion:
            if self._running_motion is not None:
                self.finished += 1
            self._running_motion = core.motion
        if core.state in (CoreState.SERVO_OFF, CoreState.ALARM):
            self.queue.clear()
        elif core.state == CoreState.READY and core.motion is None and self.queue:
            spec = self.queue.popleft()
            try:
                self._start(spec)
            except Exception as exc:
                self.queue.clear()
                core.raise_alarm(
                    AlarmCode.TRAJECTORY_FAILURE, "queue", f"queued {spec.label}: {exc}"
                )
        if self.boxes and core.state == CoreState.BUSY:
            self._check_boxes()

    def _start(self, spec: MotionSpec) -> None:
        self.core.start(spec.build(self.core.kin, self.dt))
        self._running_motion = self.core.motion
        self.started += 1
        _log.info("motion started: %s", spec.label)

    def _check_boxes(self) -> None:
        for side, box in self.boxes.items():
            pose = self.core.kin.pose(side, FrameType.CURRENT_FRAME)
            p = pin.SE3(box.base_offset).actInv(pose).translation
            if np.any(p < box.lower) or np.any(p > box.upper):
                mm = ", ".join(f"{1e3 * x:.1f}" for x in p)
                self.core.raise_alarm(
                    AlarmCode.CARTESIAN_SOFT_LIMIT,
                    f"{side.name.lower()}_arm",
                    f"{side.name} control point at ({mm}) mm left the Cartesian soft limit",
                )
                return

    def _shutdown_step(self) -> bool:
        """True when the loop should end (shutdown requested and the robot is safe)."""
        if not self.shutdown_requested.is_set():
            return False
        now = time.monotonic()
        if self._shutdown_deadline is None:
            self._shutdown_deadline = now + self.stop_timeout
            self.queue.clear()
            self.core.stop()
            _log.info("shutdown: decelerating to a stop")
        if self.core.is_moving and now < self._shutdown_deadline:
            return False
        self.core.servo_off()
        self.publish()  # the last snapshot says so (the gateway may answer a little longer)
        _log.info("shutdown: servo off")
        return True

    def publish(self) -> None:
        """Write the snapshot (loop thread, once per cycle)."""
        w, core = self.writer, self.core
        h = w.header
        w.begin()
        h[snap.H_CYCLE] = core.cycles
        h[snap.H_CORE_STATE] = int(core.state)
        h[snap.H_HW_STATE] = snap.HW_STATES.index(self.hw.state)
        flags = 0
        if core.is_moving:
            flags |= snap.F_MOVING
        if core.motion is not None:
            flags |= snap.F_MOTION
        if core.state == CoreState.PAUSED:
            flags |= snap.F_PAUSED
        if len(self.queue) >= self.queue_depth:
            flags |= snap.F_QUEUE_FULL
        if self.hw.state == HardwareState.ACTIVE and core.state != CoreState.SERVO_OFF:
            flags |= snap.F_SERVO_ON
        h[snap.H_FLAGS] = flags
        h[snap.H_QUEUE] = len(self.queue)
        h[snap.H_STARTED] = self.started
        h[snap.H_FINISHED] = self.finished
        v = w.values
        v[snap.V_STAMP] = time.monotonic()
        w.q[:] = core.measured_hw
        w.q_cmd[:] = core.hw_command
        if self._frames_changed:
            self._publish_frames()
        if core.cycles % self._stats_every == 0:
            self._publish_stats()
        w.set_alarms(
            [
                {
                    "code": a.code,
                    "type": int(a.type),
                    "description": a.description,
                    "module": a.module,
                }
                for a in core.alarms
            ]
        )
        w.end()

    def _publish_frames(self) -> None:
        """Original frame and control-point offsets (between begin() and end()). They change
        only through commands, so they are written then, not every cycle (~5 us saved)."""
        kin, v = self.core.kin, self.writer.values
        v[snap.V_ORIGINAL : snap.V_ORIGINAL + 12] = kin.original_frame.homogeneous[:3].ravel()
        v[snap.V_ORIGINAL_THETA] = kin.original_theta
        for k, side in enumerate((RightLeft.RIGHT, RightLeft.LEFT)):
            if side in kin.arms:
                off = kin.control_point_offset(side).homogeneous[:3].ravel()
                v[snap.V_OFFSETS + 12 * k : snap.V_OFFSETS + 12 * (k + 1)] = off
        self._frames_changed = False

    def _publish_stats(self) -> None:
        stats = self.loop.stats
        v = self.writer.values
        if stats.cycles:
            s = stats.summary()
            v[snap.V_COMPUTE : snap.V_COMPUTE + 3] = (
                s["compute_us_p50"],
                s["compute_us_p99"],
                s["compute_us_max"],
            )
            v[snap.V_WAKE : snap.V_WAKE + 3] = (
                s["wake_latency_us_p50"],
                s["wake_latency_us_p99"],
                s["wake_latency_us_max"],
            )
        self.writer.header[snap.H_OVERRUNS] = stats.overruns

    def close(self) -> None:
        self.writer.unlink()

    # ------------------------------------------------------------------ commands
    # Each cmd_<name> runs in the loop thread between cycles; SI arguments.

    def _require_powered(self) -> None:
        state = self.core.state
        if state == CoreState.ALARM:
            raise Refused(ReturnCode.STATUS_ERR, "alarms are active: clearAlarms, then servoOn")
        if state == CoreState.SERVO_OFF:
            raise Refused(ReturnCode.NOT_SV_ON_ERR, "the servos are off: call servoOn first")

    def cmd_servo_on(self) -> None:
        try:
            self.core.servo_on()
        except CoreError as exc:
            raise Refused(ReturnCode.NG, f"servo on failed: {exc}") from None
        except Exception as exc:
            raise Refused(ReturnCode.NG, f"servo on failed: {exc}") from None

    def cmd_servo_off(self) -> None:
        self.queue.clear()
        self.core.servo_off()

    def cmd_clear_alarms(self) -> None:
        self.core.clear_alarms()

    def cmd_stop(self) -> None:
        self.queue.clear()
        self.core.stop()
        if self.core.state == CoreState.PAUSED and self.core.motion is None:
            self.core.resume()  # paused while idle: stop → Ready as from a paused motion

    def cmd_abort(self) -> None:
        self.queue.clear()
        self.core.abort()

    def cmd_pause(self) -> None:
        self.core.pause()

    def cmd_resume(self) -> None:
        self.core.resume()

    def cmd_start(self, spec: MotionSpec, queued: bool = False) -> str:
        """Start ``spec`` now (READY only) or, ``queued``, append it behind the running one.

        Returns "started", "queued", or "extended" (a streamed set-point joined the running
        stream).
        """
        self._require_powered()
        state = self.core.state
        if (
            isinstance(spec, JointStreamSpec)
            and not self.queue
            and state in (CoreState.BUSY, CoreState.PAUSED)
            and spec.extends(self.core.motion)
        ):
            self.core.motion.extend(spec.target)  # type: ignore[union-attr]
            return "extended"
        if not queued:
            if state != CoreState.READY:
                raise Refused(
                    ReturnCode.STATUS_ERR,
                    f"the robot is {state.text}: a motion command is accepted only when "
                    "ready (this interface does not queue); wait, stop or resume first",
                )
            self._check_plan(spec)
            self._start_now(spec)
            return "started"
        if state == CoreState.READY and self.core.motion is None and not self.queue:
            self._start_now(spec)
            return "started"
        if len(self.queue) >= self.queue_depth:
            raise Refused(
                ReturnCode.FULL_MOTION_QUEUE_ERR,
                f"the motion queue is full ({self.queue_depth} waiting): wait or stop",
            )
        self.queue.append(spec)
        return "queued"

    def _start_now(self, spec: MotionSpec) -> None:
        try:
            self._start(spec)
        except ValueError as exc:  # e.g. a finite but absurd target no time law can cover
            raise Refused(ReturnCode.VALUE_ERR, f"{spec.label}: cannot be planned: {exc}") from None

    def _check_plan(self, spec: MotionSpec) -> None:
        if spec.planned_from is None:
            return
        moved = float(np.max(np.abs(self.core.kin.q - spec.planned_from), initial=0.0))
        if moved > PLAN_TOLERANCE:
            raise Refused(
                ReturnCode.STATUS_ERR,
                "the robot moved while this command was being planned (another command ran "
                "first): send it again",
            )

    def cmd_gripper(self, side: RightLeft, ratio: float) -> None:
        self._require_powered()
        if self.core.state == CoreState.PAUSED:
            raise Refused(ReturnCode.STATUS_ERR, "paused: resume or stop before moving a gripper")
        self.core.move_gripper(side, ratio)

    def _require_still(self, what: str) -> None:
        if self.core.is_moving or self.queue:
            raise Refused(ReturnCode.STATUS_ERR, f"{what} is not allowed while the robot moves")

    def cmd_reset_original_frame(self) -> None:
        self._require_still("resetOriginalFrame")
        self.core.kin.reset_original_frame()
        self._frames_changed = True

    def cmd_set_control_point_offset(self, side: RightLeft, offset: np.ndarray) -> None:
        self._require_still("setControlPointOffset")
        self.core.kin.set_control_point_offset(side, pin.SE3(offset))
        self._frames_changed = True

    def cmd_set_joint_limits(self, indices: np.ndarray, lower: np.ndarray, upper: np.ndarray):
        """Narrow (or restore) the IK position limits of kinematic joints ``indices``."""
        if self.core.state == CoreState.ALARM:
            raise Refused(ReturnCode.STATUS_ERR, "alarms are active: clear them first")
        self._require_still("setSoftLimitJoint")
        q = self.core.kin.q[indices]
        outside = [
            int(i)
            for i, x, lo, hi in zip(indices, q, lower, upper, strict=True)
            if not lo <= x <= hi
        ]
        if outside:
            names = ", ".join(self.core.kin.joint_names[i] for i in outside)
            raise Refused(
                ReturnCode.VALUE_ERR, f"joints {names} are outside the new limits right now"
            )
        box = self.core.ik.box
        q_min, q_max = box.q_min.copy(), box.q_max.copy()
        q_min[indices], q_max[indices] = lower, upper
        box.q_min, box.q_max = q_min, q_max

    def cmd_set_cartesian_box(self, side: RightLeft, box: CartesianBox | None) -> None:
        self._require_still("setSoftLimitCartesian")
        if box is None:
            self.boxes.pop(side, None)
        else:
            self.boxes[side] = box

    def cmd_status(self) -> dict[str, Any]:
        return {"state": int(self.core.state), "queue": len(self.queue)}

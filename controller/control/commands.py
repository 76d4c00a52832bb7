"""The control process's commands: what the gateway may ask of the loop.

Each ``cmd_<name>`` runs in the loop thread between two cycles, with SI arguments, and
answers with a value or raises :class:`~controller.errors.Refused` (or another
:class:`~controller.errors.ImotionError`) carrying its return code. The gateway maps
NOT_SV_ON_ERR to STATUS_ERR for operations whose original does not list it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from controller.contract.motion_specs import CartesianBox, JointStreamSpec, MotionSpec
from controller.control.core import MotionCore
from controller.control.events import LoopEvents
from controller.control.motion_queue import MotionQueue
from controller.control.pending_start import PendingStart
from controller.control.publisher import SnapshotPublisher
from controller.control.soft_limits import CartesianSoftLimits
from controller.errors import Refused
from controller.vocabulary import CoreState, ReturnCode, RightLeft
from hal.interface import HardwareInterface

#: A motion started "now" is refused when the robot moved more than this since planning
#: [rad, m].
PLAN_TOLERANCE = 2e-3

#: Commands that do not touch the motion core and may block (they talk to another process):
#: run in the calling channel thread, never in the loop thread.
DIRECT = frozenset({"inject_fault", "clear_faults"})

#: Commands that overtake every other waiting command (they only ever make the robot
#: safer: they stop, pause or switch off).
URGENT = frozenset({"stop", "pause", "abort", "servo_off"})


class Commands:
    """The ``cmd_*`` handlers; mixed into :class:`controller.control.process.Controller`."""

    core: MotionCore
    hw: HardwareInterface
    queue: MotionQueue
    events: LoopEvents
    soft_limits: CartesianSoftLimits
    publisher: SnapshotPublisher
    dt: float
    started: int
    #: A start accepted and not yet started (:mod:`controller.control.pending_start`).
    pending: PendingStart | None

    def _start(self, spec: MotionSpec) -> None:
        """Accept ``spec``: its motion is built in the loop's slack and started in the next
        step, which answers (a build that fails answers VALUE_ERR there)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ power
    def _require_powered(self) -> None:
        state = self.core.state
        if state == CoreState.ALARM:
            raise Refused(ReturnCode.STATUS_ERR, "alarms are active: clearAlarms, then servoOn")
        if state == CoreState.SERVO_OFF:
            raise Refused(ReturnCode.NOT_SV_ON_ERR, "the servos are off: call servoOn first")

    def cmd_servo_on(self) -> None:
        try:
            self.core.servo_on()
        except Exception as exc:
            raise Refused(ReturnCode.NG, f"servo on failed: {exc}") from None

    def cmd_servo_off(self) -> None:
        self.events.ending("servo off")
        self.queue.clear()
        self.core.servo_off()

    def cmd_clear_alarms(self) -> None:
        self.core.clear_alarms()

    # ------------------------------------------------------------------ motion control
    def cmd_stop(self) -> None:
        self.events.ending("stopped")
        self.queue.clear()
        self.core.stop()
        if self.core.state == CoreState.PAUSED and self.core.motion is None:
            self.core.resume()  # paused while idle: stop → Ready as from a paused motion

    def cmd_abort(self) -> None:
        self.events.ending("aborted")
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
            if self.pending is not None:
                raise Refused(
                    ReturnCode.STATUS_ERR,
                    f"{self.pending.spec.label} is starting: a motion command is accepted "
                    "only when ready (this interface does not queue)",
                )
            self._check_plan(spec)
            self._start(spec)
            return "started"
        idle = self.core.motion is None and self.pending is None and not self.queue
        if state == CoreState.READY and idle:
            self._start(spec)
            return "started"
        self.queue.append(spec)
        return "queued"

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

    # ------------------------------------------------------------------ settings
    def _require_still(self, what: str) -> None:
        if self.core.state == CoreState.PAUSED and self.core.motion is not None:
            raise Refused(
                ReturnCode.STATUS_ERR,
                f"{what} is not allowed while a motion is paused: stop it (or resume it and "
                "wait for its end) first",
            )
        if self.core.is_moving or self.queue or self.pending is not None:
            raise Refused(ReturnCode.STATUS_ERR, f"{what} is not allowed while the robot moves")

    def cmd_reset_original_frame(self) -> None:
        self._require_still("resetOriginalFrame")
        self.core.kin.reset_original_frame()
        self.publisher.frames_changed = True

    def cmd_set_control_point_offset(self, side: RightLeft, offset: np.ndarray) -> None:
        self._require_still("setControlPointOffset")
        self.core.kin.set_control_point_offset(side, pin.SE3(offset))
        self.publisher.frames_changed = True

    def cmd_set_joint_limits(
        self, indices: np.ndarray, lower: np.ndarray, upper: np.ndarray
    ) -> None:
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
        self.soft_limits.set(side, box)

    # ------------------------------------------------------------------ testing (hal hil)
    def _emulator(self) -> Any:
        emulator = getattr(self.hw, "emulator", None)
        if emulator is None:
            raise Refused(
                ReturnCode.STATUS_ERR,
                "fault injection needs the drive emulator: start imotiond with --hal hil",
            )
        return emulator

    def cmd_inject_fault(self, kind: str, target: str, params: dict[str, Any]) -> None:
        """Inject fault ``kind`` into drive (or bus) ``target`` of the emulator."""
        try:
            self._emulator().inject(kind, target or None, **params)
        except (ValueError, KeyError, TypeError) as exc:
            raise Refused(ReturnCode.VALUE_ERR, f"inject {kind}: {exc}") from None

    def cmd_clear_faults(self, kind: str = "", target: str = "") -> int:
        """Clear lasting injected faults (all when ``kind`` and ``target`` are empty)."""
        try:
            return int(self._emulator().clear(kind or None, target or None))
        except (ValueError, KeyError, TypeError) as exc:
            raise Refused(ReturnCode.VALUE_ERR, f"clear faults: {exc}") from None

    def cmd_status(self) -> dict[str, Any]:
        return {"state": self.core.state, "queue": len(self.queue)}

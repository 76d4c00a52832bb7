"""The snapshot publisher: what the control process shows the gateway, once per cycle.

Runs in the loop thread after the cycle; writes the shared-memory snapshot
(:mod:`controller.contract.snapshot`) under its seqlock. Frames and offsets change only
through commands and loop statistics only every ``STATS_PERIOD``, so those are written
only then.
"""

from __future__ import annotations

import time
from pathlib import Path

from controller.contract import snapshot as snap
from controller.control.core import MotionCore
from controller.control.loop import FixedRateLoop
from controller.model.alarms import Alarm
from controller.vocabulary import CoreState, RightLeft
from hal.interface import HardwareInterface, HardwareState

#: Loop statistics are refreshed in the snapshot this often [s].
STATS_PERIOD = 0.2


class SnapshotPublisher:
    """Writes the control process's state into the snapshot file (loop thread only)."""

    def __init__(
        self,
        path: Path,
        core: MotionCore,
        hardware: HardwareInterface,
        loop: FixedRateLoop,
        rate_hz: float,
        queue_depth: int,
    ):
        self.core = core
        self.hw = hardware
        self.loop = loop  #: its ``stats`` may be replaced (e.g. by a CycleLog) after start
        self.writer = snap.SnapshotWriter(path, len(hardware.joint_names), queue_depth)
        self._stats_every = max(1, round(STATS_PERIOD * rate_hz))
        #: The original frame or a control-point offset changed since the last publish.
        self.frames_changed = True
        #: The alarms last published (None: none yet).
        self._alarms: list[Alarm] | None = None

    def publish(
        self, queued: int, queue_full: bool, started: int, finished: int, starting: bool = False
    ) -> None:
        """Write one snapshot: ``queued`` motions waiting, motion counters; ``starting``: a
        motion accepted, started in the next step (:mod:`controller.control.pending_start`),
        shown as running (BUSY) already: between two queued motions the robot is never
        shown ready."""
        w, core = self.writer, self.core
        h = w.header
        w.begin()
        hw_state = snap.HW_STATES.index(self.hw.state)
        flags = 0
        state = core.state
        if starting and state == CoreState.READY:
            state = CoreState.BUSY
            flags |= snap.F_MOVING | snap.F_MOTION
        if core.is_moving:
            flags |= snap.F_MOVING
        if core.motion is not None:
            flags |= snap.F_MOTION
        if core.state == CoreState.PAUSED:
            flags |= snap.F_PAUSED
        if queue_full:
            flags |= snap.F_QUEUE_FULL
        if self.hw.state == HardwareState.ACTIVE and core.state != CoreState.SERVO_OFF:
            flags |= snap.F_SERVO_ON
        # Two slice writes instead of one per field (this runs every cycle).
        h[snap.H_CYCLE : snap.H_QUEUE + 1] = (core.cycles, state, hw_state, flags, queued)
        h[snap.H_STARTED : snap.H_FINISHED + 1] = (started, finished)
        w.values[snap.V_STAMP] = time.monotonic()
        w.q[:] = core.measured_hw
        w.q_cmd[:] = core.hw_command
        if self.frames_changed:
            self._publish_frames()
        if core.cycles % self._stats_every == 0:
            self._publish_stats()
        if core.alarms != self._alarms:  # (the writer rewrites only what changed)
            self._alarms = list(core.alarms)
            w.set_alarms(
                [
                    {
                        "code": a.code,
                        "type": int(a.type),
                        "description": a.description,
                        "module": a.module,
                    }
                    for a in self._alarms
                ]
            )
        w.end()

    def _publish_frames(self) -> None:
        """Original frame and control-point offsets (between begin() and end())."""
        kin, v = self.core.kin, self.writer.values
        v[snap.V_ORIGINAL : snap.V_ORIGINAL + 12] = kin.original_frame.homogeneous[:3].ravel()
        v[snap.V_ORIGINAL_THETA] = kin.original_theta
        for k, side in enumerate((RightLeft.RIGHT, RightLeft.LEFT)):
            if side in kin.arms:
                off = kin.control_point_offset(side).homogeneous[:3].ravel()
                v[snap.V_OFFSETS + 12 * k : snap.V_OFFSETS + 12 * (k + 1)] = off
        self.frames_changed = False

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

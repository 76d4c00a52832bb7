"""The black box's writer: on every alarm, the ring of the last cycles to an MCAP file.

Runs as a thread of the gateway process (see :mod:`controller.contract.blackbox` for why not in
the control process). It polls the ring's alarm counter; when the counter moves it waits
``blackbox.after_s`` more of cycles, copies the ring and writes
``<blackbox.dir>/blackbox-<UTC time>-<code>.mcap`` with Foxglove schemas:

- ``/joint_states/measured``, ``/joint_states/commanded`` (foxglove.JointStates) and
  ``/blackbox/cycle`` (JSON: state, motion id, alarms, QP iterations, wake and compute time
  [us]) for every cycle;
- ``/tf`` (foxglove.FrameTransforms, measured) every 10th cycle, so a 3D panel replays it;
- ``/alarms`` (foxglove.Log) the active alarms at the alarm's cycle; ``/robot_description``;
- metadata ``imotion`` (robot, loop rate, joints, limits) and ``alarm`` (cycle, time, codes).

The file's path is logged (level warning) once written.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from datetime import UTC, datetime
from pathlib import Path

import foxglove
from foxglove.messages import LogLevel

from controller.contract.blackbox import Cycles, RingReader
from controller.gateway.observe import foxglove_msgs as fm
from controller.gateway.observe.urdf_frames import parse_joints
from controller.gateway.planning.robot_view import RobotView
from controller.model.robot import Robot
from controller.vocabulary import CoreState

_log = logging.getLogger("imotiond.blackbox")

#: How often the writer looks at the alarm counter [s].
POLL_PERIOD = 0.05
#: Every how many cycles a /tf message goes into the file.
TF_EVERY = 10


def write_blackbox(
    path: Path,
    cycles: Cycles,
    robot: Robot,
    hw_joints: list[str],
    rate_hz: float,
    alarm_seq: int,
    alarms: list[dict],
) -> None:
    """Write ``cycles`` (and the alarms active at row ``alarm_seq``) as MCAP to ``path``."""
    ctx = foxglove.Context()
    ch = fm.channels(ctx, blackbox=True)
    urdf = robot.urdf_path.read_text()
    joints = parse_joints(urdf)
    with foxglove.open_mcap(path, context=ctx) as writer:
        writer.write_metadata("imotion", fm.robot_metadata(robot, hw_joints, rate_hz))
        at = cycles.stamp[cycles.seq == alarm_seq]
        t_alarm = float(at[0]) if at.size else float(cycles.stamp[-1])
        writer.write_metadata(
            "alarm",
            {
                "cycle": str(alarm_seq),
                "time": datetime.fromtimestamp(t_alarm, UTC).isoformat(),
                "alarms": json.dumps(alarms),
            },
        )
        t0 = int(cycles.stamp[0] * 1e9) if len(cycles) else 0
        ch["/robot_description"].log({"data": urdf}, log_time=t0)
        for k in range(len(cycles)):
            t = float(cycles.stamp[k])
            t_ns = int(t * 1e9)
            ch["/joint_states/measured"].log(
                fm.joint_states(hw_joints, cycles.q[k], t), log_time=t_ns
            )
            ch["/joint_states/commanded"].log(
                fm.joint_states(hw_joints, cycles.q_cmd[k], t), log_time=t_ns
            )
            wake, compute = float(cycles.wake_us[k]), float(cycles.compute_us[k])
            ch["/blackbox/cycle"].log(
                {
                    "cycle": int(cycles.seq[k]),
                    "state": CoreState(int(cycles.state[k])).text,
                    "motion": int(cycles.motion[k]),
                    "alarms": int(cycles.alarms[k]),
                    "qp_iterations": int(cycles.qp_iterations[k]),
                    "wake_us": wake if wake == wake else None,
                    "compute_us": compute if compute == compute else None,
                },
                log_time=t_ns,
            )
            if k % TF_EVERY == 0:
                values = dict(zip(hw_joints, cycles.q[k].tolist(), strict=True))
                ch["/tf"].log(fm.frame_transforms(joints, values, t), log_time=t_ns)
        for alarm in alarms:
            msg = fm.log(LogLevel.Error, fm.alarm_text(alarm), alarm["module"], t_alarm)
            ch["/alarms"].log(msg, log_time=int(t_alarm * 1e9))


class BlackBoxWriter:
    """The thread (see the module docstring)."""

    def __init__(self, ring_path: Path, directory: Path, after_s: float, view: RobotView):
        self.ring = RingReader(ring_path)
        self.directory = Path(directory)
        self.after_s = after_s
        self.view = view
        #: Paths written so far.
        self.written: list[Path] = []
        #: The ring's alarm events when it was last copied for a file (from here on, each
        #: new one gets a file).
        self._copied_events = self.ring.alarm_events
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="blackbox", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        seen = self._copied_events
        while not self._stop.wait(POLL_PERIOD):
            events = self.ring.alarm_events
            if events == seen:
                continue
            self._copied_events = events
            try:
                self.write_now(self.ring.alarm_count - 1)
            except Exception as exc:  # never end the thread: the next alarm gets its file
                _log.error("black box: cannot write the file: %s", exc)
            # Alarms within the same window (in the ring's copy) share the file; one raised
            # later, while the file was written, gets its own.
            seen = self._copied_events

    def write_now(self, alarm_seq: int) -> Path:
        """Wait for ``after_s`` of cycles after row ``alarm_seq``, then write the file."""
        after = round(self.after_s * self.ring.rate_hz)
        deadline = time.monotonic() + self.after_s + 1.0
        while self.ring.count <= alarm_seq + after and time.monotonic() < deadline:
            if self._stop.wait(min(0.05, max(self.after_s, 0.001))):
                break
        self._copied_events = self.ring.alarm_events  # (read first: a later one is not in)
        cycles = self.ring.copy()
        alarms = self.view.snapshot().alarms
        self.directory.mkdir(parents=True, exist_ok=True)
        now = datetime.now(UTC).strftime("%Y%m%dT%H%M%S.%fZ")
        code = f"-{int(alarms[-1]['code']):04X}" if alarms else ""
        path = self.directory / f"blackbox-{now}{code}.mcap"
        write_blackbox(
            path,
            cycles,
            self.view.robot,
            self.view.hw_joints,
            self.ring.rate_hz,
            alarm_seq,
            alarms,
        )
        self.written.append(path)
        before = int((cycles.seq <= alarm_seq).sum())
        _log.warning(
            "black box written: %s (%d cycles before the alarm, %d after; %s)",
            path,
            before,
            len(cycles) - before,
            "; ".join(fm.alarm_text(a) for a in alarms) or "no alarm active any more",
        )
        return path

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5.0)
        self.ring.close()

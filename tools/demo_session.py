#!/usr/bin/env python3
"""The main job: imotiond on SmartPal V in MuJoCo, driven through gRPC by a scripted session.

Usage: python tools/demo_session.py [--out out/demo] [--quick] [--rate HZ] [--no-frames]

Starts ``imotiond --robot smartpal5 --hal sim`` as a child process on 127.0.0.1 (the port
picked by the system), waits until it answers, then runs through the generated gRPC stubs
(Spec A, IntegratedMotion): servoOn; a straight-line move of the right hand; an elbow swing with the
hand held (moveCPHoldRel); a waist bend (moveUnitAbs LUMBER); a vehicle move with both
hands held (moveCPHoldRel vehicle_x: when the body moves, CP-hold holds both control points
on a two-arm robot; both hands' drift is measured and printed); a move that is paused and
resumed (the hand back down, before the vehicle move); a move that is stopped; a move of
the hand into the body, refused before anything moves with a comment naming the two links;
a CP-hold swinging the elbow into the body (refused by the gateway's dry run, or stopped
short by the loop's collision rows: reported, not required). Every ReturnID and every state
change (Monitor.StreamState) is printed. Writes to ``--out``:

    frames/frame_NNN.png   the robot rendered from the streamed joints, every 0.5 s
    frames.png             a contact sheet of the frames
    joints.png             joint angles per unit over time, and tracking (deviation of the
                           hand from the commanded line; held hands during CP-hold moves)
    session.mcap           the state stream as recorded by ``imotion record`` (MCAP)
    session-joints.png     ``imotion plot session.mcap``: joints vs limits, loop timing
    session-timing.png
    session.json           ReturnIDs, state changes, tracking figures
    imotiond.log           the daemon's log

Ends the daemon with SIGTERM and checks that it exits 0 (decelerating stop, servo off).
The last line printed is a JSON summary. ``--quick`` shortens the moves and renders fewer,
smaller frames (the test uses it).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import grpc
import numpy as np

from controller.cli.plot import plot_file
from controller.client.convert import from_message
from controller.client.recording import Recorder as McapRecorder
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc

ROOT = Path(__file__).resolve().parents[1]
ROBOT = "smartpal5"
CODES = {
    0: "OK",
    -1: "NG",
    -2: "STATUS_ERR",
    -3: "VALUE_ERR",
    -4: "NOT_SV_ON_ERR",
    -5: "FULL_MOTION_QUEUE_ERR",
    -6: "CANNOT_REACH_TARGET_ERR",
}
STATES = {
    0x010: "Unpowered",
    0x011: "ServoOff",
    0x012: "Ready",
    0x013: "Busy",
    0x014: "Pause",
    0x015: "Alarm",
}
UNIT_NAMES = {0: "RIGHT_ARM", 1: "LEFT_ARM", 2: "LUMBER", 3: "VEHICLE"}
RIGHT, LEFT = pb.RIGHT, pb.LEFT
START_TIMEOUT = 90.0  #: [s] the daemon must answer within this
MOTION_TIMEOUT = 30.0  #: [s] longest single motion
STOP_TIMEOUT = 10.0  #: [s] SIGTERM → exit


def log(text: str) -> None:
    with _print_lock:
        print(text, flush=True)


_print_lock = threading.Lock()


# ---------------------------------------------------------------------- the daemon
class DaemonProcess:
    """``imotiond`` as a child process (log to a file), on a port the system picks."""

    def __init__(self, out: Path, rate: float | None, extra: list[str] | None = None):
        self.address = ""  #: host:port, from its "ready" line (:meth:`wait_ready`)
        self.channel: grpc.Channel | None = None
        cmd = [sys.executable, "-m", "controller.daemon.main", "--robot", ROBOT, "--hal", "sim"]
        cmd += ["--listen", "127.0.0.1:0"]
        if rate:
            cmd += ["--rate", f"{rate:g}"]
        cmd += extra or []
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(
            os.pathsep
        )
        self.log_path = out / "imotiond.log"
        self._log = open(self.log_path, "w")  # closed in stop()
        self.proc = subprocess.Popen(
            cmd, cwd=ROOT, env=env, stdout=self._log, stderr=subprocess.STDOUT
        )

    def wait_ready(self, timeout: float = START_TIMEOUT) -> grpc.Channel:
        """Its address from its "ready ... listening on ADDRESS" log line (it listens then),
        and a channel to it. (A channel opened before it listens would retry with gRPC's
        growing back-off: seconds after it is ready.)"""
        end = time.monotonic() + timeout
        ready = re.compile(r'msg="ready: .* listening on (\S+?)"')
        while time.monotonic() < end:
            exited = self.proc.poll() is not None  # before the read: its last line is in
            if found := ready.search(self.log_path.read_text(errors="replace")):
                self.address = found.group(1)
                self.channel = grpc.insecure_channel(self.address)
                stub = pb_grpc.IntegratedMotionStub(self.channel)
                stub.GetState(pb.GetStateRequest(), timeout=max(1.0, end - time.monotonic()))
                return self.channel
            if exited:
                raise RuntimeError(
                    f"imotiond exited with {self.proc.returncode} before answering "
                    f"(see {self.log_path})"
                )
            time.sleep(0.05)
        raise RuntimeError(f"imotiond was not ready in {timeout:g} s (see {self.log_path})")

    def stop(self) -> tuple[int | None, float]:
        """SIGTERM; returns (exit code or None when it had to be killed, seconds taken)."""
        if self.channel is not None:
            self.channel.close()
        t0 = time.monotonic()
        code: int | None
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                code = self.proc.wait(STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                code = None
        else:
            code = self.proc.returncode
        self._log.close()
        return code, time.monotonic() - t0


# ---------------------------------------------------------------------- recording
@dataclass
class Sample:
    t: float  #: [s] since the session started
    status: int
    units: dict[str, list[float]]  #: API units
    points: dict[int, np.ndarray]  #: arm → 4x4 pose, original frame [m]
    elbows: dict[int, float]  #: arm → elbow [deg]
    alarms: list[str]
    loop: Any


@dataclass
class Phase:
    label: str
    start: float
    end: float = math.nan
    #: Straight line the hand is commanded along: (arm, a, b) in the original frame [m].
    line: tuple[int, np.ndarray, np.ndarray] | None = None
    #: Held control point: (arm, pose at the start).
    held: tuple[int, np.ndarray] | None = None


class Recorder:
    """Monitor.StreamState in a thread: stores samples, prints state and alarm changes."""

    def __init__(
        self, channel: grpc.Channel, rate_hz: float, t0: float, mcap: McapRecorder | None = None
    ):
        self.mcap = mcap  #: also written here, as ``imotion record`` does
        self.samples: list[Sample] = []
        self.changes: list[dict[str, Any]] = []
        self._stream = pb_grpc.MonitorStub(channel).StreamState(
            pb.StreamStateRequest(rate_hz=rate_hz)
        )
        self._t0 = t0
        self._thread = threading.Thread(target=self._run, name="recorder", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        last_state: int | None = None
        last_alarms: list[str] = []
        try:
            for msg in self._stream:
                s = to_sample(msg, time.monotonic() - self._t0)
                self.samples.append(s)
                if self.mcap is not None:
                    self.mcap.add(from_message(msg), time.time())
                if s.status != last_state:
                    old = STATES.get(last_state, "-") if last_state is not None else "-"
                    new = STATES.get(s.status, hex(s.status))
                    log(f"  [{s.t:6.2f} s] state {old} -> {new} (0x{s.status:03x})")
                    self.changes.append({"t": round(s.t, 3), "from": old, "to": new})
                    last_state = s.status
                if s.alarms != last_alarms:
                    log(f"  [{s.t:6.2f} s] alarms: {s.alarms or 'none'}")
                    last_alarms = s.alarms
        except grpc.RpcError as exc:
            if exc.code() != grpc.StatusCode.CANCELLED:
                log(f"  state stream ended: {exc.code().name}: {exc.details()}")

    def wait_newer(self, t: float, timeout: float = 1.0) -> None:
        """Until a sample taken after ``t`` [s since the start] arrived."""
        end = time.monotonic() + timeout
        while time.monotonic() < end and (not self.samples or self.samples[-1].t <= t):
            time.sleep(0.005)

    def latest(self) -> Sample:
        while not self.samples:
            time.sleep(0.01)
        return self.samples[-1]

    def close(self) -> None:
        self._stream.cancel()
        self._thread.join(2.0)
        if self.mcap is not None:
            self.mcap.close()
            self.mcap = None


def to_sample(msg: Any, t: float) -> Sample:
    units = {UNIT_NAMES[j.unit]: list(j.position) for j in msg.joints}
    points, elbows = {}, {}
    for cp in msg.control_points:
        m = np.array(cp.pose.car_pos.m).reshape(3, 4)
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = m[:, :3], m[:, 3] / 1e3
        points[int(cp.arm)] = pose
        elbows[int(cp.arm)] = cp.pose.elbow
    alarms = [f"0x{a.code:x} {a.description}" for a in msg.alarms]
    return Sample(t, msg.status_id, units, points, elbows, alarms, msg.loop)


# ---------------------------------------------------------------------- the session
@dataclass
class Session:
    channel: grpc.Channel
    recorder: Recorder
    t0: float
    returns: list[dict[str, Any]] = field(default_factory=list)
    phases: list[Phase] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.a = pb_grpc.IntegratedMotionStub(self.channel)

    def now(self) -> float:
        return time.monotonic() - self.t0

    def call(
        self, label: str, method: Callable[..., Any], request: Any, refusal: bool = False
    ) -> Any:
        """One RPC; prints and records its ReturnID. ``refusal``: the call demonstrates a
        refusal (a refused answer is not counted as a failure of the session)."""
        reply = method(request, timeout=60.0)
        rid = reply.return_id
        name = CODES.get(rid.id, str(rid.id))
        log(f"  [{self.now():6.2f} s] {label}: {name} ({rid.id}) {rid.comment}")
        entry = {"t": round(self.now(), 3), "call": label, "id": rid.id, "code": name}
        self.returns.append({**entry, "comment": rid.comment, "refusal": refusal})
        return reply

    def moving(self) -> bool:
        return bool(self.a.IsMoving(pb.IsMovingRequest()).is_moving)

    def wait_started(self, timeout: float = 0.5) -> None:
        """Until isMoving reads true (the snapshot may lag the OK by a cycle)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end and not self.moving():
            time.sleep(0.005)

    def wait_idle(self, timeout: float = MOTION_TIMEOUT) -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if not self.moving():
                # let the state stream see the end before the next command
                self.recorder.wait_newer(self.now() + 0.005)
                return
            time.sleep(0.02)
        raise RuntimeError(f"the motion did not end within {timeout:g} s")

    def pose(self, arm: pb.RightLeft) -> np.ndarray:
        r = self.a.GetFeedbackPosCartesian(
            pb.GetFeedbackPosCartesianRequest(type=arm, frame_type=pb.ORIGINAL_FRAME)
        )
        m = np.array(r.pos.car_pos.m).reshape(3, 4)
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = m[:, :3], m[:, 3] / 1e3
        return pose

    def joints(self, unit: pb.UnitType) -> list[float]:
        r = self.a.GetFeedbackPosJoint(pb.GetFeedbackPosJointRequest(type=unit))
        return [round(x, 2) for x in r.position]

    def begin(self, label: str, **kw: Any) -> Phase:
        log(f"\n== {label}")
        phase = Phase(label, self.now(), **kw)
        self.phases.append(phase)
        return phase

    def end(self, phase: Phase) -> None:
        phase.end = self.now()

    def motion(self, label: str, method: Callable[..., Any], request: Any) -> bool:
        """Start a motion, wait until it ends; False when it was refused."""
        ok = self.call(label, method, request).return_id.id == 0
        if ok:
            self.wait_started()
            self.wait_idle()
        return ok


def hg(dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> pb.HgMatrix:
    """Pure translation [mm]."""
    return pb.HgMatrix(m=[1, 0, 0, dx, 0, 1, 0, dy, 0, 0, 1, dz])


def linear_rel(arm: pb.RightLeft, dz: float, speed: float) -> pb.MoveLinearCartesianRelRequest:
    return pb.MoveLinearCartesianRelRequest(
        type=arm,
        frame_type=pb.BASE_FRAME,
        rel_hg_mat=hg(dz=dz),
        speed=pb.CartesianSpeed(translation=speed, rotation=30.0),
        accel=pb.CartesianAccel(translation=2 * speed, rotation=60.0),
        is_hold_other_arm=False,
    )


def cp_hold_rel(arm: pb.RightLeft, **rel: float) -> pb.MoveCPHoldRelRequest:
    return pb.MoveCPHoldRelRequest(
        type=arm,
        rel_pos=pb.RedundantPos(**rel),
        speed=pb.RedundantSpeed(
            elbow=30.0, lumbar_ry=15.0, vehicle_translation=100.0, vehicle_rotation=30.0
        ),
        accel=pb.RedundantAccel(
            elbow=60.0, lumbar_ry=30.0, vehicle_translation=200.0, vehicle_rotation=60.0
        ),
    )


def run_script(s: Session, quick: bool) -> dict[str, Any]:
    """The scripted session; returns measured figures."""
    a = s.a
    figures: dict[str, Any] = {}
    reach = 50.0 if quick else 100.0  # hand line [mm]
    swing = 15.0 if quick else 30.0  # elbow swing [deg]
    bend = 10.0 if quick else 20.0  # waist bend (upper joint) [deg]
    drive = 80.0 if quick else 150.0  # vehicle [mm]

    log("\n== start")
    s.call("getVersion", a.GetVersion, pb.GetVersionRequest())
    log(f"  version: {a.GetVersion(pb.GetVersionRequest()).version}")
    s.call("getState", a.GetState, pb.GetStateRequest())
    s.call("servoOn", a.ServoOn, pb.ServoOnRequest())
    s.wait_started(0.3)

    # 1. straight line
    start = s.pose(RIGHT)
    goal = start[:3, 3] + np.array([0.0, 0.0, reach / 1e3])
    p = s.begin(
        f"1. right hand +{reach:g} mm up on a straight line",
        line=(RIGHT, start[:3, 3].copy(), goal),
    )
    s.motion(
        f"moveLinearCartesianRel(RIGHT, BASE_FRAME, z +{reach:g} mm, 50 mm/s)",
        a.MoveLinearCartesianRel,
        linear_rel(RIGHT, reach, 50.0),
    )
    s.end(p)
    end = s.pose(RIGHT)[:3, 3]
    figures["line_end_error_mm"] = round(1e3 * float(np.linalg.norm(end - goal)), 3)

    # 2. elbow swing, hand held
    p = s.begin(
        f"2. elbow swing -{swing:g} deg and back, right hand held", held=(RIGHT, s.pose(RIGHT))
    )
    for d in (-swing, swing):
        s.motion(
            f"moveCPHoldRel(RIGHT, elbow {d:+g} deg)", a.MoveCPHoldRel, cp_hold_rel(RIGHT, elbow=d)
        )
    s.end(p)

    # 3. waist bend (absolute: CP-hold moves may have shifted the two waist joints)
    p = s.begin(f"3. waist bend: LUMBER to [0, {bend:g}] deg and back")
    for target in ([0.0, bend], [0.0, 0.0]):
        s.motion(
            f"moveUnitAbs(LUMBER, {target} deg, 15 deg/s)",
            a.MoveUnitAbs,
            pb.MoveUnitAbsRequest(unit=pb.LUMBER, abs_pos=target, speed=[15.0], accel=[30.0]),
        )
    s.end(p)

    # 4. pause and resume during a move
    start = s.pose(RIGHT)
    goal = start[:3, 3] - np.array([0.0, 0.0, reach / 1e3])
    p = s.begin(
        f"4. right hand back down {reach:g} mm: pause, resume",
        line=(RIGHT, start[:3, 3].copy(), goal),
    )
    s.call(
        f"moveLinearCartesianRel(RIGHT, BASE_FRAME, z -{reach:g} mm, 40 mm/s)",
        a.MoveLinearCartesianRel,
        linear_rel(RIGHT, -reach, 40.0),
    )
    s.wait_started()
    time.sleep(0.6 if quick else 1.0)
    s.call("pause", a.Pause, pb.PauseRequest())
    time.sleep(1.0)
    s.call("getState", a.GetState, pb.GetStateRequest())
    s.call("resume", a.Resume, pb.ResumeRequest())
    s.wait_started()
    s.wait_idle()
    s.end(p)
    end = s.pose(RIGHT)[:3, 3]
    figures["paused_line_end_error_mm"] = round(1e3 * float(np.linalg.norm(end - goal)), 3)

    # 5. vehicle move, both hands held (CP-hold holds both hands when the body moves)
    left0 = s.pose(LEFT)
    veh0 = s.joints(pb.VEHICLE)
    p = s.begin(
        f"5. vehicle {drive:g} mm backward, both hands held (CP-hold)", held=(RIGHT, s.pose(RIGHT))
    )
    s.motion(
        f"moveCPHoldRel(RIGHT, vehicle_x -{drive:g} mm, 100 mm/s)",
        a.MoveCPHoldRel,
        cp_hold_rel(RIGHT, vehicle_x=-drive),
    )
    s.end(p)
    veh1 = s.joints(pb.VEHICLE)
    drift = 1e3 * float(np.linalg.norm(s.pose(LEFT)[:3, 3] - left0[:3, 3]))
    assert p.held is not None
    held_err = 1e3 * float(np.linalg.norm(s.pose(RIGHT)[:3, 3] - p.held[1][:3, 3]))
    log(f"  vehicle {veh0} -> {veh1} (x, y mm, theta deg)")
    log(f"  right hand (held) moved {held_err:.3f} mm; left hand (held) moved {drift:.3f} mm")
    figures["vehicle_reached_mm"] = round(veh0[0] - veh1[0], 1)
    figures["vehicle_held_hand_error_mm"] = round(held_err, 3)
    figures["vehicle_left_hand_drift_mm"] = round(drift, 3)

    # 6. stop during a move
    p = s.begin(f"6. vehicle forward {drive:g} mm, stopped halfway", held=(RIGHT, s.pose(RIGHT)))
    s.call(
        f"moveCPHoldRel(RIGHT, vehicle_x +{drive:g} mm, 100 mm/s)",
        a.MoveCPHoldRel,
        cp_hold_rel(RIGHT, vehicle_x=drive),
    )
    s.wait_started()
    time.sleep(0.6 if quick else 0.9)
    s.call("stop", a.Stop, pb.StopRequest())
    s.wait_idle()
    s.end(p)
    veh2 = s.joints(pb.VEHICLE)
    log(f"  stopped with the vehicle at {veh2} (x, y mm, theta deg)")
    figures["stopped_vehicle_x_mm"] = veh2[0]

    figures.update(collision_steps(s))

    log("\n== end")
    s.call("getState", a.GetState, pb.GetStateRequest())
    s.call("getActiveAlarm", a.GetActiveAlarm, pb.GetActiveAlarmRequest())
    loop = s.recorder.latest().loop
    figures["loop"] = {
        "cycles": int(loop.cycles),
        "overruns": int(loop.overruns),
        "wake_latency_p99_us": round(loop.wake_latency.p99_us, 1),
        "compute_p99_us": round(loop.compute.p99_us, 1),
    }
    log(
        f"  loop: {loop.cycles} cycles, {loop.overruns} overruns; last second: wake latency "
        f"p99 {loop.wake_latency.p99_us:.0f} us, compute p99 {loop.compute.p99_us:.0f} us"
    )
    return figures


def collision_steps(s: Session) -> dict[str, Any]:
    """7. A move into the body, refused before anything moves (the comment names the two
    links); 8. the hand 150 mm inwards, then a CP-hold swinging the elbow into the body:
    accepted, the control loop's collision rows stop it short of the body with a
    MOTION_BLOCKED warning naming the links (issue 10)."""
    a = s.a
    figures: dict[str, Any] = {}
    p = s.begin("7. right hand 200 mm towards the body (PTP): refused, nothing moves")
    before = s.pose(RIGHT)
    reply = s.call(
        "movePTPCartesianRel(RIGHT, y +200 mm, 3 s)",
        a.MovePTPCartesianRel,
        pb.MovePTPCartesianRelRequest(type=RIGHT, rel_hg_mat=hg(dy=200.0), time=3.0),
        refusal=True,
    )
    rid = reply.return_id
    if rid.id == 0:  # not refused (another collision model?): let it end
        s.wait_started()
        s.wait_idle()
    moved = 1e3 * float(np.linalg.norm(s.pose(RIGHT)[:3, 3] - before[:3, 3]))
    log(f"  refused: {rid.id != 0}; the hand moved {moved:.3f} mm")
    figures["refused_move"] = {"code": CODES.get(rid.id, str(rid.id)), "comment": rid.comment}
    figures["refused_move_hand_moved_mm"] = round(moved, 3)
    s.end(p)

    inward = pb.MoveLinearCartesianRelRequest(
        type=RIGHT,
        frame_type=pb.BASE_FRAME,
        rel_hg_mat=hg(dy=150.0),
        speed=pb.CartesianSpeed(translation=100.0, rotation=30.0),
        accel=pb.CartesianAccel(translation=200.0, rotation=60.0),
        is_hold_other_arm=False,
    )
    s.motion("moveLinearCartesianRel(RIGHT, y +150 mm)", a.MoveLinearCartesianRel, inward)
    p = s.begin("8. elbow swing +20 deg into the body, right hand held (CP-hold)")
    held = s.pose(RIGHT)
    reply = s.call(
        "moveCPHoldRel(RIGHT, elbow +20 deg)",
        a.MoveCPHoldRel,
        cp_hold_rel(RIGHT, elbow=20.0),
        refusal=True,
    )
    rid = reply.return_id
    outcome, warnings = "refused before moving", []
    if rid.id == 0:
        s.wait_started()
        s.wait_idle()
        state = s.a.GetState(pb.GetStateRequest())
        outcome = f"ran; state {STATES.get(state.status_id, state.status_id)}"
        alarms = s.call(
            "getActiveAlarm", a.GetActiveAlarm, pb.GetActiveAlarmRequest(), refusal=True
        ).alarms
        warnings = [f"0x{al.code:03X} {al.description}" for al in alarms]
        for w in warnings:
            log(f"  alarm {w}")
    drift = 1e3 * float(np.linalg.norm(s.pose(RIGHT)[:3, 3] - held[:3, 3]))
    log(f"  {outcome}: {rid.comment or '(no comment)'}; held hand moved {drift:.3f} mm")
    figures["cp_hold_into_body"] = {
        "code": CODES.get(rid.id, str(rid.id)),
        "comment": rid.comment,
        "outcome": outcome,
        "alarms": warnings,
        "held_hand_moved_mm": round(drift, 3),
    }
    s.end(p)
    return figures


# ---------------------------------------------------------------------- outputs
def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from ``p`` to the segment a-b."""
    ab = b - a
    u = float(np.clip(np.dot(p - a, ab) / max(float(np.dot(ab, ab)), 1e-18), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + u * ab)))


def tracking(samples: list[Sample], phases: list[Phase]) -> dict[str, Any]:
    """Per phase: deviation of the hand from its commanded line or held pose [mm]."""
    out: dict[str, Any] = {}
    for ph in phases:
        inside = [s for s in samples if ph.start <= s.t <= ph.end]
        if ph.line is not None:
            arm, a, b = ph.line
            dev = [1e3 * segment_distance(s.points[arm][:3, 3], a, b) for s in inside]
        elif ph.held is not None:
            arm, pose = ph.held
            dev = [1e3 * float(np.linalg.norm(s.points[arm][:3, 3] - pose[:3, 3])) for s in inside]
        else:
            continue
        out[ph.label] = {"t": [s.t for s in inside], "mm": dev}
    return out


def write_plot(path: Path, samples: list[Sample], phases: list[Phase]) -> dict[str, float]:
    from demo_plot import Panel, Series, save_sheet

    t = np.array([s.t for s in samples])
    bands = [(ph.label.split(" ")[0], ph.start, ph.end) for ph in phases]
    panels = []
    labels = {
        "RIGHT_ARM": ("right arm joints", "deg", [f"J{k + 1}" for k in range(7)]),
        "LEFT_ARM": ("left arm joints", "deg", [f"J{k + 1}" for k in range(7)]),
        "LUMBER": ("waist joints (LUMBER)", "deg", ["lower", "upper"]),
        "VEHICLE": ("vehicle (original frame)", "mm / deg", ["x [mm]", "y [mm]", "theta [deg]"]),
    }
    for unit, (title, y_label, names) in labels.items():
        values = np.array([s.units.get(unit, [math.nan] * len(names)) for s in samples])
        series = [Series(n, t, values[:, k]) for k, n in enumerate(names)]
        panels.append(Panel(title, y_label, series, bands=bands))
    track = tracking(samples, phases)
    worst: dict[str, float] = {}
    series = []
    for label, d in track.items():
        short = label.split(" ")[0] + (" line" if "line" in label or "down" in label else " held")
        series.append(Series(short, np.array(d["t"]), np.array(d["mm"])))
        worst[label] = round(max(d["mm"], default=0.0), 3)
    panels.append(
        Panel(
            "right hand: distance from the commanded line (1, 5) or from its held pose (2, 4, 6)",
            "mm",
            series,
            bands=bands,
            x_range=(float(t[0]), float(t[-1])) if t.size else None,
        )
    )
    save_sheet(panels, path)
    return worst


def write_frames(
    out: Path, samples: list[Sample], phases: list[Phase], every: float, size: tuple[int, int]
) -> int:
    from demo_render import FrameRenderer, contact_sheet

    from controller.model.robot import load_robot

    frames_dir = out / "frames"
    frames_dir.mkdir(parents=True, exist_ok=True)
    for old in frames_dir.glob("frame_*.png"):
        old.unlink()
    renderer = FrameRenderer(load_robot(ROBOT), *size)
    images: list[Any] = []
    next_t = -math.inf
    try:
        for s in samples:
            if s.t < next_t:
                continue
            next_t = s.t + every
            phase = next((p for p in phases if p.start <= s.t <= p.end), None)
            segments = []
            if phase is not None and phase.line is not None:
                segments.append((phase.line[1], phase.line[2]))
            text = f"t = {s.t:5.1f} s  {STATES.get(s.status, '?'):6s}  "
            text += phase.label if phase else ""
            image = renderer.render(s.units, list(s.points.values()), segments, text)
            image.save(frames_dir / f"frame_{len(images):03d}.png")
            images.append(image)
    finally:
        renderer.close()
    step = max(1, len(images) // 12)
    contact_sheet(images[::step][:12]).save(out / "frames.png")
    return len(images)


# ---------------------------------------------------------------------- main
def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/demo"))
    parser.add_argument("--quick", action="store_true", help="shorter moves, fewer frames")
    parser.add_argument("--rate", type=float, default=None, help="loop rate [Hz]")
    parser.add_argument("--no-frames", action="store_true", help="skip rendering")
    args = parser.parse_args()
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.monotonic()

    log(f"starting imotiond (robot {ROBOT}, hal sim); log: {out / 'imotiond.log'}")
    daemon = DaemonProcess(out, args.rate)
    result: dict[str, Any] = {"ok": False}
    recorder = None
    try:
        channel = daemon.wait_ready()
        log(f"imotiond answers on {daemon.address} after {time.monotonic() - t_start:.1f} s")
        t0 = time.monotonic()
        recorder = Recorder(channel, 50.0, t0, McapRecorder(out / "session.mcap"))
        recorder.latest()
        session = Session(channel, recorder, t0)
        figures = run_script(session, args.quick)
        time.sleep(0.1)
        recorder.close()
        samples = list(recorder.samples)
        worst = write_plot(out / "joints.png", samples, session.phases)
        log(f"\nwrote {out / 'joints.png'}")
        for label, mm in worst.items():
            log(f"  {label}: max deviation {mm:.2f} mm")
        plots = plot_file(out / "session.mcap", out)
        log(f"wrote {out / 'session.mcap'} and {', '.join(p.name for p in plots)}")
        n_frames = 0
        if not args.no_frames:
            # --quick (the test): a frame per 2.5 s (~8 for its ~18 s), each ~0.4 s to render
            every = 2.5 if args.quick else 0.5
            size = (320, 240) if args.quick else (640, 480)
            n_frames = write_frames(out, samples, session.phases, every, size)
            log(f"wrote {n_frames} frames to {out / 'frames'} and {out / 'frames.png'}")
        result.update(
            returns=session.returns,
            state_changes=recorder.changes,
            figures=figures,
            max_deviation_mm=worst,
            frames=n_frames,
            samples=len(samples),
        )
    except (RuntimeError, grpc.RpcError, OSError) as exc:
        text = exc.details() if isinstance(exc, grpc.RpcError) else str(exc)
        log(f"demo failed: {text}")
        result["error"] = text
    finally:
        if recorder is not None:
            recorder.close()
        code, took = daemon.stop()
    log(f"\nimotiond stopped by SIGTERM: exit code {code} after {took:.2f} s")
    result["daemon_exit"] = code
    result["daemon_stop_s"] = round(took, 2)
    result["seconds"] = round(time.monotonic() - t_start, 1)
    unexpected = [r for r in result.get("returns", []) if r["id"] != 0 and not r["refusal"]]
    result["ok"] = "error" not in result and code == 0 and not unexpected
    (out / "session.json").write_text(json.dumps(result, indent=1))
    summary = {k: v for k, v in result.items() if k not in ("returns", "state_changes")}
    summary["returns"] = len(result.get("returns", []))
    summary["not_ok_returns"] = len(unexpected)
    print(json.dumps(summary))
    return 0 if result["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())

"""Live view: the robot, its joints, control points, loop and alarms over the Foxglove protocol.

Runs in the gateway process (``view.listen``), beside gRPC: like StreamState it only reads
the shared-memory snapshot, so a viewer costs the control loop nothing (no GIL shared, no
lock, no message). A thread samples the snapshot at ``view.rate_hz`` and logs the topics of
:mod:`controller.gateway.observe.foxglove_msgs` to a ``foxglove-sdk`` WebSocket server (the SDK's
Rust core does the networking); topics nobody subscribed to are not even computed.

Any Foxglove-protocol viewer opens it (Foxglove, Lichtblick: "Open connection", Foxglove
WebSocket, ``ws://127.0.0.1:8765``). The URDF is the ``/robot_description`` parameter and
topic; files it refers to (``package://`` or ``file://`` URIs below the robot directory) come
through the asset handler.
"""

from __future__ import annotations

import logging
import threading
import time
from pathlib import Path
from typing import Any

import foxglove
import numpy as np
import pinocchio as pin
from foxglove.messages import (
    ArrowPrimitive,
    LogLevel,
    SceneEntity,
    SceneUpdate,
    SpherePrimitive,
    Vector3,
)
from foxglove.websocket import Capability, ServerListener

from controller.contract.config import DaemonConfig, parse_listen
from controller.contract.snapshot import Snapshot
from controller.gateway.observe import foxglove_msgs as fm
from controller.gateway.observe.urdf_frames import parse_joints, root_link
from controller.gateway.planning.robot_view import RobotView
from controller.vocabulary import FrameType, RightLeft

_log = logging.getLogger("imotiond.view")

PARAMETER = "/robot_description"
#: The robot description is sent again this often [s].
DESCRIPTION_PERIOD = 2.0
#: ... and on this many ticks after someone subscribed to it.
DESCRIPTION_TICKS = 3


class _Listener(ServerListener):
    """Answers parameter requests; notes new subscribers of the robot description."""

    def __init__(self, view: LiveView):
        self.view = view

    def on_subscribe(self, client: Any, channel: Any) -> None:
        if channel.topic == PARAMETER:
            # The subscription is registered after this callback: send on a few ticks.
            self.view.description_due = DESCRIPTION_TICKS

    def on_get_parameters(
        self, client: Any, param_names: list[str], request_id: str | None = None
    ) -> list[foxglove.Parameter]:
        if param_names and PARAMETER not in param_names:
            return []
        return [foxglove.Parameter(PARAMETER, value=self.view.urdf)]


class LiveView:
    """The server and its publishing thread (see the module docstring)."""

    def __init__(self, cfg: DaemonConfig, view: RobotView):
        assert cfg.view.listen is not None
        _, host, port = parse_listen(cfg.view.listen)
        self.view = view
        self.robot = view.robot
        self.period = 1.0 / cfg.view.rate_hz
        self.urdf = self.robot.urdf_path.read_text()
        self.joints = parse_joints(self.urdf)
        self.root = root_link(self.urdf)
        self.hw_joints = view.hw_joints
        self._revolute = np.array(
            [n not in self.robot.joints or self.robot.joints[n].kind == "revolute"
             for n in self.hw_joints]
        )  # fmt: skip
        self.description_due = 0
        self.ctx = foxglove.Context()
        self.channels = fm.channels(self.ctx)
        self.server = foxglove.start_server(
            name=f"imotiond {self.robot.id}",
            host=str(host),
            port=int(port or 0),
            capabilities=[Capability.Parameters],
            server_listener=_Listener(self),
            asset_handler=self.asset,
            context=self.ctx,
        )
        self.url = f"ws://{host}:{self.server.port}"
        self._last_alarms: list[dict[str, Any]] = []
        self._last_state = ""
        self._description_t = 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="live-view", daemon=True)
        self._thread.start()
        _log.info("live view on %s (Foxglove WebSocket, %g Hz)", self.url, cfg.view.rate_hz)

    # ------------------------------------------------------------------ assets
    def asset(self, uri: str) -> bytes | None:
        """Files below the robot directory: ``package://<anything>/<path>`` or ``file://``."""
        base = self.robot.directory.resolve()
        if uri.startswith("package://"):
            rest = uri.removeprefix("package://")
            path = base / rest.split("/", 1)[1] if "/" in rest else base / rest
        elif uri.startswith("file://"):
            path = Path(uri.removeprefix("file://"))
        else:
            return None
        path = path.resolve()
        if not path.is_relative_to(base) or not path.is_file():
            return None
        return path.read_bytes()

    # ------------------------------------------------------------------ publishing
    def _run(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            try:
                self.publish(self.view.snapshot())
            except Exception:  # a bad sample must not end the view
                _log.exception("live view: publishing failed")
            next_t += self.period
            delay = next_t - time.monotonic()
            if delay < 0:
                next_t, delay = time.monotonic(), 0.0
            self._stop.wait(delay)

    def publish(self, snap: Snapshot) -> None:
        """Log every subscribed topic for one snapshot."""
        ch = self.channels
        t = time.time()
        t_ns = int(t * 1e9)
        description = ch["/robot_description"]
        # Sent when someone subscribes, and again every DESCRIPTION_PERIOD (a subscriber
        # that arrives between the callback and its registration still gets it).
        if description.has_sinks() and (
            self.description_due > 0 or t - self._description_t > DESCRIPTION_PERIOD
        ):
            self.description_due = max(0, self.description_due - 1)
            self._description_t = t
            description.log({"data": self.urdf}, log_time=t_ns)
        if ch["/tf"].has_sinks():
            values = dict(zip(self.hw_joints, snap.q.tolist(), strict=True))
            ch["/tf"].log(fm.frame_transforms(self.joints, values, t), log_time=t_ns)
        for name, q in (("measured", snap.q), ("commanded", snap.q_cmd)):
            channel = ch[f"/joint_states/{name}"]
            if channel.has_sinks():
                channel.log(fm.joint_states(self.hw_joints, q, t), log_time=t_ns)
        if ch["/control_points"].has_sinks() or ch["/tracking_error"].has_sinks():
            update, tracking = self._control_points(snap, t)
            ch["/control_points"].log(update, log_time=t_ns)
            ch["/tracking_error"].log(tracking, log_time=t_ns)
        ch["/loop"].log(
            {
                "cycle": snap.cycle,
                "overruns": snap.overruns,
                "wake_us": snap.wake_us.tolist(),
                "compute_us": snap.compute_us.tolist(),
            },
            log_time=t_ns,
        )
        ch["/state"].log(
            {
                "state": snap.core_state.text,
                "hardware": snap.hw_state.value,
                "moving": snap.moving,
                "servo_on": snap.servo_on,
                "queue": snap.queue,
                "motions_started": snap.started,
                "motions_finished": snap.finished,
                "alarms": len(snap.alarms),
            },
            log_time=t_ns,
        )
        self._log_events(snap, t)

    def _log_events(self, snap: Snapshot, t: float) -> None:
        """State changes and alarms raised or cleared, as log messages on /alarms."""
        out = self.channels["/alarms"]
        state = snap.core_state.text
        if state != self._last_state:
            text = f"state: {self._last_state or '(start)'} -> {state}"
            out.log(fm.log(LogLevel.Info, text, "state", t), log_time=int(t * 1e9))
            self._last_state = state
        if snap.alarms == self._last_alarms:
            return
        for alarm in snap.alarms:
            if alarm not in self._last_alarms:
                msg = fm.log(LogLevel.Error, fm.alarm_text(alarm), alarm["module"], t)
                out.log(msg, log_time=int(t * 1e9))
        if not snap.alarms:
            out.log(fm.log(LogLevel.Info, "alarms cleared", "alarms", t), log_time=int(t * 1e9))
        self._last_alarms = snap.alarms

    def _control_points(self, snap: Snapshot, t: float) -> tuple[SceneUpdate, dict[str, Any]]:
        """Measured control points and their commanded targets (world = URDF root link)."""
        measured, target = {}, {}
        with self.view.at(snap) as kin:
            for side in kin.arms:
                measured[side] = kin.original_frame * kin.pose(side, FrameType.ORIGINAL_FRAME)
        # Servo off, the command is not followed: the target is where the robot is.
        q_target = snap.q_cmd if snap.servo_on else snap.q
        with self.view.at(snap, q_target[self.view.hw_index]) as kin:
            for side in kin.arms:
                target[side] = kin.original_frame * kin.pose(side, FrameType.ORIGINAL_FRAME)
        entities, arms = [], {}
        for side in measured:
            m, c = measured[side], target[side]
            entities.append(self._marker(side, m.homogeneous, t))
            entities.append(
                SceneEntity(
                    timestamp=fm.stamp(t),
                    frame_id=self.root,
                    id=f"{side.name.lower()}_target",
                    spheres=[
                        SpherePrimitive(
                            pose=fm.pose(c.homogeneous),
                            size=Vector3(x=0.05, y=0.05, z=0.05),
                            color=fm.TARGET,
                        )
                    ],
                )
            )
            delta = m.actInv(c)
            arms[side.name] = {
                "position_mm": 1e3 * float(np.linalg.norm(c.translation - m.translation)),
                "orientation_deg": float(np.degrees(np.linalg.norm(pin.log3(delta.rotation)))),
            }
        err = q_target - snap.q
        scaled = np.where(self._revolute, np.degrees(err), 1e3 * err)
        k = int(np.argmax(np.abs(scaled))) if scaled.size else 0
        tracking = {
            "arms": arms,
            "joint_max": float(np.abs(scaled[k])) if scaled.size else 0.0,
            "joint_max_name": self.hw_joints[k] if scaled.size else "",
        }
        return SceneUpdate(entities=entities), tracking

    def _marker(self, side: RightLeft, pose: np.ndarray, t: float) -> SceneEntity:
        """A ball with the frame's axes (x red, y green, z blue)."""
        arrows = []
        for axis, color in zip(range(3), (fm.RED, fm.GREEN, fm.BLUE), strict=True):
            turn = np.eye(4)
            # An arrow points along its pose's x axis: turn x onto y or z.
            if axis == 1:
                turn[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
            elif axis == 2:
                turn[:3, :3] = [[0, 0, -1], [0, 1, 0], [1, 0, 0]]
            arrows.append(
                ArrowPrimitive(
                    pose=fm.pose(pose @ turn),
                    shaft_length=0.07,
                    shaft_diameter=0.006,
                    head_length=0.02,
                    head_diameter=0.014,
                    color=color,
                )
            )
        return SceneEntity(
            timestamp=fm.stamp(t),
            frame_id=self.root,
            id=f"{side.name.lower()}_control_point",
            spheres=[
                SpherePrimitive(
                    pose=fm.pose(pose), size=Vector3(x=0.03, y=0.03, z=0.03), color=fm.YELLOW
                )
            ],
            arrows=arrows,
        )

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.server.stop()


def start_live_view(cfg: DaemonConfig, view: RobotView) -> LiveView | None:
    """The live view when ``view.listen`` is set (the caller checked the security rules)."""
    if cfg.view.listen is None:
        return None
    return LiveView(cfg, view)

"""MCAP recordings: Monitor.StreamState to a file (``imotion record``), and reading files back.

:class:`Recorder` writes each :class:`~controller.client.types.StateSample` with Foxglove
schemas (``foxglove-sdk``), so any MCAP viewer shows it:

====================== ===================== ================================================
topic                  schema                content
====================== ===================== ================================================
/joint_states          foxglove.JointStates  every unit's joints, names ``UNIT/k`` [rad, m]
/control_points        foxglove.PosesInFrame control points in frame ``original`` [m]
/state                 JSON                  Spec A state id and message, alarm count
/loop                  JSON                  cycle, overruns, wake/compute p50/p99/max [us]
/alarms                foxglove.Log          alarms raised and cleared, state changes
====================== ===================== ================================================

The daemon's black-box files (``blackbox.dir``) use the topics listed in
``controller/gateway/observe/foxglove_msgs.py``; :func:`read_mcap` reads both kinds (needs the
``mcap`` package, extra ``plot``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import foxglove
from foxglove.channels import JointStatesChannel, LogChannel, PosesInFrameChannel
from foxglove.messages import (
    JointState,
    JointStates,
    Log,
    LogLevel,
    Pose,
    PosesInFrame,
    Quaternion,
    Timestamp,
    Vector3,
)

from controller.client.foxglove_ws import decoder
from controller.client.types import StateSample

STATE_SCHEMA = {
    "title": "imotion.RecordedState",
    "type": "object",
    "properties": {
        "status_id": {"type": "integer"},
        "status_message": {"type": "string"},
        "alarms": {"type": "integer"},
    },
}
LOOP_SCHEMA = {
    "title": "imotion.Loop",
    "type": "object",
    "properties": {
        "cycle": {"type": "integer"},
        "overruns": {"type": "integer"},
        "wake_us": {"type": "array", "items": {"type": "number"}},
        "compute_us": {"type": "array", "items": {"type": "number"}},
    },
}


def _quaternion(r: list[list[float]]) -> Quaternion:
    """Quaternion of a rotation matrix (rows)."""
    m00, m11, m22 = r[0][0], r[1][1], r[2][2]
    w = math.sqrt(max(0.0, 1.0 + m00 + m11 + m22)) / 2.0
    x = math.copysign(math.sqrt(max(0.0, 1.0 + m00 - m11 - m22)) / 2.0, r[2][1] - r[1][2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - m00 + m11 - m22)) / 2.0, r[0][2] - r[2][0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - m00 - m11 + m22)) / 2.0, r[1][0] - r[0][1])
    return Quaternion(x=x, y=y, z=z, w=w)


class Recorder:
    """StreamState samples into an MCAP file; use as a context manager."""

    def __init__(self, path: Path, metadata: dict[str, str] | None = None):
        self.ctx = foxglove.Context()
        self.joints = JointStatesChannel("/joint_states", context=self.ctx)
        self.points = PosesInFrameChannel("/control_points", context=self.ctx)
        self.state = foxglove.Channel("/state", schema=STATE_SCHEMA, context=self.ctx)
        self.loop = foxglove.Channel("/loop", schema=LOOP_SCHEMA, context=self.ctx)
        self.alarms = LogChannel("/alarms", context=self.ctx)
        self.writer = foxglove.open_mcap(Path(path), allow_overwrite=True, context=self.ctx)
        self.writer.write_metadata("imotion", dict(metadata or {}, source="StreamState"))
        self.samples = 0
        self._status = ""
        self._alarms: list[Any] = []

    def add(self, sample: StateSample, t: float) -> None:
        """One sample received at wall-clock time ``t`` [s]."""
        ns = int(t * 1e9)
        ts = Timestamp.from_epoch_secs(t)
        joints = []
        for unit in sample.joints:
            name = getattr(unit.unit, "name", str(unit.unit))
            for k, value in enumerate(unit.position):
                # spec units: deg, vehicle x/y in mm
                si = value / 1e3 if name == "VEHICLE" and k < 2 else math.radians(value)
                joints.append(JointState(name=f"{name}/{k + 1}", position=si))
        self.joints.log(JointStates(timestamp=ts, joints=joints), log_time=ns)
        poses = []
        for cp in sample.controlPoints:
            rows = [[float(v) for v in row] for row in cp.pose.carPos]
            poses.append(
                Pose(
                    position=Vector3(x=rows[0][3] / 1e3, y=rows[1][3] / 1e3, z=rows[2][3] / 1e3),
                    orientation=_quaternion(rows),
                )
            )
        self.points.log(PosesInFrame(timestamp=ts, frame_id="original", poses=poses), log_time=ns)
        self.state.log(
            {
                "status_id": int(sample.statusId),
                "status_message": sample.statusMessage,
                "alarms": len(sample.alarms),
            },
            log_time=ns,
        )
        loop = sample.loop
        self.loop.log(
            {
                "cycle": int(loop.cycles),
                "overruns": int(loop.overruns),
                "wake_us": list(loop.wakeLatency),
                "compute_us": list(loop.compute),
            },
            log_time=ns,
        )
        self._events(sample, ts, ns)
        self.samples += 1

    def _events(self, sample: StateSample, ts: Timestamp, ns: int) -> None:
        if sample.statusMessage != self._status:
            text = f"state: {self._status or '(start)'} -> {sample.statusMessage}"
            self.alarms.log(Log(timestamp=ts, level=LogLevel.Info, message=text, name="state"),
                            log_time=ns)  # fmt: skip
            self._status = sample.statusMessage
        alarms = list(sample.alarms)
        for alarm in alarms:
            if alarm not in self._alarms:
                text = f"alarm 0x{int(alarm.code):04X} ({alarm.moduleName}): {alarm.description}"
                self.alarms.log(
                    Log(timestamp=ts, level=LogLevel.Error, message=text, name=alarm.moduleName),
                    log_time=ns,
                )
        if self._alarms and not alarms:
            self.alarms.log(
                Log(timestamp=ts, level=LogLevel.Info, message="alarms cleared", name="alarms"),
                log_time=ns,
            )
        self._alarms = alarms

    def close(self) -> None:
        self.writer.close()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass
class Recording:
    """A decoded MCAP file: messages per topic as (log_time [s], dict), and metadata."""

    topics: dict[str, list[tuple[float, dict[str, Any]]]] = field(default_factory=dict)
    schemas: dict[str, str] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)

    def messages(self, topic: str) -> list[tuple[float, dict[str, Any]]]:
        return self.topics.get(topic, [])


def read_mcap(path: Path, topics: Iterable[str] | None = None) -> Recording:
    """Decode every message (of ``topics``) of an MCAP file written with Foxglove schemas."""
    from mcap.reader import make_reader

    wanted = set(topics) if topics is not None else None
    out = Recording()
    decoders: dict[int, Any] = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for schema, channel, message in reader.iter_messages(
            topics=list(wanted) if wanted is not None else None
        ):
            dec = decoders.get(channel.id)
            if dec is None:
                name = schema.name if schema is not None else ""
                dec = decoders[channel.id] = decoder(
                    channel.message_encoding, name, schema.data if schema is not None else b""
                )
                out.schemas[channel.topic] = name
            out.topics.setdefault(channel.topic, []).append(
                (message.log_time / 1e9, dec(message.data))
            )
        f.seek(0)
        for record in make_reader(f).iter_metadata():
            out.metadata[record.name] = dict(record.metadata)
    return out


def metadata_limits(rec: Recording) -> dict[str, dict[str, Any]]:
    """Joint kinds and limits [rad, m] from the ``imotion`` metadata (empty when absent)."""
    text = rec.metadata.get("imotion", {}).get("limits")
    return dict(json.loads(text)) if text else {}

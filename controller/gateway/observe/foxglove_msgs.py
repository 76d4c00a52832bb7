"""Foxglove messages and channels shared by the live view and the black box.

Topics (one schema each, so any Foxglove-protocol viewer or MCAP reader understands them):

======================== ============================ =========================================
topic                    schema                       content
======================== ============================ =========================================
/robot_description       JSON ``{"data": URDF}``      the URDF (also the parameter of that name)
/tf                      foxglove.FrameTransforms     one transform per URDF joint
/joint_states/measured   foxglove.JointStates         measured joints [rad, m]
/joint_states/commanded  foxglove.JointStates         commanded joints [rad, m]
/control_points          foxglove.SceneUpdate         control points (solid) and targets
/tracking_error          JSON                         per arm [mm, deg]; joints [deg or mm]
/loop                    JSON                         cycle, overruns, wake/compute [us]
/state                   JSON                         controller and hardware state, queue
/alarms                  foxglove.Log                 alarms raised and cleared, state changes
/blackbox/cycle          JSON                         black box only: one record per cycle
======================== ============================ =========================================
"""

from __future__ import annotations

import json
import math
from typing import Any

import foxglove
import numpy as np
from foxglove.messages import (
    Color,
    FrameTransform,
    FrameTransforms,
    JointState,
    JointStates,
    Log,
    LogLevel,
    Pose,
    Quaternion,
    Timestamp,
    Vector3,
)

from controller.gateway.observe.urdf_frames import UrdfJoint, joint_transform, quaternion
from controller.model.robot import Robot

DESCRIPTION_SCHEMA = {
    "title": "std_msgs/String",
    "type": "object",
    "properties": {"data": {"type": "string", "description": "URDF document"}},
}
_NUMBER = {"type": "number"}
TRACKING_SCHEMA = {
    "title": "imotion.TrackingError",
    "type": "object",
    "properties": {
        "arms": {
            "type": "object",
            "description": "per arm: position [mm] and orientation [deg] of the commanded "
            "control point from the measured one",
            "additionalProperties": {
                "type": "object",
                "properties": {"position_mm": _NUMBER, "orientation_deg": _NUMBER},
            },
        },
        "joint_max": {
            "type": "number",
            "description": "largest |commanded - measured| over the joints "
            "[deg for revolute, mm for prismatic]",
        },
        "joint_max_name": {"type": "string"},
    },
}
LOOP_SCHEMA = {
    "title": "imotion.Loop",
    "type": "object",
    "properties": {
        "cycle": {"type": "integer"},
        "overruns": {"type": "integer"},
        "wake_us": {"type": "array", "items": _NUMBER, "description": "p50, p99, max [us]"},
        "compute_us": {"type": "array", "items": _NUMBER, "description": "p50, p99, max [us]"},
    },
}
STATE_SCHEMA = {
    "title": "imotion.State",
    "type": "object",
    "properties": {
        "state": {"type": "string"},
        "hardware": {"type": "string"},
        "moving": {"type": "boolean"},
        "servo_on": {"type": "boolean"},
        "queue": {"type": "integer"},
        "motions_started": {"type": "integer"},
        "motions_finished": {"type": "integer"},
        "alarms": {"type": "integer"},
    },
}
CYCLE_SCHEMA = {
    "title": "imotion.BlackBoxCycle",
    "type": "object",
    "properties": {
        "cycle": {"type": "integer", "description": "row number since the daemon started"},
        "state": {"type": "string"},
        "motion": {"type": "integer", "description": "motions started so far"},
        "alarms": {"type": "integer"},
        "qp_iterations": {"type": "integer"},
        "wake_us": _NUMBER,
        "compute_us": _NUMBER,
    },
}

RED = Color(r=0.9, g=0.2, b=0.2, a=1.0)
GREEN = Color(r=0.2, g=0.8, b=0.2, a=1.0)
BLUE = Color(r=0.2, g=0.4, b=0.95, a=1.0)
YELLOW = Color(r=1.0, g=0.85, b=0.1, a=1.0)
TARGET = Color(r=0.1, g=0.9, b=0.9, a=0.45)


def stamp(t: float) -> Timestamp:
    """Foxglove timestamp of a wall-clock time [s]."""
    return Timestamp.from_epoch_secs(t)


def channels(ctx: foxglove.Context, blackbox: bool = False) -> dict[str, Any]:
    """Every channel of the table above, bound to ``ctx`` (a server or an MCAP file)."""
    from foxglove.channels import (
        FrameTransformsChannel,
        JointStatesChannel,
        LogChannel,
        SceneUpdateChannel,
    )

    out: dict[str, Any] = {
        "/robot_description": foxglove.Channel(
            "/robot_description", schema=DESCRIPTION_SCHEMA, context=ctx
        ),
        "/tf": FrameTransformsChannel("/tf", context=ctx),
        "/joint_states/measured": JointStatesChannel("/joint_states/measured", context=ctx),
        "/joint_states/commanded": JointStatesChannel("/joint_states/commanded", context=ctx),
        "/alarms": LogChannel("/alarms", context=ctx),
    }
    if blackbox:
        out["/blackbox/cycle"] = foxglove.Channel(
            "/blackbox/cycle", schema=CYCLE_SCHEMA, context=ctx
        )
    else:
        out["/control_points"] = SceneUpdateChannel("/control_points", context=ctx)
        out["/tracking_error"] = foxglove.Channel(
            "/tracking_error", schema=TRACKING_SCHEMA, context=ctx
        )
        out["/loop"] = foxglove.Channel("/loop", schema=LOOP_SCHEMA, context=ctx)
        out["/state"] = foxglove.Channel("/state", schema=STATE_SCHEMA, context=ctx)
    return out


def joint_states(names: list[str], values: np.ndarray, t: float) -> JointStates:
    return JointStates(
        timestamp=stamp(t),
        joints=[JointState(name=n, position=float(v)) for n, v in zip(names, values, strict=True)],
    )


def frame_transforms(
    joints: list[UrdfJoint], values: dict[str, float], t: float
) -> FrameTransforms:
    """One transform per URDF joint (parent link → child link) at ``values`` [rad, m]."""
    ts = stamp(t)
    out = []
    for j in joints:
        r, p = joint_transform(j, values.get(j.name, 0.0))
        qx, qy, qz, qw = quaternion(r)
        out.append(
            FrameTransform(
                timestamp=ts,
                parent_frame_id=j.parent,
                child_frame_id=j.child,
                translation=Vector3(x=float(p[0]), y=float(p[1]), z=float(p[2])),
                rotation=Quaternion(x=qx, y=qy, z=qz, w=qw),
            )
        )
    return FrameTransforms(transforms=out)


def pose(homogeneous: np.ndarray) -> Pose:
    """A Foxglove pose of a 4x4 (or 3x4) homogeneous transform [m]."""
    p = homogeneous[:3, 3]
    qx, qy, qz, qw = quaternion(homogeneous[:3, :3])
    return Pose(
        position=Vector3(x=float(p[0]), y=float(p[1]), z=float(p[2])),
        orientation=Quaternion(x=qx, y=qy, z=qz, w=qw),
    )


def log(level: LogLevel, message: str, name: str, t: float) -> Log:
    return Log(timestamp=stamp(t), level=level, message=message, name=name)


def alarm_text(alarm: dict[str, Any]) -> str:
    return f"alarm 0x{int(alarm['code']):04X} ({alarm['module']}): {alarm['description']}"


def robot_metadata(robot: Robot, hw_joints: list[str], rate_hz: float) -> dict[str, str]:
    """MCAP metadata ``imotion``: robot, loop rate, joint kinds and limits [rad, m]."""
    limits = {}
    for name in hw_joints:
        spec = robot.joints.get(name)
        if spec is None:
            continue
        limits[name] = {
            "kind": spec.kind,
            "lower": spec.lower if math.isfinite(spec.lower) else None,
            "upper": spec.upper if math.isfinite(spec.upper) else None,
        }
    return {
        "robot": robot.id,
        "rate_hz": f"{rate_hz:g}",
        "joints": json.dumps(hw_joints),
        "limits": json.dumps(limits),
    }

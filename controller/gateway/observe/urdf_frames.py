"""The transforms of a URDF's joints at a configuration, as a viewer needs them.

A 3D viewer loads the URDF and places each link from one transform per joint, parent link
to child link: the joint's fixed origin times its motion (rotation about the axis for
revolute and continuous joints, translation along it for prismatic ones). This module reads
those origins and axes from the URDF text once and evaluates them for joint values [rad, m].
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class UrdfJoint:
    name: str
    kind: str  #: revolute, continuous, prismatic, fixed, ...
    parent: str  #: parent link
    child: str  #: child link
    rotation: np.ndarray  #: origin rotation (3x3)
    translation: np.ndarray  #: origin translation [m]
    axis: np.ndarray  #: unit axis in the child frame


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF rpy [rad]: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = (
        np.cos(roll),
        np.sin(roll),
        np.cos(pitch),
        np.sin(pitch),
        np.cos(yaw),
        np.sin(yaw),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix of ``angle`` [rad] about the unit ``axis`` (Rodrigues)."""
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def quaternion(r: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation matrix."""
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0.0:
        s = 2.0 * np.sqrt(trace + 1.0)
        w, x = 0.25 * s, (r[2, 1] - r[1, 2]) / s
        y, z = (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = 2.0 * np.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        w, x = (r[2, 1] - r[1, 2]) / s, 0.25 * s
        y, z = (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s
    elif r[1, 1] > r[2, 2]:
        s = 2.0 * np.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        w, x = (r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s
        y, z = 0.25 * s, (r[1, 2] + r[2, 1]) / s
    else:
        s = 2.0 * np.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        w, x = (r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s
        y, z = (r[1, 2] + r[2, 1]) / s, 0.25 * s
    return float(x), float(y), float(z), float(w)


def _floats(text: str | None, default: str) -> np.ndarray:
    return np.array([float(v) for v in (text or default).split()])


def parse_joints(urdf: str) -> list[UrdfJoint]:
    """Every ``<joint>`` of a URDF document, in file order."""
    root = ET.fromstring(urdf)
    out = []
    for j in root.iter("joint"):
        origin = j.find("origin")
        xyz = _floats(origin.get("xyz") if origin is not None else None, "0 0 0")
        rpy = _floats(origin.get("rpy") if origin is not None else None, "0 0 0")
        axis_el = j.find("axis")
        axis = _floats(axis_el.get("xyz") if axis_el is not None else None, "1 0 0")
        norm = float(np.linalg.norm(axis))
        parent, child = j.find("parent"), j.find("child")
        if parent is None or child is None:
            raise ValueError(f"URDF joint {j.get('name')!r} lacks a parent or child link")
        out.append(
            UrdfJoint(
                name=str(j.get("name")),
                kind=str(j.get("type")),
                parent=str(parent.get("link")),
                child=str(child.get("link")),
                rotation=rpy_matrix(*rpy),
                translation=xyz,
                axis=axis / norm if norm > 0 else np.array([1.0, 0.0, 0.0]),
            )
        )
    return out


def root_link(urdf: str) -> str:
    """The link that is no joint's child."""
    root = ET.fromstring(urdf)
    children = {c.get("link") for c in root.iter("child")}
    links = [str(link.get("name")) for link in root.iter("link")]
    return next(name for name in links if name not in children)


def joint_transform(joint: UrdfJoint, value: float) -> tuple[np.ndarray, np.ndarray]:
    """Child link in the parent link at joint ``value`` [rad, m]: (rotation, translation)."""
    if joint.kind in ("revolute", "continuous"):
        return joint.rotation @ axis_angle(joint.axis, value), joint.translation
    if joint.kind == "prismatic":
        return joint.rotation, joint.translation + joint.rotation @ (joint.axis * value)
    return joint.rotation, joint.translation

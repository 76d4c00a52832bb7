"""HgMatrix helpers for callers: 3 x 4 ``[R | p]`` arrays with ``p`` in [mm], angles in [deg].

Roll-pitch-yaw is the fixed-axis x-y-z convention: ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``
(the same as the robot profiles' ``rpy``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def hg_matrix(value: object, name: str = "HgMatrix") -> np.ndarray:
    """``value`` as a 3 x 4 float array.

    Accepts a 3 x 4 nested sequence or array, 12 numbers row-major, or a 4 x 4 homogeneous
    matrix (its last row is dropped). Non-finite values pass through (the daemon answers
    VALUE_ERR); a wrong shape or a non-number raises :class:`ValueError` naming ``name``.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected a 3x4 matrix of numbers, got {value!r}") from exc
    if arr.shape == (12,):
        arr = arr.reshape(3, 4)
    elif arr.shape == (4, 4):
        arr = arr[:3, :]
    if arr.shape != (3, 4):
        raise ValueError(f"{name}: expected a 3x4 matrix (or 12 numbers), got shape {arr.shape}")
    return arr


def _cos_sin(deg: float) -> tuple[float, float]:
    """cos and sin of an angle [deg]; exact at multiples of 90 deg."""
    if float(deg) % 90.0 == 0.0:
        return [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][int(float(deg) // 90.0) % 4]
    rad = math.radians(deg)
    return math.cos(rad), math.sin(rad)


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation matrix of roll-pitch-yaw angles [deg]."""
    cr, sr = _cos_sin(roll)
    cp, sp = _cos_sin(pitch)
    cy, sy = _cos_sin(yaw)
    return 0.0 + np.array(  # 0.0 + turns -0.0 into 0.0
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def pose(
    xyz: Sequence[float] = (0.0, 0.0, 0.0), rpy: Sequence[float] = (0.0, 0.0, 0.0)
) -> np.ndarray:
    """An HgMatrix from a position [mm] and roll-pitch-yaw angles [deg]."""
    if len(xyz) != 3 or len(rpy) != 3:
        raise ValueError(f"pose: xyz and rpy need 3 numbers each, got {len(xyz)} and {len(rpy)}")
    out = np.empty((3, 4))
    out[:, :3] = rpy_matrix(*rpy)
    out[:, 3] = np.asarray(xyz, dtype=float)
    return out


def rpy_of(hg: object) -> tuple[float, float, float]:
    """Roll-pitch-yaw angles [deg] of an HgMatrix's rotation block."""
    rot = hg_matrix(hg)[:, :3]
    pitch = math.atan2(-rot[2, 0], math.hypot(rot[0, 0], rot[1, 0]))
    if math.cos(pitch) > 1e-9:
        roll = math.atan2(rot[2, 1], rot[2, 2])
        yaw = math.atan2(rot[1, 0], rot[0, 0])
    else:  # gimbal lock: only roll - yaw (or roll + yaw) is defined; put it all in roll
        roll = math.atan2(-rot[1, 2], rot[1, 1])
        yaw = 0.0
    return (math.degrees(roll), math.degrees(pitch), math.degrees(yaw))


def xyz_of(hg: object) -> tuple[float, float, float]:
    """Position [mm] of an HgMatrix."""
    p = hg_matrix(hg)[:, 3]
    return (float(p[0]), float(p[1]), float(p[2]))


def rotation_angle(a: object, b: object) -> float:
    """Angle [deg] of the rotation between two HgMatrix rotation blocks."""
    rel = hg_matrix(a)[:, :3].T @ hg_matrix(b)[:, :3]
    cos = (float(np.trace(rel)) - 1.0) / 2.0
    return math.degrees(math.acos(min(1.0, max(-1.0, cos))))

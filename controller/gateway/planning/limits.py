"""Argument limits that need the robot, the same on every interface: the vehicle workspace,
the tool offset, arcs, the longest motion. Comments in the interfaces' units (mm, deg, s).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from controller.bounds import MAX_TOOL_OFFSET_MM, require_duration, show
from controller.errors import ArgumentError
from controller.gateway.planning.reach import speed_limit
from controller.model.kinematics import Kinematics
from controller.model.robot import Robot
from controller.vocabulary import RightLeft

#: Vehicle axes: name, factor SI -> interface unit, unit.
_VEHICLE_AXES = (("x", 1e3, "mm"), ("y", 1e3, "mm"), ("theta", math.degrees(1.0), "deg"))
#: Smallest distance [mm] between the three points of an arc, and from their line.
ARC_MIN_MM = 1e-3


def require_tool_offset(offset: pin.SE3, name: str) -> pin.SE3:
    """A control-point offset from the flange [m] no farther than
    :data:`~controller.bounds.MAX_TOOL_OFFSET_MM`."""
    distance = 1e3 * float(np.linalg.norm(offset.translation))
    if distance > MAX_TOOL_OFFSET_MM:
        raise ArgumentError(
            f"{name}: {show(distance)} mm from the flange is not a plausible tool "
            f"(limit {MAX_TOOL_OFFSET_MM:g} mm)"
        )
    return offset


def vehicle_workspace(robot: Robot) -> tuple[np.ndarray, np.ndarray] | None:
    """The vehicle workspace (x [m], y [m], theta [rad] corners, original frame), or None."""
    vehicle = robot.profile.vehicle
    return None if vehicle is None else vehicle.workspace.si()


def require_in_workspace(robot: Robot, index: int, value: float, name: str) -> None:
    """VALUE_ERR unless vehicle axis ``index`` (0 x, 1 y, 2 theta) at ``value`` [m or rad,
    original frame] lies inside the profile's vehicle workspace."""
    require_range_in_workspace(robot, index, value, value, name)


def require_range_in_workspace(robot: Robot, index: int, lo: float, hi: float, name: str) -> None:
    """VALUE_ERR unless ``lo..hi`` of vehicle axis ``index`` [m or rad] lies in the workspace."""
    workspace = vehicle_workspace(robot)
    if workspace is None:
        return
    w_lo, w_hi = workspace[0][index], workspace[1][index]
    if lo >= w_lo - 1e-9 and hi <= w_hi + 1e-9:
        return
    axis, scale, unit = _VEHICLE_AXES[index]
    shown = show(lo * scale) if lo == hi else f"{show(lo * scale)}..{show(hi * scale)}"
    raise ArgumentError(
        f"{name}: vehicle {axis} {shown} {unit} is outside the vehicle workspace "
        f"{w_lo * scale:g}..{w_hi * scale:g} {unit} (original frame; profile vehicle.workspace)"
    )


def require_pose_duration(
    start: pin.SE3, goal: pin.SE3, speed: tuple[float, float], accel: tuple[float, float]
) -> None:
    """VALUE_ERR for a straight-line move from ``start`` to ``goal`` [m] at ``speed`` [m/s,
    rad/s] and ``accel`` [m/s², rad/s²] longer than the longest motion (comment in mm, deg)."""
    distance = 1e3 * float(np.linalg.norm(goal.translation - start.translation))
    turn = math.degrees(float(np.linalg.norm(pin.log3(start.rotation.T @ goal.rotation))))
    require_duration(distance, 1e3 * speed[0], 1e3 * accel[0], "speed.translation", "mm")
    deg = math.degrees(1.0)
    require_duration(turn, deg * speed[1], deg * accel[1], "speed.rotation", "deg")


def require_arc(start: np.ndarray, via: np.ndarray, end: np.ndarray) -> None:
    """VALUE_ERR unless ``start``, ``via`` and ``end`` [m] span a circle: three distinct
    points not on one line."""
    a, b = via - start, end - start
    tol = ARC_MIN_MM / 1e3
    if np.linalg.norm(a) < tol:
        raise ArgumentError("carPointR: the via point is the start point: no arc through it")
    if np.linalg.norm(b) < tol:
        raise ArgumentError("carPointT: the target is the start point: no arc to it")
    if np.linalg.norm(b - a) < tol:
        raise ArgumentError("carPointR: the via point coincides with the target")
    if np.linalg.norm(np.cross(a, b)) / np.linalg.norm(b) < tol:
        raise ArgumentError(
            "carPointR: the start, via and target points lie on one line: no unique arc"
        )


def require_cartesian_speed(kin: Kinematics, side: RightLeft, speed: tuple[float, float]) -> None:
    """VALUE_ERR for a Cartesian speed (translation [mm/s], rotation [deg/s]) above what
    ``side``'s arm can do with every joint at its speed limit (:func:`speed_limit`)."""
    t_max, r_max = speed_limit(kin, side)
    for name, value, top, unit in (
        ("translation", speed[0], 1e3 * t_max, "mm/s"),
        ("rotation", speed[1], math.degrees(r_max), "deg/s"),
    ):
        if value > top:
            raise ArgumentError(
                f"speed.{name}: {show(value)} {unit} is more than the arm can do (at most "
                f"{top:.0f} {unit} with every joint at its speed limit)"
            )

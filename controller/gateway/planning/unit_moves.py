"""moveUnit planning: one unit's joints (an arm, the waist) or the vehicle to a target.

SI in: joints [rad or m] per joint, the vehicle as (x [m], y [m], theta [rad]) in the
original frame; speeds and accelerations per joint, or (translation, rotation) for the
vehicle. Out: a checked :class:`MotionSpec`, or ArgumentError/Refused(VALUE_ERR).
"""

from __future__ import annotations

import math

import numpy as np

from controller.bounds import require_duration
from controller.contract.motion_specs import MotionSpec
from controller.contract.snapshot import Snapshot
from controller.errors import ArgumentError
from controller.gateway.planning.limits import require_in_workspace
from controller.gateway.planning.planner import Planner
from controller.model.robot import JointSpec
from controller.vocabulary import UnitType


def check_within(value: float, limit: float, name: str, spec: JointSpec, rate: str) -> None:
    """ArgumentError when ``value`` (SI) exceeds the hardware ``limit`` (SI) of ``spec``'s
    joint; the comment in the interface's units (mm or deg, per ``rate``: "/s", "/s²")."""
    if value <= limit * (1 + 1e-9):
        return
    if spec.kind == "revolute":
        mine, shown, unit = math.degrees(value), math.degrees(limit), f"deg{rate}"
    else:
        mine, shown, unit = 1e3 * value, 1e3 * limit, f"mm{rate}"
    raise ArgumentError(
        f"{name}: {mine:g} {unit} exceeds the hardware limit of {spec.name} ({shown:g} {unit})"
    )


def check_unit_rates(
    planner: Planner, unit: UnitType, speed: np.ndarray, accel: np.ndarray
) -> None:
    """Speeds and accelerations (SI; the vehicle: translation, rotation) within the hardware
    limits of the unit's joints."""
    robot = planner.view.robot
    names = robot.unit_joints(unit.name)
    if unit == UnitType.VEHICLE:
        specs = [robot.joints[names[0]], robot.joints[names[2]]]
    else:
        specs = [robot.joints[n] for n in names]
    for i, spec in enumerate(specs):
        check_within(float(speed[i]), spec.velocity, f"speed[{i}]", spec, "/s")
        check_within(float(accel[i]), spec.acceleration, f"accel[{i}]", spec, "/s²")


def plan_unit_move(
    planner: Planner,
    snap: Snapshot,
    unit: UnitType,
    target: np.ndarray,
    speed: np.ndarray,
    accel: np.ndarray,
    relative: bool,
) -> MotionSpec:
    """A unit move from the measured state (Spec A never queues): joints to ``target`` (or by
    it, ``relative``), the vehicle to the pose ``target`` in the original frame (or by it).
    The vehicle's target must lie in its workspace; no move may take longer than the longest
    motion (VALUE_ERR)."""
    q0 = planner.base_q(snap, queued=False)
    target = np.asarray(target, dtype=float)
    pos_name = "rel_pos" if relative else "abs_pos"
    if unit == UnitType.VEHICLE:
        with planner.view.at(snap, q0) as kin:
            start = kin.vehicle_pose()
        if relative:
            target = target + start
        for i in range(3):
            require_in_workspace(planner.view.robot, i, float(target[i]), f"{pos_name}[{i}]")
        travel = float(np.hypot(*(target - start)[:2]))
        turn = abs(float(target[2] - start[2]))
        deg = math.degrees(1.0)
        require_duration(1e3 * travel, 1e3 * speed[0], 1e3 * accel[0], "speed[0]", "mm")
        require_duration(deg * turn, deg * speed[1], deg * accel[1], "speed[1]", "deg")
        return planner.vehicle(
            q0, target, (float(speed[0]), float(speed[1])), (float(accel[0]), float(accel[1]))
        )
    names = planner.view.robot.unit_joints(unit.name)
    joints = np.array([planner.view.kin.index(j) for j in names])
    if relative:
        target = target + q0[joints]
    for i, name in enumerate(names):
        spec = planner.view.robot.joints[name]
        scale, shown = (math.degrees(1.0), "deg") if spec.kind == "revolute" else (1e3, "mm")
        delta = float(target[i] - q0[joints[i]])
        v, a = scale * float(speed[i]), scale * float(accel[i])
        require_duration(scale * delta, v, a, f"speed[{i}] ({name})", shown)
    return planner.joint(q0, joints, target, speed, accel, label=f"{unit.name} move", absolute=True)

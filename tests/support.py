"""Test helpers: loaded robots (cached), fresh kinematics, random configurations."""

from __future__ import annotations

import functools

import numpy as np

from config import robot_ids
from controller.model.kinematics import Kinematics
from controller.model.robot import Robot, load_robot

ROBOT_IDS = robot_ids()
#: Range [m] / [rad] drawn for unbounded vehicle axes in random configurations.
VEHICLE_SPAN = 5.0


@functools.cache
def robot(robot_id: str) -> Robot:
    return load_robot(robot_id)


def kinematics(robot_id: str) -> Kinematics:
    """A fresh Kinematics (tests change offsets and frames, so none is shared)."""
    return Kinematics(robot(robot_id))


def random_configuration(kin: Kinematics, rng: np.random.Generator) -> np.ndarray:
    """A configuration uniformly inside the joint limits (vehicle within ±VEHICLE_SPAN)."""
    q = np.empty(kin.nv)
    for name in kin.joint_names:
        spec = kin.robot.joints[name]
        lo = max(spec.lower, -VEHICLE_SPAN)
        hi = min(spec.upper, VEHICLE_SPAN)
        q[kin.index(name)] = rng.uniform(lo, hi)
    return q

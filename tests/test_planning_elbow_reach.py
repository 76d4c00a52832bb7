"""controller.gateway.planning.elbow_reach: the elbow's self-motion under joint limits
(issue 15.3)."""

from __future__ import annotations

import math

import numpy as np

from controller.gateway.planning.elbow_reach import ELBOW_TOL, reach_elbow
from controller.model.kinematics import Kinematics
from controller.vocabulary import RightLeft
from tests.planning_support import robot

RIGHT = RightLeft.RIGHT


def setup(name: str) -> tuple[Kinematics, np.ndarray, np.ndarray, np.ndarray]:
    rob = robot(name)
    kin = Kinematics(rob)
    home = rob.home()
    q = np.array([home.get(n, 0.0) for n in kin.joint_names])
    specs = [rob.joints[n] for n in kin.joint_names]
    return kin, q, np.array([s.lower for s in specs]), np.array([s.upper for s in specs])


def test_a_small_elbow_change_is_reached_with_the_hand_kept():
    kin, q, lo, hi = setup("seednoid")
    kin.update(q)
    hand = kin.pose(RIGHT).copy()
    target = kin.elbow_angle(RIGHT) - math.radians(5)
    reached, at_limit = reach_elbow(kin, RIGHT, q, target, lo, hi)
    assert at_limit == [] and reached == target
    assert abs(math.remainder(kin.elbow_angle(RIGHT) - target, math.tau)) < ELBOW_TOL
    assert np.linalg.norm(kin.pose(RIGHT).translation - hand.translation) < 1e-3


def test_an_elbow_change_past_a_joint_limit_stops_there_and_names_the_joint():
    kin, q, lo, hi = setup("seednoid")
    kin.update(q)
    target = kin.elbow_angle(RIGHT) + math.radians(20)
    reached, at_limit = reach_elbow(kin, RIGHT, q, target, lo, hi)
    assert at_limit, "a joint limit should stop the elbow"
    assert all(name.startswith("r_") for name in at_limit)
    assert abs(math.remainder(reached - target, math.tau)) > ELBOW_TOL

"""controller.control.blocked: a motion the collision rows hold back stops and says so once."""

from __future__ import annotations

import math

import numpy as np

from controller.control.blocked import BLOCKED_ERROR, BLOCKED_TIME, BlockWatch
from controller.control.core import CoreState
from controller.model.alarms import AlarmCode, AlarmType
from controller.model.redundant_axes import elbow_axis
from controller.motion.motions import CPHoldMotion
from controller.vocabulary import RightLeft
from tests.motion_support import DT, make_core

STEP = 0.002


def test_blocked_only_when_a_row_binds_and_the_error_does_not_shrink() -> None:
    watch = BlockWatch()
    cycles = math.ceil(BLOCKED_TIME / STEP)
    big = 2 * BLOCKED_ERROR
    for _ in range(3 * cycles):  # nothing binds: never blocked
        assert not watch.observe(-1, big, STEP)
    for _ in range(3 * cycles):  # binds, but on its path (small error)
        assert not watch.observe(3, 0.5 * BLOCKED_ERROR, STEP)
    for i in range(3 * cycles):  # binds, error shrinking: progress along the constraint
        assert not watch.observe(3, big - 1e-3 * i, STEP)
    blocked = [watch.observe(3, big + 1e-5 * i, STEP) for i in range(cycles + 2)]
    assert blocked[-1] and not blocked[0]
    watch.reset()
    assert not watch.observe(3, big, STEP)


def cp_hold_elbow(robot_id: str, backend: str, degrees: float) -> tuple:
    """SmartPal V: right hand held, its elbow swung ``degrees`` (towards the body when
    positive); the core, the motion, the hand's start pose, the closest distance seen and the
    elbow angle per cycle."""
    core = make_core(robot_id, backend)
    assert core.collision is not None
    side = RightLeft.RIGHT
    start = core.kin.elbow_angle(side)
    pose = core.kin.pose(side)
    motion = CPHoldMotion(
        core.kin,
        DT,
        (side,),
        {elbow_axis(side): start + math.radians(degrees)},
        np.array([math.radians(30)]),
        np.array([math.radians(60)]),
    )
    core.start(motion)
    closest, elbow = math.inf, []
    for _ in range(10_000):
        if core.motion is None:
            break
        core.cycle()
        closest = min(closest, float(core.collision.distances.distances.min()))
        elbow.append(core.kin.elbow_angle(side) - start)
    return core, pose, closest, np.degrees(elbow)


def test_a_cp_hold_pushing_the_elbow_into_the_body_stops_on_its_path_and_says_so_once() -> None:
    """Closed loop on MuJoCo: the elbow swings 130 deg towards the torso; the collision rows
    hold it, the core stops the motion with one MOTION_BLOCKED warning naming the links, the
    hand never leaves its place, the elbow never turns back (no oscillation) and the
    security distance holds."""
    core, pose, closest, elbow = cp_hold_elbow("smartpal5", "mujoco", 130.0)
    assert core.motion is None and core.state == CoreState.READY
    (alarm,) = core.alarms
    assert alarm.code == AlarmCode.MOTION_BLOCKED and alarm.type == AlarmType.WARNING
    assert "lumbar_upper_link" in alarm.description and "r_arm_link" in alarm.description
    security = core.robot.profile.collision_avoidance.security
    assert closest >= security - 1e-3
    assert float(elbow[-1]) < 60.0  # stopped well short of the target
    assert np.all(np.diff(elbow) > -0.01)  # monotone: never swinging back [deg]
    np.testing.assert_allclose(
        core.kin.pose(RightLeft.RIGHT).translation, pose.translation, atol=1e-3
    )
    for _ in range(200):  # held still afterwards, no further alarm
        core.cycle()
    assert len(core.alarms) == 1 and core.state == CoreState.READY


def test_an_elbow_swing_away_from_the_body_is_not_blocked() -> None:
    core, _, _, elbow = cp_hold_elbow("smartpal5", "ideal", -60.0)
    assert core.state == CoreState.READY and not core.alarms
    assert abs(float(elbow[-1]) + 60.0) < 0.1


def test_a_vehicle_driven_at_a_static_obstacle_stops_short_of_it_and_names_it() -> None:
    """Obstacles of the daemon configuration reach the control loop's rows (MotionCore's
    ``obstacles``): the vehicle driven 0.6 m forward towards a wall 0.45 m ahead of the
    body stops short of it with one MOTION_BLOCKED warning naming the wall."""
    from controller.control.core import MotionCore
    from controller.model.obstacles import Obstacle
    from controller.motion.motions import VehicleMotion
    from hal.ideal_backend import IdealBackend
    from tests.support import robot

    wall = Obstacle(name="wall", type="plane", pos=[0.45, 0.0, 0.0], rpy=[0.0, -math.pi / 2, 0.0])
    r = robot("smartpal5")
    core = MotionCore(r, IdealBackend(r, DT), DT, obstacles=[wall])
    core.servo_on()
    core.cycle()
    assert core.collision is not None
    assert any(b == "obstacle:wall" for _, b in core.collision.distances.pair_links)
    start = core.kin.vehicle_pose()
    motion = VehicleMotion(core.kin, DT, start + np.array([0.6, 0.0, 0.0]), (0.2, 0.5), (0.4, 1.0))
    core.start(motion)
    closest = math.inf
    for _ in range(20_000):
        if core.motion is None:
            break
        core.cycle()
        closest = min(closest, float(core.collision.distances.distances.min()))
    assert core.motion is None and core.state == CoreState.READY
    (alarm,) = core.alarms
    assert alarm.code == AlarmCode.MOTION_BLOCKED and "obstacle:wall" in alarm.description
    assert core.kin.vehicle_pose()[0] - start[0] < 0.6 - 0.05  # well short of the target
    assert closest >= r.profile.collision_avoidance.security - 1e-3

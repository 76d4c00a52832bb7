"""Motions in closed loop: paths kept, axes together, holds, masks, limits, stop/pause."""

from __future__ import annotations

import math
import os

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from controller.control.core import CoreState, MotionCore
from controller.model.redundant_axes import RedundantAxis, axis_value, elbow_axis
from controller.motion.motions import (
    CartesianMotion,
    CPHoldMotion,
    JointMotion,
    VehicleMotion,
)
from controller.motion.paths import ArcPath, LinePath
from controller.motion.posture import PosturePath
from controller.motion.reachability import ReachabilityChecker
from controller.vocabulary import RightLeft, UnitType
from tests.motion_support import DT, chord_twist, make_core, run_motion

RIGHT = RightLeft.RIGHT
SPEED = (0.25, math.radians(60))
ACCEL = (0.5, math.radians(120))


def line_deviation(path: LinePath, pose: pin.SE3) -> tuple[float, float]:
    """Distance [m] from the line and angle [rad] from the geodesic at the closest point."""
    rel = pose.translation - path.start.translation
    u = path.dp / path.length
    along = float(rel @ u)
    dist = float(np.linalg.norm(rel - along * u))
    s = min(max(along / path.length, 0.0), 1.0)
    return dist, float(np.linalg.norm(pin.log3(path.at(s).rotation.T @ pose.rotation)))


def hand_target(core: MotionCore, dp, rot) -> tuple[pin.SE3, pin.SE3]:
    start = core.kin.pose(RIGHT)
    end = pin.SE3(start.rotation @ pin.exp3(np.array(rot)), start.translation + np.array(dp))
    return start, end


def checked_line(core: MotionCore, dp, rot, allowed=None, ranges=None) -> CartesianMotion:
    """A line motion of the right hand that the reachability check accepts."""
    start, end = hand_target(core, dp, rot)
    motion = CartesianMotion(
        core.kin, DT, RIGHT, LinePath(start, end), SPEED, ACCEL, allowed or {}, ranges
    )
    reason = ReachabilityChecker(core.kin).check(core.kin, RIGHT, motion.path, motion.setup())
    assert reason is None, reason
    return motion


@pytest.mark.parametrize("robot_id", ["smartpal5", "pa10", "rh", "seednoid"])
def test_straight_line_stays_on_the_line_in_mujoco(robot_id: str):
    """Measured on the simulated plant: <= 0.05 mm from the line, <= 0.01 deg from the
    geodesic, and the target reached."""
    core = make_core(robot_id, "mujoco")
    start, end = hand_target(core, [0.1, -0.05, 0.12], [0, 0.2, 0.3])
    path = LinePath(start, end)
    worst = [0.0, 0.0]

    def check(c: MotionCore) -> None:
        d, a = line_deviation(path, c.kin.pose(RIGHT))
        worst[0], worst[1] = max(worst[0], d), max(worst[1], a)

    run_motion(core, CartesianMotion(core.kin, DT, RIGHT, path, SPEED, ACCEL, {}), check)
    for _ in range(50):
        core.cycle()
    assert worst[0] <= 0.05e-3, f"{worst[0] * 1e3:.4f} mm off the line"
    assert math.degrees(worst[1]) <= 0.01, f"{math.degrees(worst[1]):.5f} deg off"
    err = core.kin.pose(RIGHT).translation - end.translation
    assert np.linalg.norm(err) < 0.05e-3


def test_arc_passes_through_the_via_point():
    core = make_core("smartpal5")
    start = core.kin.pose(RIGHT)
    via = pin.SE3(start.rotation, start.translation + np.array([0.0, 0.06, 0.06]))
    end = pin.SE3(
        start.rotation @ pin.exp3(np.array([0, 0, 0.3])),
        start.translation + np.array([0.0, 0.12, 0.0]),
    )
    path = ArcPath(start, via, end)
    motion = CartesianMotion(core.kin, DT, RIGHT, path, SPEED, ACCEL, {elbow_axis(RIGHT): True})
    assert ReachabilityChecker(core.kin).check(core.kin, RIGHT, path, motion.setup()) is None
    radial, closest = [], []

    def check(c: MotionCore) -> None:
        p = c.kin.pose(RIGHT).translation
        radial.append(abs(np.linalg.norm(p - path.centre) - path.radius))
        closest.append(np.linalg.norm(p - via.translation))

    run_motion(core, motion, check)
    assert max(radial) < 0.05e-3
    assert min(closest) < 0.5e-3  # passes the via point (within one cycle's travel)
    assert np.linalg.norm(core.kin.pose(RIGHT).translation - end.translation) < 0.05e-3


@pytest.mark.parametrize("robot_id", ["smartpal5", "pa10", "rh", "seednoid"])
def test_ptp_axes_start_and_arrive_together(robot_id: str):
    core = make_core(robot_id)
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    box = core.ik.box
    start = core.q_cmd[joints].copy()
    lo, hi = box.q_min[joints], box.q_max[joints]
    # A different move for every joint, well inside its range, to a pose free of
    # self-collision (the collision rows would stop it short: RH's first choice folds the
    # flange into link4).
    for signs in (np.resize([1.0, -1.0], len(joints)), np.resize([-1.0, 1.0], len(joints))):
        target = np.clip(
            start + signs * 0.25 * (hi - lo), lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo)
        )
        q = core.kin.q.copy()
        q[joints] = target
        assert core.collision is not None
        core.collision.distances.compute(q)
        if core.collision.distances.distances.min() > core.collision.security + 1e-3:
            break
    else:
        pytest.fail("no collision-free target")
    delta = target - start
    moving = np.abs(delta) > 1e-3
    motion = JointMotion(core.kin, DT, joints, target, box.v_max[joints], box.a_max[joints])
    spread = []

    def check(c: MotionCore) -> None:
        progress = (c.q_cmd[joints][moving] - start[moving]) / delta[moving]
        spread.append(float(progress.max() - progress.min()))

    cycles = run_motion(core, motion, check)
    assert moving.sum() >= len(joints) - 1
    assert max(spread) < 0.01, "joints out of step"
    assert np.allclose(core.q_cmd[joints], target, atol=1e-6)
    assert cycles * DT > 0.2


@pytest.mark.parametrize("joint", [0, 2, 4])
def test_ptp_at_full_speed_never_passes_a_target_near_its_limit(joint: int):
    """Issue 15.4: a target inside the braking distance of a limit (the IK brakes at half
    the acceleration there) made the joint lag, then overshoot by up to 1.6 deg."""
    core = make_core("seednoid")
    box = core.ik.box
    j = core.kin.unit_indices(UnitType.RIGHT_ARM)[joint : joint + 1]
    far, near = box.q_min[j] + 0.3, box.q_max[j] - 0.05
    run_motion(core, JointMotion(core.kin, DT, j, far, box.v_max[j], box.a_max[j]))
    peak = []
    motion = JointMotion(core.kin, DT, j, near, box.v_max[j], box.a_max[j])
    run_motion(core, motion, lambda c: peak.append(float(c.q[j][0])))
    assert max(peak) <= near[0] + 1e-6
    assert motion.profile_limits[1] < float(box.a_max[j][0] / (near - far)[0])


def test_ptp_with_a_duration_takes_that_long():
    core = make_core("pa10")
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    start = core.q_cmd[joints].copy()
    specs = core.ik.box
    motion = JointMotion(
        core.kin, DT, joints, start + 0.2, specs.v_max[joints], specs.a_max[joints], 2.0
    )
    cycles = run_motion(core, motion)
    assert abs(cycles * DT - 2.0) <= 3 * DT


def cp_hold_targets(core: MotionCore) -> dict[RedundantAxis, float]:
    """A feasible move of every redundant axis the robot has, from the home pose."""
    kin = core.kin
    steps = {
        RedundantAxis.RIGHT_ELBOW: math.radians(8),
        RedundantAxis.LUMBAR_RX: math.radians(0.5),
        RedundantAxis.LUMBAR_RY: math.radians(8),
        RedundantAxis.LUMBAR_RZ: math.radians(8),
        RedundantAxis.VEHICLE_X: -0.08,
        RedundantAxis.VEHICLE_Y: 0.04,
        RedundantAxis.VEHICLE_THETA: math.radians(-4),
    }
    return {a: axis_value(kin, a) + d for a, d in steps.items() if a in core.ik.axes}


@pytest.mark.parametrize(
    ("robot_id", "held"),
    [
        ("smartpal5", (RIGHT,)),
        ("smartpal5", (RIGHT, RightLeft.LEFT)),
        ("pa10", (RIGHT,)),
        ("rh", (RIGHT,)),
        ("seednoid", (RIGHT,)),
        ("seednoid", (RIGHT, RightLeft.LEFT)),
    ],
)
def test_cp_hold_keeps_the_hands_while_the_redundant_axes_move(robot_id, held):
    """In MuJoCo: elbow, waist and vehicle (whichever the robot has) move to new targets;
    the held control points stay within 0.05 mm (measured) and every axis arrives."""
    core = make_core(robot_id, "mujoco")
    kin = core.kin
    start = {side: kin.pose(side).copy() for side in held}
    targets = cp_hold_targets(core)
    if len(held) == 2:
        targets.pop(RedundantAxis.RIGHT_ELBOW, None)
    speed = np.array(
        [
            0.1 if a in (RedundantAxis.VEHICLE_X, RedundantAxis.VEHICLE_Y) else math.radians(15)
            for a in targets
        ]
    )
    motion = CPHoldMotion(kin, DT, held, targets, speed, 2 * speed)
    worst, lateral = [], [0.0]
    vx, vy, vt = kin.unit_indices(UnitType.VEHICLE) if kin.has_vehicle else (0, 0, 0)

    def check(c: MotionCore) -> None:
        worst.append(
            max(np.linalg.norm(c.kin.pose(s).translation - start[s].translation) for s in held)
        )
        if c.ik.rows.differential:
            th = c.q[vt]  # the measured heading the solve used
            lateral.append(abs(-math.sin(th) * c.v_cmd[vx] + math.cos(th) * c.v_cmd[vy]))

    run_motion(core, motion, check)
    for _ in range(100):
        core.cycle()
    assert max(worst) <= 0.05e-3, f"hand moved {max(worst) * 1e3:.4f} mm"
    assert max(lateral) < 1e-9  # a differential base never moves sideways
    for axis, goal in targets.items():
        assert abs(axis_value(kin, axis) - goal) < 1e-5, axis


@pytest.mark.parametrize("robot_id", ["smartpal5", "pa10", "rh", "seednoid"])
def test_masked_axes_never_move(robot_id: str):
    """No redundant axis selected: waist, vehicle and other-arm joints are never commanded
    to move, the elbow angle stays (ideal drives)."""
    core = make_core(robot_id)
    kin = core.kin
    fixed = np.concatenate(
        [kin.unit_indices(u) for u in (UnitType.LUMBER, UnitType.VEHICLE, UnitType.LEFT_ARM)]
    )
    before = core.q_cmd[fixed].copy()
    elbow0 = kin.elbow_angle(RIGHT) if kin.has_elbow(RIGHT) else 0.0
    motion = checked_line(core, [0.03, 0, 0.03], [0, 0, 0.1])  # reachable on all four
    elbow = [0.0]

    def check(c: MotionCore) -> None:
        assert np.array_equal(c.q_cmd[fixed], before)
        if kin.has_elbow(RIGHT):
            elbow.append(abs(c.kin.elbow_angle(RIGHT) - elbow0))

    run_motion(core, motion, check)
    assert max(elbow) < 1e-5


def test_redundant_limits_hold():
    """Elbow and trunk allowed within narrow ranges: they stay inside while the hand moves
    where, unconstrained, they would leave them."""
    core = make_core("smartpal5")
    kin = core.kin
    e0 = axis_value(kin, elbow_axis(RIGHT))
    ranges = {
        elbow_axis(RIGHT): (e0 - math.radians(2), e0 + math.radians(2)),
        RedundantAxis.LUMBAR_RY: (-math.radians(1), math.radians(3)),
    }
    allowed = {elbow_axis(RIGHT): True, RedundantAxis.LUMBAR_RY: True}
    start, end = hand_target(core, [0.15, 0.05, -0.15], [0, 0.3, 0])
    seen = {axis: [] for axis in ranges}

    def check(c: MotionCore) -> None:
        for axis in ranges:
            seen[axis].append(axis_value(c.kin, axis))

    motion = CartesianMotion(kin, DT, RIGHT, LinePath(start, end), SPEED, ACCEL, allowed, ranges)
    run_motion(core, motion, check)
    for axis, (lo, hi) in ranges.items():
        assert min(seen[axis]) >= lo - 1e-6 and max(seen[axis]) <= hi + 1e-6, axis


def test_differential_base_never_moves_sideways():
    core = make_core("rh")
    kin = core.kin
    vx, vy, vt = kin.unit_indices(UnitType.VEHICLE)
    lateral = []

    def check(c: MotionCore) -> None:
        th = c.q[vt]  # the measured heading the solve used
        lateral.append(abs(-math.sin(th) * c.v_cmd[vx] + math.cos(th) * c.v_cmd[vy]))

    target = np.array([-0.3, 0.4, math.radians(45)])
    run_motion(
        core,
        VehicleMotion(kin, DT, target, (0.3, math.radians(45)), (0.5, math.radians(90))),
        check,
    )
    assert max(lateral) < 1e-9
    assert np.allclose(kin.vehicle_pose(), target, atol=1e-4)


def _accelerations_ok(core: MotionCore, previous: list[np.ndarray]) -> bool:
    v = core.v_cmd.copy()
    ok = previous == [] or bool(
        np.all(np.abs(v - previous[0]) <= core.ik.box.a_max * DT * (1 + 1e-9) + 1e-12)
    )
    previous[:] = [v]
    return ok


@pytest.mark.parametrize("action", ["stop", "pause"])
def test_stop_and_pause_decelerate_on_the_path_within_the_limits(action: str):
    core = make_core("smartpal5")
    motion = checked_line(core, [0.1, -0.05, 0.12], [0, 0.2, 0.3])
    path = motion.path
    end = path.at(1.0)
    core.start(motion)
    prev: list[np.ndarray] = []
    for _ in range(250):  # well into the cruise
        core.cycle()
        assert _accelerations_ok(core, prev)
    getattr(core, action)()
    dev = []
    for _ in range(600):
        core.cycle()
        assert _accelerations_ok(core, prev)
        dev.append(line_deviation(path, core.kin.pose(RIGHT))[0])
    assert max(dev) < 0.05e-3
    assert np.abs(core.v_cmd).max() < 1e-9
    remaining = np.linalg.norm(core.kin.pose(RIGHT).translation - end.translation)
    assert remaining > 0.01  # stopped before the end
    if action == "stop":
        assert core.state == CoreState.READY and core.motion is None
    else:
        assert core.state == CoreState.PAUSED
        core.resume()
        assert core.state == CoreState.BUSY
        while core.motion is not None:
            core.cycle()
            assert _accelerations_ok(core, prev)
        assert np.linalg.norm(core.kin.pose(RIGHT).translation - end.translation) < 0.05e-3


def test_abort_holds_within_one_cycle():
    core = make_core("smartpal5")
    core.start(checked_line(core, [0.1, -0.05, 0.12], [0, 0.2, 0.3]))
    for _ in range(200):
        core.cycle()
    assert np.abs(core.v_cmd).max() > 0.01
    core.abort()
    core.cycle()
    held = core.q_cmd.copy()
    assert np.abs(core.v_cmd).max() == 0.0
    for _ in range(20):
        core.cycle()
    assert np.array_equal(core.q_cmd, held)
    assert core.state == CoreState.READY


# ------------------------------------------------------------------ property: joint limits
_CORES: dict[str, MotionCore] = {}
#: Random commands per robot: 100 in the suite, after the corners below (each runs up to 250
#: full cycles: 300 took a tenth of the suite's time); IMOTION_PROPERTY_EXAMPLES=1000 (or
#: more) for a thorough run.
PROPERTY_EXAMPLES = int(os.environ.get("IMOTION_PROPERTY_EXAMPLES", "100"))
#: The corners of the input space, always run first: the longest reach and the largest
#: rotation both ways, from the arm pushed towards either end of its range, with every
#: redundant axis free or none, holding the other hand or not.
_ALL = [True] * len(RedundantAxis)
_NONE = [False] * len(RedundantAxis)
_CORNERS = [
    dict(dp=(0.5, 0.5, 0.5), rot=(1.2, 1.2, 1.2), mask=_ALL, hold=True, start_offset=0.6),
    dict(dp=(-0.5, -0.5, -0.5), rot=(-1.2, -1.2, -1.2), mask=_ALL, hold=False, start_offset=-0.6),
    dict(dp=(0.5, -0.5, 0.5), rot=(-1.2, 1.2, -1.2), mask=_NONE, hold=False, start_offset=0.6),
    dict(dp=(-0.5, 0.5, -0.5), rot=(1.2, -1.2, 1.2), mask=_NONE, hold=True, start_offset=-0.6),
]


def _with_corners(test):  # type: ignore[no-untyped-def]
    for corner in reversed(_CORNERS):
        test = example(**corner)(test)
    return test


def _shared_core(robot_id: str) -> MotionCore:
    if robot_id not in _CORES:
        _CORES[robot_id] = make_core(robot_id)
    return _CORES[robot_id]


@pytest.mark.parametrize("robot_id", ["smartpal5", "pa10", "rh", "seednoid"])
@_with_corners
@settings(
    max_examples=PROPERTY_EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
@given(
    dp=st.tuples(*[st.floats(-0.5, 0.5) for _ in range(3)]),
    rot=st.tuples(*[st.floats(-1.2, 1.2) for _ in range(3)]),
    mask=st.lists(st.booleans(), min_size=len(RedundantAxis), max_size=len(RedundantAxis)),
    hold=st.booleans(),
    start_offset=st.floats(-0.6, 0.6),
)
def test_no_target_and_mask_ever_crosses_a_joint_limit(robot_id, dp, rot, mask, hold, start_offset):
    """Per robot, the corners and PROPERTY_EXAMPLES random targets (reachable or not, no
    reachability check), random masks and random arm postures: commanded positions never
    leave the joint limits."""
    core = _shared_core(robot_id)
    kin, hw = core.kin, core.hw
    core.clear_alarms()
    core.servo_off()
    home = kin.home()
    arm = kin.unit_indices(UnitType.RIGHT_ARM)
    lo, hi = core.ik.box.q_min, core.ik.box.q_max
    q = home.copy()
    q[arm] = np.clip(home[arm] + start_offset, lo[arm] + 1e-3, hi[arm] - 1e-3)
    hw.place({name: float(q[kin.index(name)]) for name in kin.joint_names})
    core.servo_on()
    core.cycle()
    start = kin.pose(RIGHT)
    end = pin.SE3(start.rotation @ pin.exp3(np.array(rot)), start.translation + np.array(dp))
    allowed = {axis: m for axis, m in zip(RedundantAxis, mask, strict=True)}
    path = LinePath(start, end)
    core.start(
        CartesianMotion(kin, DT, RIGHT, path, (1.0, 3.0), (4.0, 12.0), allowed, hold_other=hold)
    )
    for _ in range(250):
        core.cycle()
        assert core.state in (CoreState.BUSY, CoreState.READY), core.alarms
        assert np.all(core.q_cmd >= lo - 1e-9) and np.all(core.q_cmd <= hi + 1e-9)
        if core.motion is None:
            break
    core.abort()


def test_cartesian_targets_are_the_path_at_each_cycle_through_pause_and_stop():
    """The targets are exactly the path's and the feed-forward the twist from one cycle's pose
    to the next, cycle by cycle, with variable periods, pause and stop."""
    core = make_core("smartpal5", "ideal")
    start, end = hand_target(core, [0.1, -0.05, 0.12], [0, 0.2, 0.3])
    path = LinePath(start, end)
    motion = CartesianMotion(core.kin, DT, RIGHT, path, SPEED, ACCEL, {})
    for k in range(3000):
        if k == 200:
            motion.pause()
        if k == 400:
            motion.resume()
        if k == 600:
            motion.stop()
        s0 = motion.profile.s
        motion.advance(DT * (1 + (k % 3)))
        s1, dt = motion.profile.s, motion.profile.dt
        now = path.at(s0)
        assert np.array_equal(motion.task.target.homogeneous, now.homogeneous)
        np.testing.assert_allclose(
            motion.task.twist, chord_twist(now, path.at(s1), dt), rtol=0, atol=1e-9
        )
        if motion.finished:
            break
    assert motion.finished


def test_raising_the_hand_follows_the_checked_joint_path_on_the_line():
    """SmartPal V's hand 15 cm up from home, elbow free, at 0.25 m/s on the simulated plant:
    the motion's posture follows the checked joint path, so the loop keeps r_arm_j6 off its
    limit as the check did: on the line within 0.05 mm, ending on the checked configuration,
    no warning. Was (posture drawn to the start): 7 mm off the line with r_arm_j6 braked on
    its limit (issue 16.2), and with the check's minimum-norm path not a reference either."""
    core = make_core("smartpal5", "mujoco")
    start, end = hand_target(core, [0.0, 0.0, 0.15], [0.0, 0.0, 0.0])
    path = LinePath(start, end)
    elbow = {RedundantAxis.RIGHT_ELBOW: True}
    probe = CartesianMotion(core.kin, DT, RIGHT, path, SPEED, ACCEL, elbow)
    checker = ReachabilityChecker(core.kin)
    assert checker.check(core.kin, RIGHT, path, probe.setup()) is None
    cap, _ = checker.braking_speed_limit(RIGHT, *probe.profile_limits)
    v, a = checker.path_parameter_limits()
    posture = PosturePath(np.array(checker.path_s), np.array(checker.path_q))
    motion = CartesianMotion(
        core.kin,
        DT,
        RIGHT,
        path,
        SPEED,
        ACCEL,
        elbow,
        path_limits=(min(v, cap), a),
        posture=posture,
    )
    worst = [0.0]

    def watch(c: MotionCore) -> None:
        worst[0] = max(worst[0], line_deviation(path, c.kin.pose(RIGHT))[0])

    run_motion(core, motion, watch)
    assert core.alarms == []
    assert worst[0] <= 0.05e-3, f"{worst[0] * 1e3:.4f} mm off the line"
    np.testing.assert_allclose(core.kin.q, checker.last_q, atol=math.radians(0.5))


def test_a_prepared_motion_takes_the_posture_of_its_start_and_of_each_resume():
    core = make_core("smartpal5")
    kin, box = core.kin, core.ik.box
    right, left = (kin.unit_indices(UnitType[f"{s}_ARM"]) for s in ("RIGHT", "LEFT"))

    def ptp(joints: np.ndarray, delta: float) -> JointMotion:
        target = kin.q[joints] + delta
        return JointMotion(kin, DT, joints, target, box.v_max[joints], box.a_max[joints])

    motion = ptp(right, 0.1)
    motion.prepare()  # planned here, started after the left arm has moved
    setup = motion.setup()
    assert motion.setup() is setup and not setup.frozen.flags.writeable
    posture = setup.tasks[-1]
    run_motion(core, ptp(left, 0.1))
    core.start(motion)
    assert np.array_equal(posture.reference, core.kin.q) and not posture.rate.any()
    for _ in range(100):
        core.cycle()
    core.pause()
    while core.state != CoreState.PAUSED:
        core.cycle()
    core.cycle()  # held: the measured state moves on by the last commands
    posture.rate[:] = 1.0
    core.resume()
    assert core.ik.tasks[-1] is posture and np.array_equal(posture.reference, core.kin.q)
    assert not posture.rate.any()
    while core.motion is not None:
        core.cycle()
    assert core.state == CoreState.READY and not core.alarms

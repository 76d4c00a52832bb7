"""ReachabilityChecker: a Cartesian path followed by a position-level IK before it is run."""

from __future__ import annotations

import itertools
import math
import re

import numpy as np
import pinocchio as pin
import pytest

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis
from controller.motion.motions import CartesianMotion
from controller.motion.paths import ArcPath, LinePath
from controller.motion.position_ik import POSITION_TOL
from controller.motion.reachability import MAX_SAMPLES, SAMPLE_STEP, ReachabilityChecker
from controller.vocabulary import RightLeft, UnitType
from tests.support import count_solves, kinematics

RIGHT, LEFT = RightLeft.RIGHT, RightLeft.LEFT
DT = 0.002
SPEED = (0.25, math.radians(60))
ACCEL = (0.5, math.radians(120))
ELBOW = {RedundantAxis.RIGHT_ELBOW: True}
WAIST = {RedundantAxis.LUMBAR_RY: True}
#: SmartPal V waist (lumbarRy = lumbar_lower + lumbar_upper): its full range [rad].
WAIST_FULL_RANGE = (math.radians(-12.0), math.radians(121.0))


def at_home(robot_id: str) -> Kinematics:
    kin = kinematics(robot_id)
    kin.update(kin.home())
    return kin


def line_from_hand(kin: Kinematics, dp, rot=(0.0, 0.0, 0.0), side=RIGHT) -> LinePath:
    """Line from the control point, ``dp`` [m] in the original frame, ``rot`` [rad] about the
    control point's own axes."""
    start = kin.pose(side)
    end = pin.SE3(
        start.rotation @ pin.exp3(np.asarray(rot, dtype=float)),
        start.translation + np.asarray(dp, dtype=float),
    )
    return LinePath(start, end)


def check(
    kin: Kinematics,
    path: LinePath | ArcPath,
    allowed: dict[RedundantAxis, bool] | None = None,
    ranges: dict[RedundantAxis, tuple[float, float] | None] | None = None,
    hold_other: bool = False,
    checker: ReachabilityChecker | None = None,
) -> str | None:
    """The checker's verdict on moving the right hand along ``path`` as a CartesianMotion
    with these settings would (a fresh checker unless one is given)."""
    motion = CartesianMotion(
        kin, DT, RIGHT, path, SPEED, ACCEL, allowed or {}, ranges, hold_other=hold_other
    )
    checker = checker or ReachabilityChecker(kin)
    return checker.check(kin, RIGHT, path, motion.setup(), hold=LEFT if hold_other else None)


def assert_refused(reason: str | None) -> None:
    assert isinstance(reason, str) and reason, "expected a refusal with a reason"
    assert reason.startswith(("the path at ", "the target ")), reason


# ------------------------------------------------------------------------------ verdicts
def test_short_line_in_front_of_the_hand_is_reachable():
    kin = at_home("smartpal5")
    assert check(kin, line_from_hand(kin, [0.1, 0.0, 0.0])) is None


def test_short_arc_is_reachable():
    kin = at_home("smartpal5")
    start = kin.pose(RIGHT)
    via = pin.SE3(start.rotation, start.translation + np.array([0.0, 0.06, 0.06]))
    end = pin.SE3(
        start.rotation @ pin.exp3(np.array([0.0, 0.0, 0.3])),
        start.translation + np.array([0.0, 0.12, 0.0]),
    )
    assert check(kin, ArcPath(start, via, end), ELBOW) is None


def test_target_far_out_of_reach_is_refused_with_the_distance_left():
    kin = at_home("smartpal5")
    reason = check(kin, line_from_hand(kin, [1.5, 0.0, 0.0]), {**ELBOW, **WAIST})
    assert_refused(reason)
    assert "not reachable" in reason
    assert "mm" in reason


def test_target_far_out_of_reach_is_refused_with_no_redundant_axis_either():
    kin = at_home("smartpal5")
    assert_refused(check(kin, line_from_hand(kin, [1.5, 0.0, 0.0])))


#: IK solves a refusal may take (SmartPal V, 1.5 m forward with elbow and waist free: 1413
#: before past-the-jump samples were no longer split, about 270 after).
REFUSAL_SOLVES = 500


def test_a_line_leaving_the_reach_is_refused_where_it_does_in_few_solves(monkeypatch):
    """The line leaves the reach half-way, where the stretched arm's IK swings r_arm_j4 by
    13 deg at every sample: the pass is refused from its first jump on, so the samples
    past it are not split (up to 63 solves each). The refusal says where, as a share of the
    path and in mm."""
    kin = at_home("smartpal5")
    solves = count_solves(monkeypatch)
    reason = check(kin, line_from_hand(kin, [1.5, 0.0, 0.0]), {**ELBOW, **WAIST})
    assert_refused(reason)
    assert solves[0] <= REFUSAL_SOLVES
    assert re.match(r"the path at (\d+) % \((\d+) of 1500 mm\) is not reachable: ", reason), reason
    share, along = (int(x) for x in re.findall(r"\d+", reason)[:2])
    assert 30 <= share <= 70 and abs(along - 15 * share) <= 15
    # The reachable part of that line still is.
    assert check(kin, line_from_hand(kin, [0.3, 0.0, 0.0]), {**ELBOW, **WAIST}) is None


def test_a_turn_in_place_is_refused_with_the_angle_along_it():
    kin = at_home("smartpal5")
    kin.set_control_point_offset(RIGHT, pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.5])))
    kin.update(kin.q)
    reason = check(kin, line_from_hand(kin, [0, 0, 0], [math.radians(-40.0), 0.0, 0.0]), ELBOW)
    assert_refused(reason)
    assert re.match(r"the (target|path at \d+ % \(\d+ of 40 deg\)) ", reason), reason


@pytest.mark.parametrize("allowed", [{}, {**ELBOW, **WAIST}], ids=["held", "elbow+waist"])
def test_target_behind_the_robot_through_the_torso_is_refused(allowed):
    kin = at_home("smartpal5")
    start = kin.pose(RIGHT)
    behind = np.array([-0.4, start.translation[1], start.translation[2]])
    reason = check(kin, LinePath(start, pin.SE3(start.rotation, behind)), allowed)
    assert_refused(reason)
    assert "not reachable" in reason


def test_raising_the_hand_needs_the_elbow():
    """15 cm straight up: with the elbow held the wrist runs into its limit on the way; with
    the elbow free the check keeps r_arm_j6 off its limit through the elbow (it rode its
    limit half-way with minimum-norm steps, which the loop could not follow on the line:
    issue 16.2, 7 mm off the line at 0.25 m/s; the loop now follows the checked path,
    tests/test_motions.py)."""
    kin = at_home("smartpal5")
    path = line_from_hand(kin, [0.0, 0.0, 0.15])
    held = check(kin, path, {})
    assert_refused(held)
    assert "not reachable" in held
    checker = ReachabilityChecker(kin)
    assert check(kin, path, ELBOW, checker=checker) is None
    j6 = kin.index("r_arm_j6")
    closest = min(q[j6] for q in checker.path_q) - checker.q_min[j6]
    assert closest > math.radians(3.0)


def test_waist_range_that_excludes_the_needed_bend_refuses_a_far_low_target():
    """30 cm forward and down needs about 56 deg of trunk bend."""
    kin = at_home("smartpal5")
    path = line_from_hand(kin, [0.3, 0.0, -0.3])
    narrow = {RedundantAxis.LUMBAR_RY: (math.radians(-1.0), math.radians(10.0))}
    assert_refused(check(kin, path, WAIST, narrow))
    assert check(kin, path, WAIST, {RedundantAxis.LUMBAR_RY: WAIST_FULL_RANGE}) is None
    assert check(kin, path, WAIST) is None  # no range: unlimited
    assert_refused(check(kin, path, {}))  # waist not allowed: frozen


def test_the_plan_keeps_the_waist_inside_its_range():
    kin = at_home("smartpal5")
    checker = ReachabilityChecker(kin)
    lo, hi = math.radians(-1.0), math.radians(45.0)
    path = line_from_hand(kin, [0.2, 0.0, -0.2])
    assert check(kin, path, WAIST, {RedundantAxis.LUMBAR_RY: (lo, hi)}, checker=checker) is None
    bend = checker.kin.lumbar_angle(RedundantAxis.LUMBAR_RY.lumbar)
    assert lo - 1e-6 <= bend <= hi + 1e-6
    assert bend > math.radians(5.0)  # the waist did take part


@pytest.mark.parametrize("robot_id", ["pa10", "rh"])
@pytest.mark.parametrize(
    ("dp", "rot"),
    [([0.05, 0.0, 0.0], [0.0, 0.0, 0.0]), ([0.03, -0.03, 0.03], [0.2, 0.0, 0.2])],
    ids=["shift", "shift+turn"],
)
def test_small_moves_on_single_arm_robots_are_reachable(robot_id, dp, rot):
    kin = at_home(robot_id)
    assert check(kin, line_from_hand(kin, dp, rot)) is None


@pytest.mark.parametrize("allowed", [{}, WAIST], ids=["waist frozen", "waist allowed"])
def test_holding_the_other_arm_still_allows_a_small_move(allowed):
    kin = at_home("smartpal5")
    checker = ReachabilityChecker(kin)
    left = kin.pose(LEFT)
    path = line_from_hand(kin, [0.05, 0.0, -0.05])
    assert check(kin, path, allowed, hold_other=True, checker=checker) is None
    # The planned configuration keeps the held hand where it was.
    planned = checker.kin.pose(LEFT)
    assert np.linalg.norm(planned.translation - left.translation) < POSITION_TOL


# ---------------------------------------------------------------------- live kinematics
@pytest.mark.parametrize("dp", [[0.1, 0.0, 0.0], [1.5, 0.0, 0.0]], ids=["reachable", "refused"])
def test_the_check_leaves_the_live_kinematics_alone(dp):
    kin = at_home("smartpal5")
    q = kin.q.copy()
    poses = {side: kin.pose(side).copy() for side in kin.arms}
    offsets = {side: kin.control_point_offset(side).copy() for side in kin.arms}
    original = kin.original_frame.copy()
    check(kin, line_from_hand(kin, dp), ELBOW)
    assert np.array_equal(kin.q, q)
    for side in kin.arms:
        assert kin.pose(side).isApprox(poses[side], 0.0)
        assert kin.control_point_offset(side).isApprox(offsets[side], 0.0)
    assert kin.original_frame.isApprox(original, 0.0)


def test_the_checker_takes_the_live_control_point_offset():
    """A checker built before the tool changed still plans for the live control point."""
    kin = at_home("smartpal5")
    checker = ReachabilityChecker(kin)
    kin.set_control_point_offset(RIGHT, pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.5])))
    kin.update(kin.q)
    assert check(kin, line_from_hand(kin, [0.05, 0.0, 0.0]), checker=checker) is None
    checker.kin.update(kin.q)
    assert checker.kin.pose(RIGHT).isApprox(kin.pose(RIGHT), 1e-12)


def test_a_long_tool_makes_a_wrist_turn_unreachable():
    """Turning 40 deg about the tool's x axis: in place with the stock tool; with a 0.5 m
    tool the flange must swing around the tool tip, beyond what the arm can do."""
    kin = at_home("smartpal5")
    checker = ReachabilityChecker(kin)
    turn = [math.radians(-40.0), 0.0, 0.0]
    assert check(kin, line_from_hand(kin, [0, 0, 0], turn), ELBOW, checker=checker) is None
    kin.set_control_point_offset(RIGHT, pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.5])))
    kin.update(kin.q)
    assert_refused(check(kin, line_from_hand(kin, [0, 0, 0], turn), ELBOW, checker=checker))


def test_the_checker_takes_the_live_original_frame():
    """After the vehicle moved and the original frame was reset, poses are in the new frame."""
    kin = at_home("smartpal5")
    checker = ReachabilityChecker(kin)
    q = kin.q.copy()
    vx, _, vtheta = kin.unit_indices(UnitType.VEHICLE)
    q[vx], q[vtheta] = 1.0, 0.7
    kin.update(q)
    kin.reset_original_frame()
    assert check(kin, line_from_hand(kin, [0.05, 0.0, 0.0]), checker=checker) is None
    assert checker.kin.original_frame.isApprox(kin.original_frame, 1e-12)


# ------------------------------------------------------------------------------ history
def test_a_refused_check_does_not_change_the_verdict_on_the_next_one():
    """One checker serves many requests: a refusal whose IK ran the QP into its iteration
    limit must not leave a warm start that refuses the next, reachable, path."""
    kin = at_home("smartpal5")
    small = line_from_hand(kin, [0.05, 0.0, 0.0])
    assert check(kin, small) is None  # fresh checker
    checker = ReachabilityChecker(kin)
    awkward = line_from_hand(kin, [0.2, 0.0, -0.1], [-0.4, -0.8, -1.2])
    assert_refused(check(kin, awkward, WAIST, checker=checker))
    assert check(kin, small, checker=checker) is None


# ------------------------------------------------------------------- solve_pose (PTP targets)
def test_solve_pose_puts_the_control_point_on_the_target_within_the_limits():
    from controller.motion.motions import JointMotion
    from tests.motion_support import DT, make_core

    core = make_core("smartpal5")
    kin = core.planning_kinematics()
    start = kin.pose(RightLeft.RIGHT)
    target = pin.SE3(
        start.rotation @ pin.exp3(np.array([0.3, -0.2, 0.4])),
        start.translation + np.array([0.1, 0.1, 0.15]),
    )
    motion = CartesianMotion(
        kin,
        DT,
        RightLeft.RIGHT,
        LinePath(start, target),
        (0.2, 1.0),
        (0.5, 2.0),
        {RedundantAxis.RIGHT_ELBOW: True},
    )
    setup = motion.setup()
    q, reason = ReachabilityChecker(kin).solve_pose(kin, RightLeft.RIGHT, target, setup)
    assert reason is None
    box = core.ik.box
    assert np.all(q >= box.q_min) and np.all(q <= box.q_max)
    assert np.array_equal(q[setup.frozen], kin.q[setup.frozen])
    # A joint-space PTP to that configuration ends with the hand on the target.
    arm = kin.unit_indices(UnitType.RIGHT_ARM)
    core.start(JointMotion(core.kin, DT, arm, q[arm], box.v_max[arm], box.a_max[arm]))
    while core.motion is not None:
        core.cycle()
    reached = core.kin.pose(RightLeft.RIGHT)
    assert np.linalg.norm(reached.translation - target.translation) < 2e-4
    assert np.linalg.norm(pin.log3(reached.rotation.T @ target.rotation)) < math.radians(0.1)


def test_solve_pose_out_of_reach_gives_a_reason():
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    start = kin.pose(RightLeft.RIGHT)
    far = pin.SE3(start.rotation, start.translation + np.array([1.5, 0, 0]))
    motion = CartesianMotion(
        kin, 0.002, RightLeft.RIGHT, LinePath(start, far), (0.2, 1.0), (0.5, 2.0), {}
    )
    _, reason = ReachabilityChecker(kin).solve_pose(kin, RightLeft.RIGHT, far, motion.setup())
    assert reason is not None and "not reachable" in reason


def test_path_parameter_limits_keep_every_joint_within_its_limits():
    kin = at_home("smartpal5")
    path = line_from_hand(kin, (0.08, 0.04, -0.06))
    checker = ReachabilityChecker(kin)
    assert check(kin, path, ELBOW, checker=checker) is None
    v_s, a_s = checker.path_parameter_limits(share=1.0)
    assert 0.0 < v_s < math.inf and 0.0 < a_s < math.inf
    q = np.array(checker.path_q)
    slope = np.abs(np.diff(q, axis=0) / np.diff(checker.path_s)[:, None])
    # at the limiting rate no joint exceeds its speed or braking deceleration anywhere
    assert np.all(slope * v_s <= checker.v_max * (1 + 1e-9))
    assert np.all(slope * a_s <= 0.5 * checker.a_max * (1 + 1e-9))
    # and one joint is exactly at a bound (the limits are tight, not arbitrary)
    assert np.isclose(np.max(slope * v_s / checker.v_max), 1.0) or np.isclose(
        np.max(slope * a_s / (0.5 * checker.a_max)), 1.0
    )


def test_path_parameter_limits_of_a_still_path_are_unbounded():
    kin = at_home("pa10")
    checker = ReachabilityChecker(kin)
    assert checker.path_parameter_limits() == (math.inf, math.inf)


def test_a_path_with_too_many_samples_is_refused_without_sampling_it():
    # issue 16.1: a 1e9 m path allocated 1e11 samples (MemoryError after 12-30 s)
    kin = at_home("smartpal5")
    for far in (1e9, 0.02 * MAX_SAMPLES):
        reason = check(kin, line_from_hand(kin, (far, 0.0, 0.0)))
        assert reason is not None and "too long to check" in reason


#: Cartesian speed [m/s] at which the continuity test asks the checked path to be followable.
LINE_SPEED = 0.1
#: 100 mm along each axis from home.
HOME_LINES = [
    (robot_id, axis, sign)
    for robot_id in ("smartpal5", "pa10", "rh")
    for axis in range(3)
    for sign in (1.0, -1.0)
]


@pytest.mark.parametrize(
    ("robot_id", "axis", "sign"),
    HOME_LINES,
    ids=[f"{r}-{'+-'[g < 0]}{'xyz'[a]}" for r, a, g in HOME_LINES],
)
def test_the_checked_joint_path_is_continuous(robot_id: str, axis: int, sign: float):
    """Consecutive samples of the checked path (the configurations the loop's null space
    follows) are no farther apart than each joint can go at its speed limit in the time the
    hand takes between them at 0.1 m/s. Was (SmartPal V, +z): the check's minimum-norm steps
    ran r_arm_j6 into its limit and the arm swung r_arm_j2 by 11 deg within 1 cm."""
    kin = at_home(robot_id)
    dp = np.zeros(3)
    dp[axis] = 0.1 * sign
    path = line_from_hand(kin, dp)
    checker = ReachabilityChecker(kin)
    assert check(kin, path, ELBOW, checker=checker) is None
    q = np.array(checker.path_q)
    s = np.array(checker.path_s)
    dt = np.diff(s) * path.length / LINE_SPEED
    over = np.abs(np.diff(q, axis=0)) / (checker.v_max * dt[:, None])
    k, j = np.unravel_index(int(np.argmax(over)), over.shape)
    assert over[k, j] <= 1.0, (
        f"{kin.joint_names[j]} moves {math.degrees(abs(q[k + 1, j] - q[k, j])):.1f} deg "
        f"between s = {s[k]:.3f} and {s[k + 1]:.3f}"
    )
    # The sample spacing the check promises, and the end on the target.
    assert np.diff(s).max() * path.length <= SAMPLE_STEP + 1e-12
    np.testing.assert_allclose(s[-1], 1.0)


def test_fast_stretches_are_sampled_densely_and_a_jump_stays_a_jump():
    """Between two samples a joint moving more than the jump bound is sampled again in halves:
    a continuous motion ends up in steps under the bound, a jump (a change of IK branch)
    does not shrink and is named with its size."""
    kin = at_home("smartpal5")
    checker = ReachabilityChecker(kin)
    j = kin.index("r_arm_j2")
    q0 = kin.q.copy()

    def at(value: float) -> np.ndarray:
        q = q0.copy()
        q[j] += value
        return q

    def smooth(q: np.ndarray, s: float) -> tuple[np.ndarray, str | None]:
        return at(math.radians(20.0) * s), None

    def flip(q: np.ndarray, s: float) -> tuple[np.ndarray, str | None]:
        return at(math.radians(20.0) if s > 0.3 else 0.0), None

    steps = checker._segment(q0, 0.0, 1.0, smooth)
    qs = [q0] + [q for _, q, _ in steps]
    assert all(checker._jump(a, b) is None for a, b in itertools.pairwise(qs))
    assert len(steps) >= 4  # 20 deg in steps of at most 5 (the bound)
    steps = checker._segment(q0, 0.0, 1.0, flip)
    qs = [q0] + [q for _, q, _ in steps]
    jumps = [checker._jump(a, b) for a, b in itertools.pairwise(qs)]
    assert jumps.count(None) == len(jumps) - 1
    assert ("r_arm_j2", "20.0 deg") in jumps

"""controller.gateway.planning.jara_arm: arm settings, the arm frame and JARA targets."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from controller.errors import ArgumentError
from controller.gateway.planning.jara_arm import (
    ArmSettings,
    CarPos,
    cartesian_target,
    check_box,
    joint_target,
    to_arm_frame,
)
from controller.vocabulary import RightLeft, UnitType
from tests.planning_support import context, robot

RIGHT = RightLeft.RIGHT


def settings() -> ArmSettings:
    return ArmSettings.for_arm(robot("smartpal5"), RIGHT, (250.0, 90.0), 0.2, 0.1)


def test_settings_default_to_the_hardware_and_convert_to_si():
    s = settings()
    assert len(s.joint_names) == 7
    np.testing.assert_allclose(s.max_speed_joint, s.hw_speed)
    v, a = s.joint_speed(100)
    np.testing.assert_allclose(v, np.radians(s.hw_speed))
    np.testing.assert_allclose(a, v / s.accel_time_joint)
    (vt, vr), _ = s.cartesian_speed(100)
    assert (vt, vr) == pytest.approx((0.25, math.radians(90.0)))


def test_a_relative_target_is_a_change_in_the_arm_frame_with_the_elbow_added():
    ctx, _, _ = context("smartpal5")
    s = settings()
    s.base_offset = pin.SE3(pin.utils.rotate("z", math.pi / 2), np.zeros(3))
    snap = ctx.snapshot()
    with ctx.planner.view.at(snap) as kin:
        start = to_arm_frame(kin, RIGHT, s)
        elbow0 = kin.elbow_angle(RIGHT)
        rel = CarPos(pin.SE3(np.eye(3), np.array([0.01, 0.0, 0.0])), math.radians(5))
        goal, elbow = cartesian_target(ctx.planner, kin, RIGHT, s, rel, True, "carPoint")
        arm_goal = s.base_offset.actInv(kin.original_frame * goal)
    # the arm frame is the current (body) frame at start: compare there
    np.testing.assert_allclose(arm_goal.translation[0] - start.translation[0], 0.01, atol=1e-6)
    assert elbow == pytest.approx(elbow0 + math.radians(5))


def test_soft_limits_box_and_joints():
    s = settings()
    s.soft_box = (np.full(3, -100.0), np.full(3, 100.0))
    with pytest.raises(ArgumentError, match="outside the Cartesian soft limit"):
        check_box(s, pin.SE3(np.eye(3), np.array([0.2, 0.0, 0.0])), "carPoint")
    check_box(s, pin.SE3(np.eye(3), np.array([0.05, 0.0, 0.0])), "carPoint")
    ctx, _, _ = context("smartpal5")
    joints = ctx.planner.view.kin.unit_indices(UnitType.RIGHT_ARM)
    q0 = ctx.view.measured_q(ctx.snapshot())
    s.soft_upper[0] = math.degrees(q0[joints[0]]) + 1.0
    with pytest.raises(ArgumentError, match=r"jointPoints\[0\] .* outside the soft limit"):
        joint_target(s, joints, np.r_[math.radians(2), np.zeros(6)], q0, True, "jointPoints")
    got = joint_target(s, joints, np.r_[math.radians(0.5), np.zeros(6)], q0, True, "jointPoints")
    assert got[0] == pytest.approx(q0[joints[0]] + math.radians(0.5))

"""controller.gateway.planning.unit_moves: moveUnit specs from SI arguments, no daemon."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.contract.motion_specs import JointMoveSpec, VehicleMoveSpec
from controller.errors import ArgumentError, Refused
from controller.gateway.planning.unit_moves import check_unit_rates, plan_unit_move
from controller.vocabulary import ReturnCode, UnitType
from tests.planning_support import context


def test_a_relative_arm_move_builds_on_the_measured_joints():
    ctx, _, _ = context("smartpal5")
    snap = ctx.snapshot()
    names = ctx.robot.unit_joints("RIGHT_ARM")
    q0 = np.array([snap.q[list(ctx.robot.joints).index(n)] for n in names])
    rel = np.zeros(len(names))
    rel[0] = math.radians(5)
    v = np.full(len(names), 0.2)
    spec = plan_unit_move(ctx.planner, snap, UnitType.RIGHT_ARM, rel, v, v, relative=True)
    assert isinstance(spec, JointMoveSpec)
    np.testing.assert_allclose(spec.target, q0 + rel)


def test_a_target_outside_the_joint_limits_is_value_err():
    ctx, _, _ = context("smartpal5")
    names = ctx.robot.unit_joints("RIGHT_ARM")
    target = np.full(len(names), 10.0)
    v = np.full(len(names), 0.2)
    with pytest.raises(Refused) as err:
        plan_unit_move(ctx.planner, ctx.snapshot(), UnitType.RIGHT_ARM, target, v, v, False)
    assert err.value.code == ReturnCode.VALUE_ERR and "outside its limits" in err.value.comment


def test_a_vehicle_move_is_a_pose_in_the_original_frame():
    ctx, _, _ = context("smartpal5")
    target = np.array([0.1, -0.05, 0.2])
    spec = plan_unit_move(
        ctx.planner,
        ctx.snapshot(),
        UnitType.VEHICLE,
        target,
        np.array([0.1, 0.2]),
        np.array([0.2, 0.4]),
        relative=True,
    )
    assert isinstance(spec, VehicleMoveSpec)
    np.testing.assert_allclose(spec.target, target)  # from the origin at start


def test_rates_above_the_hardware_limits_name_the_joint_in_interface_units():
    ctx, _, _ = context("smartpal5")
    n = len(ctx.robot.unit_joints("RIGHT_ARM"))
    with pytest.raises(ArgumentError, match=r"speed\[0\]: .* deg/s exceeds the hardware limit"):
        check_unit_rates(ctx.planner, UnitType.RIGHT_ARM, np.full(n, 100.0), np.full(n, 0.1))
    with pytest.raises(ArgumentError, match=r"speed\[0\]: .* mm/s exceeds"):
        check_unit_rates(ctx.planner, UnitType.VEHICLE, np.array([100.0, 0.1]), np.ones(2) * 0.1)

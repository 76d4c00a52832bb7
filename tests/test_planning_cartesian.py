"""controller.gateway.planning.cartesian: Spec A linear and PTP specs, no daemon."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest

from controller.contract.motion_specs import CartesianMoveSpec, JointMoveSpec
from controller.errors import Refused
from controller.gateway.planning.cartesian import plan_linear, plan_ptp
from controller.model.redundant_axes import RedundantAxis
from controller.vocabulary import FrameType, ReturnCode, RightLeft
from tests.planning_support import context
from tests.support import count_solves

RIGHT = RightLeft.RIGHT
ELBOW = {RedundantAxis.RIGHT_ELBOW: True}


def up(dz: float) -> pin.SE3:
    return pin.SE3(np.eye(3), np.array([0.0, 0.0, dz]))


def test_a_relative_linear_move_targets_the_current_pose_plus_the_change():
    ctx, _, _ = context("smartpal5")
    snap = ctx.snapshot()
    start, _ = ctx.view.pose(snap, RIGHT, FrameType.ORIGINAL_FRAME)
    spec = plan_linear(
        ctx.planner, snap, RIGHT, up(0.02), (0.05, 0.3), (0.1, 0.6), False, ELBOW, {}, False, "rel"
    )
    assert isinstance(spec, CartesianMoveSpec)
    np.testing.assert_allclose(
        spec.target[:3, 3], start.translation + np.array([0.0, 0.0, 0.02]), atol=1e-12
    )
    assert spec.planned_from is not None


def test_a_target_out_of_reach_is_cannot_reach():
    ctx, _, _ = context("smartpal5")
    with pytest.raises(Refused) as err:
        plan_linear(
            ctx.planner,
            ctx.snapshot(),
            RIGHT,
            up(3.0),
            (0.05, 0.3),
            (0.1, 0.6),
            False,
            ELBOW,
            {},
            False,
            "rel",
        )
    assert err.value.code == ReturnCode.CANNOT_REACH_TARGET_ERR


def test_a_line_leaving_the_reach_is_cannot_reach_saying_where_in_few_solves(monkeypatch):
    """0.8 m forward with the elbow and the waist: within the chain's reach bound, so the path
    is sampled; it leaves the reach near its end. Took 1571 IK solves (about 10 s on a loaded
    2-core machine) before the samples past the pass's first jump were no longer split."""
    ctx, _, _ = context("smartpal5")
    count = count_solves(monkeypatch)
    allowed = {**ELBOW, RedundantAxis.LUMBAR_RY: True}

    def forward(dx: float) -> CartesianMoveSpec | JointMoveSpec:
        target = pin.SE3(np.eye(3), np.array([dx, 0.0, 0.0]))
        snap = ctx.snapshot()
        args = (snap, RIGHT, target, (0.05, 0.3), (0.1, 0.6), False, allowed, {}, False, "rel")
        return plan_linear(ctx.planner, *args)

    with pytest.raises(Refused) as err:
        forward(0.8)
    assert err.value.code == ReturnCode.CANNOT_REACH_TARGET_ERR
    assert count[0] <= 500
    assert re.match(r"the path at \d+ % \(\d+ of 800 mm\) is not reachable: ", err.value.comment)
    assert isinstance(forward(0.6), CartesianMoveSpec)  # the reachable part of it still is


def test_a_ptp_move_is_a_joint_move_of_the_given_duration():
    ctx, _, _ = context("smartpal5")
    spec = plan_ptp(ctx.planner, ctx.snapshot(), RIGHT, up(0.03), 2.0, ELBOW, {}, False, True)
    assert isinstance(spec, JointMoveSpec) and spec.duration == 2.0

"""controller.gateway.planning.planner: the queue tail relative moves build on (issue 15.1),
the elbow reachability check of Cartesian moves (15.3)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from controller.errors import Refused
from controller.model.redundant_axes import RedundantAxis
from controller.vocabulary import CoreState, FrameType, ReturnCode, RightLeft
from tests.planning_support import context, snapshot

RIGHT = RightLeft.RIGHT


def test_the_queue_tail_is_used_only_while_something_executes_or_waits():
    ctx, reader, _ = context("smartpal5")
    planner = ctx.planner
    measured = ctx.view.measured_q(reader.snap)
    tail = measured + 0.1
    planner.remember(tail)
    busy = snapshot(ctx.robot, state=CoreState.BUSY, moving=True)
    np.testing.assert_allclose(planner.base_q(busy, queued=True), tail)
    # stopped, then paused while idle: nothing executes or waits any more (issue 15.1)
    paused = snapshot(ctx.robot, state=CoreState.PAUSED)
    np.testing.assert_allclose(planner.base_q(paused, queued=True), measured)
    assert planner.tail is None and planner.tail_poses == {}


def test_a_paused_motion_keeps_the_tail():
    ctx, _, _ = context("smartpal5")
    planner = ctx.planner
    tail = ctx.view.measured_q(ctx.snapshot()) + 0.1
    planner.remember(tail)
    paused_motion = snapshot(ctx.robot, state=CoreState.PAUSED, motion=True)  # still
    np.testing.assert_allclose(planner.base_q(paused_motion, queued=True), tail)


def test_forget_queue():
    ctx, _, _ = context("smartpal5")
    ctx.planner.remember(np.zeros(3), {RIGHT: pin.SE3.Identity()})
    ctx.planner.forget_queue()
    assert ctx.planner.tail is None and ctx.planner.tail_pose(RIGHT) is None


def test_a_linear_move_with_an_elbow_out_of_reach_is_value_err_naming_the_joint():
    ctx, _, _ = context("seednoid")
    snap = ctx.snapshot()
    q0 = ctx.view.measured_q(snap)
    pose, elbow = ctx.view.pose(snap, RIGHT, FrameType.ORIGINAL_FRAME)
    allowed = {RedundantAxis.RIGHT_ELBOW: True}
    with pytest.raises(Refused) as err:
        ctx.planner.cartesian(
            snap,
            q0,
            RIGHT,
            pose,
            (0.05, 0.3),
            (0.1, 0.6),
            allowed,
            {},
            False,
            elbow=elbow + math.radians(20),
        )
    assert err.value.code == ReturnCode.VALUE_ERR
    assert "elbow" in err.value.comment and "r_shoulder" in err.value.comment
    spec, _ = ctx.planner.cartesian(
        snap,
        q0,
        RIGHT,
        pose,
        (0.05, 0.3),
        (0.1, 0.6),
        allowed,
        {},
        False,
        elbow=elbow - math.radians(5),
    )
    assert spec.elbow == pytest.approx(elbow - math.radians(5))

"""controller.gateway.services.jara_arm: JARA motions without gRPC or a daemon: queueing
from the queue's end, VALUE_ERR for unreachable targets, CarPos conversion."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.contract.motion_specs import CartesianMoveSpec, JointMoveSpec, JointStreamSpec
from controller.errors import ArgumentError, Refused
from controller.gateway.services.jara_arm import JaraArmService, car_pos
from controller.vocabulary import CoreState, ReturnCode, RightLeft
from tests.planning_support import context, snapshot

RIGHT = RightLeft.RIGHT
IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0]


def service(robot: str = "smartpal5"):
    ctx, reader, channel = context(robot)
    return JaraArmService(ctx), reader, channel


def test_car_pos_converts_mm_and_deg():
    target = car_pos([1, 0, 0, 10, 0, 1, 0, 0, 0, 0, 1, 0], 5.0, "carPoint")
    np.testing.assert_allclose(target.pose.translation, [0.01, 0, 0])
    assert target.elbow == pytest.approx(math.radians(5.0))
    with pytest.raises(ArgumentError, match=r"carPoint.carPos: expected 12 numbers"):
        car_pos([1, 0, 0], 0.0, "carPoint")


def test_the_arm_argument():
    svc, _, _ = service("pa10")
    assert svc.arm(0)[0] == RIGHT
    with pytest.raises(ArgumentError, match="no LEFT arm"):
        svc.arm(1)
    with pytest.raises(ArgumentError, match="not RIGHT"):
        svc.arm(7)


def test_a_relative_joint_move_queued_behind_another_builds_on_its_end():
    svc, reader, channel = service()
    joints = svc.joints(RIGHT)
    q0 = svc.ctx.view.measured_q(reader.snap)[joints]
    assert svc.ptp_joint(RIGHT, np.r_[5.0, np.zeros(6)], relative=True) is None
    reader.snap = snapshot(svc.ctx.robot, state=CoreState.BUSY, moving=True)
    channel.answers["start"] = "queued"
    comment = svc.ptp_joint(RIGHT, np.r_[2.0, np.zeros(6)], relative=True)
    assert comment == "OK (queued behind the running motion)"
    _first, second = channel.specs()
    assert isinstance(second, JointMoveSpec)
    assert second.target[0] == pytest.approx(q0[0] + math.radians(7.0))
    # a stop empties the queue: the next relative move builds on the measured state again
    svc.ctx.call("stop")
    reader.snap = snapshot(svc.ctx.robot, state=CoreState.PAUSED)
    svc.ptp_joint(RIGHT, np.r_[1.0, np.zeros(6)], relative=True)
    assert channel.specs()[-1].target[0] == pytest.approx(q0[0] + math.radians(1.0))


def test_a_linear_move_and_an_unreachable_one():
    svc, _, channel = service()
    up = car_pos([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 10.0], 0.0, "carPoint")
    svc.linear(RIGHT, up, relative=True, name="carPoint")
    assert isinstance(channel.specs()[-1], CartesianMoveSpec)
    far = car_pos([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 3000.0], 0.0, "carPoint")
    with pytest.raises(Refused) as err:
        svc.linear(RIGHT, far, relative=True, name="carPoint")
    assert err.value.code == ReturnCode.VALUE_ERR  # JARA has no CANNOT_REACH_TARGET_ERR


def test_streams_and_the_servo_state():
    svc, reader, channel = service()
    svc.stream_joint(RIGHT, np.zeros(7), relative=True)
    assert isinstance(channel.specs()[-1], JointStreamSpec)
    reader.snap = snapshot(svc.ctx.robot, state=CoreState.SERVO_OFF)
    with pytest.raises(Refused) as err:
        svc.ptp_joint(RIGHT, np.zeros(7), relative=True)
    assert err.value.code == ReturnCode.NOT_SV_ON_ERR


def test_both_arms_together():
    svc, _, channel = service()
    target = car_pos([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 10.0], 0.0, "x")
    svc.dual_linear({RIGHT: target, RightLeft.LEFT: target}, relative=True)
    svc.dual_ptp_joint({RIGHT: np.zeros(7), RightLeft.LEFT: np.zeros(7)}, relative=True)
    assert [type(s).__name__ for s in channel.specs()] == ["DualCartesianSpec", "JointMoveSpec"]

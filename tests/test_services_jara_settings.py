"""controller.gateway.services.jara_settings: JARA settings in spec units, without a daemon."""

from __future__ import annotations

import numpy as np
import pytest

from controller.errors import ArgumentError, Refused
from controller.gateway.services.jara_arm import JaraArmService
from controller.gateway.services.jara_settings import JaraSettingsService
from controller.vocabulary import CoreState, ReturnCode, RightLeft
from tests.planning_support import context, snapshot

RIGHT = RightLeft.RIGHT


def service():
    ctx, reader, channel = context("smartpal5")
    return JaraSettingsService(JaraArmService(ctx)), reader, channel


def test_joint_feedback_includes_the_gripper():
    svc, _, _ = service()
    assert len(svc.joint_positions(RIGHT)) == 8


def test_soft_limits_joint_round_trip_and_refusals():
    svc, reader, channel = service()
    limits = svc.soft_limit_joint(RIGHT)
    narrow = [(lo + 1.0, hi - 1.0) for lo, hi in limits]
    svc.set_soft_limit_joint(RIGHT, narrow)
    np.testing.assert_allclose(svc.soft_limit_joint(RIGHT), narrow)
    assert channel.names() == ["set_joint_limits"]
    with pytest.raises(ArgumentError, match="wider than the hardware"):
        svc.set_soft_limit_joint(RIGHT, [(lo - 1.0, hi) for lo, hi in limits])
    reader.snap = snapshot(svc.ctx.robot, state=CoreState.BUSY, moving=True)
    with pytest.raises(Refused) as err:
        svc.set_soft_limit_joint(RIGHT, limits)
    assert err.value.code == ReturnCode.STATUS_ERR


def test_speeds_and_accel_times():
    svc, _, _ = service()
    svc.set_max_speed_cartesian(RIGHT, 300, 60)
    assert svc.arms.arms[RIGHT].max_speed_cartesian == (300, 60)
    with pytest.raises(ArgumentError, match=r"speed\.translation"):
        svc.set_max_speed_cartesian(RIGHT, -1, 60)
    hw = svc.arms.arms[RIGHT].hw_speed
    with pytest.raises(ArgumentError, match="exceeds the hardware limit"):
        svc.set_max_speed_joint(RIGHT, list(hw * 2))
    with pytest.raises(ArgumentError, match=r"outside 1\.\.100"):
        svc.set_speed_joint(RIGHT, 0)
    with pytest.raises(ArgumentError, match="shorter than the drives allow"):
        svc.set_min_accel_time_joint(RIGHT, 1e-6)


def test_cartesian_box_must_contain_the_control_point():
    svc, _, channel = service()
    (x, y, z) = svc.feedback_cartesian(RIGHT)[0][:, 3]
    box = [(x - 50, x + 50), (y - 50, y + 50), (z - 50, z + 50)]
    svc.set_soft_limit_cartesian(RIGHT, box)
    assert channel.names() == ["set_cartesian_box"]
    np.testing.assert_allclose(svc.soft_limit_cartesian(RIGHT), box)
    with pytest.raises(ArgumentError, match="outside the new limits"):
        svc.set_soft_limit_cartesian(RIGHT, [(x + 10, x + 50), box[1], box[2]])


def test_a_joint_move_with_a_bad_gripper_value_sends_nothing():
    """Issue 17.3: the gripper value is checked before the arm moves."""
    svc, _, channel = service()
    with pytest.raises(ArgumentError, match="gripper value"):
        svc.move_joints(RIGHT, [0.0] * 7 + [1e6], relative=True, stream=True)
    with pytest.raises(ArgumentError, match="expected 7 or 8 joint values"):
        svc.move_joints(RIGHT, [0.0] * 9, relative=True, stream=False)
    assert channel.calls == []
    svc.move_joints(RIGHT, [0.0] * 7, relative=True, stream=False)
    assert channel.names() == ["start"]


def test_home_and_offsets():
    svc, _, channel = service()
    home = list(svc.arms.arms[RIGHT].home)
    svc.set_home(RIGHT, home)
    with pytest.raises(ArgumentError, match=r"jointPoint\[0\]"):
        svc.set_home(RIGHT, [10000.0, *home[1:]])
    svc.set_base_offset(RIGHT, [1, 0, 0, 100, 0, 1, 0, 0, 0, 0, 1, 0])
    np.testing.assert_allclose(svc.base_offset(RIGHT)[:, 3], [100, 0, 0])
    assert channel.names() == ["set_cartesian_box"]

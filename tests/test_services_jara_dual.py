"""controller.gateway.services.jara_dual: both arms, without gRPC or a daemon."""

from __future__ import annotations

import numpy as np
import pytest

from controller.errors import ArgumentError, Refused
from controller.gateway.services.jara_arm import JaraArmService
from controller.gateway.services.jara_dual import JaraDualService
from controller.vocabulary import ReturnCode, RightLeft
from tests.planning_support import context

R, L = RightLeft.RIGHT, RightLeft.LEFT


def service(robot: str = "smartpal5"):
    ctx, _reader, channel = context(robot)
    return JaraDualService(JaraArmService(ctx)), channel


def test_one_arm_robots_are_refused():
    svc, channel = service("pa10")
    with pytest.raises(Refused) as err:
        svc.servo_arms(True)
    assert err.value.code == ReturnCode.VALUE_ERR and channel.calls == []


def test_hands_off_refuse_grippers():
    svc, channel = service()
    svc.servo_hands(False)
    with pytest.raises(Refused) as err:
        svc.grippers({R: 0.0, L: None})
    assert err.value.code == ReturnCode.STATUS_ERR
    svc.servo_hands(True)
    svc.grippers({R: 0.0, L: None})
    assert channel.names() == ["gripper"]


def test_joint_moves_check_both_arms_first():
    svc, channel = service()
    with pytest.raises(ArgumentError, match=r"lArm\[1\]: nan"):
        svc.move_ptp_joint({R: [0.0] * 7, L: [0.0, float("nan")] + [0.0] * 5}, relative=True)
    with pytest.raises(ArgumentError, match="rArm: expected 7"):
        svc.move_ptp_joint({R: [0.0] * 6, L: [0.0] * 7}, relative=True)
    assert channel.calls == []
    svc.move_ptp_joint({R: [1.0] + [0.0] * 6, L: [0.0] * 7}, relative=True)
    assert channel.names() == ["start"]


def test_relative_position_is_left_in_the_right_frame():
    svc, _ = service()
    rel = svc.relative_position()
    assert rel.shape == (3, 4)
    np.testing.assert_allclose(rel[:, :3] @ rel[:, :3].T, np.eye(3), atol=1e-9)

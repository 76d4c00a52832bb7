"""JARA_ARM_DUAL over real gRPC: every Common and Middle operation; both arms start and stop
together; hands servo; invalid flags and ratios."""

from __future__ import annotations

import numpy as np
import pytest

from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import ReturnCode
from tests.daemon_support import TestDaemon


def DC(name, **kw):
    return getattr(pb, f"DualManipulatorCommon{name}Request")(**kw)


def DM(name, **kw):
    return getattr(pb, f"DualManipulatorMiddle{name}Request")(**kw)


def car(z=0.0, x=0.0):
    m = [1, 0, 0, x, 0, 1, 0, 0, 0, 0, 1, z]
    return pb.CarPosWithElbow(car_pos=pb.HgMatrix(m=m))


def code(reply):
    return reply.return_id.id


@pytest.fixture(scope="module")
def d():
    daemon = TestDaemon("smartpal5")
    assert code(daemon.dual_common.ServoONArm(DC("ServoONArm"))) == ReturnCode.OK
    yield daemon
    daemon.close()


def positions(d):
    out = {}
    for arm in (0, 1):
        r = d.middle.GetFeedbackPosCartesian(
            pb.ManipulatorMiddleGetFeedbackPosCartesianRequest(arm=arm)
        )
        out[arm] = np.array(r.pos.car_pos.m).reshape(3, 4)
    return out


def arm_joints(d, arm):
    r = d.common.GetFeedbackPosJoint(pb.ManipulatorCommonGetFeedbackPosJointRequest(arm=arm))
    return np.array(r.pos)


def test_dual_linear_rel_moves_both_and_they_finish_together(d):
    start = positions(d)
    assert (
        code(
            d.dual_middle.MoveLinearCartesianRel(
                DM("MoveLinearCartesianRel", r_arm=car(z=30), l_arm=car(z=15))
            )
        )
        == ReturnCode.OK
    )
    # sample mid-way: both arms are moving at the same time, in proportion
    mid = None
    for _ in range(500):
        now = positions(d)
        dz_r = now[0][2, 3] - start[0][2, 3]
        if 5.0 < dz_r < 25.0:
            mid = now
            break
    assert mid is not None
    share_r = (mid[0][2, 3] - start[0][2, 3]) / 30.0
    share_l = (mid[1][2, 3] - start[1][2, 3]) / 15.0
    assert share_r == pytest.approx(share_l, abs=0.05)
    assert d.wait_idle()
    end = positions(d)
    assert end[0][2, 3] - start[0][2, 3] == pytest.approx(30.0, abs=0.05)
    assert end[1][2, 3] - start[1][2, 3] == pytest.approx(15.0, abs=0.05)


def test_dual_linear_abs_and_ptp(d):
    now = positions(d)
    target = {
        arm: pb.CarPosWithElbow(car_pos=pb.HgMatrix(m=now[arm].ravel().tolist())) for arm in (0, 1)
    }
    for arm in (0, 1):
        target[arm].car_pos.m[11] -= 10.0
        r = d.middle.GetFeedbackPosCartesian(
            pb.ManipulatorMiddleGetFeedbackPosCartesianRequest(arm=arm)
        )
        target[arm].elbow = r.pos.elbow
    assert (
        code(
            d.dual_middle.MoveLinearCartesianAbs(
                DM("MoveLinearCartesianAbs", r_arm=target[0], l_arm=target[1])
            )
        )
        == ReturnCode.OK
    )
    assert d.wait_idle()
    assert (
        code(
            d.dual_middle.MovePTPCartesianRel(
                DM("MovePTPCartesianRel", r_arm=car(x=10), l_arm=car(x=10))
            )
        )
        == ReturnCode.OK
    )
    assert d.wait_idle()
    end = positions(d)
    for arm in (0, 1):
        assert end[arm][0, 3] - now[arm][0, 3] == pytest.approx(10.0, abs=0.05)
        assert end[arm][2, 3] - now[arm][2, 3] == pytest.approx(-10.0, abs=0.05)
    assert (
        code(
            d.dual_middle.MovePTPCartesianAbs(
                DM("MovePTPCartesianAbs", r_arm=target[0], l_arm=target[1])
            )
        )
        == ReturnCode.OK
    )
    assert d.wait_idle()


def test_dual_ptp_joint(d):
    r0, l0 = arm_joints(d, 0)[:7], arm_joints(d, 1)[:7]
    rel_r, rel_l = [-3.0] + [0.0] * 6, [3.0] + [0.0] * 6
    assert (
        code(d.dual_middle.MovePTPJointRel(DM("MovePTPJointRel", r_arm=rel_r, l_arm=rel_l)))
        == ReturnCode.OK
    )
    assert d.wait_idle()
    np.testing.assert_allclose(arm_joints(d, 0)[:7], r0 + rel_r, atol=1e-3)
    np.testing.assert_allclose(arm_joints(d, 1)[:7], l0 + rel_l, atol=1e-3)
    assert (
        code(d.dual_middle.MovePTPJointAbs(DM("MovePTPJointAbs", r_arm=r0, l_arm=l0)))
        == ReturnCode.OK
    )
    assert d.wait_idle()
    np.testing.assert_allclose(arm_joints(d, 0)[:7], r0, atol=1e-3)
    r = d.dual_middle.MovePTPJointAbs(DM("MovePTPJointAbs", r_arm=r0[:3], l_arm=l0))
    assert code(r) == ReturnCode.VALUE_ERR and "rArm" in r.return_id.comment


def test_relative_position_is_left_in_right_frame(d):
    r = d.dual_middle.GetRelativePosition(DM("GetRelativePosition"))
    rel = np.array(r.rel_pos.m).reshape(3, 4)
    p = positions(d)  # JARA arm frames = robot frame with identity base offsets
    right = np.vstack([p[0], [0, 0, 0, 1]])
    left = np.vstack([p[1], [0, 0, 0, 1]])
    expected = np.linalg.inv(right) @ left
    np.testing.assert_allclose(rel, expected[:3], atol=1e-6)


def test_grippers_and_hands(d):
    dm, dc = d.dual_middle, d.dual_common
    assert code(dm.MoveGripper(DM("MoveGripper", r_arm=30, l_arm=60))) == ReturnCode.OK
    assert d.wait_idle()
    got = [d.spec_a.GetGripperPos(pb.GetGripperPosRequest(type=a)).angle_ratio for a in (0, 1)]
    assert got == [30, 60]
    assert code(dm.CloseGripper(DM("CloseGripper", r_arm=1, l_arm=0))) == ReturnCode.OK
    assert code(dm.OpenGripper(DM("OpenGripper", r_arm=0, l_arm=1))) == ReturnCode.OK
    assert d.wait_idle()
    got = [d.spec_a.GetGripperPos(pb.GetGripperPosRequest(type=a)).angle_ratio for a in (0, 1)]
    assert got == [0, 100]
    assert code(dm.CloseGripper(DM("CloseGripper", r_arm=2, l_arm=0))) == ReturnCode.VALUE_ERR
    assert code(dm.MoveGripper(DM("MoveGripper", r_arm=101, l_arm=0))) == ReturnCode.VALUE_ERR
    assert code(dc.ServoOFFHand(DC("ServoOFFHand"))) == ReturnCode.OK
    assert code(dm.OpenGripper(DM("OpenGripper", r_arm=1, l_arm=1))) == ReturnCode.STATUS_ERR
    assert code(dc.ServoONHand(DC("ServoONHand"))) == ReturnCode.OK
    assert code(dm.OpenGripper(DM("OpenGripper", r_arm=1, l_arm=1))) == ReturnCode.OK
    assert d.wait_idle()


def test_servo_arm_off_and_on(d):
    assert code(d.dual_common.ServoOFFArm(DC("ServoOFFArm"))) == ReturnCode.OK
    assert not d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on
    r = d.dual_middle.MovePTPJointRel(DM("MovePTPJointRel", r_arm=[1] + [0] * 6, l_arm=[0] * 7))
    assert code(r) == ReturnCode.NOT_SV_ON_ERR
    assert code(d.dual_common.ServoONHand(DC("ServoONHand"))) == ReturnCode.STATUS_ERR
    assert code(d.dual_common.ServoONArm(DC("ServoONArm"))) == ReturnCode.OK
    assert d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on


def test_unreachable_dual_target_moves_nothing(d):
    before = positions(d)
    r = d.dual_middle.MoveLinearCartesianRel(
        DM("MoveLinearCartesianRel", r_arm=car(z=3000), l_arm=car())
    )
    assert code(r) == ReturnCode.VALUE_ERR  # JARA has no CANNOT_REACH_TARGET_ERR
    assert "reach" in r.return_id.comment
    after = positions(d)
    np.testing.assert_allclose(after[0], before[0], atol=1e-9)

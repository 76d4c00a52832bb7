"""JARA_ARM over real gRPC: every Common and Middle operation, queueing, settings, frames,
invalid arguments (nothing moves), state bits."""

from __future__ import annotations

import numpy as np
import pytest

from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import ReturnCode, SpecAState
from tests.daemon_support import TestDaemon

OK, VALUE_ERR, STATUS_ERR = ReturnCode.OK, ReturnCode.VALUE_ERR, ReturnCode.STATUS_ERR


def hg(x=0.0, y=0.0, z=0.0, rot=None):
    r = np.eye(3) if rot is None else np.asarray(rot)
    m = np.hstack([r, [[x], [y], [z]]])
    return pb.HgMatrix(m=m.ravel().tolist())


def car(x=0.0, y=0.0, z=0.0, elbow=0.0):
    return pb.CarPosWithElbow(car_pos=hg(x, y, z), elbow=elbow)


def M(name, **kw):
    return getattr(pb, f"ManipulatorMiddle{name}Request")(**kw)


def C(name, **kw):
    return getattr(pb, f"ManipulatorCommon{name}Request")(**kw)


@pytest.fixture(scope="module")
def daemon():
    d = TestDaemon("smartpal5", queue_depth=3)
    yield d
    d.close()


@pytest.fixture(scope="module")
def pa10():
    d = TestDaemon("pa10")
    yield d
    d.close()


@pytest.fixture
def d(daemon):
    daemon.reset()
    daemon.wait_idle()
    yield daemon
    daemon.middle.Stop(M("Stop"))
    daemon.wait_idle()


def joints(d, arm=0):
    return np.array(d.common.GetFeedbackPosJoint(C("GetFeedbackPosJoint", arm=arm)).pos)


def pose(d, arm=0):
    r = d.middle.GetFeedbackPosCartesian(M("GetFeedbackPosCartesian", arm=arm))
    return np.array(r.pos.car_pos.m).reshape(3, 4), r.pos.elbow


def code(reply):
    return reply.return_id.id


def test_common_info_state_and_joints(d):
    info = d.common.GetManipInfo(C("GetManipInfo", arm=1)).m_info
    assert (info.manufactur, info.axis_num, info.is_gripper) == ("Yaskawa Electric", 7, True)
    assert info.cmd_cycle == d.cfg.jara.cmd_cycle_ms
    state = d.common.GetState(C("GetState")).state
    assert state & 0x01 and not state & 0x04
    assert len(joints(d)) == 8  # 7 joints + the gripper


def test_servo_bits_and_alarm_codes(d):
    assert code(d.common.ServoOFF(C("ServoOFF"))) == OK
    assert d.common.GetState(C("GetState")).state & 0x01 == 0
    r = d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[1] + [0] * 6))
    assert code(r) == ReturnCode.NOT_SV_ON_ERR
    assert code(d.common.ServoON(C("ServoON"))) == OK
    assert code(d.common.ClearAlarms(C("ClearAlarms"))) == OK
    assert list(d.common.GetActiveAlarm(C("GetActiveAlarm")).alarms) == []


def test_queue_runs_in_order_and_reports_full(d):
    start, _ = pose(d)
    codes = [
        code(d.middle.MoveLinearCartesianRel(M("MoveLinearCartesianRel", car_point=car(z=10))))
        for _ in range(5)
    ]
    assert codes[:4] == [OK] * 4
    assert codes[4] == ReturnCode.FULL_MOTION_QUEUE_ERR
    assert d.common.GetState(C("GetState")).state & 0x02
    assert d.wait_idle()
    end, _ = pose(d)
    assert end[2, 3] - start[2, 3] == pytest.approx(40.0, abs=0.05)


def test_spec_a_state_follows_the_queue_as_it_drains(d):
    """getState's answers are kept ready by core state, hardware state and queue length
    (controller/gateway/grpc/base.py Replies): each step of a draining queue shows."""
    for _ in range(3):
        r = d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[10] + [0] * 6))
        assert code(r) == OK, r.return_id.comment
    seen: list[str] = []

    def ready() -> bool:
        reply = d.spec_a.GetState(pb.GetStateRequest())
        if not seen or seen[-1] != reply.message:
            seen.append(reply.message)
        return reply.status_id == SpecAState.READY

    assert d.wait_for(ready, 60.0)
    busy = "Busy: executing a motion"
    assert [m for m in seen if m.startswith("Busy")][-3:] == [
        f"{busy} (2 queued)",
        f"{busy} (1 queued)",
        busy,
    ], seen
    assert seen[-1].startswith("Ready")


def test_stop_empties_the_queue(d):
    start = joints(d)
    for _ in range(3):
        d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[10] + [0] * 6))
    assert code(d.middle.Stop(M("Stop"))) == OK
    assert d.wait_idle()
    moved = joints(d)[0] - start[0]
    assert 0.0 <= moved < 10.0


def test_pause_resume(d):
    d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[20] + [0] * 6))
    assert code(d.middle.Pause(M("Pause"))) == OK
    assert d.wait_for(lambda: d.common.GetState(C("GetState")).state & 0x10)
    held = joints(d)[0]
    assert code(d.middle.Resume(M("Resume"))) == OK
    assert d.wait_idle()
    assert joints(d)[0] > held


def test_speed_settings_round_trip_and_validation(d):
    m = d.middle
    assert m.GetSpeedJoint(M("GetSpeedJoint")).spd_ratio == 50  # profile default
    assert code(m.SetSpeedJoint(M("SetSpeedJoint", spd_ratio=0))) == VALUE_ERR
    assert code(m.SetSpeedJoint(M("SetSpeedJoint", spd_ratio=101))) == VALUE_ERR
    assert code(m.SetSpeedJoint(M("SetSpeedJoint", spd_ratio=80))) == OK
    assert m.GetSpeedJoint(M("GetSpeedJoint")).spd_ratio == 80
    assert code(m.SetSpeedCartesian(M("SetSpeedCartesian", spd_ratio=30))) == OK
    assert m.GetSpeedCartesian(M("GetSpeedCartesian")).spd_ratio == 30
    speed = pb.CartesianSpeed(translation=300, rotation=60)
    assert code(m.SetMaxSpeedCartesian(M("SetMaxSpeedCartesian", speed=speed))) == OK
    got = m.GetMaxSpeedCartesian(M("GetMaxSpeedCartesian")).speed
    assert (got.translation, got.rotation) == (300, 60)
    bad = pb.CartesianSpeed(translation=-1, rotation=60)
    r = m.SetMaxSpeedCartesian(M("SetMaxSpeedCartesian", speed=bad))
    assert code(r) == VALUE_ERR and "translation" in r.return_id.comment
    hw = list(m.GetMaxSpeedJoint(M("GetMaxSpeedJoint")).speed)
    assert len(hw) == 7
    r = m.SetMaxSpeedJoint(M("SetMaxSpeedJoint", speed=[v * 2 for v in hw]))
    assert code(r) == VALUE_ERR and "hardware limit" in r.return_id.comment
    assert code(m.SetMaxSpeedJoint(M("SetMaxSpeedJoint", speed=[v / 2 for v in hw]))) == OK
    assert code(m.SetMaxSpeedJoint(M("SetMaxSpeedJoint", speed=hw[:3]))) == VALUE_ERR
    m.SetMaxSpeedJoint(M("SetMaxSpeedJoint", speed=hw))


def test_accel_times(d):
    m = d.middle
    t_min = m.GetMinAccelTimeJoint(M("GetMinAccelTimeJoint")).acl_time
    assert t_min > 0
    r = m.SetAccelTimeJoint(M("SetAccelTimeJoint", acl_time=t_min / 2))
    assert code(r) == VALUE_ERR and "minimum" in r.return_id.comment
    assert code(m.SetAccelTimeJoint(M("SetAccelTimeJoint", acl_time=t_min * 2))) == OK
    assert code(m.SetMinAccelTimeJoint(M("SetMinAccelTimeJoint", acl_time=1e-4))) == VALUE_ERR
    assert code(m.SetMinAccelTimeJoint(M("SetMinAccelTimeJoint", acl_time=t_min))) == OK
    assert code(m.SetMinAccelTimeCartesian(M("SetMinAccelTimeCartesian", acl_time=0.2))) == OK
    assert m.GetMinAccelTimeCartesian(M("GetMinAccelTimeCartesian")).acl_time == 0.2
    assert code(m.SetAccelTimeCartesian(M("SetAccelTimeCartesian", acl_time=0.1))) == VALUE_ERR
    assert code(m.SetAccelTimeCartesian(M("SetAccelTimeCartesian", acl_time=0.3))) == OK
    assert (
        code(m.SetAccelTimeCartesian(M("SetAccelTimeCartesian", acl_time=float("nan"))))
        == VALUE_ERR
    )


def test_ptp_joint_units_and_gripper_value(d):
    target = joints(d)
    target[0] += 7.5
    target[3] -= 4.0
    assert code(d.middle.MovePTPJointAbs(M("MovePTPJointAbs", joint_points=target[:7]))) == OK
    assert d.wait_idle()
    np.testing.assert_allclose(joints(d)[:7], target[:7], atol=1e-3)
    r = d.middle.MovePTPJointAbs(M("MovePTPJointAbs", joint_points=[0, 0, 0]))
    assert code(r) == VALUE_ERR and "7" in r.return_id.comment
    r = d.middle.MovePTPJointAbs(M("MovePTPJointAbs", joint_points=[500] + [0] * 6))
    assert code(r) == VALUE_ERR and "r_arm_j1" in r.return_id.comment


def test_cartesian_moves_in_arm_frame_with_base_offset(d):
    m = d.middle
    before, _ = pose(d)
    assert code(m.SetBaseOffset(M("SetBaseOffset", offset=hg(100, 0, 0)))) == OK
    shifted, _ = pose(d)
    assert shifted[0, 3] == pytest.approx(before[0, 3] - 100.0, abs=1e-6)
    got = np.array(m.GetBaseOffset(M("GetBaseOffset")).offset.m).reshape(3, 4)
    assert got[0, 3] == pytest.approx(100.0)
    target = car(shifted[0, 3], shifted[1, 3] + 30.0, shifted[2, 3])
    target.car_pos.m[:] = np.hstack(
        [shifted[:, :3], [[shifted[0, 3]], [shifted[1, 3] + 30], [shifted[2, 3]]]]
    ).ravel()
    _, elbow = pose(d)
    target.elbow = elbow
    assert code(m.MoveLinearCartesianAbs(M("MoveLinearCartesianAbs", car_point=target))) == OK
    assert d.wait_idle()
    after, _ = pose(d)
    assert after[1, 3] - shifted[1, 3] == pytest.approx(30.0, abs=0.05)
    m.SetBaseOffset(M("SetBaseOffset", offset=hg()))


def test_all_other_motion_ops(d):
    m = d.middle
    _, _elbow = pose(d)
    assert code(m.MovePTPCartesianRel(M("MovePTPCartesianRel", car_point=car(z=20)))) == OK
    assert (
        code(
            m.MoveCircularCartesianRel(
                M("MoveCircularCartesianRel", car_point_r=car(x=15, z=15), car_point_t=car(z=30))
            )
        )
        == OK
    )
    assert d.wait_idle()
    p, e = pose(d)
    assert (
        code(
            m.MovePTPCartesianAbs(
                M(
                    "MovePTPCartesianAbs",
                    car_point=pb.CarPosWithElbow(
                        car_pos=pb.HgMatrix(m=p.ravel().tolist()), elbow=e
                    ),
                )
            )
        )
        == OK
    )
    assert (
        code(
            m.MoveCircularCartesianAbs(
                M(
                    "MoveCircularCartesianAbs",
                    car_point_r=pb.CarPosWithElbow(
                        car_pos=hg(p[0, 3] + 10, p[1, 3], p[2, 3] - 10, p[:, :3]), elbow=e
                    ),
                    car_point_t=pb.CarPosWithElbow(
                        car_pos=hg(p[0, 3], p[1, 3], p[2, 3] - 20, p[:, :3]), elbow=e
                    ),
                )
            )
        )
        == OK
    )
    assert d.wait_idle()
    for name, kw in (
        ("MoveLinearCartesianRelCmdCycle", {"car_point": car(z=1)}),
        ("MovePTPCartesianRelCmdCycle", {"car_point": car(z=1)}),
        ("MovePTPJointRelCmdCycle", {"joint_points": [0.2] + [0] * 6}),
    ):
        assert code(getattr(m, name)(M(name, **kw))) == OK, name
    assert d.wait_idle()
    p, e = pose(d)
    target = pb.CarPosWithElbow(car_pos=pb.HgMatrix(m=p.ravel().tolist()), elbow=e)
    j = joints(d)[:7]
    for name, kw in (
        ("MoveLinearCartesianAbsCmdCycle", {"car_point": target}),
        ("MovePTPCartesianAbsCmdCycle", {"car_point": target}),
        ("MovePTPJointAbsCmdCycle", {"joint_points": j}),
    ):
        assert code(getattr(m, name)(M(name, **kw))) == OK, name
    assert d.wait_idle()
    np.testing.assert_allclose(joints(d)[:7], j, atol=0.05)


def test_home(d):
    m = d.middle
    home = list(m.GetHome(M("GetHome")).joint_point)
    assert len(home) == 7
    new = list(home)
    new[0] += 5
    assert code(m.SetHome(M("SetHome", joint_point=new))) == OK
    assert code(m.GoHome(M("GoHome"))) == OK
    assert d.wait_idle()
    np.testing.assert_allclose(joints(d)[:7], new, atol=1e-3)
    assert code(m.SetHome(M("SetHome", joint_point=[999] * 7))) == VALUE_ERR
    m.SetHome(M("SetHome", joint_point=home))
    m.GoHome(M("GoHome"))
    assert d.wait_idle()


def test_grippers_and_grasp_force(d):
    m = d.middle
    assert code(m.MoveGripper(M("MoveGripper", angle_ratio=101))) == VALUE_ERR
    assert code(m.CloseGripper(M("CloseGripper"))) == OK
    assert d.wait_idle()
    assert code(m.OpenGripper(M("OpenGripper", arm=1))) == OK
    assert code(m.MoveGripper(M("MoveGripper", angle_ratio=40))) == OK
    assert d.wait_idle()
    assert code(m.SetGraspForce(M("SetGraspForce", force_ratio=70))) == OK
    assert m.GetGraspForce(M("GetGraspForce")).force_ratio == 70
    assert code(m.SetGraspForce(M("SetGraspForce", force_ratio=170))) == VALUE_ERR


def test_soft_limits(d):
    c, m = d.common, d.middle
    limits = list(c.GetSoftLimitJoint(C("GetSoftLimitJoint")).soft_limit)
    assert len(limits) == 7
    j = joints(d)
    narrow = [pb.LimitValue(upper=lv.upper, lower=lv.lower) for lv in limits]
    narrow[0] = pb.LimitValue(upper=j[0] + 5.0, lower=j[0] - 5.0)
    assert code(c.SetSoftLimitJoint(C("SetSoftLimitJoint", soft_limit=narrow))) == OK
    r = m.MovePTPJointRel(M("MovePTPJointRel", joint_points=[10] + [0] * 6))
    assert code(r) == VALUE_ERR and "soft limit" in r.return_id.comment
    wide = list(narrow)
    wide[0] = pb.LimitValue(upper=limits[0].upper + 10, lower=limits[0].lower)
    assert code(c.SetSoftLimitJoint(C("SetSoftLimitJoint", soft_limit=wide))) == VALUE_ERR
    assert code(c.SetSoftLimitJoint(C("SetSoftLimitJoint", soft_limit=narrow[:2]))) == VALUE_ERR
    assert code(c.SetSoftLimitJoint(C("SetSoftLimitJoint", soft_limit=limits))) == OK

    p, _ = pose(d)
    box = {
        n: pb.LimitValue(upper=p[i, 3] + 50, lower=p[i, 3] - 50)
        for i, n in enumerate(("x_limit", "y_limit", "z_limit"))
    }
    assert code(m.SetSoftLimitCartesian(M("SetSoftLimitCartesian", **box))) == OK
    got = m.GetSoftLimitCartesian(M("GetSoftLimitCartesian"))
    assert got.z_limit.upper == pytest.approx(p[2, 3] + 50)
    r = m.MoveLinearCartesianRel(M("MoveLinearCartesianRel", car_point=car(z=80)))
    assert code(r) == VALUE_ERR and "soft limit" in r.return_id.comment
    far = dict(box, z_limit=pb.LimitValue(upper=p[2, 3] - 10, lower=p[2, 3] - 60))
    assert code(m.SetSoftLimitCartesian(M("SetSoftLimitCartesian", **far))) == VALUE_ERR
    huge = {n: pb.LimitValue(upper=1e4, lower=-1e4) for n in box}
    assert code(m.SetSoftLimitCartesian(M("SetSoftLimitCartesian", **huge))) == OK


def test_control_point_offset(d):
    original = d.ctx.snapshot().offsets[0].copy()  # 3x4 [m]
    assert (
        code(d.middle.SetControlPointOffset(M("SetControlPointOffset", offset=hg(0, 0, 50)))) == OK
    )
    a, _ = pose(d)
    assert (
        code(d.middle.SetControlPointOffset(M("SetControlPointOffset", offset=hg(0, 0, 80)))) == OK
    )
    b, _ = pose(d)
    assert np.linalg.norm(b[:, 3] - a[:, 3]) == pytest.approx(30.0, abs=1e-6)
    restore = np.hstack([original[:, :3], 1e3 * original[:, 3:]])
    d.middle.SetControlPointOffset(
        M("SetControlPointOffset", offset=pb.HgMatrix(m=restore.ravel().tolist()))
    )


@pytest.mark.parametrize(
    "call",
    [
        lambda d: d.middle.MoveLinearCartesianRel(
            M(
                "MoveLinearCartesianRel",
                car_point=pb.CarPosWithElbow(car_pos=pb.HgMatrix(m=[1, 0, 0])),
            )
        ),
        lambda d: d.middle.MoveLinearCartesianRel(
            M("MoveLinearCartesianRel", car_point=pb.CarPosWithElbow(car_pos=hg(rot=2 * np.eye(3))))
        ),
        lambda d: d.middle.MoveLinearCartesianRel(
            M("MoveLinearCartesianRel", car_point=car(z=float("inf")))
        ),
        lambda d: d.middle.MoveLinearCartesianRel(
            M("MoveLinearCartesianRel", car_point=car(elbow=float("nan")))
        ),
        lambda d: d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[float("nan")] * 7)),
        lambda d: d.middle.MoveCircularCartesianRel(
            M("MoveCircularCartesianRel", car_point_r=car(z=10), car_point_t=car(z=10))
        ),
        lambda d: d.middle.MoveLinearCartesianRel(
            M("MoveLinearCartesianRel", arm=5, car_point=car(z=10))
        ),
        lambda d: d.middle.SetBaseOffset(M("SetBaseOffset", offset=hg(rot=-np.eye(3)))),
    ],
)
def test_invalid_arguments_move_nothing(d, call):
    before = joints(d)
    r = call(d)
    assert code(r) == VALUE_ERR, r.return_id.comment
    assert r.return_id.comment
    assert not d.spec_a.IsMoving(pb.IsMovingRequest()).is_moving
    np.testing.assert_allclose(joints(d), before, atol=1e-9)


def test_left_arm_on_a_one_arm_robot(pa10):
    r = pa10.common.GetManipInfo(C("GetManipInfo", arm=1))
    assert code(r) == VALUE_ERR and "LEFT" in r.return_id.comment
    assert pa10.common.GetManipInfo(C("GetManipInfo", arm=0)).m_info.axis_num == 7
    r = pa10.dual_middle.GetRelativePosition(pb.DualManipulatorMiddleGetRelativePositionRequest())
    assert code(r) == VALUE_ERR


def test_alarm_state_bit_and_status_err(d):
    from hal.interface import HardwareFault

    d.daemon.hw.inject_fault(HardwareFault(0x400, "r_arm_j1", "test fault"))
    assert d.wait_for(lambda: d.common.GetState(C("GetState")).state & 0x04)
    r = d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[1] + [0] * 6))
    assert code(r) == STATUS_ERR
    alarms = d.common.GetActiveAlarm(C("GetActiveAlarm")).alarms
    assert alarms[0].code == 0x400 and alarms[0].module_name == ""
    assert code(d.common.ServoON(C("ServoON"))) == ReturnCode.NG
    d.common.ClearAlarms(C("ClearAlarms"))
    assert code(d.common.ServoON(C("ServoON"))) == OK


def test_cmd_cycle_set_points_stream_into_one_motion(d):
    import time

    start = joints(d)[:7]
    comments = []
    for k in range(1, 16):
        target = start.copy()
        target[0] += 0.5 * k  # deg: 25 deg/s at a 20 ms command cycle
        r = d.middle.MovePTPJointAbsCmdCycle(M("MovePTPJointAbsCmdCycle", joint_points=target))
        assert code(r) == OK, r.return_id.comment
        comments.append(r.return_id.comment)
        time.sleep(d.cfg.jara.cmd_cycle_ms / 1000.0)
    assert any("stream" in c for c in comments), comments
    assert d.wait_idle()
    np.testing.assert_allclose(joints(d)[:7], target, atol=1e-3)


def state_bits(d):
    return d.common.GetState(C("GetState")).state


def test_relative_move_after_stop_and_pause_builds_on_where_the_arm_is(d):
    """Issue 15.1: +30 deg on J3 stopped at ~10 deg, pause, +1 deg, resume went to 31 deg:
    the queue's commanded end survived the stop (and the pause kept it)."""
    ratio = d.middle.GetSpeedJoint(M("GetSpeedJoint")).spd_ratio
    assert code(d.middle.SetSpeedJoint(M("SetSpeedJoint", spd_ratio=20))) == OK
    try:
        start = joints(d)[2]
        r = d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[0, 0, 30, 0, 0, 0, 0]))
        assert code(r) == OK, r.return_id.comment
        assert d.wait_for(lambda: joints(d)[2] - start > 5.0)
        assert code(d.middle.Stop(M("Stop"))) == OK
        assert d.wait_idle()
        stopped = joints(d)[2]
        assert stopped - start < 25.0  # really stopped short
        assert code(d.middle.Pause(M("Pause"))) == OK
        assert d.wait_for(lambda: state_bits(d) & 0x10)
        r = d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[0, 0, 1, 0, 0, 0, 0]))
        assert code(r) == OK, r.return_id.comment
        assert code(d.middle.Resume(M("Resume"))) == OK
        assert d.wait_idle()
        assert joints(d)[2] == pytest.approx(stopped + 1.0, abs=0.05)
    finally:
        d.middle.SetSpeedJoint(M("SetSpeedJoint", spd_ratio=ratio))


def test_paused_and_still_is_not_moving(d):
    """Issue 15.9 (ruling: 0x02 = the axes move): paused and still read 0x13 (moving +
    paused), so a client waiting for 0x02 to clear after pause waited forever."""
    r = d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[20] + [0] * 6))
    assert code(r) == OK
    assert state_bits(d) & 0x02  # moving
    assert code(d.middle.Pause(M("Pause"))) == OK
    assert d.wait_for(lambda: state_bits(d) & 0x10)
    bits = state_bits(d)
    assert bits & 0x01 and bits & 0x10 and not bits & 0x02, hex(bits)
    r = d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[-5] + [0] * 6))
    assert code(r) == OK and "queued" in r.return_id.comment, r.return_id.comment
    bits = state_bits(d)  # a motion queued behind the paused one moves nothing yet
    assert bits & 0x10 and not bits & 0x02, hex(bits)
    assert code(d.middle.Resume(M("Resume"))) == OK
    assert d.wait_for(lambda: not state_bits(d) & 0x10)
    assert d.wait_idle()
    assert not state_bits(d) & 0x02


@pytest.fixture(scope="module")
def seednoid():
    daemon = TestDaemon("seednoid")
    daemon.reset()
    yield daemon
    daemon.close()


def test_an_elbow_target_out_of_reach_is_refused_naming_the_joint(seednoid):
    """Issue 15.3: elbow +20 deg from home (SEED-Noid) answered OK and stopped at 6.97 deg
    (a shoulder joint at its limit); now VALUE_ERR saying which joint limits it, nothing
    moves; a reachable elbow change is still executed."""
    d = seednoid
    assert code(d.middle.GoHome(M("GoHome"))) == OK
    assert d.wait_idle()
    for elbow in (20.0,):
        before = joints(d)
        r = d.middle.MoveLinearCartesianRel(M("MoveLinearCartesianRel", car_point=car(elbow=elbow)))
        assert code(r) == VALUE_ERR, r.return_id.comment
        comment = r.return_id.comment
        assert "elbow" in comment and "r_shoulder" in comment and "limit" in comment, comment
        assert not d.spec_a.IsMoving(pb.IsMovingRequest()).is_moving
        np.testing.assert_allclose(joints(d), before, atol=1e-9)
    _, elbow0 = pose(d)
    r = d.middle.MoveLinearCartesianRel(M("MoveLinearCartesianRel", car_point=car(elbow=-10.0)))
    assert code(r) == OK, r.return_id.comment  # within reach: still executed
    assert d.wait_idle()
    assert pose(d)[1] - elbow0 < -5.0


@pytest.mark.parametrize("n", [8, 9, 100_000])
def test_a_refused_streamed_set_point_leaves_no_trace(d, n):
    """Issue 17.3: movePTPJointAbsCmdCycle with 8 (a gripper value out of range), 9 or
    100 000 values was refused and the arm moved anyway (the stream started before the
    gripper value was checked)."""
    before = joints(d)
    values = list(before[:7] + 5.0) + [1e6] * (n - 7)
    r = d.middle.MovePTPJointAbsCmdCycle(M("MovePTPJointAbsCmdCycle", joint_points=values))
    assert code(r) == VALUE_ERR, r.return_id.comment
    assert not d.spec_a.IsMoving(pb.IsMovingRequest()).is_moving
    np.testing.assert_allclose(joints(d), before, atol=1e-9)


def test_a_relative_move_queued_behind_a_paused_motion_builds_on_its_end(d):
    """The other half of 15.1: a paused motion still ends where it was going."""
    start = joints(d)[0]
    assert code(d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[10] + [0] * 6))) == OK
    assert code(d.middle.Pause(M("Pause"))) == OK
    assert d.wait_for(lambda: state_bits(d) & 0x10)
    r = d.middle.MovePTPJointRel(M("MovePTPJointRel", joint_points=[2] + [0] * 6))
    assert code(r) == OK and "queued" in r.return_id.comment, r.return_id.comment
    assert code(d.middle.Resume(M("Resume"))) == OK
    assert d.wait_idle()
    assert joints(d)[0] == pytest.approx(start + 12.0, abs=0.05)

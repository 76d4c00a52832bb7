"""JARA_ARM (right arm) and JARA_ARM_LEFT (left arm) over CORBA against a running imotiond
(SmartPal V, sim): every Common and Middle operation from a client built from the product's
IDL, settings shared with gRPC (one service), reads equal to gRPC's, bad input VALUE_ERR
with nothing moving."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

pytest.importorskip("omniORB")

from controller.corba.stubs import JARA_ARM, JARA_ARM_LEFT
from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import JaraState, ReturnCode
from tests.corba_support import NOTHING_MOVED, CorbaDaemon

NAN, INF = math.nan, math.inf
ARMS = {
    "right": (JARA_ARM, "jara_arm", "", pb.RIGHT),
    "left": (JARA_ARM_LEFT, "jara_arm_left", "Left", pb.LEFT),
}


class Arm:
    """One arm's two servants (CORBA) and its gRPC twins."""

    def __init__(self, d: CorbaDaemon, name: str):
        module, key, prefix, self.arm = ARMS[name]
        self.m = module
        self.c = d.ref(
            f"{key}_common", getattr(module, f"{prefix}ManipulatorCommonInterface_Common")
        )
        self.mid = d.ref(
            f"{key}_middle", getattr(module, f"{prefix}ManipulatorCommonInterface_Middle")
        )
        self.d = d

    def grpc_c(self, op: str, **args: Any) -> Any:
        request = getattr(pb, f"ManipulatorCommon{op}Request")(arm=self.arm, **args)
        return getattr(self.d.common_grpc, op)(request)

    def grpc_m(self, op: str, **args: Any) -> Any:
        request = getattr(pb, f"ManipulatorMiddle{op}Request")(arm=self.arm, **args)
        return getattr(self.d.middle_grpc, op)(request)

    def hg(self, p: Any = (0.0, 0.0, 0.0)) -> list[list[float]]:
        m = np.zeros((3, 4))
        m[:, :3] = np.eye(3)
        m[:, 3] = p
        return m.tolist()

    def car(self, hg: Any, elbow: float = 0.0) -> Any:
        return self.m.CarPosWithElbow(hg, elbow, 0)


@pytest.fixture(scope="module", params=list(ARMS))
def a(request: pytest.FixtureRequest, corba_daemon: CorbaDaemon) -> Iterator[Arm]:
    corba_daemon.back_to_start()
    yield Arm(corba_daemon, request.param)


@pytest.fixture(autouse=True)
def ready(corba_daemon: CorbaDaemon) -> None:
    corba_daemon.ready()


def rid(reply: Any) -> tuple[int, str]:
    r = reply[0] if isinstance(reply, tuple) else reply
    return int(r.id), str(r.comment)


def ok(reply: Any) -> Any:
    code, comment = rid(reply)
    assert code == ReturnCode.OK, comment
    return reply


# ------------------------------------------------------------------ reads
def test_common_reads_are_the_grpc_answers(a: Arm) -> None:
    assert ok(a.c.getState())[1] == a.grpc_c("GetState").state
    assert ok(a.c.getState())[1] & JaraState.SERVO_ON
    assert ok(a.c.getActiveAlarm())[1] == []
    np.testing.assert_allclose(
        ok(a.c.getFeedbackPosJoint())[1], a.grpc_c("GetFeedbackPosJoint").pos, atol=1e-3
    )
    info = ok(a.c.getManipInfo())[1]
    g = a.grpc_c("GetManipInfo").m_info
    assert (info.manufactur, info.type, info.axisNum, info.cmdCycle, info.isGripper) == (
        g.manufactur, g.type, g.axis_num, g.cmd_cycle, g.is_gripper)  # fmt: skip
    limits = ok(a.c.getSoftLimitJoint())[1]
    assert [(lv.lower, lv.upper) for lv in limits] == [
        (lv.lower, lv.upper) for lv in a.grpc_c("GetSoftLimitJoint").soft_limit
    ]


def test_middle_reads_are_the_grpc_answers(a: Arm) -> None:
    m = a.mid
    np.testing.assert_allclose(
        np.ravel(ok(m.getBaseOffset())[1]), a.grpc_m("GetBaseOffset").offset.m
    )
    cp = ok(m.getFeedbackPosCartesian())[1]
    g = a.grpc_m("GetFeedbackPosCartesian").pos
    np.testing.assert_allclose(np.ravel(cp.carPos), g.car_pos.m, atol=1e-3)
    speed = ok(m.getMaxSpeedCartesian())[1]
    gs = a.grpc_m("GetMaxSpeedCartesian").speed
    assert (speed.translation, speed.rotation) == (gs.translation, gs.rotation)
    assert ok(m.getMaxSpeedJoint())[1] == list(a.grpc_m("GetMaxSpeedJoint").speed)
    assert ok(m.getMinAccelTimeCartesian())[1] == a.grpc_m("GetMinAccelTimeCartesian").acl_time
    assert ok(m.getMinAccelTimeJoint())[1] == a.grpc_m("GetMinAccelTimeJoint").acl_time
    _, x, y, z = ok(m.getSoftLimitCartesian())
    g3 = a.grpc_m("GetSoftLimitCartesian")
    assert [(v.lower, v.upper) for v in (x, y, z)] == [
        (v.lower, v.upper) for v in (g3.x_limit, g3.y_limit, g3.z_limit)
    ]
    assert ok(m.getHome())[1] == list(a.grpc_m("GetHome").joint_point)
    assert ok(m.getSpeedCartesian())[1] == a.grpc_m("GetSpeedCartesian").spd_ratio
    assert ok(m.getSpeedJoint())[1] == a.grpc_m("GetSpeedJoint").spd_ratio
    assert ok(m.getGraspForce())[1] == a.grpc_m("GetGraspForce").force_ratio


# ------------------------------------------------------------------ settings, shared
SETTINGS: list[tuple[str, Callable[[Arm], Any], Callable[[Arm], Any], Callable[[Arm], Any]]] = [
    # (name, set over CORBA, read over gRPC -> expected, restore over CORBA)
    ("speed ratios",
     lambda a: (ok(a.mid.setSpeedCartesian(30)), ok(a.mid.setSpeedJoint(40))),
     lambda a: (a.grpc_m("GetSpeedCartesian").spd_ratio, a.grpc_m("GetSpeedJoint").spd_ratio)
     == (30, 40),
     lambda a: (a.mid.setSpeedCartesian(50), a.mid.setSpeedJoint(50))),
    ("max speed Cartesian",
     lambda a: ok(a.mid.setMaxSpeedCartesian(a.m.CartesianSpeed(200.0, 45.0))),
     lambda a: a.grpc_m("GetMaxSpeedCartesian").speed.translation == 200.0,
     lambda a: a.mid.setMaxSpeedCartesian(a.m.CartesianSpeed(250.0, 90.0))),
    ("grasp force",
     lambda a: ok(a.mid.setGraspForce(70)),
     lambda a: a.grpc_m("GetGraspForce").force_ratio == 70,
     lambda a: a.mid.setGraspForce(50)),
    ("base offset",
     lambda a: ok(a.mid.setBaseOffset(a.hg((0.0, 0.0, 10.0)))),
     lambda a: a.grpc_m("GetBaseOffset").offset.m[11] == 10.0,
     lambda a: a.mid.setBaseOffset(a.hg())),
    ("Cartesian soft limit",
     lambda a: ok(a.mid.setSoftLimitCartesian(*[a.m.LimitValue(2000.0, -2000.0)] * 3)),
     lambda a: a.grpc_m("GetSoftLimitCartesian").x_limit.upper == 2000.0,
     lambda a: a.mid.setSoftLimitCartesian(*[a.m.LimitValue(10000.0, -10000.0)] * 3)),
]  # fmt: skip


@pytest.mark.parametrize(("name", "put", "seen", "restore"), SETTINGS, ids=[s[0] for s in SETTINGS])
def test_settings_are_the_ones_grpc_sees(
    a: Arm, name: str, put: Any, seen: Any, restore: Any
) -> None:
    try:
        put(a)
        assert seen(a)
    finally:
        for reply in np.atleast_1d(np.array(restore(a), dtype=object)):
            ok(reply)


def test_accel_times_are_the_ones_grpc_sees(a: Arm) -> None:
    m = a.mid
    cart, joint = ok(m.getMinAccelTimeCartesian())[1], ok(m.getMinAccelTimeJoint())[1]
    try:
        ok(m.setMinAccelTimeCartesian(cart + 0.1))
        ok(m.setMinAccelTimeJoint(joint + 0.2))
        ok(m.setAccelTimeCartesian(cart + 0.3))
        ok(m.setAccelTimeJoint(joint + 0.4))
        assert a.grpc_m("GetMinAccelTimeCartesian").acl_time == pytest.approx(cart + 0.1)
        assert a.grpc_m("GetMinAccelTimeJoint").acl_time == pytest.approx(joint + 0.2)
        assert rid(m.setAccelTimeJoint(joint + 0.1))[0] == ReturnCode.VALUE_ERR  # < minimum
    finally:
        ok(m.setMinAccelTimeCartesian(cart))
        ok(m.setMinAccelTimeJoint(joint))
        ok(m.setAccelTimeCartesian(cart))
        ok(m.setAccelTimeJoint(joint))


def test_joint_soft_limits_home_and_max_speeds_round_trip(a: Arm) -> None:
    limits = ok(a.c.getSoftLimitJoint())[1]
    home = ok(a.mid.getHome())[1]
    speeds = ok(a.mid.getMaxSpeedJoint())[1]
    try:
        narrower = [a.m.LimitValue(lv.upper - 1.0, lv.lower + 1.0) for lv in limits]
        ok(a.c.setSoftLimitJoint(narrower))
        assert a.grpc_c("GetSoftLimitJoint").soft_limit[0].upper == limits[0].upper - 1.0
        ok(a.mid.setHome([*home[:-1], home[-1] + 1.0]))
        assert a.grpc_m("GetHome").joint_point[-1] == home[-1] + 1.0
        ok(a.mid.setMaxSpeedJoint([s / 2 for s in speeds]))
        assert a.grpc_m("GetMaxSpeedJoint").speed[0] == speeds[0] / 2
    finally:
        ok(a.c.setSoftLimitJoint(limits))
        ok(a.mid.setHome(home))
        ok(a.mid.setMaxSpeedJoint(speeds))


# ------------------------------------------------------------------ motions
def _moves(a: Arm) -> dict[str, Callable[[], Any]]:
    up = a.car(a.hg((0.0, 0.0, 10.0)))
    # JARA's Cartesian moves keep the elbow angle: the moves up before the relative arc
    # bring the wrist pitch (r_arm_j6) within 2 deg of its limit, so that arc comes back
    # down (one more rise is refused naming the joint: the check finds no branch off it).
    down = a.car(a.hg((0.0, 0.0, -10.0)))
    via = a.car(a.hg((0.0, 5.0, -5.0)))
    cp = ok(a.mid.getFeedbackPosCartesian())[1]
    target = np.array(cp.carPos)
    target[2, 3] += 10.0
    absolute = a.car(target.tolist(), cp.elbow)
    via_abs = np.array(cp.carPos)
    via_abs[1, 3] += 5.0
    via_abs[2, 3] += 5.0
    q = ok(a.c.getFeedbackPosJoint())[1]
    n = ok(a.c.getManipInfo())[1].axisNum
    q_abs = list(q[:n])
    q_abs[0] += 3.0
    rel = [3.0] + [0.0] * (n - 1)
    m = a.mid
    return {
        "movePTPJointAbs": lambda: m.movePTPJointAbs(q_abs),
        "movePTPJointRel": lambda: m.movePTPJointRel(rel),
        "movePTPJointAbsCmdCycle": lambda: m.movePTPJointAbsCmdCycle(q_abs),
        "movePTPJointRelCmdCycle": lambda: m.movePTPJointRelCmdCycle([0.2] + [0.0] * (n - 1)),
        "moveLinearCartesianAbs": lambda: m.moveLinearCartesianAbs(absolute),
        "moveLinearCartesianRel": lambda: m.moveLinearCartesianRel(up),
        "moveLinearCartesianAbsCmdCycle": lambda: m.moveLinearCartesianAbsCmdCycle(absolute),
        "moveLinearCartesianRelCmdCycle": lambda: m.moveLinearCartesianRelCmdCycle(
            a.car(a.hg((0.0, 0.0, 0.5)))),
        "movePTPCartesianAbs": lambda: m.movePTPCartesianAbs(absolute),
        "movePTPCartesianRel": lambda: m.movePTPCartesianRel(up),
        "movePTPCartesianAbsCmdCycle": lambda: m.movePTPCartesianAbsCmdCycle(absolute),
        "movePTPCartesianRelCmdCycle": lambda: m.movePTPCartesianRelCmdCycle(
            a.car(a.hg((0.0, 0.0, 0.5)))),
        "moveCircularCartesianAbs": lambda: m.moveCircularCartesianAbs(
            a.car(via_abs.tolist(), cp.elbow), absolute),
        "moveCircularCartesianRel": lambda: m.moveCircularCartesianRel(via, down),
        "goHome": lambda: m.goHome(),
    }  # fmt: skip


MOVES = [
    "movePTPJointAbs", "movePTPJointRel", "movePTPJointAbsCmdCycle", "movePTPJointRelCmdCycle",
    "moveLinearCartesianAbs", "moveLinearCartesianRel", "moveLinearCartesianAbsCmdCycle",
    "moveLinearCartesianRelCmdCycle", "movePTPCartesianAbs", "movePTPCartesianRel",
    "movePTPCartesianAbsCmdCycle", "movePTPCartesianRelCmdCycle", "moveCircularCartesianAbs",
    "moveCircularCartesianRel", "goHome",
]  # fmt: skip


@pytest.mark.parametrize("op", MOVES)
def test_every_move_is_accepted_and_moves_the_arm(a: Arm, op: str) -> None:
    before = np.array(ok(a.c.getFeedbackPosJoint())[1])
    ok(_moves(a)[op]())
    a.d.wait_idle()
    after = np.array(ok(a.c.getFeedbackPosJoint())[1])
    if op == "goHome" and np.allclose(after, before, atol=1e-3):
        return  # already at home
    assert not np.allclose(after, before, atol=1e-4), op


def test_queue_pause_resume_stop(a: Arm) -> None:
    m = a.mid
    n = ok(a.c.getManipInfo())[1].axisNum
    ok(m.movePTPJointRel([20.0] + [0.0] * (n - 1)))
    ok(m.movePTPJointRel([-20.0] + [0.0] * (n - 1)))  # queued behind the first
    assert ok(a.c.getState())[1] & JaraState.MOVING
    ok(m.pause())
    assert a.d.wait_for(lambda: bool(ok(a.c.getState())[1] & JaraState.PAUSED))
    ok(m.resume())
    ok(m.stop())
    assert a.d.wait_for(lambda: not ok(a.c.getState())[1] & JaraState.MOVING)


def test_grippers_servo_alarms(a: Arm) -> None:
    ok(a.mid.openGripper())
    ok(a.mid.closeGripper())
    ok(a.mid.moveGripper(40))
    a.d.wait_idle()
    ok(a.c.servoOFF())
    assert a.d.wait_for(lambda: not ok(a.c.getState())[1] & JaraState.SERVO_ON)
    code, comment = rid(a.mid.movePTPJointRel([1.0]))
    twin = a.grpc_m("MovePTPJointRel", joint_points=[1.0])
    assert (code, comment) == (twin.return_id.id, twin.return_id.comment)
    ok(a.c.servoON())
    ok(a.c.clearAlarms())
    ok(a.mid.setControlPointOffset(a.hg()))


# ------------------------------------------------------------------ bad input
BAD: list[tuple[str, Callable[[Arm], Any], str]] = [
    ("movePTPJointAbs: 2 values", lambda a: a.mid.movePTPJointAbs([0.0, 0.0]), "jointPoints"),
    ("movePTPJointRel: NaN", lambda a: a.mid.movePTPJointRel([NAN] * 7), "jointPoints[0]"),
    ("movePTPJointRel: 100 values", lambda a: a.mid.movePTPJointRel([0.0] * 100), "jointPoints"),
    ("moveLinearCartesianRel: 1e308 mm",
     lambda a: a.mid.moveLinearCartesianRel(a.car(a.hg((1e308, 0.0, 0.0)))), "carPoint"),
    ("movePTPCartesianRel: elbow inf",
     lambda a: a.mid.movePTPCartesianRel(a.car(a.hg(), INF)), "carPoint.elbow"),
    ("setSoftLimitJoint: 2 limits",
     lambda a: a.c.setSoftLimitJoint([a.m.LimitValue(1.0, -1.0)] * 2), "soft_limit"),
    ("setSoftLimitJoint: NaN",
     lambda a: a.c.setSoftLimitJoint([a.m.LimitValue(NAN, -1.0)] * 7), "soft_limit[0]"),
    ("setMaxSpeedJoint: 3 values", lambda a: a.mid.setMaxSpeedJoint([10.0] * 3), "speed"),
    ("setSpeedJoint: 0 %", lambda a: a.mid.setSpeedJoint(0), "spd_ratio"),
    ("setSpeedCartesian: 101 %", lambda a: a.mid.setSpeedCartesian(101), "spd_ratio"),
    ("moveGripper: 101 %", lambda a: a.mid.moveGripper(101), "angle_ratio"),
    ("setAccelTimeJoint: NaN", lambda a: a.mid.setAccelTimeJoint(NAN), "acl_time"),
    ("setHome: 1 value", lambda a: a.mid.setHome([0.0]), "jointPoint"),
    ("setBaseOffset: inf", lambda a: a.mid.setBaseOffset(a.hg((INF, 0.0, 0.0))), "offset"),
    ("setMaxSpeedCartesian: -1",
     lambda a: a.mid.setMaxSpeedCartesian(a.m.CartesianSpeed(-1.0, 10.0)), "speed"),
]  # fmt: skip


@pytest.mark.parametrize(("case", "call", "names"), BAD, ids=[b[0] for b in BAD])
def test_bad_input_is_value_err_and_nothing_moves(
    a: Arm, case: str, call: Callable[[Arm], Any], names: str
) -> None:
    before = a.d.joints()
    code, comment = rid(call(a))
    assert code == ReturnCode.VALUE_ERR, comment
    assert comment.startswith(names), comment
    assert not ok(a.c.getState())[1] & JaraState.MOVING
    np.testing.assert_allclose(a.d.joints(), before, atol=NOTHING_MOVED)

"""Spec A (IntegratedMotionInterface) over CORBA against a running imotiond (SmartPal V, sim):
every operation from a client built from the product's IDL, with the same codes, comments
and results as over gRPC on the same daemon; bad input (unknown enum values, wrong lengths,
NaN, 1e308) is VALUE_ERR, nothing moves, the daemon stays up."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

pytest.importorskip("omniORB")

from omniORB import tcInternal

from controller.corba.stubs import _GlobalIDL as A
from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import ReturnCode
from controller.vocabulary import SpecAState as S
from tests.corba_support import NOTHING_MOVED, CorbaDaemon

NAN, INF = math.nan, math.inf
ARM_SPEED, ARM_ACCEL = [30.0], [100.0]
C_SPEED, C_ACCEL = A.CartesianSpeed(100.0, 30.0), A.CartesianAccel(500.0, 100.0)
G_SPEED = pb.CartesianSpeed(translation=100.0, rotation=30.0)
G_ACCEL = pb.CartesianAccel(translation=500.0, rotation=100.0)
R_SPEED = A.RedundantSpeed(60.0, 0.0, 10.0, 0.0, 200.0, 20.0)
R_ACCEL = A.RedundantAccel(200.0, 0.0, 30.0, 0.0, 400.0, 60.0)
ZERO_LIMIT = A.LimitValue(0.0, 0.0)


def hg(p: Any = (0.0, 0.0, 0.0), rot: Any = None) -> list[list[float]]:
    m = np.zeros((3, 4))
    m[:, :3] = np.eye(3) if rot is None else rot
    m[:, 3] = p
    return m.tolist()


def pos(p: Any = (0.0, 0.0, 0.0)) -> A.RedundantPos:
    return A.RedundantPos(0.0, 0.0, 0.0, 0.0, *p)


@pytest.fixture(scope="module")
def d(corba_daemon: CorbaDaemon) -> CorbaDaemon:
    corba_daemon.back_to_start()
    return corba_daemon


@pytest.fixture(scope="module")
def s(d: CorbaDaemon) -> Any:
    return d.ref("spec_a", A.IntegratedMotionInterface)


@pytest.fixture(autouse=True)
def ready(d: CorbaDaemon) -> None:
    d.ready()


def rid(reply: Any) -> tuple[int, str]:
    r = reply[0] if isinstance(reply, tuple) else reply
    return int(r.id), str(r.comment)


def ok(reply: Any) -> Any:
    code, comment = rid(reply)
    assert code == ReturnCode.OK, comment
    return reply


# ------------------------------------------------------------------ reads
def test_reads_are_the_grpc_answers(d: CorbaDaemon, s: Any) -> None:
    g = d.spec_a_grpc
    _, status, message = ok(s.getState())
    r = g.GetState(pb.GetStateRequest())
    assert (status, message) == (r.status_id, r.message) == (S.READY, r.message)
    assert ok(s.getVersion())[1] == g.GetVersion(pb.GetVersionRequest()).version
    assert ok(s.getActiveAlarm())[1] == []
    assert s.isMoving() is False and s.isServoOn() is True
    for side in (0, 1):
        for frame in (A.ORIGINAL_FRAME, A.CURRENT_FRAME):
            _, cp = ok(s.getFeedbackPosCartesian(A.RightLeft._items[side], frame))
            r = g.GetFeedbackPosCartesian(
                pb.GetFeedbackPosCartesianRequest(type=side, frame_type=frame._v)
            )
            np.testing.assert_allclose(np.ravel(cp.carPos), r.pos.car_pos.m, atol=1e-3)
            assert cp.elbow == pytest.approx(r.pos.elbow, abs=1e-3)
        _, ratio = ok(s.getGripperPos(A.RightLeft._items[side]))
        assert ratio == g.GetGripperPos(pb.GetGripperPosRequest(type=side)).angle_ratio
    for unit in A.UnitType._items:
        _, values = ok(s.getFeedbackPosJoint(unit))
        r = g.GetFeedbackPosJoint(pb.GetFeedbackPosJointRequest(type=unit._v))
        np.testing.assert_allclose(values, r.position, atol=1e-3)


# ------------------------------------------------------------------ motions
def motion_calls(s: Any) -> dict[str, Callable[[], Any]]:
    """One valid call per Spec A motion operation (accepted in Ready at the start pose)."""
    _, cp = ok(s.getFeedbackPosCartesian(A.RIGHT, A.ORIGINAL_FRAME))
    up = np.array(cp.carPos)
    up[2, 3] += 20.0
    rel = hg((0.0, 0.0, 20.0))
    _, arm = ok(s.getFeedbackPosJoint(A.RIGHT_ARM))
    target = list(arm)
    target[0] += 5.0
    return {
        "moveUnitAbs": lambda: s.moveUnitAbs(A.RIGHT_ARM, target, ARM_SPEED, ARM_ACCEL),
        "moveUnitRel": lambda: s.moveUnitRel(A.RIGHT_ARM, [2, 0, 0, 0, 0, 0, 0], ARM_SPEED,
                                             ARM_ACCEL),
        "moveCPHoldAbs": lambda: s.moveCPHoldAbs(
            A.RIGHT, A.RedundantPos(cp.elbow + 5, 0.0, *_lumbar_vehicle(s)), R_SPEED, R_ACCEL
        ),
        "moveCPHoldRel": lambda: s.moveCPHoldRel(
            A.RIGHT, A.RedundantPos(5.0, 0, 0, 0, 0, 0, 0), R_SPEED, R_ACCEL
        ),
        "moveLinearCartesianAbs": lambda: s.moveLinearCartesianAbs(
            A.RIGHT, up.tolist(), C_SPEED, C_ACCEL, False
        ),
        "moveLinearCartesianRel": lambda: s.moveLinearCartesianRel(
            A.RIGHT, A.BASE_FRAME, rel, C_SPEED, C_ACCEL, False
        ),
        "movePTPCartesianAbs": lambda: s.movePTPCartesianAbs(A.RIGHT, up.tolist(), 1.0, False),
        "movePTPCartesianRel": lambda: s.movePTPCartesianRel(A.RIGHT, rel, 1.0, True),
        "openGripper": lambda: s.openGripper(A.RIGHT),
        "closeGripper": lambda: s.closeGripper(A.LEFT),
        "moveGripper": lambda: s.moveGripper(A.RIGHT, 50),
    }  # fmt: skip


def _lumbar_vehicle(s: Any) -> tuple[float, ...]:
    lumbar = float(sum(ok(s.getFeedbackPosJoint(A.LUMBER))[1]))
    x, y, th = ok(s.getFeedbackPosJoint(A.VEHICLE))[1]
    return (lumbar, 0.0, x, y, th)


MOTION_OPS = [
    "moveUnitAbs", "moveUnitRel", "moveCPHoldAbs", "moveCPHoldRel", "moveLinearCartesianAbs",
    "moveLinearCartesianRel", "movePTPCartesianAbs", "movePTPCartesianRel", "openGripper",
    "closeGripper", "moveGripper",
]  # fmt: skip


@pytest.mark.parametrize("op", MOTION_OPS)
def test_every_motion_is_accepted_and_moves(d: CorbaDaemon, s: Any, op: str) -> None:
    grippers = {"openGripper": (A.RIGHT, 100), "closeGripper": (A.LEFT, 0),
                "moveGripper": (A.RIGHT, 50)}  # fmt: skip
    before = d.joints()
    ok(motion_calls(s)[op]())
    d.wait_idle()
    if op in grippers:
        side, ratio = grippers[op]
        assert d.wait_for(lambda: abs(ok(s.getGripperPos(side))[1] - ratio) <= 2)
    else:
        assert not np.allclose(d.joints(), before, atol=1e-3)


@pytest.mark.parametrize("op", MOTION_OPS)
def test_servo_off_refusals_are_the_grpc_ones(d: CorbaDaemon, s: Any, op: str) -> None:
    """Same code and comment over both transports (the one service decides)."""
    call = motion_calls(s)[op]
    ok(s.servoOff())
    assert d.wait_for(lambda: d.state() == S.SERVO_OFF)
    code, comment = rid(call())
    grpc_reply = getattr(d.spec_a_grpc, op[0].upper() + op[1:])(_grpc_twin(op, s))
    assert (code, comment) == (grpc_reply.return_id.id, grpc_reply.return_id.comment)
    assert code in (ReturnCode.STATUS_ERR, ReturnCode.NOT_SV_ON_ERR)


def _grpc_twin(op: str, s: Any) -> Any:
    """The gRPC request of the same operation with the same arguments as
    :func:`motion_calls` (arguments are checked before the state)."""
    rel = pb.HgMatrix(m=np.ravel(hg((0.0, 0.0, 20.0))).tolist())
    _, cp = ok(s.getFeedbackPosCartesian(A.RIGHT, A.ORIGINAL_FRAME))
    up = np.array(cp.carPos)
    up[2, 3] += 20.0
    up_hg = pb.HgMatrix(m=up.ravel().tolist())
    target = list(ok(s.getFeedbackPosJoint(A.RIGHT_ARM))[1])
    target[0] += 5.0
    lumbar, _, x, y, th = _lumbar_vehicle(s)
    red_speed = pb.RedundantSpeed(
        elbow=60, lumbar_ry=10, vehicle_translation=200, vehicle_rotation=20
    )
    red_accel = pb.RedundantAccel(
        elbow=200, lumbar_ry=30, vehicle_translation=400, vehicle_rotation=60
    )
    return {
        "moveUnitAbs": pb.MoveUnitAbsRequest(unit=pb.RIGHT_ARM, abs_pos=target,
                                             speed=ARM_SPEED, accel=ARM_ACCEL),
        "moveUnitRel": pb.MoveUnitRelRequest(unit=pb.RIGHT_ARM, rel_pos=[2, 0, 0, 0, 0, 0, 0],
                                             speed=ARM_SPEED, accel=ARM_ACCEL),
        "moveCPHoldAbs": pb.MoveCPHoldAbsRequest(
            type=pb.RIGHT, abs_pos=pb.RedundantPos(elbow=cp.elbow + 5, lumbar_ry=lumbar,
                                                   vehicle_x=x, vehicle_y=y, vehicle_theta=th),
            speed=red_speed, accel=red_accel),
        "moveCPHoldRel": pb.MoveCPHoldRelRequest(
            type=pb.RIGHT, rel_pos=pb.RedundantPos(elbow=5), speed=red_speed, accel=red_accel),
        "moveLinearCartesianAbs": pb.MoveLinearCartesianAbsRequest(
            type=pb.RIGHT, abs_hg_mat=up_hg, speed=G_SPEED, accel=G_ACCEL),
        "moveLinearCartesianRel": pb.MoveLinearCartesianRelRequest(
            type=pb.RIGHT, rel_hg_mat=rel, speed=G_SPEED, accel=G_ACCEL),
        "movePTPCartesianAbs": pb.MovePTPCartesianAbsRequest(type=pb.RIGHT, abs_hg_mat=up_hg,
                                                             time=1),
        "movePTPCartesianRel": pb.MovePTPCartesianRelRequest(type=pb.RIGHT, rel_hg_mat=rel, time=1,
                                                             is_hold_other_arm=True),
        "openGripper": pb.OpenGripperRequest(type=pb.RIGHT),
        "closeGripper": pb.CloseGripperRequest(type=pb.LEFT),
        "moveGripper": pb.MoveGripperRequest(type=pb.RIGHT, angle_ratio=50),
    }[op]  # fmt: skip


# ------------------------------------------------------------------ flow, servo, settings
def test_pause_resume_stop_abort(d: CorbaDaemon, s: Any) -> None:
    ok(s.moveUnitRel(A.RIGHT_ARM, [40, 0, 0, 0, 0, 0, 0], [10.0], [50.0]))
    assert s.isMoving() is True
    ok(s.pause())
    assert d.wait_for(lambda: ok(s.getState())[1] == S.PAUSE)
    ok(s.resume())
    assert d.wait_for(lambda: ok(s.getState())[1] == S.BUSY)
    ok(s.stop())
    assert d.wait_for(lambda: ok(s.getState())[1] == S.READY)
    ok(s.moveUnitRel(A.RIGHT_ARM, [-40, 0, 0, 0, 0, 0, 0], [10.0], [50.0]))
    ok(s.abort())
    assert d.wait_for(lambda: s.isMoving() is False)


def test_servo_alarms_frame(d: CorbaDaemon, s: Any) -> None:
    ok(s.servoOff())
    assert d.wait_for(lambda: s.isServoOn() is False)
    ok(s.servoOn())
    assert d.wait_for(lambda: s.isServoOn() is True)
    ok(s.clearAlarms())
    ok(s.resetOriginalFrame())


def test_control_point_offset_is_the_one_grpc_sees(d: CorbaDaemon, s: Any) -> None:
    def z() -> float:
        r = d.spec_a_grpc.GetFeedbackPosCartesian(
            pb.GetFeedbackPosCartesianRequest(type=pb.RIGHT, frame_type=pb.ORIGINAL_FRAME)
        )
        return float(np.reshape(r.pos.car_pos.m, (3, 4))[:, 3] @ [0, 0, 1])

    before = z()
    try:
        ok(s.setControlPointOffset(A.RIGHT, hg((0.0, 0.0, 50.0))))
        assert z() != pytest.approx(before, abs=1.0)
    finally:
        restore = d.spec_a_grpc.SetControlPointOffset(
            pb.SetControlPointOffsetRequest(
                type=pb.RIGHT, offset=pb.HgMatrix(m=np.ravel(hg()).tolist())
            )
        )
    assert restore.return_id.id == ReturnCode.OK


def test_select_redundant_axes(s: Any) -> None:
    mask = A.RedundantAxesMask(True, False, False, False, False, False, False)
    limit = A.RedundantLimit(*([ZERO_LIMIT] * 8))
    ok(s.selectRedundantAxes(mask, limit))
    bad = A.RedundantLimit(A.LimitValue(10.0, 20.0), *([ZERO_LIMIT] * 7))
    assert rid(s.selectRedundantAxes(mask, bad))[0] == ReturnCode.VALUE_ERR


# ------------------------------------------------------------------ bad input
def _raw(s: Any, op: str, args: tuple[Any, ...], enums: tuple[int, ...]) -> Any:
    """Call ``op`` with the parameters at ``enums`` sent as plain numbers (the bytes a C++
    client casting an int to the enum sends)."""
    ins, outs = getattr(A.IntegratedMotionInterface, f"_d_{op}")[:2]
    ins = tuple(tcInternal.tv_ulong if i in enums else t for i, t in enumerate(ins))
    return s._obj.invoke(op, (ins, outs, None), args)


BAD_INPUT = [
    ("closeGripper: RightLeft 2", lambda s: _raw(s, "closeGripper", (2,), (0,)), "type"),
    ("getFeedbackPosJoint: UnitType 9",
     lambda s: _raw(s, "getFeedbackPosJoint", (9,), (0,)), "type"),
    ("getFeedbackPosCartesian: FrameType 5",
     lambda s: _raw(s, "getFeedbackPosCartesian", (0, 5), (0, 1)), "frame_type"),
    ("moveLinearCartesianRel: CommandFrameType 3",
     lambda s: _raw(s, "moveLinearCartesianRel",
                    (0, 3, hg((0, 0, 10)), C_SPEED, C_ACCEL, False), (0, 1)), "frame_type"),
    ("moveUnitAbs: UnitType 4",
     lambda s: _raw(s, "moveUnitAbs", (4, [0.0], [1.0], [1.0]), (0,)), "unit"),
    ("moveUnitRel: 3 values for 7 joints",
     lambda s: s.moveUnitRel(A.RIGHT_ARM, [1.0, 2.0, 3.0], ARM_SPEED, ARM_ACCEL), "rel_pos"),
    ("moveUnitRel: 100 values",
     lambda s: s.moveUnitRel(A.RIGHT_ARM, [0.0] * 100, ARM_SPEED, ARM_ACCEL), "rel_pos"),
    ("moveUnitRel: NaN", lambda s: s.moveUnitRel(A.RIGHT_ARM, [NAN] + [0.0] * 6, ARM_SPEED,
                                                ARM_ACCEL), "rel_pos[0]"),
    ("moveUnitRel: speed inf", lambda s: s.moveUnitRel(A.RIGHT_ARM, [1.0] + [0.0] * 6, [INF],
                                                      ARM_ACCEL), "speed[0]"),
    ("movePTPCartesianRel: 1e308 mm",
     lambda s: s.movePTPCartesianRel(A.RIGHT, hg((0, 0, 1e308)), 1.0, False), "rel_hg_mat"),
    ("movePTPCartesianRel: time NaN",
     lambda s: s.movePTPCartesianRel(A.RIGHT, hg((0, 0, 10)), NAN, False), "time"),
    ("moveLinearCartesianAbs: rotation not orthonormal",
     lambda s: s.moveLinearCartesianAbs(A.RIGHT, hg((400, 0, 400), np.eye(3) * 2), C_SPEED,
                                        C_ACCEL, False), "abs_hg_mat"),
    ("moveCPHoldRel: elbow NaN",
     lambda s: s.moveCPHoldRel(A.RIGHT, A.RedundantPos(NAN, 0, 0, 0, 0, 0, 0), R_SPEED,
                               R_ACCEL), "rel_pos.elbow"),
    ("moveGripper: 101 %", lambda s: s.moveGripper(A.RIGHT, 101), "angle_ratio"),
    ("setControlPointOffset: inf", lambda s: s.setControlPointOffset(A.RIGHT, hg((INF, 0, 0))),
     "offset"),
    ("selectRedundantAxes: limit NaN",
     lambda s: s.selectRedundantAxes(
         A.RedundantAxesMask(True, False, False, False, False, False, False),
         A.RedundantLimit(A.LimitValue(NAN, 0.0), *([ZERO_LIMIT] * 7))), "limit.rightElbow"),
]  # fmt: skip


@pytest.mark.parametrize(("case", "call", "names"), BAD_INPUT, ids=[c[0] for c in BAD_INPUT])
def test_bad_input_is_value_err_and_nothing_moves(
    d: CorbaDaemon, s: Any, case: str, call: Callable[[Any], Any], names: str
) -> None:
    before = d.joints()
    code, comment = rid(call(s))
    assert code == ReturnCode.VALUE_ERR, comment
    assert comment.startswith(names), comment
    assert s.isMoving() is False
    np.testing.assert_allclose(d.joints(), before, atol=NOTHING_MOVED)
    assert ok(s.getState())[1] == S.READY  # the daemon is up and unchanged


def test_commands_are_logged_with_their_interface(d: CorbaDaemon, s: Any) -> None:
    start = len(d.lines)
    ok(s.clearAlarms())
    line = d.wait_line(r"command accepted.*op=clearAlarms", timeout=10.0, start=start).string
    assert "service=corba:IntegratedMotionInterface" in line

"""JARA_ARM_DUAL over CORBA against a running imotiond (SmartPal V, sim): the 14 operations
from a client built from the product's IDL, getRelativePosition's ruling (the pose in the
comment), refusals identical to gRPC's, bad input VALUE_ERR with nothing moving."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pytest

pytest.importorskip("omniORB")

from controller.corba.stubs import JARA_ARM_DUAL as D
from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import ReturnCode
from controller.vocabulary import SpecAState as S
from tests.corba_support import NOTHING_MOVED, CorbaDaemon

NAN = math.nan


@pytest.fixture(scope="module")
def d(corba_daemon: CorbaDaemon) -> CorbaDaemon:
    corba_daemon.back_to_start()
    return corba_daemon


@pytest.fixture(scope="module")
def c(d: CorbaDaemon) -> Any:
    return d.ref("jara_dual_common", D.DualManipulatorCommonInterface_Common)


@pytest.fixture(scope="module")
def m(d: CorbaDaemon) -> Any:
    return d.ref("jara_dual_middle", D.DualManipulatorCommonInterface_Middle)


@pytest.fixture(autouse=True)
def ready(d: CorbaDaemon) -> None:
    d.ready()


def ok(reply: Any) -> Any:
    assert reply.id == ReturnCode.OK, reply.comment
    return reply


def hg(p: Any = (0.0, 0.0, 0.0)) -> list[list[float]]:
    out = np.zeros((3, 4))
    out[:, :3] = np.eye(3)
    out[:, 3] = p
    return out.tolist()


def car(p: Any = (0.0, 0.0, 0.0), elbow: float = 0.0) -> Any:
    return D.CarPosWithElbow(hg(p), elbow, 0)


def test_relative_position_is_in_the_comment(d: CorbaDaemon, m: Any) -> None:
    reply = ok(m.getRelativePosition(hg()))
    numbers = [float(x) for x in re.findall(r"-?\d[\d.e+-]*", reply.comment.split("]]")[0])]
    g = d.dual_middle_grpc.GetRelativePosition(pb.DualManipulatorMiddleGetRelativePositionRequest())
    np.testing.assert_allclose(numbers, g.rel_pos.m, atol=1e-3)
    assert "in mm" in reply.comment


def test_moves_grippers_and_hands(d: CorbaDaemon, c: Any, m: Any) -> None:
    n = 7
    for call in (
        lambda: m.movePTPJointRel([2.0] + [0.0] * (n - 1), [-2.0] + [0.0] * (n - 1)),
        lambda: m.moveLinearCartesianRel(car((0.0, 0.0, 10.0)), car((0.0, 0.0, 10.0))),
        lambda: m.movePTPCartesianRel(car((0.0, 0.0, -10.0)), car((0.0, 0.0, -10.0))),
    ):
        before = d.joints()
        ok(call())
        d.wait_idle()
        assert not np.allclose(d.joints(), before, atol=1e-4)
    q = d.joints()
    ok(m.movePTPJointAbs(list(q[:7]), list(q[7:14])))  # where they are: accepted, no motion
    d.wait_idle()
    (r, r_elbow), (l_, l_elbow) = _poses(d)
    up_r, up_l = r.copy(), l_.copy()
    up_r[2, 3] += 5.0
    up_l[2, 3] += 5.0
    ok(m.moveLinearCartesianAbs(D.CarPosWithElbow(up_r.tolist(), r_elbow, 0),
                                D.CarPosWithElbow(up_l.tolist(), l_elbow, 0)))  # fmt: skip
    d.wait_idle()
    ok(m.movePTPCartesianAbs(D.CarPosWithElbow(r.tolist(), r_elbow, 0),
                             D.CarPosWithElbow(l_.tolist(), l_elbow, 0)))  # fmt: skip
    d.wait_idle()
    ok(m.openGripper(1, 1))
    ok(m.closeGripper(1, 0))
    ok(m.moveGripper(30, 60))
    d.wait_idle()
    ok(c.servoOFFHand())
    reply = m.openGripper(1, 1)
    twin = d.dual_middle_grpc.OpenGripper(
        pb.DualManipulatorMiddleOpenGripperRequest(r_arm=1, l_arm=1)
    )
    assert (reply.id, reply.comment) == (twin.return_id.id, twin.return_id.comment)
    assert reply.id == ReturnCode.STATUS_ERR
    ok(c.servoONHand())
    ok(c.servoOFFArm())
    assert d.wait_for(lambda: d.state() == S.SERVO_OFF)
    ok(c.servoONArm())


def _poses(d: CorbaDaemon) -> list[tuple[np.ndarray, float]]:
    """Both control points (HgMatrix [mm], elbow [deg]) in the arm frames (JARA_ARM
    feedback, over gRPC)."""
    out = []
    for arm in (pb.RIGHT, pb.LEFT):
        r = d.middle_grpc.GetFeedbackPosCartesian(
            pb.ManipulatorMiddleGetFeedbackPosCartesianRequest(arm=arm)
        )
        out.append((np.reshape(r.pos.car_pos.m, (3, 4)), r.pos.elbow))
    return out


BAD = [
    ("movePTPJointAbs: 3 right values",
     lambda m: m.movePTPJointAbs([0.0] * 3, [0.0] * 7), "rArm"),
    ("movePTPJointRel: NaN left", lambda m: m.movePTPJointRel([0.0] * 7, [NAN] * 7), "lArm[0]"),
    ("moveLinearCartesianRel: 1e308",
     lambda m: m.moveLinearCartesianRel(car((1e308, 0, 0)), car()), "rArm.carPos"),
    ("closeGripper: flag 2", lambda m: m.closeGripper(2, 0), "rArm"),
    ("moveGripper: 101 %", lambda m: m.moveGripper(0, 101), "lArm"),
]  # fmt: skip


@pytest.mark.parametrize(("case", "call", "names"), BAD, ids=[b[0] for b in BAD])
def test_bad_input_is_value_err_and_nothing_moves(
    d: CorbaDaemon, m: Any, case: str, call: Any, names: str
) -> None:
    before = d.joints()
    reply = call(m)
    assert reply.id == ReturnCode.VALUE_ERR, reply.comment
    assert reply.comment.startswith(names), reply.comment
    assert not d.moving()
    np.testing.assert_allclose(d.joints(), before, atol=NOTHING_MOVED)

"""Motion quality through the daemon (imotiond on ``--hal ideal``/``sim`` over gRPC): moves
end on their targets, never pass them, and "Ready"/idle means still (issues 15, 16, 17)."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import pytest

from controller.rpc import imotion_pb2 as pb
from controller.service.codes import Code
from tests.daemon_support import TestDaemon

OK = Code.OK


def M(name, **kw):
    return getattr(pb, f"ManipulatorMiddle{name}Request")(**kw)


def C(name, **kw):
    return getattr(pb, f"ManipulatorCommon{name}Request")(**kw)


def code(reply) -> int:
    return int(reply.return_id.id)


def jara_joints(d: TestDaemon, arm: int = 0) -> np.ndarray:
    return np.array(d.common.GetFeedbackPosJoint(C("GetFeedbackPosJoint", arm=arm)).pos)


def watch(d: TestDaemon, read: Callable[[], np.ndarray], timeout: float = 30.0) -> np.ndarray:
    """Samples of ``read()`` until the daemon says idle (IsMoving false), then the final
    one; rows in time order."""
    samples = [read()]
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        samples.append(read())
        if not d.spec_a.IsMoving(pb.IsMovingRequest()).is_moving:
            break
    samples.append(read())
    return np.array(samples)


@pytest.fixture(scope="module")
def seednoid():
    d = TestDaemon("seednoid")
    yield d
    d.close()


@pytest.fixture
def noid(seednoid):
    seednoid.reset()
    seednoid.wait_idle()
    yield seednoid
    seednoid.middle.Stop(M("Stop"))
    seednoid.wait_idle()


# ------------------------------------------------------------------ 15.4 PTP overshoot
def test_ptp_joint_at_full_speed_never_passes_its_target(noid):
    """Issue 15.4: J3 −40 → 85 deg at 100 % passed 85 deg by 1.6 deg (the target lies
    within the braking distance of the 90 deg limit)."""
    d = noid
    assert code(d.middle.SetSpeedJoint(M("SetSpeedJoint", spd_ratio=100))) == OK
    target = jara_joints(d)[:7]
    target[2] = -40.0
    assert code(d.middle.MovePTPJointAbs(M("MovePTPJointAbs", joint_points=target))) == OK
    assert d.wait_idle()
    target[2] = 85.0
    assert code(d.middle.MovePTPJointAbs(M("MovePTPJointAbs", joint_points=target))) == OK
    samples = watch(d, lambda: jara_joints(d)[:7])
    assert samples[:, 2].max() <= 85.0 + 1e-3, samples[:, 2].max()
    np.testing.assert_allclose(samples[-1], target, atol=1e-3)

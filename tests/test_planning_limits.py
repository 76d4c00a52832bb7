"""controller.gateway.planning.limits through the daemon: the vehicle workspace (issue
16.5), the tool offset, arcs (issue 15.6); and the comments of issue 15.8."""

from __future__ import annotations

import logging
from collections.abc import Iterator

import numpy as np
import pytest

from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import ReturnCode
from tests.daemon_support import TestDaemon

RIGHT = pb.RIGHT
V_SPEED, V_ACCEL = [100.0, 10.0], [100.0, 10.0]  # mm/s, deg/s; mm/s², deg/s²


def hg(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> pb.HgMatrix:
    return pb.HgMatrix(m=[1.0, 0, 0, x, 0, 1.0, 0, y, 0, 0, 1.0, z])


@pytest.fixture(scope="module")
def daemon() -> Iterator[TestDaemon]:
    d = TestDaemon("smartpal5")
    d.reset()
    assert d.wait_for(lambda: d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on)
    yield d
    d.close()


@pytest.fixture
def d(daemon: TestDaemon, caplog: pytest.LogCaptureFixture) -> Iterator[TestDaemon]:
    """The daemon; the test must leave the robot where it was, and log no traceback."""
    q0 = np.array(daemon.ctx.snapshot().q)
    with caplog.at_level(logging.INFO, logger="imotiond"):
        yield daemon
    assert not [r for r in caplog.records if r.exc_info]
    assert float(np.abs(np.array(daemon.ctx.snapshot().q) - q0).max()) < 1e-9


def value_err(reply: object) -> str:
    rid = reply.return_id  # type: ignore[attr-defined]
    assert rid.id == ReturnCode.VALUE_ERR, rid
    return str(rid.comment)


# ------------------------------------------------------------------ vehicle workspace
@pytest.mark.parametrize(
    "rel_pos, fragment",
    [
        ([1e12, 0.0, 0.0], "out of range"),  # beyond the edge bound (100 m)
        ([20_000.0, 0.0, 0.0], "outside the vehicle workspace -10000..10000 mm"),
        ([0.0, -10_500.0, 0.0], "vehicle y -10500 mm"),
        ([0.0, 0.0, 1e12], "out of range"),
        ([0.0, 0.0, 800.0], "outside the vehicle workspace -720..720 deg"),
    ],
)
def test_move_unit_rel_refuses_targets_outside_the_workspace(
    d: TestDaemon, rel_pos: list[float], fragment: str
) -> None:
    request = pb.MoveUnitRelRequest(unit=pb.VEHICLE, rel_pos=rel_pos, speed=V_SPEED, accel=V_ACCEL)
    assert fragment in value_err(d.spec_a.MoveUnitRel(request))


def test_move_unit_abs_refuses_a_heading_outside_the_workspace(d: TestDaemon) -> None:
    for theta in (1e12, 1e308, 721.0):
        request = pb.MoveUnitAbsRequest(
            unit=pb.VEHICLE, abs_pos=[0.0, 0.0, theta], speed=V_SPEED, accel=V_ACCEL
        )
        assert "abs_pos[2]" in value_err(d.spec_a.MoveUnitAbs(request))


def test_cp_hold_refuses_a_vehicle_target_outside_the_workspace(d: TestDaemon) -> None:
    request = pb.MoveCPHoldRelRequest(
        type=RIGHT,
        rel_pos=pb.RedundantPos(vehicle_x=15_000.0),
        speed=pb.RedundantSpeed(vehicle_translation=200.0, vehicle_rotation=20.0),
        accel=pb.RedundantAccel(vehicle_translation=400.0, vehicle_rotation=60.0),
    )
    assert "rel_pos.vehicle_x" in value_err(d.spec_a.MoveCPHoldRel(request))


def test_redundant_limits_of_the_vehicle_lie_in_the_workspace(d: TestDaemon) -> None:
    limit = pb.RedundantLimit(vehicle_x=pb.LimitValue(upper=50_000.0, lower=-10.0))
    mask = pb.RedundantAxesMask(elbow=True, vehicle_x=True)
    request = pb.SelectRedundantAxesRequest(redundancy=mask, limit=limit)
    assert "limit.vehicle_x" in value_err(d.spec_a.SelectRedundantAxes(request))
    limit = pb.RedundantLimit(vehicle_theta=pb.LimitValue(upper=10.0, lower=-1000.0))
    request = pb.SelectRedundantAxesRequest(redundancy=mask, limit=limit)
    assert "limit.vehicle_theta" in value_err(d.spec_a.SelectRedundantAxes(request))
    ok = pb.RedundantLimit(vehicle_x=pb.LimitValue(upper=500.0, lower=-500.0))
    request = pb.SelectRedundantAxesRequest(redundancy=pb.RedundantAxesMask(elbow=True), limit=ok)
    assert d.spec_a.SelectRedundantAxes(request).return_id.id == ReturnCode.OK


# ------------------------------------------------------------------ arcs (issue 15.6)
def _arc(d: TestDaemon, via: pb.HgMatrix, target: pb.HgMatrix) -> str:
    request = pb.ManipulatorMiddleMoveCircularCartesianRelRequest(
        car_point_r=pb.CarPosWithElbow(car_pos=via), car_point_t=pb.CarPosWithElbow(car_pos=target)
    )
    return value_err(d.middle.MoveCircularCartesianRel(request))


def test_arcs_without_a_circle_are_value_errors_with_a_plain_comment(d: TestDaemon) -> None:
    assert "one line" in _arc(d, hg(10.0), hg(20.0))  # collinear
    assert "via point is the start" in _arc(d, hg(), hg(20.0))
    assert "target is the start" in _arc(d, hg(10.0), hg())
    assert "coincides with the target" in _arc(d, hg(10.0, 5.0), hg(10.0, 5.0))


def test_absolute_arc_through_the_start_is_a_value_error(d: TestDaemon) -> None:
    here = d.middle.GetFeedbackPosCartesian(
        pb.ManipulatorMiddleGetFeedbackPosCartesianRequest()
    ).pos
    m = list(here.car_pos.m)
    via = pb.CarPosWithElbow(car_pos=pb.HgMatrix(m=m), elbow=here.elbow)
    m2 = list(m)
    m2[3] += 20.0
    target = pb.CarPosWithElbow(car_pos=pb.HgMatrix(m=m2), elbow=here.elbow)
    request = pb.ManipulatorMiddleMoveCircularCartesianAbsRequest(
        car_point_r=via, car_point_t=target
    )
    assert "via point is the start" in value_err(d.middle.MoveCircularCartesianAbs(request))


# ------------------------------------------------------------------ issue 15.8
def test_set_soft_limit_joint_in_alarm_says_alarms_are_active(daemon: TestDaemon) -> None:
    from hal.interface import HardwareFault

    d = daemon
    limits = d.common.GetSoftLimitJoint(pb.ManipulatorCommonGetSoftLimitJointRequest()).soft_limit
    request = pb.ManipulatorCommonSetSoftLimitJointRequest(soft_limit=limits)
    d.daemon.hw.inject_fault(HardwareFault(0x400, "r_arm_j1", "test fault"))
    try:
        assert d.wait_for(
            lambda: d.common.GetState(pb.ManipulatorCommonGetStateRequest()).state & 4
        )
        rid = d.common.SetSoftLimitJoint(request).return_id
        assert rid.id == ReturnCode.STATUS_ERR
        assert rid.comment == "alarms are active: clearAlarms first"
    finally:
        d.reset()
        assert d.wait_for(lambda: d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on)

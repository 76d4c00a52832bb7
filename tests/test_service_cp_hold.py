"""Spec A moveCPHold through the daemon: only the commanded axes move, and when the body
(waist or vehicle) moves under both hands, both control points are held."""

from __future__ import annotations

import numpy as np
import pytest

from controller.rpc import imotion_pb2 as pb
from tests.daemon_support import TestDaemon


@pytest.fixture(scope="module")
def d():
    daemon = TestDaemon("smartpal5")
    daemon.reset()
    yield daemon
    daemon.close()


def state(d):
    a = d.spec_a
    units = [
        np.array(a.GetFeedbackPosJoint(pb.GetFeedbackPosJointRequest(type=u)).position)
        for u in (2, 3)  # LUMBER, VEHICLE
    ]
    hands = [
        np.array(
            a.GetFeedbackPosCartesian(pb.GetFeedbackPosCartesianRequest(type=s)).pos.car_pos.m
        )[3::4]
        for s in (0, 1)
    ]
    return units, hands


def cp_hold(d, **rel):
    speed = pb.RedundantSpeed(elbow=20, lumbar_ry=10, vehicle_translation=100, vehicle_rotation=10)
    accel = pb.RedundantAccel(elbow=40, lumbar_ry=20, vehicle_translation=200, vehicle_rotation=20)
    r = d.spec_a.MoveCPHoldRel(
        pb.MoveCPHoldRelRequest(type=0, rel_pos=pb.RedundantPos(**rel), speed=speed, accel=accel)
    )
    assert r.return_id.id == 0, r.return_id.comment
    assert d.wait_idle()


def test_elbow_swing_moves_neither_waist_nor_vehicle(d):
    (waist0, vehicle0), (right0, left0) = state(d)
    cp_hold(d, elbow=-30)  # outward (+30 brings the elbow within 20 mm of the torso)
    (waist1, vehicle1), (right1, left1) = state(d)
    np.testing.assert_allclose(waist1, waist0, atol=1e-9)
    np.testing.assert_allclose(vehicle1, vehicle0, atol=1e-9)
    np.testing.assert_allclose(right1, right0, atol=0.01)  # mm
    np.testing.assert_allclose(left1, left0, atol=1e-9)


@pytest.mark.parametrize("rel", [{"vehicle_x": 150}, {"lumbar_ry": 10}])
def test_body_moves_under_both_held_hands(d, rel):
    (waist0, vehicle0), (right0, left0) = state(d)
    cp_hold(d, **rel)
    (waist1, vehicle1), (right1, left1) = state(d)
    if "vehicle_x" in rel:
        assert vehicle1[0] - vehicle0[0] == pytest.approx(150.0, abs=0.01)
        np.testing.assert_allclose(waist1, waist0, atol=1e-9)
    else:
        assert waist1.sum() - waist0.sum() == pytest.approx(10.0, abs=0.01)
        np.testing.assert_allclose(vehicle1, vehicle0, atol=1e-9)
    np.testing.assert_allclose(right1, right0, atol=0.01)
    np.testing.assert_allclose(left1, left0, atol=0.01)


def test_a_cp_hold_to_where_the_axes_already_are_is_ok_and_moves_nothing(d):
    (waist0, vehicle0), (right0, _) = state(d)
    cp_hold(d)  # every relative amount 0
    (waist1, vehicle1), (right1, _) = state(d)
    np.testing.assert_allclose(waist1, waist0, atol=1e-9)
    np.testing.assert_allclose(vehicle1, vehicle0, atol=1e-9)
    np.testing.assert_allclose(right1, right0, atol=1e-9)


SPEED = pb.RedundantSpeed(
    elbow=20, lumbar_rx=10, lumbar_ry=10, lumbar_rz=10, vehicle_translation=100, vehicle_rotation=10
)
ACCEL = pb.RedundantAccel(
    elbow=40, lumbar_rx=20, lumbar_ry=20, lumbar_rz=20, vehicle_translation=200, vehicle_rotation=20
)


def rel_request(**rel):
    return pb.MoveCPHoldRelRequest(type=0, rel_pos=pb.RedundantPos(**rel), speed=SPEED, accel=ACCEL)


def test_elbow_ruling_refuses_more_than_half_a_turn_and_absurd_angles(d):
    """Issue 16.11: +720 deg was OK "already at its target", 1e6 deg was accepted. Ruling:
    absolute -360..360 deg, relative -180..180 deg, VALUE_ERR outside (docs/interfaces)."""
    (waist0, vehicle0), (right0, _) = state(d)
    r = d.spec_a.MoveCPHoldRel(rel_request(elbow=720))
    assert r.return_id.id == -3, r.return_id.comment
    assert "rel_pos.elbow" in r.return_id.comment and "-180..180" in r.return_id.comment
    r = d.spec_a.MoveCPHoldAbs(
        pb.MoveCPHoldAbsRequest(
            type=0, abs_pos=pb.RedundantPos(elbow=1e6), speed=SPEED, accel=ACCEL
        )
    )
    assert r.return_id.id == -3, r.return_id.comment
    assert "abs_pos.elbow" in r.return_id.comment
    assert not d.spec_a.IsMoving(pb.IsMovingRequest()).is_moving
    (waist1, vehicle1), (right1, _) = state(d)
    np.testing.assert_allclose(right1, right0, atol=1e-9)
    np.testing.assert_allclose(waist1, waist0, atol=1e-9)
    np.testing.assert_allclose(vehicle1, vehicle0, atol=1e-9)


@pytest.fixture(scope="module")
def pa10():
    daemon = TestDaemon("pa10")
    daemon.reset()
    yield daemon
    daemon.close()


def test_axes_the_robot_lacks_are_named_in_the_comment(pa10):
    """Issue 16.10: PA10 (no waist, no vehicle) answered OK "every redundant axis is already
    at its target" for lumbar/vehicle values; the comment now says they are ignored."""
    r = pa10.spec_a.MoveCPHoldRel(rel_request(lumbar_rx=5, vehicle_x=100))
    assert r.return_id.id == 0, r.return_id.comment
    comment = r.return_id.comment
    assert "no lumbar_rx, vehicle_x" in comment and "ignored" in comment, comment
    assert not pa10.spec_a.IsMoving(pb.IsMovingRequest()).is_moving


@pytest.fixture(scope="module")
def seednoid():
    daemon = TestDaemon("seednoid")
    daemon.reset()
    yield daemon
    daemon.close()


@pytest.mark.parametrize("dy", [150.0, -150.0])
def test_a_refusal_names_the_commanded_axis_and_the_binding_joints(seednoid, dy):
    """Issue 16.9: vehicleY +150 mm was refused blaming "vehicleX stopped 12 mm short"."""
    r = seednoid.spec_a.MoveCPHoldRel(rel_request(vehicle_y=dy))
    assert r.return_id.id == -6, r.return_id.comment  # CANNOT_REACH_TARGET_ERR
    comment = r.return_id.comment
    assert "vehicleY" in comment and "vehicleX" not in comment, comment
    assert "at their limits" in comment or "reach" in comment, comment
    assert not seednoid.spec_a.IsMoving(pb.IsMovingRequest()).is_moving

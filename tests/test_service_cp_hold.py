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
    cp_hold(d, elbow=30)
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

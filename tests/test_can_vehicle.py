"""hal.can.vehicle: wheel matrices, command -> wheels -> odometry round trip."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.model.profile import Wheels
from hal.can.vehicle import VehicleMapping, wheel_matrix

OMNI = Wheels(kind="omni", count=3, radius=0.075, track=0.45)
MECANUM = Wheels(kind="mecanum", count=4, radius=0.076, track=0.39, wheelbase=0.453)
DIFF = Wheels(kind="differential", count=2, radius=0.1, track=0.4)


def test_wheel_speeds_of_simple_motions():
    # Differential: forward 1 m/s turns both wheels at 1/r; turning spins them apart.
    np.testing.assert_allclose(wheel_matrix(DIFF) @ [1, 0, 0], [10, 10])
    np.testing.assert_allclose(wheel_matrix(DIFF) @ [0, 0, 1], [-2, 2])
    # Mecanum sideways: front-left and rear-right backwards.
    np.testing.assert_allclose(np.sign(wheel_matrix(MECANUM) @ [0, 1, 0]), [-1, 1, 1, -1])
    # Omni: pure rotation turns every wheel alike.
    w = wheel_matrix(OMNI) @ [0, 0, 1]
    np.testing.assert_allclose(w, w[0])
    with pytest.raises(ValueError):
        wheel_matrix(Wheels(kind="mecanum", count=4, radius=0.1, track=0.3))


@pytest.mark.parametrize("wheels", [OMNI, MECANUM])
def test_wheels_following_exactly_reproduce_the_commanded_pose(wheels: Wheels):
    cmd, odo = VehicleMapping(wheels), VehicleMapping(wheels)
    n = cmd.matrix.shape[0]
    cmd.start(np.zeros(n))
    odo.start(np.zeros(n))
    dt = 0.002
    for k in range(1, 2001):
        t = k * dt
        pose = np.array([0.5 * math.sin(t), 0.3 * (1 - math.cos(t)), 0.8 * t])
        targets = cmd.command(pose).copy()
        odo.measure(targets, None, dt)
    np.testing.assert_allclose(odo.pose, pose, atol=1e-9)
    assert np.all(np.isfinite(odo.velocity))


def test_differential_base_cannot_slide_sideways():
    cmd, odo = VehicleMapping(DIFF), VehicleMapping(DIFF)
    cmd.start(np.zeros(2))
    odo.start(np.zeros(2))
    odo.measure(cmd.command(np.array([0.1, 0.05, 0.0])).copy(), None, 0.01)
    assert odo.pose[0] == pytest.approx(0.1)
    assert odo.pose[1] == pytest.approx(0.0)


def test_hold_resets_the_command_to_the_odometry():
    m = VehicleMapping(OMNI)
    m.start(np.array([1.0, 2.0, 3.0]), pose=np.array([0.2, 0.1, 0.3]))
    m.hold()
    np.testing.assert_allclose(m.command_pose, [0.2, 0.1, 0.3])
    np.testing.assert_allclose(m.wheel_targets, [1.0, 2.0, 3.0])


def test_an_empty_mapping_has_arrays_of_no_wheels():
    m = VehicleMapping.empty()
    assert m.matrix.shape == (0, 3) and m.inverse.shape == (3, 0)
    assert m.pose.shape == m.velocity.shape == m.command_pose.shape == (3,)
    assert m._wheels.shape == m.wheel_targets.shape == (0,)


def test_measured_wheels_is_the_odometry_array_itself():
    mapping = VehicleMapping(OMNI)
    wheels = mapping.measured_wheels
    mapping.start(np.array([0.1, 0.2, 0.3]))
    mapping.measure(np.array([0.2, 0.2, 0.4]), None, 0.002)
    assert mapping.measured_wheels is wheels  # updated in place (compiled callers share it)
    np.testing.assert_array_equal(wheels, [0.2, 0.2, 0.4])
    assert VehicleMapping.empty().measured_wheels.shape == (0,)

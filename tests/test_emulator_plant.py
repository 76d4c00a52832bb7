"""hal.emulator.plant: what a period does to the simulation (the compiled and NumPy steps
are compared in test_emulator_kernels.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.model import jit
from controller.model.robot import load_robot
from hal.can.drive_profile import drives_path, load_drive_profile
from hal.emulator.plant import Plant
from hal.interface import HardwareState


@pytest.mark.parametrize("compiled", [True, False])
def test_a_diverged_simulation_is_put_back_within_the_step_and_the_plant_steps_on(
    compiled, monkeypatch, tmp_path
):
    monkeypatch.chdir(tmp_path)  # MuJoCo appends its warning to ./MUJOCO_LOG.TXT
    robot = load_robot("pa10")
    profile = load_drive_profile(drives_path(robot), robot)
    plant = Plant(robot, profile, 1.0 / profile.rate_hz, compiled=compiled and jit.available())
    plant.start()
    start = plant.position_counts()
    torque = np.ones(start.size, dtype=bool)
    for _ in range(3):
        plant.step(start, torque)
    before = plant.sim_time
    plant.backend.data.qvel[0] = math.nan
    plant.step(start, torque)
    # The step's physics diverged and was reset in that same step: servos on again, finite
    # measured values, time going on (a SYNC's TPDOs never carry a faulted simulation).
    assert plant.backend.state is HardwareState.ACTIVE
    assert plant.backend.servo_mask.all()
    assert np.isfinite(plant.position).all() and np.isfinite(plant.velocity).all()
    assert plant.sim_time > before
    plant.step(start, torque)
    assert plant.backend.state is HardwareState.ACTIVE

"""DriveEmulator: the MuJoCo plant, construction, the synchronous API, bus-off."""

from __future__ import annotations

import math

import can
import numpy as np
import pytest

from controller.model.robot import load_robot
from hal.can.vehicle import VehicleMapping
from hal.emulator.drive_state import PowerState
from hal.emulator.emulator import DriveEmulator
from tests.emulator_support import FakeClock, FrameMaster, tpdo1


@pytest.fixture(scope="module")
def pa10():
    return load_robot("pa10")


@pytest.fixture(scope="module")
def smartpal5():
    return load_robot("smartpal5")


def _operational(emulator: DriveEmulator) -> None:
    """Every drive OPERATIONAL and enabled, without frames (direct API)."""
    for drive in emulator.drives.values():
        drive.on_nmt(bytes([0x01, 0]), 0.0)
        for controlword in (0x06, 0x07, 0x0F):
            drive._apply_controlword(controlword)
        drive._after_state_change(False)
        assert drive.sm.state is PowerState.OPERATION_ENABLED


def test_every_joint_tracks_a_sine_in_csp(smartpal5):
    with DriveEmulator(smartpal5) as emulator:
        _operational(emulator)
        joints = [n for n in emulator.drives if n not in emulator.profile.wheels]
        scaling = {n: emulator.profile.drives[n].scaling() for n in joints}
        start = {n: scaling[n].to_si(emulator.drives[n].actual) for n in joints}
        middle = {n: 0.5 * (smartpal5.joints[n].lower + smartpal5.joints[n].upper) for n in joints}
        away = {n: 1.0 if middle[n] > start[n] else -1.0 for n in joints}  # from the limits
        worst = 0.0
        for k in range(1, 251):  # 0.5 s of a 0.05 rad, 2 Hz sine
            offset = 0.05 * math.sin(math.pi * 2.0 * k * emulator.period)
            for n in joints:
                emulator.drives[n].target = scaling[n].to_counts(start[n] + away[n] * offset)
            emulator.on_sync()
            for n in joints:
                wanted = start[n] + away[n] * offset
                worst = max(worst, abs(scaling[n].to_si(emulator.drives[n].actual) - wanted))
        assert worst < math.radians(0.5)


def test_wheel_drives_move_the_base_and_report_consistent_wheels(smartpal5):
    """Wheel targets from the master's own mapping drive the base; the wheels the emulator
    reports give back the pose through the master's odometry."""
    with DriveEmulator(smartpal5) as emulator:
        _operational(emulator)
        wheels = emulator.profile.wheels
        scaling = [emulator.profile.drives[w].scaling() for w in wheels]
        master = VehicleMapping(smartpal5.profile.vehicle.wheels)
        angles = np.array(
            [s.to_si(emulator.drives[w].actual) for s, w in zip(scaling, wheels, strict=True)]
        )
        master.start(angles)
        odometry = VehicleMapping(smartpal5.profile.vehicle.wheels)
        odometry.start(angles)
        steps = 500
        for k in range(1, steps + 1):  # 1 s: forward 0.2 m while turning 0.3 rad
            s = k / steps
            targets = master.command(np.array([0.2 * s, 0.0, 0.3 * s]))
            for w, sc, target in zip(wheels, scaling, targets, strict=True):
                emulator.drives[w].target = sc.to_counts(target)
            emulator.on_sync()
            measured = np.array(
                [sc.to_si(emulator.drives[w].actual) for sc, w in zip(scaling, wheels, strict=True)]
            )
            odometry.measure(measured, None, emulator.period)
        for _ in range(100):  # settle
            emulator.on_sync()
            measured = np.array(
                [sc.to_si(emulator.drives[w].actual) for sc, w in zip(scaling, wheels, strict=True)]
            )
            odometry.measure(measured, None, emulator.period)
        data = emulator.plant.backend.read()
        names = emulator.plant.backend.joint_names
        pose = np.array([data.position[names.index(j)] for j in smartpal5.unit_joints("VEHICLE")])
        assert pose == pytest.approx([0.2, 0.0, 0.3], abs=2e-3)
        assert odometry.pose == pytest.approx(pose, abs=1e-4)


def test_one_wheel_without_torque_stops_the_base(smartpal5):
    with DriveEmulator(smartpal5) as emulator:
        _operational(emulator)
        wheel = emulator.profile.wheels[0]
        emulator.inject("emcy", wheel)
        for drive_name in emulator.profile.wheels:
            drive = emulator.drives[drive_name]
            drive.target = drive.actual + 100_000
        for _ in range(20):
            emulator.on_sync()
        assert not emulator.plant.backend._servo_mask[-3:].any()


def test_construction_errors_name_the_problem(pa10, tmp_path):
    with pytest.raises(ValueError, match="unknown buses"):
        DriveEmulator(pa10, channels={"can9": ("virtual", "x")})
    with pytest.raises(ValueError, match="period"):
        DriveEmulator(pa10, period=0.0)
    emulator = DriveEmulator(pa10, channels={"arm_a": ("no_such_interface", "x")})
    with pytest.raises(OSError, match="bus arm_a"):
        emulator.open()
    emulator.close()
    with DriveEmulator(pa10) as emulator, pytest.raises(ValueError, match="unknown bus"):
        emulator.open_master_bus("can9")


def test_wait_answered_counts_the_syncs_handled_per_bus(pa10):
    clock = FakeClock()
    with DriveEmulator(pa10, clock=clock) as emulator:
        emulator.open()
        a, b = FrameMaster(emulator, "arm_a", clock), FrameMaster(emulator, "arm_b", clock)
        a.nmt(0x01)
        a.send(0x080)
        b.send(0x080)  # arm_b pre-operational: handled, nobody answers
        emulator.poll()
        assert emulator.sync_counts() == {"arm_a": 1, "arm_b": 1}
        assert not emulator.wait_answered({"arm_a": 2}, 0.0)
        assert emulator.wait_answered({"arm_a": 1, "arm_b": 1}, 0.0)
        assert tpdo1(a.frames(), 1) is not None and tpdo1(b.frames(), 5) is None
        emulator.inject("bus_off", bus="arm_a")
        emulator.process("arm_a", can.Message(arbitration_id=0x080, is_extended_id=False))
        assert emulator.sync_counts()["arm_a"] == 2  # ignored while bus-off, but handled
        assert a.frames() == []
        a.close()
        b.close()

"""hal.emulator.sync_round: each bus answered on its own SYNC, the physics between rounds."""

from __future__ import annotations

import pytest

from controller.model.robot import load_robot
from hal.emulator.emulator import DriveEmulator
from tests.emulator_support import FakeClock, FrameMaster, tpdo1


@pytest.fixture(scope="module")
def pa10():
    return load_robot("pa10")


def test_each_bus_is_answered_on_its_own_sync(pa10):
    clock = FakeClock()
    with DriveEmulator(pa10, clock=clock) as emulator:
        emulator.open()
        a, b = FrameMaster(emulator, "arm_a", clock), FrameMaster(emulator, "arm_b", clock)
        a.nmt(0x01)
        b.nmt(0x01)
        a.send(0x080)
        assert tpdo1(a.exchange(), 1) is not None  # at once: no wait for arm_b
        b.send(0x080)
        assert tpdo1(b.exchange(), 5) is not None
        assert emulator.cycles == 0  # the first round: nothing to step yet
        for _ in range(3):  # arm_b goes silent: arm_a's SYNCs go on, each a new round
            a.send(0x080)
            assert tpdo1(a.exchange(), 1) is not None
        assert emulator.cycles == 3
        b.send(0x080)  # arm_b back: part of the round arm_a opened
        assert tpdo1(b.exchange(), 5) is not None
        assert emulator.cycles == 3
        b.send(0x080)  # arm_b first this time: it opens the next round
        b.exchange()
        a.send(0x080)
        a.exchange()
        assert emulator.cycles == 4
        assert emulator.sim_time == pytest.approx(4 * emulator.period)
        a.close()
        b.close()


def test_a_target_acts_over_the_period_up_to_the_next_sync(pa10):
    """TPDOs sample at SYNC: the position answering round k is that of round k - 1's target."""
    clock = FakeClock()
    with DriveEmulator(pa10, clock=clock) as emulator:
        emulator.open()
        a = FrameMaster(emulator, "arm_a", clock)
        a.nmt(0x01)
        position = tpdo1(a.cycle(), 1)[1]
        for controlword in (0x06, 0x07, 0x0F):
            status = tpdo1(a.cycle({1: (controlword, position)}), 1)
        assert status is not None and status[0] & 0x6F == 0x27  # operation enabled at once
        target = position + 2000  # counts: well inside the servo's pull
        moved = [tpdo1(a.cycle({1: (0x0F, target)}), 1)[1] for _ in range(40)]
        assert abs(moved[0] - position) < 20  # the new target has not acted yet
        assert abs(moved[1] - position) > abs(moved[0] - position)
        assert abs(moved[-1] - target) < 100
        a.close()


def test_on_sync_steps_the_physics_one_period_and_holds_when_disabled(pa10):
    with DriveEmulator(pa10) as emulator:
        before = {n: d.actual for n, d in emulator.drives.items()}
        for _ in range(50):
            emulator.on_sync()
        assert emulator.cycles == 50
        assert emulator.sim_time == pytest.approx(50 * emulator.period)
        for name, drive in emulator.drives.items():  # servo off, gravity compensated
            assert abs(drive.actual - before[name]) < 500, name

"""hal.can.setup: interpolation period encoding; a missing drive names itself."""

from __future__ import annotations

import pytest

from hal.can.backend import CanBackend, interpolation_period
from hal.can.supervision import DriveError
from hal.emulator.emulator import DriveEmulator
from tests.can_support import FakeClock
from tests.support import robot


def test_interpolation_period():
    assert interpolation_period(0.002) == (2, -3)
    assert interpolation_period(0.004) == (4, -3)
    assert interpolation_period(0.0005) == (5, -4)
    with pytest.raises(ValueError):
        interpolation_period(1 / 3)


def test_a_silent_drive_fails_set_up_naming_it():
    r = robot("pa10")
    emu = DriveEmulator(r, period=0.002, clock=FakeClock())
    emu.inject("silent", "J6")
    emu.start()
    backend = CanBackend(
        r, 0.002, emu.profile, bus_factory=lambda n, _kw: emu.open_master_bus(n), sdo_timeout=0.05
    )
    try:
        with pytest.raises(DriveError) as err:
            backend.configure()
        fault = err.value.faults[0]
        assert fault.source == "J6"
        assert "node 6 on bus arm_b: set-up failed at 0x6060" in fault.description
        assert backend.state.value == "unconfigured"
    finally:
        backend.shutdown()
        emu.close()

"""hal.can.setup: interpolation period encoding; a missing drive names itself."""

from __future__ import annotations

import logging
import subprocess
import sys

import pytest

from hal.can.backend import CanBackend
from hal.can.setup import interpolation_period, quiet_canopen, set_up_drives
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


def test_setup_knows_nothing_of_the_backend():
    """The cycle backend <-> setup is gone: setup imports neither the backend nor its parts."""
    code = (
        "import sys, hal.can.setup; "
        "parts = ('hal.can.backend', 'hal.can.cycle', 'hal.can.ports'); "
        "bad = [m for m in parts if m in sys.modules]; "
        "sys.exit(str(bad) if bad else 0)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def test_set_up_drives_beats_between_steps_and_canopen_stays_quiet(
    caplog: pytest.LogCaptureFixture,
):
    r = robot("pa10")
    emu = DriveEmulator(r, period=0.002, clock=FakeClock())
    emu.start()
    bus = emu.open_master_bus("arm_a")
    beats: list[int] = []
    canopen_log = logging.getLogger("canopen")
    saved = canopen_log.level
    canopen_log.setLevel(logging.NOTSET)
    try:
        with caplog.at_level(logging.INFO):
            set_up_drives(bus, "arm_a", ["J1", "J2"], emu.profile, r.directory, 0.002,
                          beat=lambda: beats.append(1))  # fmt: skip
        assert emu.drives["J2"].nmt_state == 0x05
        assert len(beats) >= 2 * 12  # after every SDO step of both drives
        assert not [rec for rec in caplog.records if rec.name.startswith("canopen")]
        assert canopen_log.level == logging.WARNING
        # Asked for: a level of its own (or the root at DEBUG) keeps canopen's lines.
        canopen_log.setLevel(logging.INFO)
        quiet_canopen()
        assert canopen_log.level == logging.INFO
    finally:
        canopen_log.setLevel(saved)
        bus.shutdown()
        emu.close()

"""hal.hil: ``--hal hil`` with the emulator in its own process (default) or in this one."""

from __future__ import annotations

import time

import pytest

from config import ROBOTS_DIR
from hal.can import busload
from hal.can.backend import CanBackend
from hal.can.drive_profile import load_drive_profile
from hal.factory import make_hardware
from hal.hil import EmulatorProcess
from hal.interface import HardwareState, JointCommand
from tests.support import robot

TIMEOUT = 30.0  # [s] bound of every wait (never asserted as a time)


def cycles_until(hw: CanBackend, done, dt: float = 0.002) -> bool:  # type: ignore[no-untyped-def]
    """Run read/write cycles (holding the position) until ``done()``, within TIMEOUT."""
    end = time.monotonic() + TIMEOUT
    while time.monotonic() < end:
        state = hw.read()
        hw.write(JointCommand(state.position))
        if done():
            return True
        time.sleep(dt)
    return False


def test_hil_process_is_the_default_and_takes_faults_over_stdin():
    hw = make_hardware("hil", robot("pa10"), 0.002)
    assert isinstance(hw, CanBackend) and isinstance(hw.emulator, EmulatorProcess)
    child = hw.emulator
    assert hw.lockstep is None
    assert {k["interface"] for k in map(hw.bus_kwargs, hw.profile.buses)} == {"unix"}
    assert hw.feedback_wait == pytest.approx(0.2 * 0.002)
    assert hw.profile.tpdo_timeout_cycles == 50  # 0.1 s at 500 Hz
    assert hw.profile.heartbeat.master_consumer_ms == 1000
    assert hw.sdo_timeout == 2.0
    try:
        hw.configure()
        state = hw.read()
        hw.write(JointCommand(state.position))
        hw.activate()
        assert hw.state is HardwareState.ACTIVE
        assert cycles_until(hw, lambda: hw.frames_received["arm_a"] > 100)
        assert hw.state is HardwareState.ACTIVE and not hw.faults()
        child.inject("emcy", "J3", code=0x2310)
        assert cycles_until(hw, lambda: hw.state is HardwareState.FAULT)
        assert any(f.source == "J3" and f.code == 0x404 for f in hw.faults())
        assert child.clear() == 0  # emcy is one-shot
        with pytest.raises(ValueError, match="unknown"):
            child.inject("no_such_fault", "J3")
    finally:
        hw.shutdown()
    assert child.process.returncode == 0
    assert not child.directory.exists()


def test_hil_thread_runs_the_emulator_in_process_in_lockstep():
    hw = make_hardware("hil", robot("pa10"), 0.002, {"emulator": "thread"})
    assert isinstance(hw, CanBackend) and hw.emulator is not None
    try:
        hw.configure()
        for _ in range(3):
            state = hw.read()
            hw.write(JointCommand(state.position))
        hw.activate()
        assert hw.state is HardwareState.ACTIVE
        assert hw.lockstep is hw.emulator
        assert hw.emulator.sync_counts() == hw.syncs_sent  # every SYNC answered by read()
        assert hw.lockstep_timeouts == 0
    finally:
        hw.shutdown()
    assert hw.state is HardwareState.FINALIZED


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"emulator": "fork"}, "hal.options.emulator"),
        ({"buses": {}}, "unknown keys"),
        ({"lockstep_timeout": 1.0}, "only with emulator 'thread'"),
        ({"emulator": "thread", "lockstep_timeout": -1}, "lockstep_timeout"),
        ({"nope": 1}, "unknown keys"),
        ({"emulator_priority": 120}, "emulator_priority"),
        ({"emulator": "thread", "emulator_priority": 10}, "only with emulator 'process'"),
    ],
)
def test_bad_options(options: dict, message: str):
    with pytest.raises(ValueError, match=message):
        make_hardware("hil", robot("pa10"), 0.002, options)


def test_the_1khz_bench_profile_of_smartpal5_fits_its_buses():
    """tools/bench_hil.py's 1 kHz split: every drive of drives.yaml, every bus under 70 %."""
    sp5 = robot("smartpal5")
    fast = load_drive_profile(ROBOTS_DIR / "smartpal5" / "drives-1khz.yaml", sp5)
    normal = load_drive_profile(ROBOTS_DIR / "smartpal5" / "drives.yaml", sp5)
    assert set(fast.drives) == set(normal.drives) and fast.rate_hz == 1000
    loads, warning = busload.check(fast, 1000.0)
    assert warning is None and all(load.load < busload.WARN_ABOVE for load in loads)


def test_the_emulator_process_stops_when_its_parent_goes():
    """A parent that dies closes the child's stdin: the child stops (no orphan emulator)."""
    pa10 = robot("pa10")
    child = EmulatorProcess(pa10, 0.002, ["arm_a", "arm_b"])
    try:
        assert child.process.stdin is not None
        child.process.stdin.close()  # what the parent's death does
        assert child.process.wait(TIMEOUT) == 0
    finally:
        child.close()

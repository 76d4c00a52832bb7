"""hal.can.operations: scan beside a running master; the one-drive master on the cycle I/O.

The emulator runs its threads; durations are short and nothing asserts wall-clock time.
"""

from __future__ import annotations

import threading

import can
import pytest

from hal.can import pdo
from hal.can.backend import CanBackend
from hal.can.drive_profile import Heartbeat, drives_path, load_drive_profile
from hal.can.tool import main
from hal.emulator.emulator import DriveEmulator
from hal.interface import HardwareState, JointCommand
from tests.support import robot


@pytest.fixture
def running_master():
    """pa10's drives (emulator threads) driven by a CanBackend cycling in a thread."""
    r = robot("pa10")
    dt = 0.004
    # Generous heartbeat consumers: a loaded host may stall the threads for a while, and
    # this test is about the scan, not about heartbeat timing.
    slow = Heartbeat(drive_consumer_ms=5000, master_consumer_ms=5000)
    profile = load_drive_profile(drives_path(r), r).model_copy(update={"heartbeat": slow})
    emu = DriveEmulator(r, profile, period=dt)
    emu.start()
    backend = CanBackend(
        r, dt, emu.profile, bus_factory=lambda n, _kw: emu.open_master_bus(n), lockstep=emu
    )
    stop = threading.Event()

    def loop() -> None:
        while not stop.wait(dt):
            state = backend.read()
            backend.write(JointCommand(state.position))

    backend.configure()
    backend.read()
    backend.activate()
    thread = threading.Thread(target=loop, daemon=True)
    thread.start()
    yield emu, backend
    stop.set()
    thread.join()
    backend.shutdown()
    emu.close()


def test_scan_beside_a_running_master_neither_probes_it_nor_disturbs_it(
    running_master: tuple[DriveEmulator, CanBackend], capsys: pytest.CaptureFixture[str]
):
    emu, backend = running_master
    interface, channel = emu.channels["arm_a"]
    sniffer = can.Bus(interface=interface, channel=channel)
    try:
        argv = ["--robot", "pa10", "--bus", "arm_a", "--interface", interface,
                "--channel", channel, "--sdo-timeout", "2", "scan", "--listen", "1"]  # fmt: skip
        assert main(argv) == 0
        out = capsys.readouterr().out
        rows = {line.split("│")[2].strip(): line for line in out.splitlines() if "│" in line}
        assert "(master)" in rows["127"] and "OPERATIONAL" in rows["127"]
        for node in ("1", "2", "3", "4"):
            assert "OPERATIONAL" in rows[node] and "0x" in rows[node]
        assert "a master is running" in out
        frames = []
        while (msg := sniffer.recv(0.0)) is not None:
            frames.append(msg.arbitration_id)
        assert pdo.SDO_RX + 127 not in frames  # the master's node id was never asked
        assert pdo.SDO_RX + 1 in frames  # the drives were
    finally:
        sniffer.shutdown()
    assert backend.state is HardwareState.ACTIVE and not backend.faults()


def test_enable_drives_one_drive_with_the_backends_cycle(capsys: pytest.CaptureFixture[str]):
    emu = DriveEmulator("pa10", period=0.002)
    emu.start()
    try:
        interface, channel = emu.channels["arm_b"]
        on = ["--robot", "pa10", "--bus", "arm_b", "--interface", interface, "--channel", channel,
              "--sdo-timeout", "2"]  # fmt: skip
        assert main(["enable", "J5", "--hold", "0.05", "--timeout", "5", *on]) == 0
        assert "J5: operation enabled" in capsys.readouterr().out
        assert emu.drives["J5"].nmt_state == 0x05
        assert main(["disable", "J5", "--timeout", "5", *on]) == 0
        assert "J5: switch on disabled" in capsys.readouterr().out
    finally:
        emu.close()

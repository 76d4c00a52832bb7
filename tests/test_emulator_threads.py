"""hal.emulator.threads: the threads serving the emulator's buses."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

import can
import pytest

from controller.model.robot import load_robot
from hal.can.unix_wire import HEADER
from hal.emulator.emulator import DriveEmulator
from hal.emulator.port import Port
from hal.emulator.threads import BusThreads


def _starts(record: bytes) -> list[int]:
    """Where each frame of a ``unix`` record starts."""
    starts, at = [], 0
    while at < len(record):
        starts.append(at)
        at += HEADER.size + HEADER.unpack_from(record, at)[3]
    return starts


@pytest.fixture(scope="module")
def pa10():
    return load_robot("pa10")


def test_threads_answer_a_sync_with_its_tpdos_already_on_the_bus(pa10):
    with DriveEmulator(pa10) as emulator:
        emulator.start()
        buses = {name: emulator.open_master_bus(name) for name in emulator.channels}
        nodes = {
            name: {c.node_id for c in emulator.profile.drives.values() if c.bus == name}
            for name in buses
        }
        sent = dict.fromkeys(buses, 0)
        for bus in buses.values():
            bus.send(can.Message(arbitration_id=0x000, data=[0x01, 0], is_extended_id=False))
        for _ in range(20):
            for name, bus in buses.items():
                bus.send(can.Message(arbitration_id=0x080, is_extended_id=False))
                sent[name] += 1
            assert emulator.wait_answered(sent, 5.0)
            for name, bus in buses.items():
                frames = iter(lambda b=bus: b.recv(0.0), None)
                tpdo = {
                    m.arbitration_id - 0x180 for m in frames if m.arbitration_id & 0x780 == 0x180
                }
                assert tpdo == nodes[name]
        assert emulator.sync_counts() == sent
        for bus in buses.values():
            bus.shutdown()


def test_unix_buses_are_served_by_one_select_thread(pa10, tmp_path):
    channels = {bus: ("unix", str(tmp_path / bus)) for bus in ("arm_a", "arm_b")}
    with DriveEmulator(pa10, channels=channels) as emulator:
        emulator.start()
        assert [t.name for t in emulator.threads] == ["emu"]
        buses = {name: can.Bus(interface="unix", channel=ch) for name, (_, ch) in channels.items()}
        nodes = {
            name: {c.node_id for c in emulator.profile.drives.values() if c.bus == name}
            for name in buses
        }
        try:
            for bus in buses.values():
                bus.send(can.Message(arbitration_id=0x000, data=[0x01, 0], is_extended_id=False))
            for _ in range(5):
                for name, bus in buses.items():
                    bus.send(can.Message(arbitration_id=0x080, is_extended_id=False))
                    seen: set[int] = set()
                    while seen != nodes[name]:
                        msg = bus.recv(5.0)
                        assert msg is not None, f"bus {name}: TPDO1 of {nodes[name] - seen} missing"
                        if msg.arbitration_id & 0x780 == 0x180:
                            seen.add(msg.arbitration_id - 0x180)
        finally:
            for bus in buses.values():
                bus.shutdown()


def _bus_threads(
    ports: list[Port], rounds: list[int] | None = None
) -> tuple[BusThreads, list[tuple[str, int]], threading.Event]:
    """BusThreads over ``ports`` whose callables record the frames and ticks they get; the
    handler reads a record per peer while ``more`` names ports (as the emulator's inbox) and
    counts its rounds in ``rounds``."""
    got: list[tuple[str, int]] = []
    ticked = threading.Event()

    def handle(ready: list[Port], more: Callable[[], list[Port]]) -> int:
        frames, k = [], 0
        while ready:
            k += 1
            frames += [
                (port.name, HEADER.unpack_from(record, start)[0])
                for port in ready
                for record in port.records(drain=False)
                for start in _starts(record)
            ]
            ready = more()
        if rounds is not None:
            rounds.append(k)
        got.extend(frames)
        return len(frames)

    def process(port: Port, msg: can.Message) -> None:
        got.append((port.name, msg.arbitration_id))

    service = BusThreads(ports, threading.RLock(), handle, process, lambda now: ticked.set(),
                         time.monotonic)  # fmt: skip
    return service, got, ticked


def _wait(condition, timeout: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.001)
    return True


@pytest.mark.parametrize("interface", ["unix", "virtual"])
def test_bus_threads_hand_each_bus_frames_over_and_tick_until_stopped(interface, tmp_path: Path):
    names = ("a", "b")
    channel = {n: str(tmp_path / n) if interface == "unix" else f"threads-{tmp_path.name}-{n}"
               for n in names}  # fmt: skip
    ports = [Port(n, interface, channel[n], []) for n in names]
    for port in ports:  # the emulator's ends first: the masters join them, as on a wire
        port.attach(can.Bus(interface=interface, channel=port.channel))
    masters = {n: can.Bus(interface=interface, channel=channel[n]) for n in names}
    service, got, ticked = _bus_threads(ports)
    try:
        service.start()
        expected = ["emu"] if interface == "unix" else ["emu-a", "emu-b", "emu-tick"]
        assert [t.name for t in service.threads] == expected and service.running
        for n, master in masters.items():
            master.send(can.Message(arbitration_id=0x123 if n == "a" else 0x234, data=b"\x01",
                                    is_extended_id=False))  # fmt: skip
        assert _wait(lambda: ("a", 0x123) in got and ("b", 0x234) in got)
        assert ticked.wait(5.0)
    finally:
        service.stop()
        for bus in [*masters.values(), *(p.bus for p in ports)]:
            if bus is not None:
                bus.shutdown()
    assert service.threads == [] and not service.running


def test_the_select_loop_names_the_ports_left_to_read_until_none(tmp_path: Path):
    port = Port("a", "unix", str(tmp_path / "a"), [])
    port.attach(can.Bus(interface="unix", channel=port.channel))
    master = can.Bus(interface="unix", channel=port.channel)
    ids = list(range(0x101, 0x109))
    for can_id in ids:  # eight records waiting on one peer before the loop starts
        master.send(can.Message(arbitration_id=can_id, data=b"\x01", is_extended_id=False))
    rounds: list[int] = []
    service, got, _ = _bus_threads([port], rounds)
    try:
        service.start()
        assert _wait(lambda: len(got) >= len(ids))
    finally:
        service.stop()
        master.shutdown()
        port.bus.shutdown()
    assert got == [("a", can_id) for can_id in ids]
    assert rounds[0] == len(ids)  # a record a round, all read before the handler returned

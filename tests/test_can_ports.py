"""hal.can.ports: python-can settings per bus, supervision keys, opening and closing buses."""

from __future__ import annotations

from typing import Any

import can
import pytest

from hal.can import pdo
from hal.can.drive_profile import drives_path, load_drive_profile
from hal.can.ports import (
    bus_kwargs,
    close_ports,
    frame_reader,
    open_ports,
    poller,
    record_io,
    split_supervision,
)
from hal.can.supervision import DriveError
from tests.support import robot


@pytest.fixture(scope="module")
def profile():
    r = robot("pa10")
    return load_drive_profile(drives_path(r), r)


def test_bus_kwargs_profile_then_overrides(profile):
    assert bus_kwargs(profile, "arm_a") == {
        "interface": "socketcan", "channel": "can0", "bitrate": 1_000_000,
    }  # fmt: skip
    over = {"interface": "remote", "channel": "ws://127.0.0.1:1/", "tpdo_timeout_ms": 20}
    assert bus_kwargs(profile, "arm_a", over) == {
        "interface": "remote", "channel": "ws://127.0.0.1:1/",
    }  # fmt: skip


def test_split_supervision():
    bus, sup = split_supervision({"interface": "virtual", "tpdo_timeout_cycles": 5})
    assert bus == {"interface": "virtual"} and sup == {"tpdo_timeout_cycles": 5}


def test_open_ports_builds_tables_and_frames(profile):
    names = list(profile.drives)
    nodes = [profile.drives[n].node_id for n in names]
    buses = [profile.drives[n].bus for n in names]
    over = {b: {"interface": "virtual", "channel": f"ports-test-{b}"} for b in profile.buses}
    ports = open_ports(profile, list(profile.buses), nodes, buses, over)
    try:
        assert [p.name for p in ports] == list(profile.buses)
        for port in ports:
            assert all(buses[i] == port.name for i in port.drives)
            i = port.drives[0]
            assert port.table[pdo.TPDO1 + nodes[i]] == (pdo.Kind.TPDO1, i)
            assert port.heartbeat.arbitration_id == 0x700 + profile.master_node_id
            assert port.sync.arbitration_id == pdo.SYNC and port.send_timeout == 0.0
    finally:
        close_ports(ports)


def test_a_bus_that_cannot_open_names_itself_and_closes_the_others(profile):
    opened: list[can.BusABC] = []

    def factory(name: str, kwargs: dict[str, Any]) -> can.BusABC:
        if name == "arm_b":
            raise OSError("no such device")
        bus = can.Bus(interface="virtual", channel=f"ports-fail-{name}")
        opened.append(bus)
        return bus

    with pytest.raises(DriveError) as err:
        open_ports(profile, ["arm_a", "arm_b"], [1, 5], ["arm_a", "arm_b"], None, factory)
    fault = err.value.faults[0]
    assert fault.source == "arm_b" and "no such device" in fault.description
    assert fault.code == 0x406
    assert opened and all(b._is_shutdown for b in opened)


def test_poller_never_blocks_and_keeps_filters():
    a = can.Bus(interface="virtual", channel="ports-poll")
    b = can.Bus(interface="virtual", channel="ports-poll")
    filtered = can.Bus(
        interface="virtual",
        channel="ports-poll",
        can_filters=[{"can_id": 0x181, "can_mask": 0x7FF}],
    )
    try:
        assert poller(b)(0.0)[0] is None
        a.send(can.Message(arbitration_id=0x182, data=b"", is_extended_id=False))
        a.send(can.Message(arbitration_id=0x181, data=b"", is_extended_id=False))
        assert poller(b)(0.0)[0].arbitration_id == 0x182  # type: ignore[union-attr]
        msg = poller(filtered)(0.0)[0]  # through recv(): the filter applies
        assert msg is not None and msg.arbitration_id == 0x181
    finally:
        for bus in (a, b, filtered):
            bus.shutdown()


def test_frame_reader_only_where_the_bus_offers_it_without_filters(tmp_path):
    """recv_frames (unix) is the port's fast path; a bus with filters, or an interface
    without it (virtual, SocketCAN), keeps python-can's API."""
    from hal.can.unix_bus import UnixBus

    plain = UnixBus(str(tmp_path / "b"))
    filtered = UnixBus(str(tmp_path / "b"), can_filters=[{"can_id": 0x181, "can_mask": 0x7FF}])
    virtual = can.Bus(interface="virtual", channel="ports-reader")
    try:
        assert frame_reader(plain) == plain.recv_frames
        assert frame_reader(filtered) is None and frame_reader(virtual) is None
    finally:
        for bus in (plain, filtered, virtual):
            bus.shutdown()


def test_record_io_only_where_the_bus_takes_records_without_filters(tmp_path):
    """recv_records/send_record (unix, record stubs) are the compiled path's; a bus with
    filters or without them keeps frames."""
    from hal.can.stub_bus import StubDrivesBus, StubRecordBus
    from hal.can.unix_bus import UnixBus

    plain = UnixBus(str(tmp_path / "b"))
    filtered = UnixBus(str(tmp_path / "b"), can_filters=[{"can_id": 0x181, "can_mask": 0x7FF}])
    stubs = StubRecordBus("s", [1], [False]), StubDrivesBus("t", [1], [False])
    try:
        assert record_io(plain) == (plain.recv_records, plain.send_record)
        assert record_io(stubs[0]) == (stubs[0].recv_records, stubs[0].send_record)
        assert record_io(filtered) == (None, None) and record_io(stubs[1]) == (None, None)
    finally:
        for bus in (plain, filtered, *stubs):
            bus.shutdown()

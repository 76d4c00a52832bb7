"""hal.emulator.port: one bus of the drive emulator."""

from __future__ import annotations

from pathlib import Path

import can

from hal.can.unix_wire import HEADER
from hal.emulator.port import Port


def _ids(records: list[bytes]) -> list[int]:
    return [HEADER.unpack_from(record)[0] for record in records]


def test_records_drain_every_peer_or_read_one_record_of_each(tmp_path: Path):
    port = Port("a", "unix", str(tmp_path / "a"), [])
    port.attach(can.Bus(interface="unix", channel=port.channel))
    masters = [can.Bus(interface="unix", channel=port.channel) for _ in range(2)]
    try:
        for k, master in enumerate(masters):
            for n in range(3):  # three records of one frame from each peer
                msg = can.Message(arbitration_id=0x100 * (k + 1) + n, is_extended_id=False)
                master.send(msg)
        first = port.records(drain=False)
        assert sorted(_ids(first)) == [0x100, 0x200]  # one of each peer, oldest first
        assert sorted(_ids(port.records(drain=False))) == [0x101, 0x201]
        rest = port.records()
        assert sorted(_ids(rest)) == [0x102, 0x202]
        assert port.records(drain=False) == [] and port.records() == []
    finally:
        for master in masters:
            master.shutdown()
        port.bus.shutdown()


def test_records_of_a_bus_without_records_are_encoded_here():
    port = Port("v", "virtual", "port-test-v", [])
    port.attach(can.Bus(interface="virtual", channel="port-test-v"))
    master = can.Bus(interface="virtual", channel="port-test-v")
    try:
        master.send(can.Message(arbitration_id=0x181, data=b"\x01\x02", is_extended_id=False))
        records = port.records(drain=False)
        assert len(records) == 1
        can_id, flags, dlc, length, _ = HEADER.unpack_from(records[0])
        assert (can_id, flags, dlc, length) == (0x181, 0, 2, 2)
        assert records[0][HEADER.size :] == b"\x01\x02"
    finally:
        master.shutdown()
        port.bus.shutdown()

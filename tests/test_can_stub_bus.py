"""hal.can.stub_bus: precomputed drive answers (SDO, TPDOs on SYNC, heartbeats)."""

from __future__ import annotations

import can

from hal.can import pdo
from hal.can.stub_bus import StubDrivesBus, StubRecordBus
from hal.can.unix_wire import encode
from hal.can.unix_wire import frames as unix_frames


def frames(bus: StubDrivesBus) -> list[can.Message]:
    out = []
    while (msg := bus.recv(0.0)) is not None:
        out.append(msg)
    return out


def test_sync_answers_tpdo1_and_tpdo2_and_heartbeats():
    bus = StubDrivesBus("x", [1, 2], [True, False], positions=[7, -7], heartbeat_every=2)
    bus.send(can.Message(arbitration_id=pdo.SYNC, data=b""))
    got = frames(bus)
    assert [m.arbitration_id for m in got] == [0x181, 0x182, 0x281]
    assert pdo.TPDO1_STRUCT.unpack(got[1].data) == (0x40, -7)
    bus.send(can.Message(arbitration_id=pdo.SYNC, data=b""))
    assert [m.arbitration_id for m in frames(bus)][-2:] == [0x701, 0x702]
    bus.shutdown()


def test_statusword_follows_the_controlword():
    bus = StubDrivesBus("x", [1], [False])
    for cw, sw in ((0x06, 0x21), (0x07, 0x23), (0x0F, 0x27), (0x02, 0x07), (0x00, 0x40)):
        bus.send(can.Message(arbitration_id=0x201, data=pdo.RPDO1_STRUCT.pack(cw, 0)))
        bus.send(can.Message(arbitration_id=pdo.SYNC, data=b""))
        assert pdo.TPDO1_STRUCT.unpack(frames(bus)[0].data)[0] == sw
    bus.shutdown()


def test_sdo_requests_are_confirmed():
    bus = StubDrivesBus("x", [5], [False])
    bus.send(can.Message(arbitration_id=0x605, data=bytes([0x2F, 0x60, 0x60, 0, 8, 0, 0, 0])))
    bus.send(can.Message(arbitration_id=0x605, data=bytes([0x40, 0x18, 0x10, 1, 0, 0, 0, 0])))
    bus.send(can.Message(arbitration_id=0x606, data=bytes(8)))  # not one of its nodes
    got = frames(bus)
    assert [(m.arbitration_id, m.data[0], bytes(m.data[1:4])) for m in got] == [
        (0x585, 0x60, b"\x60\x60\x00"), (0x585, 0x43, b"\x18\x10\x01"),
    ]  # fmt: skip
    assert bus.recv(0.01) is None  # a bounded wait on an empty bus
    bus.shutdown()


def test_muted_nodes_send_no_tpdo():
    bus = StubDrivesBus("x", [1, 2], [True, True])
    bus.muted.add(1)
    bus.send(can.Message(arbitration_id=pdo.SYNC, data=b""))
    assert [m.arbitration_id for m in frames(bus)] == [0x182, 0x282]
    bus.shutdown()


def record_frames(bus: StubRecordBus) -> list[tuple[int, bytes]]:
    records, others = bus.recv_records()
    assert others == []
    return [(f[0], f[4]) for r in records for f in unix_frames(r)]


def test_the_record_stub_answers_a_cycle_record_as_the_frames():
    """A master's cycle as one record (RPDO1s, SYNC) or frame by frame (python-can or a
    record of other frames): the same answer, one record per SYNC, muted nodes left out."""
    bus = StubRecordBus("x", [1, 2], [True, False], positions=[7, -7], heartbeat_every=2)
    rpdo = encode(can.Message(arbitration_id=0x201, data=pdo.RPDO1_STRUCT.pack(0x06, 0)))
    bus.send_record(memoryview(rpdo + encode(can.Message(arbitration_id=pdo.SYNC))))
    got = record_frames(bus)
    assert [cob for cob, _ in got] == [0x181, 0x182, 0x281]
    assert pdo.TPDO1_STRUCT.unpack(got[0][1]) == (0x21, 7)
    bus.send(can.Message(arbitration_id=0x202, data=pdo.RPDO1_STRUCT.pack(0x06, 0)))
    bus.send_record(encode(can.Message(arbitration_id=0x701, data=b"\x05"))
                    + encode(can.Message(arbitration_id=pdo.SYNC)))  # fmt: skip
    got = record_frames(bus)
    assert [cob for cob, _ in got] == [0x181, 0x182, 0x281, 0x701, 0x702]
    assert pdo.TPDO1_STRUCT.unpack(got[1][1]) == (0x21, -7)
    bus.muted.add(1)
    bus.send(can.Message(arbitration_id=pdo.SYNC, data=b""))
    assert [cob for cob, _ in record_frames(bus)] == [0x182]
    assert bus.syncs == 3 and bus.sent == 2 + 1 + 2 + 1
    bus.shutdown()

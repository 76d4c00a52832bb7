"""hal.can.records: the CAN master's cycle as whole records (unix wire format), compiled."""

from __future__ import annotations

import can
import numpy as np
import pytest

from controller.model import jit
from hal.can import kernels, pdo
from hal.can.cycle import CycleIO
from hal.can.ports import Port
from hal.can.records import RPDO_WIRE, RecordIO
from hal.can.stub_bus import StubRecordBus
from hal.can.supervision import Supervisor
from hal.can.unix_wire import HEADER, encode
from hal.interface import HardwareFault

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba not installed or IMOTION_JIT=0")


def port(name: str, nodes: list[int], drives: list[int]) -> Port:
    table = {c: (k, drives[j]) for c, (k, j) in pdo.receive_table(nodes).items()}
    return Port(
        name, StubRecordBus(name, nodes, [False] * len(nodes)), drives, table,
        can.Message(arbitration_id=pdo.SYNC, data=b"", is_extended_id=False),
        can.Message(arbitration_id=0x77F, data=b"\x05", is_extended_id=False),
    )  # fmt: skip


@pytest.fixture
def rig():
    """Nodes 3, 4 on bus a (drives 0, 1), node 3 on bus b (drive 2)."""
    ports = [port("a", [3, 4], [0, 1]), port("b", [3], [2])]
    sup = Supervisor(["x", "y", "z"], [3, 4, 3], ["a", "a", "b"], 0.002, np.ones(3), 0.006, 0.3, 3)
    faults: list[HardwareFault] = []
    io = CycleIO(ports, [3, 4, 3], sup, faults.extend, lambda: 2.0, 0.1)
    yield io, ports, faults
    for p in ports:
        p.bus.shutdown()


def test_tables_rows_and_headers_per_bus(rig):
    io, ports, _ = rig
    records = io._records
    assert isinstance(records, RecordIO) and records.ports == ports
    assert records.rows.tolist() == [0, 3, 5] and records.order.tolist() == [0, 1, -1, 2, -1]
    assert records.kinds[0, 0x183] == kernels.K_TPDO1 and records.drives[0, 0x184] == 1
    assert records.kinds[1, 0x703] == kernels.K_HEARTBEAT and records.drives[1, 0x183] == 2
    assert records.kinds[1, 0x184] == 0  # node 4 is not on bus b
    heads = [HEADER.unpack(bytes(h) + bytes(8))[:4] for h in records.header]
    assert heads == [(0x203, 0, 6, 6), (0x204, 0, 6, 6), (0x080, 0, 0, 0), (0x203, 0, 6, 6),
                     (0x080, 0, 0, 0)]  # fmt: skip
    assert len(records.out) == 5 * RPDO_WIRE


def test_send_then_drain_one_bus_or_all(rig):
    io, ports, faults = rig
    io.send()  # nothing seen yet: SYNCs only
    assert [p.syncs_sent for p in ports] == [1, 1] and [p.frames_sent for p in ports] == [1, 1]
    io._records.drain(ports[1])
    assert io.seen.tolist() == [False, False, True] and ports[0].frames_received == 0
    io.receive()
    assert io.seen.all() and io.statusword.tolist() == [0x40] * 3
    io.send()
    assert [p.frames_sent for p in ports] == [1 + 3, 1 + 2]
    ports[1].bus._records.append(encode(can.Message(arbitration_id=0x703, data=b"\x04")))
    io.receive()
    assert [(f.code, f.source) for f in faults] == [(0x401, "z")]  # stopped, on bus b


def test_a_cut_record_keeps_its_whole_frames_and_a_failed_send_faults(rig, caplog):
    io, ports, faults = rig
    whole = encode(can.Message(arbitration_id=0x184, data=pdo.TPDO1_STRUCT.pack(0x40, 9)))
    ports[0].bus._records.append(whole + whole[:10])
    io.receive()
    assert io.position.tolist() == [0, 9, 0] and "cut at byte 22" in caplog.text
    assert ports[0].frames_received == 1

    def broken(record: bytes | memoryview) -> None:
        raise can.CanOperationError("tx queue full")

    ports[0].send_record = broken
    io.send()
    assert ports[0].failed and "send of 0x204 failed: tx queue full" in faults[0].description
    assert ports[0].syncs_sent == 0 and ports[1].syncs_sent == 1


def test_tpdos_decode_the_same_whatever_their_time_stamps(rig):
    """The emulator's compiled round stamps every TPDO of a SYNC alike (one time per SYNC,
    not one per frame): the master reads no frame's time stamp and never orders by them."""
    io, ports, _ = rig

    def tpdo1(node: int, position: int, stamp: float) -> bytes:
        data = pdo.TPDO1_STRUCT.pack(0x27, position)
        return encode(can.Message(arbitration_id=0x180 + node, data=data, timestamp=stamp))

    ports[0].bus._records.append(tpdo1(3, 5, 1.0) + tpdo1(4, 6, 1.0))  # one stamp per SYNC
    io.receive()
    assert io.position.tolist()[:2] == [5, 6]
    ports[0].bus._records.append(tpdo1(3, 7, 9.0) + tpdo1(4, 8, 0.5))  # stamps backwards
    ports[0].bus._records.append(tpdo1(4, 9, 0.0))  # older stamp, later record: it wins
    io.receive()
    assert io.position.tolist()[:2] == [7, 9]

"""hal.can.cycle: encode/send/receive/decode of one cycle against stub drives (no emulator)."""

from __future__ import annotations

import select

import can
import numpy as np
import pytest

from controller.model import jit
from controller.model.alarms import AlarmCode
from hal.can import pdo
from hal.can.cia402 import Goal, State
from hal.can.cycle import FRAME_BITS, CycleIO
from hal.can.ports import Port, poller
from hal.can.stub_bus import StubDrivesBus, StubRecordBus
from hal.can.supervision import Supervisor
from hal.can.unix_wire import encode
from hal.can.unix_wire import frames as unix_frames
from hal.interface import HardwareFault

NODES = [3, 4, 5]


class Rig:
    """Three stub drives on one bus (node 4 without TPDO2), a CycleIO over them."""

    def __init__(self) -> None:
        self.bus = StubDrivesBus("b", NODES, [True, False, True], positions=[10, -20, 30])
        self.port = Port(
            "b", self.bus, [0, 1, 2],
            {c: (k, i) for c, (k, i) in pdo.receive_table(NODES).items()},
            can.Message(arbitration_id=pdo.SYNC, data=b"", is_extended_id=False),
            can.Message(arbitration_id=0x77F, data=b"\x05", is_extended_id=False),
        )  # fmt: skip
        self.now = 5.0
        self.faults: list[HardwareFault] = []
        self.sup = Supervisor(
            ["a", "b", "c"], NODES, ["b"] * 3, 0.002, np.full(3, 0.1), 0.006, 0.3, 3
        )
        self.io = CycleIO([self.port], NODES, self.sup, self.faults.extend, lambda: self.now, 0.1)

    def cycle(self) -> None:
        self.io.send()
        self.io.clear_fresh()
        self.io.receive()
        self.io.decode_states()


@pytest.fixture
def rig():
    r = Rig()
    yield r
    r.bus.shutdown()


def test_no_rpdo_before_the_first_tpdo1_then_every_drive(rig: Rig):
    rig.io.send()
    assert rig.bus.sent == 1 and rig.port.syncs_sent == 1  # the SYNC only
    rig.io.clear_fresh()
    rig.io.receive()
    assert rig.io.fresh.all() and rig.io.seen.all()
    assert rig.io.position.tolist() == [10, -20, 30]
    rig.io.send()
    assert rig.bus.sent == 1 + 3 + 1
    assert rig.port.frames_sent == 5
    sent_bits = 2 * FRAME_BITS[0] + 3 * FRAME_BITS[6]  # 2 SYNC, 3 RPDO1
    received_bits = 3 * FRAME_BITS[6] + 2 * FRAME_BITS[4]  # 3 TPDO1, 2 TPDO2
    assert rig.port.bits == sent_bits + received_bits and rig.port.frames_received == 5


def test_states_follow_the_goal_and_targets_are_packed(rig: Rig):
    rig.cycle()
    assert rig.io.states == [State.SWITCH_ON_DISABLED] * 3 and not rig.io.all_enabled
    rig.io.set_goal(Goal.ENABLED)
    for _ in range(4):
        rig.cycle()
    assert rig.io.all_enabled and not rig.io.any_faulted
    rig.io.hold_targets()
    assert rig.io.target.tolist() == [10, -20, 30]
    sent: list[can.Message] = []
    send = rig.bus.send

    def spy(msg: can.Message, timeout: float | None = None) -> None:
        sent.append(can.Message(arbitration_id=msg.arbitration_id, data=bytes(msg.data)))
        send(msg, timeout)

    rig.bus.send = spy  # type: ignore[method-assign]
    rig.io.target[1] = -(2**31)
    rig.io.send()
    rpdo = {m.arbitration_id: pdo.RPDO1_STRUCT.unpack(m.data) for m in sent[:-1]}
    assert rpdo == {0x203: (0x0F, 10), 0x204: (0x0F, -(2**31)), 0x205: (0x0F, 30)}
    assert sent[-1].arbitration_id == pdo.SYNC


def test_tpdo2_heartbeat_and_emcy_are_decoded(rig: Rig):
    rig.cycle()
    rig.bus._queue.append(can.Message(arbitration_id=0x285, data=pdo.TPDO2_STRUCT.pack(-77)))
    rig.bus._queue.append(can.Message(arbitration_id=0x704, data=b"\x05"))
    rig.now = 6.0
    rig.io.receive()
    assert rig.io.velocity[2] == -77 and rig.sup.last_heartbeat[1] == 6.0
    assert not rig.faults
    rig.bus._queue.append(can.Message(arbitration_id=0x704, data=b"\x00"))  # rebooted
    rig.bus._queue.append(can.Message(arbitration_id=0x083, data=b"\x10\x23\x02\0\0\0\0\0"))
    rig.io.receive()
    assert [(f.code, f.source) for f in rig.faults] == [
        (AlarmCode.HEARTBEAT_LOST, "b"), (AlarmCode.EMCY, "a"),
    ]  # fmt: skip


def test_a_failed_send_is_a_bus_error_and_the_port_stops(rig: Rig):
    def broken(msg: can.Message, timeout: float | None = None) -> None:
        raise can.CanOperationError("tx queue full")

    rig.bus.send = broken  # type: ignore[method-assign]
    rig.io.send()
    assert rig.port.failed
    assert [(f.code, f.source) for f in rig.faults] == [(AlarmCode.BUS_ERROR, "b")]
    assert "send of 0x080 failed: tx queue full" in rig.faults[0].description
    rig.io.send()
    rig.io.send_heartbeat(10.0, force=True)
    assert len(rig.faults) == 1 and rig.port.syncs_sent == 0


def test_a_bus_off_error_frame_faults(rig: Rig):
    rig.bus._queue.append(can.Message(arbitration_id=0x40, is_error_frame=True, data=bytes(8)))
    rig.io.receive()
    assert [(f.code, f.source) for f in rig.faults] == [(AlarmCode.BUS_OFF, "b")]


def test_receive_waits_for_missing_tpdos_until_the_deadline(rig: Rig):
    rig.now = 0.0
    rig.io.clear_fresh()
    rig.io.receive(deadline=0.0)  # deadline passed: no wait
    assert not rig.io.fresh.any()
    rig.io.send()
    rig.io.clear_fresh()
    rig.io.receive(deadline=1.0)
    assert rig.io.fresh.all()


def test_heartbeat_only_when_due(rig: Rig):
    rig.io.send_heartbeat(1.0)
    rig.io.send_heartbeat(1.05)
    rig.io.send_heartbeat(1.1)
    assert rig.port.frames_sent == 2
    rig.io.send_heartbeat(1.11, force=True)
    assert rig.port.frames_sent == 3


def test_poller_is_the_fast_path_on_a_plain_bus(rig: Rig):
    assert poller(rig.bus) == rig.bus._recv_internal


def test_receive_waits_on_every_bus_at_once_where_buses_have_descriptors(tmp_path):
    """unix buses (fileno): missing TPDOs on two buses are waited for with one select; a
    bus whose drive never answers ends the wait at the deadline, the others are kept."""
    import threading

    from hal.can.unix_bus import UnixBus

    masters = [UnixBus(str(tmp_path / b)) for b in "ab"]
    drives = [UnixBus(str(tmp_path / b)) for b in "ab"]
    try:
        ports = [
            Port(b, bus, [i], {c: (k, i) for c, (k, _) in pdo.receive_table([NODES[i]]).items()},
                 can.Message(arbitration_id=pdo.SYNC, data=b"", is_extended_id=False),
                 can.Message(arbitration_id=0x77F, data=b"\x05", is_extended_id=False))
            for i, (b, bus) in enumerate(zip("ab", masters, strict=True))
        ]  # fmt: skip
        assert all(p.fd is not None for p in ports)
        sup = Supervisor(["a", "b"], NODES[:2], ["a", "b"], 0.002, np.full(2, 0.1), 0.006, 0.3, 3)
        waiting = threading.Event()
        now = [0.0]

        def clock() -> float:  # called only while receive() waits
            waiting.set()
            return now[0]

        io = CycleIO(ports, NODES[:2], sup, lambda faults: None, clock, 0.1)
        for bus in masters:
            assert bus.recv(0.0) is None  # accept the drives

        def tpdo1(i: int, position: int) -> can.Message:
            data = bytes([0x27, 0, position, 0, 0, 0])
            return can.Message(arbitration_id=pdo.TPDO1 + NODES[i], data=data, is_extended_id=False)

        def answer() -> None:
            assert waiting.wait(5.0)
            for i, bus in enumerate(drives):
                bus.send(tpdo1(i, i + 1))

        thread = threading.Thread(target=answer)
        thread.start()
        io.clear_fresh()
        io.receive(deadline=1.0)  # the fake clock never reaches it: returns when all came
        thread.join()
        assert io.fresh.all() and io.position.tolist() == [1, 2]
        io.clear_fresh()
        drives[0].send(tpdo1(0, 7))
        now[0] = 1.0
        io.receive(deadline=1.0)  # deadline reached: bus b's drive is missing, a's is read
        assert list(io.fresh) == [True, False] and io.position.tolist() == [7, 2]
    finally:
        for bus in masters + drives:
            bus.shutdown()


@pytest.mark.parametrize("path", ["records", "recv_frames", "python-can API"])
def test_unix_buses_decode_the_same_through_recv_frames_and_the_api(tmp_path, path):
    """A unix bus is read as whole records (compiled), with recv_frames (no can.Message per
    classic frame) and decodes exactly as through python-can's API: every record waiting
    (here three), TPDO1/TPDO2, heartbeats, EMCY, a bus-off error frame; frames and bits
    counted alike."""
    if path == "records" and not jit.available():
        pytest.skip("numba not installed or IMOTION_JIT=0")
    from hal.can.unix_bus import UnixBus

    master = UnixBus(str(tmp_path / "b"))
    drive = UnixBus(str(tmp_path / "b"), hold_pdos=True)
    try:
        port = Port(
            "b", master, [0, 1, 2],
            {c: (k, i) for c, (k, i) in pdo.receive_table(NODES).items()},
            can.Message(arbitration_id=pdo.SYNC, data=b"", is_extended_id=False),
            can.Message(arbitration_id=0x77F, data=b"\x05", is_extended_id=False),
        )  # fmt: skip
        assert port.recv_frames == master.recv_frames
        assert port.recv_records == master.recv_records
        if path != "records":
            port.recv_records = port.send_record = None
        if path == "python-can API":
            port.recv_frames = None  # the python-can API (port.poll), as on SocketCAN
        sup = Supervisor(["a", "b", "c"], NODES, ["b"] * 3, 0.002, np.full(3, 0.1), 0.006, 0.3, 3)
        faults: list[HardwareFault] = []
        io = CycleIO([port], NODES, sup, faults.extend, lambda: 7.0, 0.1)
        assert (io._records is not None) == (path == "records")
        io.receive()  # accepts the drive
        for i, node in enumerate(NODES):
            drive.send_raw(pdo.TPDO1 + node, pdo.TPDO1_STRUCT.pack(0x27, 100 * (i + 1)))
        drive.send_raw(pdo.TPDO2 + 5, pdo.TPDO2_STRUCT.pack(-77))
        drive.send_raw(0x704, b"\x05")  # heartbeat: the held TPDOs go with it, one record
        drive.send_raw(0x083, b"\x10\x23\x02\0\0\0\0\0")  # EMCY of node 3: a record
        drive.send(can.Message(arbitration_id=0x40, is_error_frame=True, data=bytes(8)))
        io.clear_fresh()
        io.receive()
        assert io.fresh.all() and io.position.tolist() == [100, 200, 300] and io.velocity[2] == -77
        assert io.statusword.tolist() == [0x27] * 3 and sup.last_heartbeat[1] == 7.0
        assert [(f.code, f.source) for f in faults] == [
            (AlarmCode.EMCY, "a"), (AlarmCode.BUS_OFF, "b")
        ]  # fmt: skip
        assert port.frames_received == 7 and port.failed
        assert port.bits == 3 * FRAME_BITS[6] + FRAME_BITS[4] + FRAME_BITS[1] + 2 * FRAME_BITS[8]
        assert select.select([master], [], [], 0.0)[0] == []  # nothing left unread
    finally:
        master.shutdown()
        drive.shutdown()


def test_a_bus_readable_with_nothing_to_read_does_not_hold_receive(tmp_path):
    """A descriptor that stays readable while the bus reads nothing (e.g. a connection it
    cannot accept) ends receive()'s rounds: it returns, the next cycle tries again."""
    import threading

    from hal.can.unix_bus import UnixBus

    master = UnixBus(str(tmp_path / "b"))
    drive = UnixBus(str(tmp_path / "b"))
    try:
        port = Port(
            "b", master, [0], {c: (k, 0) for c, (k, _) in pdo.receive_table([3]).items()},
            can.Message(arbitration_id=pdo.SYNC, data=b"", is_extended_id=False),
            can.Message(arbitration_id=0x77F, data=b"\x05", is_extended_id=False),
        )  # fmt: skip
        port.recv_frames = lambda drain: ([], [])  # reads nothing; the frame stays queued
        sup = Supervisor(["a"], [3], ["b"], 0.002, np.full(1, 0.1), 0.006, 0.3, 3)
        io = CycleIO([port], [3], sup, lambda faults: None, lambda: 0.0, 0.1)
        drive.send(can.Message(arbitration_id=0x183, data=bytes(6), is_extended_id=False))
        assert select.select([master], [], [], 0.0)[0] == [master]
        done = threading.Event()
        thread = threading.Thread(target=lambda: (io.receive(), done.set()), daemon=True)
        thread.start()
        assert done.wait(5.0), "receive() kept polling a bus that brings nothing"
    finally:
        master.shutdown()
        drive.shutdown()


class RecordRig(Rig):
    """:class:`Rig` on a stub bus that takes and answers whole ``unix`` records."""

    def __init__(self) -> None:
        super().__init__()
        self.bus = StubRecordBus("b", NODES, [True, False, True], positions=[10, -20, 30])
        self.port = Port(
            "b", self.bus, [0, 1, 2], dict(self.port.table), self.port.sync, self.port.heartbeat
        )  # fmt: skip
        self.io.ports = [self.port]

    def inject(self, *msgs: can.Message) -> None:
        self.bus._records.append(b"".join(encode(m) for m in msgs))


@pytest.mark.skipif(not jit.available(), reason="numba not installed or IMOTION_JIT=0")
def test_records_decode_and_encode_as_the_frames_do():
    """The compiled record path (one record per bus and cycle, :func:`decode_record` /
    :func:`encode_record`) gives the frame path's feedback, states, controlwords, faults,
    counters and RPDO bytes, EMCY and heartbeats in the middle of a record included."""
    plain, fast = Rig(), RecordRig()
    assert fast.io._records is not None and plain.io._records is None
    sent: list[tuple[int, bytes]] = []
    send = plain.bus.send

    def spy(msg: can.Message, timeout: float | None = None) -> None:
        sent.append((msg.arbitration_id, bytes(msg.data)))
        send(msg, timeout)

    plain.bus.send = spy  # type: ignore[method-assign]
    records: list[bytes] = []
    send_record = fast.bus.send_record

    def record_spy(record: bytes | memoryview) -> None:
        records.append(bytes(record))
        send_record(record)

    fast.bus.send_record = record_spy  # type: ignore[method-assign]
    fast.port.send_record = record_spy
    extra = [
        can.Message(arbitration_id=0x285, data=pdo.TPDO2_STRUCT.pack(-77)),
        can.Message(arbitration_id=0x704, data=b"\x05"),
        can.Message(arbitration_id=0x704, data=b"\x7f"),  # pre-operational: a fault now
        can.Message(arbitration_id=0x083, data=b"\x10\x23\x02\0\0\0\0\0"),
        can.Message(arbitration_id=0x183, data=pdo.TPDO1_STRUCT.pack(0x27, -(2**31))),
    ]
    for k in range(8):
        for r in (plain, fast):
            if k == 1:
                r.io.set_goal(Goal.ENABLED)
            if k == 6:
                r.io.target[:] = [5, -(2**31), 2**31 - 1]
                r.now = 7.0
                if r is fast:
                    fast.inject(*extra)
                else:
                    plain.bus._queue.extend(extra)
            r.cycle()
        assert fast.io.statusword.tolist() == plain.io.statusword.tolist()
        assert fast.io.position.tolist() == plain.io.position.tolist()
        assert fast.io.velocity.tolist() == plain.io.velocity.tolist()
        assert fast.io.states == plain.io.states
        assert list(fast.io.fresh) == list(plain.io.fresh)
        assert fast.sup.last_heartbeat.tolist() == plain.sup.last_heartbeat.tolist()
        assert [(f.code, f.source, f.description) for f in fast.faults] == [
            (f.code, f.source, f.description) for f in plain.faults
        ]
        for what in ("frames_sent", "frames_received", "syncs_sent", "bits"):
            assert getattr(fast.port, what) == getattr(plain.port, what), what
    assert fast.io.all_enabled == plain.io.all_enabled
    assert [f.code for f in fast.faults] == [AlarmCode.HEARTBEAT_LOST, AlarmCode.EMCY]
    # The same RPDOs and SYNCs, frame for frame (the timestamps aside).
    frames = []
    for record in records:
        frames += [(cob, bytes(data)) for cob, _, _, _, data in unix_frames(record)]
    assert frames == sent

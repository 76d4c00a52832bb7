"""hal.can.unix_bus: the python-can ``unix`` interface (a bus = a directory of Unix sockets)."""

from __future__ import annotations

import select
import socket

import can
import pytest

import hal.can  # noqa: F401  (registers interface "unix")
from hal.can.unix_bus import UnixBus, bus_directory
from hal.can.unix_wire import MAX_RECORD, encode, frames

TIMEOUT = 5.0  # [s] bound of every wait (never asserted as a time)


def message(can_id: int, data: bytes = b"", **kwargs: object) -> can.Message:
    return can.Message(arbitration_id=can_id, data=data, is_extended_id=False, **kwargs)


@pytest.fixture
def channel(tmp_path):
    return str(tmp_path / "bus")


def test_two_participants_exchange_frames_in_order(channel):
    with can.Bus(interface="unix", channel=channel) as a, UnixBus(channel) as b:
        assert isinstance(a, UnixBus) and a.peers == 0 and b.peers == 1
        for k in range(50):
            b.send(message(0x200 + k % 8, bytes([k, 1, 2, 3, 4, 5])))
        got = [a.recv(TIMEOUT) for _ in range(50)]
        assert [m.data[0] for m in got] == list(range(50))
        assert a.peers == 1  # accepted b while receiving
        a.send(message(0x181, b"\x27\x06\x01\x02\x03\x04"))
        answer = b.recv(TIMEOUT)
        assert answer.arbitration_id == 0x181 and bytes(answer.data) == b"\x27\x06\x01\x02\x03\x04"
        assert a.recv(0.0) is None and b.recv(0.0) is None  # nothing echoed


def test_every_other_participant_gets_each_frame(channel):
    with (
        UnixBus(channel) as a,
        UnixBus(channel) as b,
        UnixBus(channel, receive_own_messages=True) as c,
    ):
        for bus in (a, b):
            assert bus.recv(0.0) is None  # accept the later ones
        c.send(message(0x080))
        for bus in (a, b, c):
            got = bus.recv(TIMEOUT)
            assert got is not None and got.arbitration_id == 0x080
        a.send(message(0x77F, b"\x05"))
        assert b.recv(TIMEOUT).arbitration_id == 0x77F
        assert c.recv(TIMEOUT).arbitration_id == 0x77F
        assert a.recv(0.0) is None


def test_fileno_is_selectable(channel):
    with UnixBus(channel) as a, UnixBus(channel) as b:
        assert select.select([a], [], [], 0.0)[0] == [a]  # b's connection waits to be accepted
        assert a.recv(0.0) is None
        assert select.select([a], [], [], 0.0)[0] == []
        b.send(message(0x080))
        assert select.select([a], [], [], TIMEOUT)[0] == [a]
        assert a.recv(0.0).arbitration_id == 0x080


def test_a_peer_that_leaves_or_died_is_forgotten(channel, tmp_path):
    a = UnixBus(channel)
    b = UnixBus(channel)
    assert a.recv(0.0) is None and a.peers == 1
    b.shutdown()
    assert a.recv(0.0) is None  # sees the close
    assert a.peers == 0
    a.send(message(0x080))  # nobody there: no error
    # a participant killed without closing leaves its socket file; the next joiner removes it
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    dead_path = bus_directory(channel) / "99999-0"
    dead.bind(str(dead_path))
    dead.close()
    c = UnixBus(channel)
    assert c.peers == 1 and not dead_path.exists()
    c.shutdown()
    a.shutdown()
    assert list(bus_directory(channel).iterdir()) == []


def test_a_peer_that_does_not_read_loses_frames_but_never_blocks_the_sender(channel):
    with UnixBus(channel) as reader, UnixBus(channel) as writer:
        sent = 0
        while writer.dropped == 0 and sent < 1_000_000:
            writer.send(message(0x181, bytes(8)))
            sent += 1
        assert writer.dropped > 0
        received = 0
        while reader.recv(0.0) is not None:
            received += 1
        assert received == sent - writer.dropped


def test_channel_names_and_errors(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    assert bus_directory("body") == tmp_path / "imotion-can" / "body"
    assert bus_directory(str(tmp_path / "x")) == tmp_path / "x"
    with pytest.raises(ValueError, match="empty"):
        bus_directory("")
    with pytest.raises(can.CanInitializationError, match="too long"):
        UnixBus(str(tmp_path / ("d" * 120)))


def test_raw_frames_match_the_message_api(channel):
    """send_raw/recv_raw (the emulator's fast path) speak the same wire frame as send/recv."""
    with UnixBus(channel) as raw, UnixBus(channel) as plain:
        assert raw.recv_raw() == []  # accepts the later participant
        raw.send_raw(0x181, b"\x27\x06\x01\x02\x03\x04")
        got = plain.recv(TIMEOUT)
        assert got.arbitration_id == 0x181 and bytes(got.data) == b"\x27\x06\x01\x02\x03\x04"
        assert not got.is_extended_id and got.timestamp > 0
        plain.send(message(0x201, b"\x0f\x00\x10\x00\x00\x00"))
        plain.send(can.Message(arbitration_id=0x1ABCDE, data=b"\x01"))  # extended: dropped there
        plain.send(message(0x080))
        frames = []
        for _ in range(100):  # bounded: until both classic frames came
            frames += raw.recv_raw()
            if len(frames) >= 2:
                break
            select.select([raw], [], [], 0.05)
        assert [(can_id, data) for _, can_id, data in frames] == [
            (0x201, b"\x0f\x00\x10\x00\x00\x00"),
            (0x080, b""),
        ]
        assert frames[0][0] <= frames[1][0]  # sender timestamps, in order


def test_held_pdos_go_with_the_next_frame_as_one_record(channel):
    """hold_pdos: RPDOs wait for the SYNC; the peer gets them in order, one record."""
    with (
        UnixBus(channel, hold_pdos=True) as master,
        socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as wire,
    ):
        wire.connect(str(master.path))
        assert master.recv(0.0) is None and master.peers == 1  # accepts it
        for k in range(3):
            master.send(message(0x201 + k, bytes([k] * 6)))
        assert select.select([wire], [], [], 0.0)[0] == []  # nothing on the wire yet
        master.send(message(0x080))  # SYNC: not a PDO, goes after the held ones
        wire.settimeout(TIMEOUT)
        got = frames(wire.recv(MAX_RECORD))  # one record
        assert [(can_id, data) for can_id, _, _, _, data in got] == [
            (0x201, bytes(6)), (0x202, bytes([1] * 6)), (0x203, bytes([2] * 6)), (0x080, b"")
        ]  # fmt: skip
        assert select.select([wire], [], [], 0.0)[0] == []
    with UnixBus(channel, hold_pdos=True) as master, UnixBus(channel) as drive:
        assert master.recv(0.0) is None
        # extended frames in the PDO range are not held; flush() and a receive send the rest
        master.send(can.Message(arbitration_id=0x181, data=b"\x01"))
        assert drive.recv(TIMEOUT).is_extended_id
        master.send(message(0x181, b"\x02"))
        master.flush()
        assert bytes(drive.recv(TIMEOUT).data) == b"\x02"
        master.send(message(0x182, b"\x03"))
        assert master.recv(0.0) is None  # receiving sends what is held first
        assert bytes(drive.recv(TIMEOUT).data) == b"\x03"


def test_without_hold_every_frame_goes_at_once(channel):
    with UnixBus(channel) as a, UnixBus(channel) as b:
        assert a.recv(0.0) is None
        a.send(message(0x201, bytes(6)))
        assert select.select([b], [], [], TIMEOUT)[0] == [b]
        assert b.recv(0.0).arbitration_id == 0x201


def test_held_frames_beyond_a_record_split_in_order(channel):
    with UnixBus(channel, hold_pdos=True) as master, UnixBus(channel) as drive:
        assert master.recv_raw() == []
        count = 2 * MAX_RECORD // 22 + 5  # 22-byte frames: over two records' worth
        for k in range(count):
            master.send_raw(0x181 + k % 4, k.to_bytes(6, "little"))
        master.flush()
        got: list[tuple[float, int, bytes]] = []
        for _ in range(100):  # bounded: until every frame came
            got += drive.recv_raw()
            if len(got) >= count:
                break
            select.select([drive], [], [], 0.05)
        assert [int.from_bytes(d, "little") for _, _, d in got] == list(range(count))


def test_records_split_into_frames_and_bad_records_are_dropped(channel, caplog):
    fields = [
        (0x181, 0, 6, 1.0, bytes(6)),
        (0x80, 0, 0, 2.0, b""),
        (0x1ABCDE, 1, 2, 3.0, b"\x01\x02"),
    ]
    record = b"".join(
        encode(can.Message(arbitration_id=i, is_extended_id=bool(f), data=d, timestamp=t))
        for i, f, _, t, d in fields
    )
    assert frames(record) == fields
    with pytest.raises(ValueError, match="cut"):
        frames(record[:-1])
    with UnixBus(channel) as a, socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as raw:
        raw.connect(str(a.path))
        raw.send(record[:-1])  # cut: the whole frames before the cut, the rest dropped
        raw.send(record)
        got = [a.recv(TIMEOUT) for _ in range(5)]
        assert [m.arbitration_id for m in got[:2]] == [0x181, 0x80]
        got = got[2:]
        assert [(m.arbitration_id, m.is_extended_id, m.timestamp) for m in got] == [
            (0x181, False, 1.0), (0x80, False, 2.0), (0x1ABCDE, True, 3.0)
        ]  # fmt: skip
        assert "cut" in caplog.text
        raw.send(record)
        select.select([a], [], [], TIMEOUT)
        assert [(c, d) for _, c, d in a.recv_raw()] == [(0x181, bytes(6)), (0x80, b"")]


def test_recv_frames_reads_everything_waiting_without_messages(channel):
    """recv_frames() (the master's fast path): classic data frames as (identifier, data),
    in order over several records; other frames, and those recv() had read, as messages."""
    with UnixBus(channel) as master, UnixBus(channel, hold_pdos=True) as drive:
        assert master.recv_frames() == ([], []) and master.peers == 1  # accepts the drive
        for k in range(3):
            drive.send_raw(0x181 + k, bytes([k] * 6))  # held: one record with the heartbeat
        drive.send(message(0x701, b"\x05"))
        drive.send(can.Message(arbitration_id=0x1ABCDE, data=b"\x01"))  # extended
        drive.send(message(0x081, bytes(8)))
        assert master.recv(TIMEOUT).arbitration_id == 0x181  # keeps the rest of its record
        classic, others = master.recv_frames()
        assert classic == [(0x081, bytes(8))]
        assert [(m.arbitration_id, m.is_extended_id, bytes(m.data)) for m in others] == [
            (0x182, False, bytes([1] * 6)), (0x183, False, bytes([2] * 6)),
            (0x701, False, b"\x05"), (0x1ABCDE, True, b"\x01"),
        ]  # fmt: skip
        assert select.select([master], [], [], 0.0)[0] == []
        assert master.recv_frames() == ([], [])


def test_recv_frames_without_drain_reads_one_record_per_peer(channel):
    """drain=False: one recv per peer; what is left keeps fileno() readable; when no peer
    had a record, an epoll round accepts new participants; a peer that left is forgotten."""
    with UnixBus(channel) as master, UnixBus(channel) as a, UnixBus(channel) as b:
        assert master.recv_frames(False) == ([], []) and master.peers == 2
        a.send(message(0x181, b"\x01"))
        a.send(message(0x181, b"\x02"))
        b.send(message(0x182, b"\x03"))
        classic, others = master.recv_frames(False)
        assert sorted(classic) == [(0x181, b"\x01"), (0x182, b"\x03")] and others == []
        assert select.select([master], [], [], 0.0)[0] == [master]  # a's second record
        assert master.recv_frames(False) == ([(0x181, b"\x02")], [])
        assert select.select([master], [], [], 0.0)[0] == []
        with UnixBus(channel) as late:
            assert select.select([master], [], [], 0.0)[0] == [master]  # to be accepted
            assert master.recv_frames(False) == ([], []) and master.peers == 3
            assert select.select([master], [], [], 0.0)[0] == []
            late.send(message(0x183))
            assert master.recv_frames(False) == ([(0x183, b"")], [])
        b.shutdown()  # b and late left
        assert master.recv_frames(False) == ([], []) and master.peers == 1


def test_records_in_and_out_whole(channel):
    """recv_records hands over each record as received (pending messages apart);
    send_record sends whole wire frames as one record, after the frames held."""
    with UnixBus(channel) as master, UnixBus(channel, hold_pdos=True) as drive:
        assert master.recv_records(False) == ([], []) and master.peers == 1
        drive.send(message(0x181, b"\x01\x02"))  # held
        drive.send_record(memoryview(encode(message(0x080)) + encode(message(0x701, b"\x05"))))
        records, others = master.recv_records()
        assert others == [] and len(records) == 1
        assert [(f[0], f[4]) for f in frames(records[0])] == [
            (0x181, b"\x01\x02"), (0x080, b""), (0x701, b"\x05"),
        ]  # fmt: skip
        drive.send(message(0x080))
        assert master.recv(TIMEOUT).arbitration_id == 0x080
        drive.send(message(0x081))
        master._pending.append(message(0x082))  # read by recv() before, not returned
        records, others = master.recv_records(True)
        assert [m.arbitration_id for m in others] == [0x082]
        assert [f[0] for r in records for f in frames(r)] == [0x081]


@pytest.mark.parametrize("hold", [True, False])
def test_hold_frames_sends_encoded_frames_as_send_raw_would(channel, hold):
    """The emulator's compiled TPDOs: held with hold_pdos (one record with the next flush),
    else one record at once; beyond a record, frame by frame, in order."""
    encoded = [encode(message(0x181 + k % 4, k.to_bytes(6, "little"))) for k in range(400)]
    with UnixBus(channel, hold_pdos=hold) as emu, UnixBus(channel) as master:
        assert emu.recv_raw() == []  # accepts the master
        emu.hold_frames(b"".join(encoded[:3]))
        if hold:
            assert select.select([master], [], [], 0.0)[0] == []  # held
            emu.flush()
        records, _ = master.recv_records()
        for _ in range(100):  # bounded: until the record came
            if records:
                break
            select.select([master], [], [], 0.05)
            records, _ = master.recv_records()
        assert records == [b"".join(encoded[:3])]  # one record, as sent
        emu.hold_frames(b"".join(encoded))  # over MAX_RECORD: split at frame boundaries
        emu.flush()
        got: list[tuple[float, int, bytes]] = []
        for _ in range(100):
            got += master.recv_raw()
            if len(got) >= len(encoded):
                break
            select.select([master], [], [], 0.05)
        assert [int.from_bytes(d, "little") for _, _, d in got] == list(range(400))

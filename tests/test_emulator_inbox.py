"""hal.emulator.inbox: records split, ordered and routed as the Python path handles frames."""

from __future__ import annotations

import select
import struct

import can
import numpy as np
import pytest

from controller.model import jit
from hal.can.unix_wire import HEADER
from hal.emulator.bank import INT, DriveBank
from hal.emulator.codes import NMT_OPERATIONAL
from hal.emulator.inbox import Inbox, route_frames, split_records
from hal.emulator.port import Port

# Run with IMOTION_JIT=0 too: the tests ask for the compiled round explicitly.
pytestmark = pytest.mark.skipif(jit.numba is None, reason="numba not installed")


def _frame(can_id: int, data: bytes, stamp: float, flags: int = 0) -> bytes:
    return HEADER.pack(can_id, flags, len(data), len(data), stamp) + data


def _split(records: list[bytes], ports: list[int]) -> tuple[int, np.ndarray, ...]:
    buf = np.frombuffer(b"".join(records), dtype=np.uint8)
    n_max = buf.size // 16
    out = [np.zeros(n_max, dtype=np.int64) for _ in range(4)]
    bad = np.zeros(len(records) + 1, dtype=bool)
    sizes = np.array([[len(r) for r in records], ports], dtype=np.int64)
    n = split_records(buf, sizes, bad, *out)
    return n, buf, bad, *out


def test_frames_come_out_in_the_order_they_were_sent_across_buses():
    bus0 = _frame(0x201, b"\x0f\x00\x01\x00\x00\x00", 3.0) + _frame(0x080, b"", 5.0)
    bus1 = _frame(0x202, b"\x0f\x00\x02\x00\x00\x00", 3.0) + _frame(0x080, b"", 4.0)
    n, buf, bad, port, can_id, start, order = _split([bus0, bus1], [0, 1])
    assert n == 4 and not bad.any()
    seen = [(int(port[j]), int(can_id[j])) for j in order[:n]]
    # by time stamp; equal stamps keep the order read (bus 0 first), as Python's stable sort
    assert seen == [(0, 0x201), (1, 0x202), (1, 0x080), (0, 0x080)]
    assert buf[start[order[0]] + 16 + 2] == 1  # the header's offset: data follows it


def test_other_frames_are_skipped_and_a_cut_record_dropped_whole():
    good = _frame(0x181, b"\x01\x02", 1.0) + _frame(0x123, b"", 1.5, flags=1)  # extended
    cut = _frame(0x182, b"\x01\x02", 2.0)[:-1]
    n, _, bad, port, can_id, _, order = _split([good, cut], [0, 1])
    assert n == 1 and can_id[order[0]] == 0x181 and port[order[0]] == 0
    assert list(bad) == [False, True, True]  # the last: some record was dropped


def _bank() -> DriveBank:
    bank = DriveBank(2)
    bank.ints[:, INT["nmt_state"]] = NMT_OPERATIONAL
    return bank


def _route(bank: DriveBank, frames: list[bytes]) -> int:
    n, buf, _, port, can_id, start, order = _split([b"".join(frames)], [0])
    routes = np.full((1, 0x800), -1, dtype=np.int64)
    routes[0, 0x201], routes[0, 0x202] = 0, 1
    return route_frames(order[:n], 0, buf, port, can_id, start, routes, bank.ints)


def test_controlword_and_target_rpdos_go_into_the_bank_the_last_one_kept():
    bank = _bank()
    rpdo = struct.pack("<Hi", 0x0F, -123456)
    frames = [
        _frame(0x201, struct.pack("<Hi", 6, 1), 1.0),
        _frame(0x201, rpdo, 1.1),
        _frame(0x202, rpdo + b"\xff\xff", 1.2),
        _frame(0x080, b"", 1.3),
    ]
    stop = _route(bank, frames)
    assert stop == 3  # the SYNC is Python's
    row = bank.ints[0]
    assert (row[INT["rx_fresh"]], row[INT["rx_controlword"]], row[INT["rx_target"]]) == (
        1,
        0x0F,
        -123456,
    )
    assert bank.ints[1, INT["rx_target"]] == -123456  # longer frames: their first 6 bytes


@pytest.mark.parametrize(
    ("column", "value", "stops"),
    [("silent", 1, False), ("nmt_state", 127, False), ("waiting", 1, True)],
)
def test_rpdos_a_drive_would_not_take_or_that_need_its_handler(column, value, stops):
    bank = _bank()
    bank.ints[0, INT[column]] = value
    stop = _route(bank, [_frame(0x201, struct.pack("<Hi", 0x0F, 5), 1.0)])
    assert stop == (0 if stops else 1)  # dropped (as the handler does) or left to it
    assert bank.ints[0, INT["rx_fresh"]] == 0


def test_a_short_rpdo_and_an_unknown_identifier_stop_the_walk():
    bank = _bank()
    assert _route(bank, [_frame(0x201, b"\x0f\x00", 1.0)]) == 0
    assert _route(bank, [_frame(0x203, struct.pack("<Hi", 0x0F, 5), 1.0)]) == 0
    assert not bank.ints[:, INT["rx_fresh"]].any()


def _unix_ports(tmp_path, names: tuple[str, ...]) -> tuple[list[Port], list[can.BusABC]]:
    """Ports (no drives: every frame goes to the Python handler) on ``unix`` buses, each with a
    master joined to it."""
    ports = [Port(n, "unix", str(tmp_path / n), []) for n in names]
    for port in ports:
        port.attach(can.Bus(interface="unix", channel=port.channel))
    return ports, [can.Bus(interface="unix", channel=port.channel) for port in ports]


@pytest.mark.parametrize("gather", [False, True])
def test_a_master_behind_frame_by_frame_is_handled_in_the_order_it_sent(tmp_path, gather):
    """Frame by frame (one record each, no hold_pdos) and two rounds behind: bus 0's second
    SYNC must come after bus 1's first, whether the buses are drained whole or read a record
    per peer and round while ``more`` names buses."""
    ports, masters = _unix_ports(tmp_path, ("a", "b"))
    sent = [  # (bus, identifier), in the order sent, stamps increasing
        (0, 0x201), (0, 0x080), (1, 0x202), (1, 0x203), (1, 0x204), (1, 0x080),
        (0, 0x201), (0, 0x080), (1, 0x202), (1, 0x203), (1, 0x204), (1, 0x080),
    ]  # fmt: skip
    for k, (bus, can_id) in enumerate(sent):
        data = b"" if can_id == 0x080 else bytes(6)
        masters[bus].send(can.Message(timestamp=100.0 + k, arbitration_id=can_id, data=data,
                                      is_extended_id=False))  # fmt: skip
    handled: list[tuple[int, int]] = []
    inbox = Inbox(ports, DriveBank(0).ints,
                  lambda port, can_id, _: handled.append((ports.index(port), can_id)))  # fmt: skip
    asked: list[list[int]] = []

    def more() -> list[int]:
        waiting = [k for k, p in enumerate(ports) if select.select([p.bus], [], [], 0.0)[0]]
        asked.append(waiting)
        return waiting

    try:
        n = inbox.handle([0, 1], more if gather else None)
    finally:
        for bus in [*masters, *(p.bus for p in ports)]:
            bus.shutdown()
    assert n == len(sent) and handled == sent  # handled per round, bus 0 would run ahead
    if gather:  # a record per peer and round: bus 1's eight, then nothing left
        assert len(asked) == 8 and asked[-1] == []

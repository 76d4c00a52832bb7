"""The frames the drive emulator receives, compiled: whole records in, the RPDOs into the bank.

Where :meth:`DriveEmulator._handle` (Python) takes every waiting frame of every bus as a
tuple, sorts them by their time stamps and calls a Python handler per frame, the
:class:`Inbox` takes each bus's records as they came off the wire (:meth:`Port.records`,
:mod:`hal.can.unix_wire`), splits all of them with one compiled call (:func:`split_records`),
orders them the same way (stable, by the sender's time stamp) and walks them with another
(:func:`route_frames`), which keeps each drive's controlword + target RPDO in its bank row
(:mod:`hal.emulator.bank`) as the drive's own handler would (:meth:`EmulatedDrive._csp_handler`)
and stops at every other frame (SYNC, SDO, NMT, heartbeats, other RPDOs, a short RPDO, a
bus that is off): the caller handles that one in Python (:meth:`DriveEmulator._frame`) and
the walk goes on after it. Same frames, same order, same effect; no Python per RPDO.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

import numpy as np

from controller.model import jit
from hal.emulator.bank import INT
from hal.emulator.codes import NMT_OPERATIONAL
from hal.emulator.port import Port

log = logging.getLogger(__name__)

#: Rounds of reads at most before what was read is handled (:meth:`Inbox.handle` with
#: ``more``: a peer sending without pause must not keep the emulator reading).
GATHER = 16
#: Bytes of a frame header on the ``unix`` wire (``<IBBBxd``), where its fields are.
_HEADER = 16
_FLAGS, _LENGTH, _STAMP = 4, 6, 8
#: Data length of the controlword + target RPDO (``<Hi``).
_CSP_SIZE = 6
_SILENT, _NMT, _WAITING = INT["silent"], INT["nmt_state"], INT["waiting"]
_RX_FRESH, _RX_ORDER = INT["rx_fresh"], INT["rx_order"]
_RX_CW, _RX_TARGET = INT["rx_controlword"], INT["rx_target"]


@jit.jit
def split_records(
    buf: np.ndarray,
    records: np.ndarray,
    bad: np.ndarray,
    port: np.ndarray,
    can_id: np.ndarray,
    start: np.ndarray,
    order: np.ndarray,
) -> int:
    """The classic 11-bit data frames of the records in ``buf`` (uint8; record ``r`` is
    ``records[0, r]`` bytes long and came from bus ``records[1, r]``): per frame its bus,
    identifier and header offset, in the order received; other frames skipped; a record
    that does not split exactly into frames dropped whole (``bad[r]``; ``bad[-1]``: any
    was). ``order`` := the frames by their time stamps, stable (the order they were sent,
    however the buses were read). Returns how many frames."""
    n = 0
    begin = 0
    dropped = 0
    for r in range(records.shape[1]):
        end = begin + records[0, r]
        at = begin
        ok = True
        while at < end:
            if at + _HEADER > end or at + _HEADER + buf[at + _LENGTH] > end:
                ok = False
                break
            at += _HEADER + buf[at + _LENGTH]
        bad[r] = not ok
        dropped += not ok
        at = begin
        while ok and at < end:
            if buf[at + _FLAGS] == 0:
                port[n] = records[1, r]
                can_id[n] = (
                    np.int64(buf[at])
                    | (np.int64(buf[at + 1]) << 8)
                    | (np.int64(buf[at + 2]) << 16)
                    | (np.int64(buf[at + 3]) << 24)
                )
                start[n] = at
                n += 1
            at += _HEADER + buf[at + _LENGTH]
        begin = end
    bad[bad.shape[0] - 1] = dropped
    stamps = np.empty(n)
    for j in range(n):
        stamps[j] = buf[start[j] + _STAMP : start[j] + _STAMP + 8].view(np.float64)[0]
    order[:n] = np.argsort(stamps, kind="mergesort")
    return n


@jit.jit
def route_frames(
    order: np.ndarray,
    first: int,
    buf: np.ndarray,
    port: np.ndarray,
    can_id: np.ndarray,
    start: np.ndarray,
    routes: np.ndarray,
    ints: np.ndarray,
) -> int:
    """Walk the frames ``order[first:]``: a controlword + target RPDO that ``routes[bus,
    identifier]`` gives to one drive (its bank row) goes into that row as the drive's
    handler would keep it; the walk stops at the first frame it does not take, whose
    position in ``order`` it returns (``order``'s length when none is left)."""
    for k in range(first, order.shape[0]):
        j = order[k]
        cid = can_id[j]
        if cid > 0x7FF:
            return k
        slot = routes[port[j], cid]
        if slot < 0:
            return k
        row = ints[slot]
        if row[_SILENT] != 0 or row[_NMT] != NMT_OPERATIONAL:
            continue  # the drive takes no RPDO now
        at = start[j]
        if row[_WAITING] != 0 or buf[at + _LENGTH] < _CSP_SIZE:
            return k  # other RPDOs waiting, or a short one: the drive's handler
        data = at + _HEADER
        if row[_RX_FRESH] == 0:
            row[_RX_ORDER] = 0
        row[_RX_CW] = buf[data] | (buf[data + 1] << 8)
        value = (
            buf[data + 2]
            | (buf[data + 3] << 8)
            | (buf[data + 4] << 16)
            | (np.int64(buf[data + 5]) << 24)
        )
        row[_RX_TARGET] = value - (1 << 32) if value >= (1 << 31) else value
        row[_RX_FRESH] = 1
    return order.shape[0]


class Inbox:
    """Receives and dispatches the frames of ``ports`` (module doc); ``ints`` is the bank's
    int array, ``frame`` handles one frame in Python (``port, identifier, data``)."""

    def __init__(
        self,
        ports: Sequence[Port],
        ints: np.ndarray,
        frame: Callable[[Port, int, bytes], None],
    ):
        self._ports = list(ports)
        self._ints = ints
        self._frame = frame
        #: Bus index, identifier -> bank row of the drive whose CSP RPDO it is (-1: Python).
        self.routes = np.full((len(self._ports), 0x800), -1, dtype=np.int64)
        self._grow(64)
        self._warm_up()

    def _grow(self, frames: int) -> None:
        self._port = np.zeros(frames, dtype=np.int64)
        self._id = np.zeros(frames, dtype=np.int64)
        self._start = np.zeros(frames, dtype=np.int64)
        self._order = np.zeros(frames, dtype=np.int64)

    def _warm_up(self) -> None:
        buf = np.zeros(_HEADER, dtype=np.uint8)
        records = np.array([[_HEADER], [0]], dtype=np.int64)
        for readonly in (False, True):  # np.frombuffer(bytes) is read-only: its own build
            buf.flags.writeable = not readonly
            n = split_records(buf, records, np.zeros(2, dtype=bool), self._port, self._id,
                              self._start, self._order)  # fmt: skip
            ints = np.zeros((1, self._ints.shape[1]), dtype=np.int64)
            route_frames(self._order[:n], 0, buf, self._port, self._id, self._start,
                         self.routes, ints)  # fmt: skip

    def refresh(self, k: int | None = None) -> None:
        """Routing tables of bus ``k`` (default: every bus) if its drives changed them."""
        for j in range(len(self._ports)) if k is None else (k,):
            port = self._ports[j]
            if port.dirty:
                port.rebuild()
            key = (port.routes_version, port.bus_off)
            if key != port.fast_key:
                self.routes[j] = port.fast_routes()
                port.fast_key = key

    def handle(
        self, ready: Sequence[int] | None = None, more: Callable[[], Sequence[int]] | None = None
    ) -> int:
        """Every frame waiting on the buses ``ready`` (indices; default: all), in the order
        they were sent; how many.

        ``more``: the buses that still hold something (one system call for all of them, e.g.
        an ``epoll`` over their descriptors). Then each read takes one record of each peer
        of a ``unix`` bus (a ``recv`` each, no ``epoll`` round per bus, :meth:`Port.records`),
        again while ``more`` names buses (at most :data:`GATHER` rounds), and everything
        read is handled together: in the order sent across buses, as a full drain of each
        would (a master that fell behind and sent frame by frame has its next round's SYNC
        on one bus handled after this round's on the others, as sent)."""
        records: list[bytes] = []
        record_ports: list[int] = []
        buses: Sequence[int] = range(len(self._ports)) if ready is None else ready
        for _ in range(GATHER if more is not None else 1):
            for k in buses:
                port = self._ports[k]
                try:
                    got = port.records(more is None)
                except Exception as exc:
                    log.error("bus %s: receive failed: %s", port.name, exc)
                    continue
                records += got
                record_ports += [k] * len(got)
            if more is None or not (buses := more()):
                break
        if not records:
            return 0
        joined = b"".join(records)
        buf = np.frombuffer(joined, dtype=np.uint8)
        if buf.size // _HEADER > self._port.size:
            self._grow(buf.size // _HEADER)
        sizes = np.array([[len(r) for r in records], record_ports], dtype=np.int64)
        bad = np.zeros(len(records) + 1, dtype=bool)
        n = split_records(buf, sizes, bad, self._port, self._id, self._start, self._order)
        if bad[-1]:
            for r in np.flatnonzero(bad[:-1]):
                log.warning("bus %s: a record of %d bytes does not split into frames (dropped)",
                            self._ports[record_ports[r]].name, len(records[r]))  # fmt: skip
        if not n:
            return 0
        bus_of, can_id, start, order = self._port, self._id, self._start, self._order[:n]
        self.refresh()
        k = 0
        while True:
            k = route_frames(order, k, buf, bus_of, can_id, start, self.routes, self._ints)
            if k >= n:
                return n
            j = int(order[k])
            index = int(bus_of[j])
            bus = self._ports[index]
            at = int(start[j])
            cid = int(can_id[j])
            data = joined[at + _HEADER : at + _HEADER + int(buf[at + _LENGTH])]
            try:
                self._frame(bus, cid, data)
            except Exception:  # one bad frame must not end the bus
                log.exception("bus %s: frame 0x%03X failed", bus.name, cid)
            self.refresh(index)  # what a frame changes (SDO, NMT) is on its own bus
            k += 1

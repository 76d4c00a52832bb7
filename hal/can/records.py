"""The CAN master's cycle on buses that take and give whole records, compiled.

A ``unix`` bus (:class:`hal.can.unix_bus.UnixBus`, and the benchmark's
:class:`hal.can.stub_bus.StubRecordBus`) offers ``recv_records`` and ``send_record``: frames
in the wire format of :mod:`hal.can.unix_wire`, one record per peer and send. On such buses
:class:`RecordIO` runs the part of a cycle that :class:`hal.can.cycle.CycleIO` otherwise
does frame by frame:

* :meth:`RecordIO.send`: every bus's RPDO1s (controlword, target [counts]) and SYNC encoded
  by one call (:func:`hal.can.kernels.encode_records`) into one buffer, then one
  ``send_record`` per bus;
* :meth:`RecordIO.drain`: each record received decoded by one call
  (:func:`hal.can.kernels.decode_record`) straight into the cycle's feedback arrays (no
  :class:`can.Message` nor tuple per frame); what the kernel leaves (EMCY, heartbeats other
  than OPERATIONAL, frames with flags) goes to the cycle's own decoding, in its place in the
  record.

Counters, faults and decoded values are those of the frame-by-frame path (tests compare
both). Only where :func:`controller.model.jit.available`: the cycle builds it then.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from typing import Protocol

import can
import numpy as np

from hal.can import kernels, pdo
from hal.can.busload import FRAME_BITS
from hal.can.ports import BUS_ERRORS, Port
from hal.can.unix_wire import HEADER, message

log = logging.getLogger(__name__)

_FRAME_BITS = np.array(FRAME_BITS, dtype=np.int64)
_RPDO_BITS, _SYNC_BITS = FRAME_BITS[6], FRAME_BITS[0]
#: Kinds of the decode tables (:func:`hal.can.kernels.decode_record`).
KIND_CODE = {
    pdo.Kind.TPDO1: kernels.K_TPDO1,
    pdo.Kind.TPDO2: kernels.K_TPDO2,
    pdo.Kind.HEARTBEAT: kernels.K_HEARTBEAT,
    pdo.Kind.EMCY: kernels.K_EMCY,
}
#: An RPDO1 on the wire [bytes]: header and 6 data bytes.
RPDO_WIRE = HEADER.size + 6


class Cycle(Protocol):
    """What :class:`RecordIO` uses of its cycle (:class:`hal.can.cycle.CycleIO`)."""

    statusword: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    fresh: np.ndarray
    seen: np.ndarray
    controlword: np.ndarray
    target: np.ndarray
    rpdo: list[can.Message]
    clock: Callable[[], float]

    def send_failed(self, port: Port, msg: can.Message, exc: BaseException) -> None: ...

    def receive_failed(self, port: Port, exc: BaseException) -> None: ...

    def decode_frame(self, port: Port, msg: can.Message) -> None: ...

    def decode_data(self, kind: pdo.Kind, i: int, data: bytes | bytearray) -> None: ...


class RecordIO:
    """Record buses ``ports`` (drives by index into ``node_ids``) of the cycle ``io``, whose
    arrays it fills and whose decoding and fault handling it uses; ``last_heartbeat`` [s]:
    the supervisor's, per drive (module doc)."""

    def __init__(
        self,
        ports: Sequence[Port],
        node_ids: Sequence[int],
        io: Cycle,
        last_heartbeat: np.ndarray,
    ):
        self.ports = list(ports)
        self.io = io
        self.last_heartbeat = last_heartbeat
        n = len(self.ports)
        #: Per bus and COB-ID: the kind of frame (:data:`KIND_CODE`) and its drive.
        self.kinds = np.zeros((n, 2048), dtype=np.int64)
        self.drives = np.zeros((n, 2048), dtype=np.int64)
        #: Frames and worst-case bits decoded per bus in one drain.
        self.counts = np.zeros((n, 2), dtype=np.int64)
        rows, heads, order = [0], [], []
        for p, port in enumerate(self.ports):
            for cob_id, (kind, i) in port.table.items():
                if cob_id < 2048 and kind in KIND_CODE:
                    self.kinds[p, cob_id] = KIND_CODE[kind]
                    self.drives[p, cob_id] = i
            for i in port.drives:
                heads.append(HEADER.pack(pdo.RPDO1 + node_ids[i], 0, 6, 6, 0.0)[:8])
                order.append(i)
            heads.append(HEADER.pack(pdo.SYNC, 0, 0, 0, 0.0)[:8])
            order.append(-1)
            rows.append(len(order))
        #: Per frame row (every bus's RPDO1s, then its SYNC): the first 8 bytes of its
        #: header, its drive (−1: the SYNC); bus ``p`` owns rows ``rows[p]:rows[p + 1]``.
        self.header = np.frombuffer(b"".join(heads), dtype=np.uint8).reshape(-1, 8).copy()
        self.order = np.array(order, dtype=np.int64)
        self.rows = np.array(rows, dtype=np.int64)
        self.out = np.zeros(RPDO_WIRE * len(order), dtype=np.uint8)
        self._view = memoryview(self.out)  # type: ignore[arg-type]
        self.bounds = np.zeros((n, 2), dtype=np.int64)
        self._stamp = np.zeros(1)
        self._stamp_bytes = self._stamp.view(np.uint8)
        #: ``(port, kinds, drives, counts)`` per bus (the row views made once).
        self.tables = [
            (port, self.kinds[p], self.drives[p], self.counts[p])
            for p, port in enumerate(self.ports)
        ]

    def send(self) -> None:
        """Every bus's record of the cycle: the RPDO1 of each drive seen (the cycle's
        :attr:`~CycleIO.controlword` and :attr:`~CycleIO.target`), then the SYNC; encoded
        in one call, one ``send_record`` per bus that has not failed."""
        io = self.io
        self._stamp[0] = time.time()
        kernels.encode_records(
            self.out, self.header, self._stamp_bytes, self.rows, self.order, io.seen,
            io.controlword, io.target, self.bounds,
        )  # fmt: skip
        view = self._view
        for port, (start, end) in zip(self.ports, self.bounds.tolist(), strict=True):
            if port.failed:
                continue
            rpdos = (end - start - HEADER.size) // RPDO_WIRE
            try:
                port.send_record(view[start:end])  # type: ignore[misc]
            except BUS_ERRORS as exc:
                first = next((i for i in port.drives if io.seen[i]), None)
                io.send_failed(port, port.sync if first is None else io.rpdo[first], exc)
                continue
            port.syncs_sent += 1
            port.frames_sent += rpdos + 1
            port.bits += _SYNC_BITS + rpdos * _RPDO_BITS

    def drain(self, only: Port | None = None) -> None:
        """Decode the records waiting on every bus (or on ``only``), one per peer."""
        io = self.io
        now = io.clock()
        decode_record, bits, last_heartbeat = (
            kernels.decode_record, _FRAME_BITS, self.last_heartbeat
        )  # fmt: skip
        sw, position, velocity, fresh, seen = (
            io.statusword, io.position, io.velocity, io.fresh, io.seen
        )  # fmt: skip
        decoded = []
        for port, kinds, drives, counts in self.tables:
            if only is not None and port is not only:
                continue
            try:
                records, others = port.recv_records(port.fd is None)  # type: ignore[misc]
            except BUS_ERRORS as exc:
                io.receive_failed(port, exc)
                continue
            for msg in others:  # read by recv() before
                io.decode_frame(port, msg)
            if not records:
                continue
            decoded.append((port, counts))
            for record in records:
                size = len(record)
                start = decode_record(record, 0, kinds, drives, bits, sw, position, velocity,
                                      fresh, seen, now, last_heartbeat, counts)  # fmt: skip
                while start < size:
                    start = self._frame(port, record, start)
                    if start < size:
                        start = decode_record(record, start, kinds, drives, bits, sw, position,
                                              velocity, fresh, seen, now, last_heartbeat,
                                              counts)  # fmt: skip
        for port, counts in decoded:
            frames, length = counts.tolist()
            port.frames_received += frames
            port.bits += length
        if decoded:
            self.counts.fill(0)

    def _frame(self, port: Port, record: bytes, start: int) -> int:
        """Decode the frame of ``record`` at byte ``start`` that the kernel left; the start
        of the next one (the record's end if it is cut: logged, the rest dropped)."""
        size = len(record)
        end = start + HEADER.size
        if end <= size:
            can_id, flags, dlc, length, stamp = HEADER.unpack_from(record, start)
            end += length
        if end > size:
            log.warning("bus %s: record of %d bytes cut at byte %d (dropped)",
                        port.name, size, start)  # fmt: skip
            return size
        data = record[start + HEADER.size : end]
        if flags:
            self.io.decode_frame(port, message(can_id, flags, dlc, stamp, data, port.name))
            return end
        port.frames_received += 1
        port.bits += FRAME_BITS[length if length < 9 else 8]
        entry = port.table.get(can_id)
        if entry is not None:
            self.io.decode_data(entry[0], entry[1], data)
        return end

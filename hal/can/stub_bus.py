"""A python-can bus whose drives answer from precomputed frames: the master measured alone.

:class:`StubDrivesBus` stands for one bus of drives without simulating them: no emulator, no
thread, no object dictionary. What it answers:

* SDO requests (0x600+id): an expedited download confirmation, or an upload of 4 zero bytes;
  enough for the master's set-up (:mod:`hal.can.setup`) to go through.
* SYNC: every drive's TPDO1 (statusword from the last controlword it got, fixed position) and
  TPDO2 where mapped, taken from frames built once; a heartbeat (operational) of every drive
  each ``heartbeat_every`` SYNCs.
* Anything else (RPDO1, NMT, the master heartbeat) is only counted.

The power state follows the controlword in one step (0x06 -> ready to switch on, 0x07 ->
switched on, 0x0F -> operation enabled, 0x02 -> quick stop active, else switch on disabled),
so ``activate()`` and ``deactivate()`` run as on real drives. It exists for
``tools/bench_can_master.py`` and the master's tests; the frames it hands out are shared
objects that the receiver must not modify (the CAN master does not).
"""

from __future__ import annotations

import struct
import threading
from collections import deque
from collections.abc import Sequence
from time import monotonic
from typing import Any

import can

from hal.can import pdo
from hal.can.unix_wire import HEADER, encode

_RPDO_WIRE = HEADER.size + 6

#: Statusword answered after each controlword (bits 0-3, 5, 6 of CiA 402).
STATUS_AFTER = {0x06: 0x0021, 0x07: 0x0023, 0x0F: 0x0027, 0x02: 0x0007}
#: Statusword of a drive that got nothing yet or a disabling controlword.
SWITCH_ON_DISABLED = 0x0040


def _frame(cob_id: int, data: bytes) -> can.Message:
    return can.Message(arbitration_id=cob_id, data=data, is_extended_id=False)


class StubDrivesBus(can.BusABC):
    """Drives ``node_ids`` on one bus; ``velocity[i]``: node i sends TPDO2 (module doc)."""

    def __init__(
        self,
        channel: str,
        node_ids: Sequence[int],
        velocity: Sequence[bool],
        positions: Sequence[int] | None = None,
        heartbeat_every: int = 25,
        **kwargs: Any,
    ):
        super().__init__(channel=channel, **kwargs)
        self.channel_info = f"stub drives {list(node_ids)} on {channel}"
        self.node_ids = list(node_ids)
        self.heartbeat_every = max(1, heartbeat_every)
        positions = list(positions) if positions is not None else [0] * len(self.node_ids)
        self._node_index = {node: k for k, node in enumerate(self.node_ids)}
        self._statusword = [SWITCH_ON_DISABLED] * len(self.node_ids)
        #: (node index, statusword) -> the TPDO1 frame (built once).
        self._tpdo1: dict[tuple[int, int], can.Message] = {}
        for k, node in enumerate(self.node_ids):
            for sw in (SWITCH_ON_DISABLED, *STATUS_AFTER.values()):
                data = pdo.TPDO1_STRUCT.pack(sw, positions[k])
                self._tpdo1[k, sw] = _frame(pdo.TPDO1 + node, data)
        self._tpdo2 = [
            _frame(pdo.TPDO2 + node, pdo.TPDO2_STRUCT.pack(0))
            for node, vel in zip(self.node_ids, velocity, strict=True)
            if vel
        ]
        self._heartbeats = [_frame(pdo.HEARTBEAT + node, b"\x05") for node in self.node_ids]
        self._queue: deque[can.Message] = deque()
        self._ready = threading.Condition()
        self.syncs = 0
        self.sent = 0
        #: Node ids that send no TPDO (a silent drive, for supervision tests).
        self.muted: set[int] = set()

    # --------------------------------------------------------------------- python-can API
    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.sent += 1
        cob = msg.arbitration_id
        function, node = cob & 0x780, cob & 0x7F
        if cob == pdo.SYNC:
            self._on_sync()
        elif function == pdo.RPDO1 and node in self._node_index:
            cw = msg.data[0] | msg.data[1] << 8
            self._statusword[self._node_index[node]] = STATUS_AFTER.get(
                cw & 0x8F, SWITCH_ON_DISABLED
            )
        elif function == pdo.SDO_RX and node in self._node_index:
            self._answer_sdo(node, bytes(msg.data))

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        queue = self._queue
        if queue:
            return queue.popleft(), True
        if timeout == 0:
            return None, True
        deadline = None if timeout is None else monotonic() + timeout
        with self._ready:
            while not queue:
                left = None if deadline is None else deadline - monotonic()
                if left is not None and left <= 0:
                    return None, True
                self._ready.wait(left)
        return queue.popleft(), True

    # ----------------------------------------------------------------------- answers
    def _on_sync(self) -> None:
        self.syncs += 1
        queue = self._queue
        tpdo1 = self._tpdo1
        if self.muted:
            for k, sw in enumerate(self._statusword):
                if self.node_ids[k] not in self.muted:
                    queue.append(tpdo1[k, sw])
            queue.extend(m for m in self._tpdo2 if m.arbitration_id & 0x7F not in self.muted)
        else:
            for k, sw in enumerate(self._statusword):
                queue.append(tpdo1[k, sw])
            queue.extend(self._tpdo2)
        if self.syncs % self.heartbeat_every == 0:
            queue.extend(self._heartbeats)

    def _answer_sdo(self, node: int, request: bytes) -> None:
        ccs = request[0] >> 5
        index_sub = request[1:4]
        if ccs == 1:  # download request -> download confirmation
            data = bytes([0x60]) + index_sub + bytes(4)
        elif ccs == 2:  # upload request -> expedited upload of 4 bytes
            data = bytes([0x43]) + index_sub + bytes(4)
        else:  # anything else: abort (0x08000000 general error)
            data = bytes([0x80]) + index_sub + (0x08000000).to_bytes(4, "little")
        with self._ready:
            self._queue.append(_frame(pdo.SDO_TX + node, data))
            self._ready.notify_all()


class StubRecordBus(StubDrivesBus):
    """:class:`StubDrivesBus` that also takes and answers whole records in the ``unix``
    wire format (:mod:`hal.can.unix_wire`), as :class:`hal.can.unix_bus.UnixBus` does
    (``recv_records``, ``send_record``): the CAN master's record path measured alone. Each
    SYNC's answer is one record of frames built once; what ``recv()`` returns is only the
    SDO answers of the set-up."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self._records: list[bytes] = []
        self._tpdo1_wire = {key: encode(msg) for key, msg in self._tpdo1.items()}
        self._tpdo2_wire = [encode(msg) for msg in self._tpdo2]
        self._heartbeats_wire = b"".join(encode(msg) for msg in self._heartbeats)
        #: (statuswords, muted) -> the record answering a SYNC (built once).
        self._answers: dict[tuple[tuple[int, ...], frozenset[int] | None], bytes] = {}
        #: Controlwords (low bytes, then high bytes) of the last cycle record taken whole.
        self._last_words = b"-"
        self._cycle_codecs: dict[int, struct.Struct] = {}

    def recv_records(self, drain: bool = True) -> tuple[list[bytes], list[can.Message]]:
        """The records answered since the last call, and the messages waiting."""
        records, self._records = self._records, []
        others: list[can.Message] = []
        if self._queue:
            with self._ready:
                others += self._queue
                self._queue.clear()
        return records, others

    def send_record(self, record: bytes | memoryview) -> None:
        """Take the frames of ``record`` as :meth:`send` does. A master's cycle (an RPDO1
        for every drive in node order, then a SYNC) whose controlwords are those of the
        last one costs one slice (the answer is then the last one); otherwise it is
        unpacked with one struct (built once per number of RPDOs), or frame by frame."""
        size = len(record)
        k, rest = divmod(size - HEADER.size, _RPDO_WIRE)
        if rest == 0 and k == len(self.node_ids):
            words = bytes(record[HEADER.size : size - HEADER.size : _RPDO_WIRE])
            words += bytes(record[HEADER.size + 1 : size - HEADER.size : _RPDO_WIRE])
            if words == self._last_words and record[size - HEADER.size] == pdo.SYNC:
                self.sent += k + 1
                self._on_sync()
                return
        else:
            words = b""
        codec = self._cycle_codecs.get(k) if rest == 0 and k >= 0 else None
        if codec is None and rest == 0 and k >= 0:
            codec = self._cycle_codecs[k] = struct.Struct("<" + "IBBBxdHi" * k + "IBBBxd")
        fields = codec.unpack_from(record) if codec is not None else ()
        if (
            not fields
            or fields[-5] != pdo.SYNC
            or any(cob & 0x780 != pdo.RPDO1 for cob in fields[0:-5:7])
        ):
            self._send_frames(bytes(record))
            return
        self.sent += k + 1
        index, status = self._node_index, self._statusword
        nodes = []
        for cob, cw in zip(fields[0:-5:7], fields[5:-5:7], strict=True):
            nodes.append(cob & 0x7F)
            if cob & 0x7F in index:
                status[index[cob & 0x7F]] = STATUS_AFTER.get(cw & 0x8F, SWITCH_ON_DISABLED)
        self._last_words = words if nodes == self.node_ids else b"-"
        self._on_sync()

    def _send_frames(self, data: bytes) -> None:
        """:meth:`send_record` frame by frame."""
        start, size = 0, len(data)
        while start + HEADER.size <= size:
            cob = data[start] | data[start + 1] << 8 | data[start + 2] << 16
            length = data[start + 6]
            body = start + HEADER.size
            self.sent += 1
            if cob == pdo.SYNC:
                self._on_sync()
            elif cob & 0x780 == pdo.RPDO1 and cob & 0x7F in self._node_index and length >= 2:
                cw = data[body] | data[body + 1] << 8
                self._statusword[self._node_index[cob & 0x7F]] = STATUS_AFTER.get(
                    cw & 0x8F, SWITCH_ON_DISABLED
                )
            start = body + length
        self._last_words = b"-"

    def _on_sync(self) -> None:
        self.syncs += 1
        key = (tuple(self._statusword), frozenset(self.muted) if self.muted else None)
        record = self._answers.get(key)
        if record is None:
            muted, nodes, tpdo1 = self.muted, self.node_ids, self._tpdo1_wire
            parts = [tpdo1[k, sw] for k, sw in enumerate(self._statusword) if nodes[k] not in muted]
            parts += [
                frame
                for frame, msg in zip(self._tpdo2_wire, self._tpdo2, strict=True)
                if msg.arbitration_id & 0x7F not in muted
            ]
            record = self._answers[key] = b"".join(parts)
        if self.syncs % self.heartbeat_every == 0:
            record += self._heartbeats_wire
        self._records.append(record)

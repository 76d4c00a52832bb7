"""One emulated bus as the drive emulator sees it: its python-can bus, drives and routing.

Frames in are routed by COB-ID to the drives' handlers (:meth:`Port.rebuild` after a drive's
routes changed: PDO mapping, SYNC COB-ID, heartbeat consumer). Frames out go through
:meth:`Port.send`, which counts and logs send errors without raising (a drive keeps running
while its bus is unwell). ``synced`` says whether this bus had its SYNC since the last
physics step: the next one starts a new round (:mod:`hal.emulator.sync_round`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import can
import numpy as np

from hal.can.unix_wire import HEADER, encode, frames
from hal.emulator.drive import EmulatedDrive
from hal.emulator.kernels import DRIVE_BYTES

log = logging.getLogger(__name__)

Handler = Callable[[bytes, float], None]


class Port:
    """Bus ``name`` on python-can ``(interface, channel)`` with ``drives`` on it."""

    def __init__(self, name: str, interface: str, channel: str, drives: list[EmulatedDrive]):
        self.name = name
        self.interface = interface
        self.channel = channel
        self.drives = drives
        #: Plant index (profile order) of each drive of this bus.
        self.indices: list[int] = []
        self.bus: can.BusABC | None = None
        self.send_raw: Callable[[int, bytes], None] | None = None
        #: Sends the frames the bus holds (``unix`` with ``hold_pdos``), else None.
        self._flush: Callable[[], None] | None = None
        self.recv_raw: Callable[[], list[tuple[float, int, bytes]]] | None = None
        self.bus_off = False
        self.routes: dict[int, list[Handler]] = {}
        #: SYNC COB-ID -> positions in :attr:`drives` of the drives it synchronises.
        self.sync_groups: dict[int, list[int]] = {}
        #: SYNC COB-ID -> plant indices (bank rows) of the same drives.
        self.sync_slots: dict[int, np.ndarray] = {}
        #: The compiled round's buffers (:func:`hal.emulator.kernels.sync_drives`): frames
        #: out, where each drive's end, which drives it left to Python.
        self.out = np.zeros(0, dtype=np.uint8)
        self.ends = np.zeros(0, dtype=np.int64)
        self.slow = np.zeros(0, dtype=bool)
        self.dirty = True
        #: Identifier -> bank row of the one drive whose controlword + target RPDO it is
        #: (-1: a frame for the Python handlers), and a count of rebuilds (the inbox's
        #: copy, :mod:`hal.emulator.inbox`, follows it).
        self._fast = np.full(0x800, -1, dtype=np.int64)
        self.routes_version = 0
        self.fast_key: tuple[int, bool] = (-1, False)
        #: This bus had a SYNC since the last physics step.
        self.synced = False
        self.send_errors = 0
        #: SYNC frames handled on this bus (answered, or ignored: bus-off, nobody listens).
        self.syncs = 0

    def attach(self, bus: can.BusABC | None) -> None:
        """Use ``bus`` (None: none). A bus with ``send_raw``/``recv_raw`` (the ``unix``
        interface) is used through those: no :class:`can.Message` per frame; one with
        ``flush`` is flushed after each SYNC answered (:meth:`flush`)."""
        self.bus = bus
        self.send_raw = getattr(bus, "send_raw", None)
        self.recv_raw = getattr(bus, "recv_raw", None)
        self._flush = getattr(bus, "flush", None)
        self._hold_frames: Callable[[bytes], None] | None = getattr(bus, "hold_frames", None)
        self._recv_records: Callable[[bool], tuple[list[bytes], list[can.Message]]] | None = (
            getattr(bus, "recv_records", None)
        )

    def flush(self) -> None:
        """Send what the bus holds (the TPDOs of a SYNC on a ``hold_pdos`` bus: one record)."""
        if self._flush is None:
            return
        try:
            self._flush()
        except (can.CanError, OSError) as exc:
            self.send_errors += 1
            log.warning("bus %s: flush failed: %s", self.name, exc)

    def send_frames(self, encoded: bytes) -> None:
        """Send classic frames already in the ``unix`` wire format (:mod:`hal.can.unix_wire`;
        the compiled round's TPDOs): held as they are on a bus that offers it, else frame by
        frame as :meth:`send`."""
        if self.bus is None or self.bus_off:
            return
        if self._hold_frames is not None:
            try:
                self._hold_frames(encoded)
            except (can.CanError, OSError) as exc:
                self.send_errors += 1
                log.warning("bus %s: send failed: %s", self.name, exc)
            return
        for can_id, _, _, _, data in frames(encoded):
            self.send(can_id, data)

    def send(self, can_id: int, data: bytes) -> None:
        bus = self.bus
        if bus is None or self.bus_off:
            return
        try:
            if self.send_raw is not None:
                self.send_raw(can_id, data)
                return
            bus.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=False))
        except (can.CanError, OSError) as exc:
            self.send_errors += 1
            if self.send_errors in (1, 10, 100) or self.send_errors % 1000 == 0:
                log.warning("bus %s: send 0x%03X failed (%d so far): %s",
                            self.name, can_id, self.send_errors, exc)  # fmt: skip

    def rebuild(self) -> None:
        """Routing table and SYNC groups from the drives' current configuration."""
        routes: dict[int, list[Handler]] = {}
        fast = np.full(0x800, -1, dtype=np.int64)
        for k, drive in enumerate(self.drives):
            for can_id, handler in drive.routes().items():
                routes.setdefault(can_id, []).append(handler)
            if 0 <= drive.csp_route < 0x800:
                fast[drive.csp_route] = self.indices[k] if k < len(self.indices) else -1
        for can_id, handlers in routes.items():
            if len(handlers) != 1 and 0 <= can_id < 0x800:
                fast[can_id] = -1  # several drives listen: their handlers, in order
        self.routes = routes
        self._fast = fast
        self.routes_version += 1
        groups: dict[int, list[int]] = {}
        for k, drive in enumerate(self.drives):
            groups.setdefault(drive.sync_cob_id, []).append(k)
        self.sync_groups = groups
        self.sync_slots = {
            can_id: np.array([self.indices[k] for k in group], dtype=np.int64)
            for can_id, group in groups.items()
        }
        n = len(self.drives)
        if self.ends.size != n:
            self.out = np.zeros(n * DRIVE_BYTES, dtype=np.uint8)
            self.ends = np.zeros(n, dtype=np.int64)
            self.slow = np.zeros(n, dtype=bool)
        self.dirty = False

    def fast_routes(self) -> np.ndarray:
        """Identifier -> bank row of the drive whose controlword + target RPDO it is, -1
        for the frames the Python handlers take (every one while the bus is off)."""
        if self.bus_off:
            return np.full(0x800, -1, dtype=np.int64)
        return self._fast

    def records(self, drain: bool = True) -> list[bytes]:
        """Every frame waiting (no wait), as records of frames in the ``unix`` wire format
        (:mod:`hal.can.unix_wire`): as received on a ``unix`` bus, else encoded here.
        ``drain=False``: on a ``unix`` bus one record of each peer (a ``recv`` each, no
        ``epoll`` round; for a caller that waits on the bus's descriptor, readable while
        more waits)."""
        if self.bus is None:
            return []
        if self._recv_records is not None:
            records, others = self._recv_records(drain)
            if others:  # read by recv() before: they came first
                records = [b"".join(encode(msg) for msg in others), *records]
            return records
        received = self.receive()
        if not received:
            return []
        pack = HEADER.pack
        return [b"".join(pack(i, 0, len(d), len(d), stamp) + d for stamp, i, d in received)]

    def receive(self) -> list[tuple[float, int, bytes]]:
        """Every frame waiting (no wait): ``(timestamp [s], identifier, data)`` of classic
        11-bit data frames; others are dropped."""
        if self.bus is None:
            return []
        if self.recv_raw is not None:
            return self.recv_raw()
        out = []
        while (msg := self.bus.recv(0.0)) is not None:
            if not (msg.is_error_frame or msg.is_remote_frame or msg.is_extended_id):
                out.append((msg.timestamp, msg.arbitration_id, bytes(msg.data)))
        return out

    def selectable(self) -> bool:
        """The bus has a file descriptor to wait on (``unix``, ``socketcan``)."""
        if self.bus is None:
            return False
        try:
            return self.bus.fileno() >= 0
        except (NotImplementedError, OSError, AttributeError):
            return False

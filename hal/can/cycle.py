"""Cycle I/O of the CAN master: encode, send, receive and decode one cycle's frames.

:class:`CycleIO` holds, per drive (index ``i`` in profile order), the latest feedback in
counts as the drives send it, the CiA 402 master of its power state machine and its
preallocated RPDO1 frame. One cycle:

1. :meth:`CycleIO.send`: per bus, every drive's RPDO1 (controlword of its
   :class:`~hal.can.cia402.DriveMaster`, asked again only when something changed:
   :meth:`CycleIO.controlwords`; target position [counts]) packed into its frame with a
   precompiled struct, then one SYNC. No RPDO goes to a drive before its first TPDO1.
2. :meth:`CycleIO.send_heartbeat`: the master's heartbeat on every bus when due.
3. :meth:`CycleIO.receive`: drain every bus without blocking and decode TPDO1 (statusword,
   position), TPDO2 (velocity), heartbeats and EMCY; optionally wait until a deadline for
   the TPDO1 of every drive. Buses that take whole records (``unix``) are read and written
   by :class:`hal.can.records.RecordIO` (compiled: one call per record, one encode for
   every bus) where :func:`controller.model.jit.available`, else, where a bus offers it
   (:attr:`Port.recv_frames`), without a :class:`can.Message` per classic frame; one
   record per peer at a time, and one ``select`` over all such buses finds what is left;
   the others through python-can's API (SocketCAN). Heartbeats and EMCY go to the
   :class:`~hal.can.supervision.Supervisor`; its faults and failed sends/receives go to
   ``on_fault`` at once (the backend quick-stops every drive).
4. :meth:`CycleIO.decode_states`: each drive's CiA 402 state (only where the statusword
   changed) and summary flags for the per-cycle checks.

The hot path allocates nothing per frame but python-can's own messages (on ``unix`` buses
nothing, or an ``(identifier, data)`` tuple without numba): feedback lives in int64 arrays
(:attr:`CycleIO.statusword`, ...; memoryviews of them for the frame-by-frame path) and in
byte buffers that numpy views without copying (:attr:`fresh`, :attr:`seen`).
Used by the backend (:mod:`hal.can.backend`, all drives) and by ``imotion-can`` (one drive).
"""

from __future__ import annotations

import select
from collections.abc import Callable, Sequence

import can
import numpy as np

from controller.model import jit
from hal.can import pdo
from hal.can.busload import FRAME_BITS
from hal.can.cia402 import DriveMaster, Goal, State, decode
from hal.can.ports import BUS_ERRORS, FrameReader, Port
from hal.can.records import RecordIO
from hal.can.supervision import Supervisor
from hal.interface import HardwareFault

#: Socketcan error-frame class bit of a bus-off (linux/can/error.h CAN_ERR_BUSOFF).
CAN_ERR_BUSOFF = 0x40

_TPDO1, _TPDO2, _HEARTBEAT = pdo.Kind.TPDO1, pdo.Kind.TPDO2, pdo.Kind.HEARTBEAT
_RPDO_BITS, _SYNC_BITS, _HB_BITS = FRAME_BITS[6], FRAME_BITS[0], FRAME_BITS[1]
_FAULTED = (State.FAULT, State.FAULT_REACTION_ACTIVE)


class CycleIO:
    """Frames of one cycle for drives ``node_ids`` on ``ports`` (module doc).

    ``on_fault`` receives every fault found while sending or receiving; ``clock`` [s] stamps
    heartbeats."""

    def __init__(
        self,
        ports: Sequence[Port],
        node_ids: Sequence[int],
        supervisor: Supervisor,
        on_fault: Callable[[list[HardwareFault]], None],
        clock: Callable[[], float],
        heartbeat_period: float,
    ):
        n = len(node_ids)
        self.node_ids = list(node_ids)
        self.supervisor = supervisor
        self.on_fault = on_fault
        self.clock = clock
        #: Master heartbeat period [s].
        self.heartbeat_period = heartbeat_period
        self.masters = [DriveMaster() for _ in range(n)]
        #: Last statusword and position actual [counts] of every drive.
        self.statusword = np.zeros(n, dtype=np.int64)
        self.position = np.zeros(n, dtype=np.int64)
        #: Last velocity actual [counts/s] (TPDO2 drives only).
        self.velocity = np.zeros(n, dtype=np.int64)
        #: Target position [counts] of the next RPDO1 of every drive.
        self.target = np.zeros(n, dtype=np.int64)
        # The same as memoryviews: Python ints in and out per frame (no NumPy scalars).
        self._sw, self._pos = memoryview(self.statusword), memoryview(self.position)  # type: ignore[arg-type]
        self._vel, self._tgt = memoryview(self.velocity), memoryview(self.target)  # type: ignore[arg-type]
        #: Controlword of the next RPDO1 of every drive, computed again only when a
        #: statusword, a drive seen or a goal changed (:meth:`controlwords`).
        self.controlword = np.zeros(n, dtype=np.int64)
        self._cw = memoryview(self.controlword)  # type: ignore[arg-type]
        self._cw_key = b""
        self._cw_dirty = True
        #: Whole records on buses that take them (:class:`hal.can.records.RecordIO`).
        self.compiled = jit.available()
        self._records: RecordIO | None = None
        self._frame_ports: list[Port] = []
        self._partial: dict[int, Port] = {}
        self._fresh = bytearray(n)
        self._seen = bytearray(n)
        #: A TPDO1 came in since the last :meth:`clear_fresh` (a view of a byte buffer).
        self.fresh = np.frombuffer(self._fresh, dtype=np.bool_)
        #: A TPDO1 ever came in (no RPDO before; the target is unknown).
        self.seen = np.frombuffer(self._seen, dtype=np.bool_)
        self.states = [State.UNKNOWN] * n
        #: Every drive decoded as Operation enabled / some drive in Fault (reaction).
        self.all_enabled = False
        self.any_faulted = False
        self._decoded: list[int | None] = [None] * n
        self._state_key = b""
        #: Each drive's RPDO1 frame (packed in place; frame-by-frame path).
        self.rpdo = [
            can.Message(arbitration_id=pdo.RPDO1 + nid, data=bytearray(6), is_extended_id=False)
            for nid in self.node_ids
        ]
        self.last_heartbeat_sent = -float("inf")
        self.ports = list(ports)

    @property
    def ports(self) -> list[Port]:
        """The buses (set when they open or close)."""
        return self._ports

    @ports.setter
    def ports(self, ports: list[Port]) -> None:
        self._ports = ports
        records = [p for p in ports if p.recv_records is not None and p.send_record is not None]
        self._records = (
            RecordIO(records, self.node_ids, self, self.supervisor.last_heartbeat)
            if records and self.compiled
            else None
        )
        taken = self._records.ports if self._records is not None else []
        #: Buses read and written frame by frame.
        self._frame_ports = [p for p in ports if p not in taken]
        #: Buses read one record per peer at a time, by descriptor (:meth:`_drain_ready`).
        self._partial = {
            p.fd: p for p in ports if p.fd is not None and (p.recv_frames is not None or p in taken)
        }

    def controlwords(self) -> np.ndarray:
        """Every drive's controlword for this cycle (:class:`DriveMaster` of each drive seen,
        asked again only when a statusword, a drive seen or a goal changed, and every cycle
        while a drive resets a fault: the same words as asking every cycle)."""
        key = self.statusword.tobytes() + bytes(self._seen)
        if key != self._cw_key or self._cw_dirty:
            self._cw_key = key
            sw, cw, seen = self._sw, self._cw, self._seen
            for i, m in enumerate(self.masters):
                if seen[i]:
                    cw[i] = m.controlword(sw[i])
            self._cw_dirty = any(m.goal is Goal.RESET for m in self.masters)
        return self.controlword

    # ------------------------------------------------------------------------------ send
    def send(self) -> None:
        """RPDO1 of every drive seen (controlword, :attr:`target`), then SYNC, per bus: one
        record per bus where it takes them (compiled), else frame by frame."""
        seen, cw, target, rpdo = self._seen, self._cw, self._tgt, self.rpdo
        self.controlwords()
        if self._records is not None:
            self._records.send()
        pack = pdo.RPDO1_STRUCT.pack_into
        for port in self._frame_ports:
            if port.failed:
                continue
            send, timeout = port.bus.send, port.send_timeout
            msg = port.sync
            rpdos = 0
            try:
                for i in port.drives:
                    if seen[i]:
                        msg = rpdo[i]
                        pack(msg.data, 0, cw[i], target[i])
                        send(msg, timeout)
                        rpdos += 1
                msg = port.sync
                send(msg, timeout)
            except BUS_ERRORS as exc:
                self.send_failed(port, msg, exc)
            else:
                port.syncs_sent += 1
                port.frames_sent += 1
                port.bits += _SYNC_BITS
            port.frames_sent += rpdos
            port.bits += rpdos * _RPDO_BITS

    def send_heartbeat(self, now: float, force: bool = False) -> None:
        """The master heartbeat on every bus, if ``force`` or one period passed."""
        if not force and now - self.last_heartbeat_sent < self.heartbeat_period:
            return
        self.last_heartbeat_sent = now
        for port in self.ports:
            if port.failed:
                continue
            try:
                port.bus.send(port.heartbeat, port.send_timeout)
            except BUS_ERRORS as exc:
                self.send_failed(port, port.heartbeat, exc)
                continue
            port.frames_sent += 1
            port.bits += _HB_BITS

    def send_failed(self, port: Port, msg: can.Message, exc: BaseException) -> None:
        """Sending ``msg`` on ``port`` raised ``exc``: the port stops, bus-off or bus error."""
        port.failed = True
        what = f"send of 0x{msg.arbitration_id:03X} failed: {exc}"
        try:
            off = port.bus.state is can.BusState.ERROR
        except Exception:  # interfaces without a state
            off = False
        self.on_fault([(Supervisor.bus_off if off else Supervisor.bus_error)(port.name, what)])

    # --------------------------------------------------------------------------- receive
    def clear_fresh(self) -> None:
        """Forget which drives sent a TPDO1 (at the start of a cycle's receive)."""
        self.fresh[:] = False

    def receive(self, deadline: float | None = None) -> None:
        """Decode every frame waiting on the buses; with ``deadline`` (the clock's time [s])
        wait until then for the TPDO1 of every drive not fresh yet: one ``select`` over the
        buses that have a file descriptor (:attr:`Port.fd`), ``recv(timeout)`` bus after bus
        on the others."""
        if self._records is not None:
            self._records.drain()
        for port in self._frame_ports:
            self._drain(port)
        self._drain_ready()
        if deadline is None or 0 not in self._fresh:  # (bytes: cheaper than numpy here)
            return
        waiting = [p for p in self.ports if self._missing(p)]
        selectable = {p.fd: p for p in waiting if p.fd is not None}
        while selectable:
            left = deadline - self.clock()
            if left <= 0:
                break
            try:
                ready = select.select(list(selectable), [], [], left)[0]
            except (OSError, ValueError) as exc:
                for port in selectable.values():
                    self.receive_failed(port, exc)
                break
            for fd in ready:
                port = selectable[fd]
                self._drain(port)
                if not self._missing(port):
                    del selectable[fd]
        for port in waiting:
            if port.fd is None:
                self._wait(port, deadline)
        self._drain_ready()

    def _drain_ready(self) -> None:
        """Buses read one record per peer at a time (:attr:`Port.recv_frames` or records,
        with a descriptor): read on while ``select`` finds any of them readable (one system
        call for all the buses when nothing more waits, the usual case) and a round brings
        frames (a descriptor that stays readable with nothing to read, e.g. a connection the
        bus cannot accept, ends it: the next cycle tries again)."""
        partial = self._partial
        if not partial:
            return
        for port in partial.values():  # (a loop: cheaper than any() on a generator)
            if port.failed:
                partial = {fd: p for fd, p in partial.items() if not p.failed}
                break
        fds = list(partial)
        while fds:
            try:
                ready = select.select(fds, [], [], 0.0)[0]
            except (OSError, ValueError) as exc:
                for port in partial.values():
                    self.receive_failed(port, exc)
                return
            if not ready:
                return
            before = sum(partial[fd].frames_received for fd in ready)
            for fd in ready:
                self._drain(partial[fd])
            if sum(partial[fd].frames_received for fd in ready) == before:
                return

    def _missing(self, port: Port) -> bool:
        """Some drive of ``port`` has not sent its TPDO1 yet (and the bus works)."""
        fresh = self._fresh
        return not port.failed and not all(fresh[i] for i in port.drives)

    def _wait(self, port: Port, deadline: float) -> None:
        """``recv(timeout)`` on ``port`` until its drives are fresh or ``deadline``."""
        while self._missing(port):
            left = deadline - self.clock()
            if left <= 0:
                break
            try:
                msg = port.bus.recv(left)
            except BUS_ERRORS as exc:
                self.receive_failed(port, exc)
                break
            if msg is None:
                break
            self.decode_frame(port, msg)
        self._drain(port)

    def _drain(self, port: Port) -> None:
        """Decode the frames waiting on ``port`` (no wait): all of them, but on a bus read
        one record per peer at a time (:meth:`_drain_frames`), where
        :meth:`_drain_ready` reads the rest."""
        if self._records is not None and port in self._records.ports:
            self._records.drain(port)
            return
        reader = port.recv_frames
        if reader is not None:
            self._drain_frames(port, reader)
            return
        poll, table = port.poll, port.table
        fresh, seen, sw, position = self._fresh, self._seen, self._sw, self._pos
        velocity = self._vel
        tpdo1, tpdo2 = pdo.TPDO1_STRUCT.unpack_from, pdo.TPDO2_STRUCT.unpack_from
        frames = bits = 0
        try:
            while (msg := poll(0.0)[0]) is not None:
                entry = table.get(msg.arbitration_id)
                dlc = msg.dlc
                if entry is None or msg.is_error_frame:
                    self.decode_frame(port, msg)
                    continue
                frames += 1
                bits += FRAME_BITS[dlc if dlc < 9 else 8]
                kind, i = entry
                if kind is _TPDO1 and dlc >= 6:
                    sw[i], position[i] = tpdo1(msg.data)
                    fresh[i] = seen[i] = 1
                elif kind is _TPDO2 and dlc >= 4:
                    (velocity[i],) = tpdo2(msg.data)
                else:
                    frames -= 1
                    bits -= FRAME_BITS[dlc if dlc < 9 else 8]
                    self.decode_frame(port, msg)
        except BUS_ERRORS as exc:
            self.receive_failed(port, exc)
        port.frames_received += frames
        port.bits += bits

    def _drain_frames(self, port: Port, reader: FrameReader) -> None:
        """:meth:`_drain` on a bus with :attr:`Port.recv_frames`: classic data frames as
        ``(identifier, data)`` (no :class:`can.Message`); one record per peer where the bus
        has a descriptor (``select`` tells what is left), else every frame waiting."""
        try:
            classic, others = reader(port.fd is None)
        except BUS_ERRORS as exc:
            self.receive_failed(port, exc)
            return
        for msg in others:  # read by recv() before, or not classic data frames
            self.decode_frame(port, msg)
        table, fresh, seen = port.table, self._fresh, self._seen
        sw, position, velocity = self._sw, self._pos, self._vel
        tpdo1, tpdo2 = pdo.TPDO1_STRUCT.unpack_from, pdo.TPDO2_STRUCT.unpack_from
        bits = 0
        for can_id, data in classic:
            size = len(data)
            bits += FRAME_BITS[size if size < 9 else 8]
            entry = table.get(can_id)
            if entry is None:
                continue
            kind, i = entry
            if kind is _TPDO1:
                if size >= 6:
                    sw[i], position[i] = tpdo1(data)
                    fresh[i] = seen[i] = 1
            elif kind is _TPDO2:
                if size >= 4:
                    (velocity[i],) = tpdo2(data)
            else:
                self.decode_data(kind, i, data)
        port.frames_received += len(classic)
        port.bits += bits

    def receive_failed(self, port: Port, exc: BaseException) -> None:
        """Receiving on ``port`` raised ``exc``: the port stops, a bus error (once)."""
        if not port.failed:
            port.failed = True
            self.on_fault([Supervisor.bus_error(port.name, f"receive failed: {exc}")])

    def decode_frame(self, port: Port, msg: can.Message) -> None:
        """Count and decode one frame received on ``port`` (any kind)."""
        port.frames_received += 1
        dlc = msg.dlc
        port.bits += FRAME_BITS[dlc if dlc < 9 else 8]
        if msg.is_error_frame:
            if msg.arbitration_id & CAN_ERR_BUSOFF:
                port.failed = True
                self.on_fault([Supervisor.bus_off(port.name, "error frame")])
            return
        entry = port.table.get(msg.arbitration_id)
        if entry is not None:
            self.decode_data(entry[0], entry[1], msg.data)

    def decode_data(self, kind: pdo.Kind, i: int, data: bytes | bytearray) -> None:
        """Decode the data of one frame of ``kind`` from drive ``i`` (counted already)."""
        if kind is _TPDO1:
            if len(data) >= 6:
                self._sw[i], self._pos[i] = pdo.TPDO1_STRUCT.unpack_from(data)
                self._fresh[i] = self._seen[i] = 1
        elif kind is _TPDO2:
            if len(data) >= 4:
                (self._vel[i],) = pdo.TPDO2_STRUCT.unpack_from(data)
        elif kind is _HEARTBEAT:
            if len(data) >= 1:
                sup = self.supervisor
                sup.last_heartbeat[i] = self.clock()
                # A PRE-OPERATIONAL heartbeat before the drive's first TPDO1 is stale: sent
                # during its set-up, before it handled the NMT start (not a fault).
                stale = data[0] == pdo.NmtState.PRE_OPERATIONAL and not self._seen[i]
                fault = None if stale else sup.nmt(i, data[0])
                if fault is not None:
                    self.on_fault([fault])
        elif kind is pdo.Kind.EMCY and len(data) >= 3:
            fault = self.supervisor.emcy(i, data[0] | data[1] << 8, data[2])
            if fault is not None:
                self.on_fault([fault])

    # ----------------------------------------------------------------------------- decode
    def decode_states(self) -> None:
        """CiA 402 state of every drive seen (decoded again only where the statusword
        changed); sets :attr:`all_enabled` and :attr:`any_faulted`."""
        key = self.statusword.tobytes() + bytes(self._seen)
        if key == self._state_key:
            return
        self._state_key = key
        sw, decoded, states, seen = self._sw, self._decoded, self.states, self._seen
        changed = False
        for i, word in enumerate(sw):
            if word != decoded[i] and seen[i]:
                decoded[i] = word
                states[i] = decode(word)
                changed = True
        if changed:
            self.all_enabled = all(s is State.OPERATION_ENABLED for s in states)
            self.any_faulted = any(s in _FAULTED for s in states)

    def set_goal(self, goal: Goal, keep_reset: bool = False) -> None:
        """Every drive's power goal (``keep_reset``: drives resetting a fault keep RESET)."""
        for m in self.masters:
            if not (keep_reset and m.goal is Goal.RESET):
                m.goal = goal
        self._cw_dirty = True

    def hold_targets(self) -> None:
        """Target := actual [counts] for every drive (exact, wheels wrap as the drive does)."""
        self.target[:] = self.position

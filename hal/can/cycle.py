"""Cycle I/O of the CAN master: encode, send, receive and decode one cycle's frames.

:class:`CycleIO` holds, per drive (index ``i`` in profile order), the latest feedback in
counts as the drives send it, the CiA 402 master of its power state machine and its
preallocated RPDO1 frame. One cycle:

1. :meth:`CycleIO.send`: per bus, every drive's RPDO1 (controlword of its
   :class:`~hal.can.cia402.DriveMaster`, target position [counts]) packed into its frame with
   a precompiled struct, then one SYNC. No RPDO goes to a drive before its first TPDO1.
2. :meth:`CycleIO.send_heartbeat`: the master's heartbeat on every bus when due.
3. :meth:`CycleIO.receive`: drain every bus without blocking and decode TPDO1 (statusword,
   position), TPDO2 (velocity), heartbeats and EMCY; optionally wait until a deadline for
   the TPDO1 of every drive. A bus that offers it (:attr:`Port.recv_frames`: ``unix``) is
   read without a :class:`can.Message` per classic frame, one record per peer at a time,
   and one ``select`` over all such buses finds what is left; the others through
   python-can's API (SocketCAN). Heartbeats and EMCY go to the
   :class:`~hal.can.supervision.Supervisor`; its faults and failed sends/receives go to
   ``on_fault`` at once (the backend quick-stops every drive).
4. :meth:`CycleIO.decode_states`: each drive's CiA 402 state (only where the statusword
   changed) and summary flags for the per-cycle checks.

The hot path allocates nothing per frame but python-can's own messages (on ``unix`` buses
an ``(identifier, data)`` tuple instead): feedback lives in
lists and in byte buffers that numpy views without copying (:attr:`fresh`, :attr:`seen`).
Used by the backend (:mod:`hal.can.backend`, all drives) and by ``imotion-can`` (one drive).
"""

from __future__ import annotations

import select
from collections.abc import Callable, Sequence

import can
import numpy as np

from hal.can import pdo
from hal.can.busload import classic_frame_bits
from hal.can.cia402 import DriveMaster, Goal, State, decode
from hal.can.ports import FrameReader, Port
from hal.can.supervision import Supervisor
from hal.interface import HardwareFault

#: Worst-case classic frame length [bit] per data length (0..8 bytes).
FRAME_BITS = [classic_frame_bits(n) for n in range(9)]
#: Socketcan error-frame class bit of a bus-off (linux/can/error.h CAN_ERR_BUSOFF).
CAN_ERR_BUSOFF = 0x40
#: Errors python-can interfaces raise on send/receive.
BUS_ERRORS = (can.CanError, OSError, ValueError)

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
        self.ports = list(ports)
        self.node_ids = list(node_ids)
        self.supervisor = supervisor
        self.on_fault = on_fault
        self.clock = clock
        #: Master heartbeat period [s].
        self.heartbeat_period = heartbeat_period
        self.masters = [DriveMaster() for _ in range(n)]
        #: Last statusword and position actual [counts] of every drive.
        self.statusword = [0] * n
        self.position = [0] * n
        #: Last velocity actual [counts/s] (TPDO2 drives only).
        self.velocity = [0] * n
        #: Target position [counts] of the next RPDO1 of every drive.
        self.target = [0] * n
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
        self._rpdo = [
            can.Message(arbitration_id=pdo.RPDO1 + nid, data=bytearray(6), is_extended_id=False)
            for nid in self.node_ids
        ]
        self.last_heartbeat_sent = -float("inf")

    # ------------------------------------------------------------------------------ send
    def send(self) -> None:
        """RPDO1 of every drive seen (controlword, :attr:`target`), then SYNC, per bus."""
        seen, masters, sw, target, rpdo = (
            self._seen, self.masters, self.statusword, self.target, self._rpdo
        )  # fmt: skip
        pack = pdo.RPDO1_STRUCT.pack_into
        for port in self.ports:
            if port.failed:
                continue
            send, timeout = port.bus.send, port.send_timeout
            msg = port.sync
            rpdos = 0
            try:
                for i in port.drives:
                    if seen[i]:
                        msg = rpdo[i]
                        pack(msg.data, 0, masters[i].controlword(sw[i]), target[i])
                        send(msg, timeout)
                        rpdos += 1
                msg = port.sync
                send(msg, timeout)
            except BUS_ERRORS as exc:
                self._send_failed(port, msg, exc)
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
                self._send_failed(port, port.heartbeat, exc)
                continue
            port.frames_sent += 1
            port.bits += _HB_BITS

    def _send_failed(self, port: Port, msg: can.Message, exc: BaseException) -> None:
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
        for port in self.ports:
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
                    self._receive_failed(port, exc)
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
        """Buses read one record per peer at a time (:attr:`Port.recv_frames` with a
        descriptor): read on while ``select`` finds any of them readable (one system call
        for all the buses when nothing more waits, the usual case) and a round brings
        frames (a descriptor that stays readable with nothing to read, e.g. a connection the
        bus cannot accept, ends it: the next cycle tries again)."""
        partial = {
            p.fd: p
            for p in self.ports
            if p.recv_frames is not None and p.fd is not None and not p.failed
        }
        while partial:
            try:
                ready = select.select(list(partial), [], [], 0.0)[0]
            except (OSError, ValueError) as exc:
                for port in partial.values():
                    self._receive_failed(port, exc)
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
                self._receive_failed(port, exc)
                break
            if msg is None:
                break
            self._decode(port, msg)
        self._drain(port)

    def _drain(self, port: Port) -> None:
        """Decode the frames waiting on ``port`` (no wait): all of them, but on a bus read
        one record per peer at a time (:meth:`_drain_frames`), where
        :meth:`_drain_ready` reads the rest."""
        reader = port.recv_frames
        if reader is not None:
            self._drain_frames(port, reader)
            return
        poll, table = port.poll, port.table
        fresh, seen, sw, position = self._fresh, self._seen, self.statusword, self.position
        velocity = self.velocity
        tpdo1, tpdo2 = pdo.TPDO1_STRUCT.unpack_from, pdo.TPDO2_STRUCT.unpack_from
        frames = bits = 0
        try:
            while (msg := poll(0.0)[0]) is not None:
                entry = table.get(msg.arbitration_id)
                dlc = msg.dlc
                if entry is None or msg.is_error_frame:
                    self._decode(port, msg)
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
                    self._decode(port, msg)
        except BUS_ERRORS as exc:
            self._receive_failed(port, exc)
        port.frames_received += frames
        port.bits += bits

    def _drain_frames(self, port: Port, reader: FrameReader) -> None:
        """:meth:`_drain` on a bus with :attr:`Port.recv_frames`: classic data frames as
        ``(identifier, data)`` (no :class:`can.Message`); one record per peer where the bus
        has a descriptor (``select`` tells what is left), else every frame waiting."""
        try:
            classic, others = reader(port.fd is None)
        except BUS_ERRORS as exc:
            self._receive_failed(port, exc)
            return
        for msg in others:  # read by recv() before, or not classic data frames
            self._decode(port, msg)
        table, fresh, seen = port.table, self._fresh, self._seen
        sw, position, velocity = self.statusword, self.position, self.velocity
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
                self._decode_data(kind, i, data)
        port.frames_received += len(classic)
        port.bits += bits

    def _receive_failed(self, port: Port, exc: BaseException) -> None:
        if not port.failed:
            port.failed = True
            self.on_fault([Supervisor.bus_error(port.name, f"receive failed: {exc}")])

    def _decode(self, port: Port, msg: can.Message) -> None:
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
            self._decode_data(entry[0], entry[1], msg.data)

    def _decode_data(self, kind: pdo.Kind, i: int, data: bytes | bytearray) -> None:
        """Decode the data of one frame of ``kind`` from drive ``i`` (counted already)."""
        if kind is _TPDO1:
            if len(data) >= 6:
                self.statusword[i], self.position[i] = pdo.TPDO1_STRUCT.unpack_from(data)
                self._fresh[i] = self._seen[i] = 1
        elif kind is _TPDO2:
            if len(data) >= 4:
                (self.velocity[i],) = pdo.TPDO2_STRUCT.unpack_from(data)
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
        sw, decoded, states, seen = self.statusword, self._decoded, self.states, self._seen
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

    def hold_targets(self) -> None:
        """Target := actual [counts] for every drive (exact, wheels wrap as the drive does)."""
        self.target[:] = self.position

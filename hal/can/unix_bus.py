"""python-can interface ``unix``: a CAN bus between the processes of one host (no SocketCAN).

A bus is a directory (``channel``). Every participant (a :class:`UnixBus`) listens on a Unix
``SOCK_SEQPACKET`` socket in it (file ``<pid>-<n>``) and, when it opens, connects to every
participant already there; later ones connect to it. So each pair of participants shares one
connection, and a frame sent goes to every other participant, as on a wire: one ``send`` per
peer, no hub, no thread. Per sender the frames arrive in order (a connection is a FIFO).

* ``channel``: a directory path, or a plain name for ``$XDG_RUNTIME_DIR/imotion-can/<name>``
  (``/tmp/imotion-can-<uid>/<name>`` without it). Created with mode 0700; socket paths must
  stay under 108 bytes.
* ``receive_own_messages``: also deliver what this participant sends (default False).
* ``hold_pdos``: PDO frames (COB-IDs 0x180-0x57F of the CANopen predefined set, 11-bit) wait
  in the sender until it sends another frame (a SYNC), reads the sockets to receive, or
  calls :meth:`UnixBus.flush`; then everything held goes to each peer as one record, in the
  order sent (default False). A master's cycle (RPDOs, then SYNC) thus costs one system call
  and one wake-up of each peer per bus, not one per frame. Meant for CANopen participants
  whose PDOs are synchronous (acted on at the next SYNC): holding them until the SYNC
  changes nothing they see. One that sends PDOs with no frame after them must call
  :meth:`UnixBus.flush` (the emulator does after each SYNC it answers).
* ``fileno()`` is an epoll descriptor, readable while a frame (or a new peer) waits, so
  ``select``, :class:`can.Notifier` and asyncio work as on SocketCAN. ``recv(timeout)``
  waits with ``select`` on it: microseconds, where ``epoll_wait`` would round a 0.4 ms
  wait up to 1 ms.
* A peer that cannot take a record right away loses it (every frame in it), counted in
  :attr:`UnixBus.dropped`, as a CAN controller with a full receive FIFO would: its queue
  holds :data:`SEND_BUFFER` bytes (thousands of frames: a process held back for tens of ms
  by a busy host loses nothing). A peer that went away is forgotten. The sender never
  blocks.

Why not ``virtual``: it lives in one process. Not ``udp_multicast``: never on this project.
Not datagram sockets: Linux queues at most ``net.unix.max_dgram_qlen`` (often 10) datagrams
per unconnected receiver, less than one cycle of a bus. Not python-can-remote: two websockets
and four threads per frame (~3 ms per SYNC round trip here).

The frames and records on the wire: :mod:`hal.can.unix_wire`. Besides python-can's API, two
fast paths without a :class:`can.Message` per frame: :meth:`UnixBus.send_raw` /
:meth:`UnixBus.recv_raw` and :meth:`UnixBus.hold_frames` (frames it encodes itself) (the
emulator) and :meth:`UnixBus.recv_frames` (the CAN master,
:mod:`hal.can.cycle`, where a bus offers it).
"""

from __future__ import annotations

import itertools
import logging
import os
import select
import socket
import tempfile
import time
from collections import deque
from pathlib import Path
from typing import Any

import can

from hal.can.unix_wire import HEADER, MAX_RECORD, decode, encode, frames, message, split

log = logging.getLogger(__name__)

INTERFACE = "unix"
_pack = HEADER.pack
#: COB-IDs held with ``hold_pdos`` (TPDO1 0x180 .. RPDO4 0x57F, predefined connection set).
PDO_FIRST, PDO_LAST = 0x180, 0x57F
_PATH_MAX = 107
#: Send buffer per peer connection [bytes] (the kernel caps it at net.core.wmem_max): how
#: much a peer may fall behind before it loses frames, about 1300 frames per MiB.
SEND_BUFFER = 1 << 20
_counter = itertools.count()


def bus_directory(channel: str | os.PathLike[str]) -> Path:
    """The directory of bus ``channel`` (module doc)."""
    text = os.fspath(channel)
    if not text:
        raise ValueError("unix bus: empty channel")
    if os.sep in text:
        return Path(text)
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    base = (
        Path(runtime) / "imotion-can"
        if runtime
        else Path(tempfile.gettempdir()) / (f"imotion-can-{os.getuid()}")
    )
    return base / text


class UnixBus(can.BusABC):
    """One participant of the Unix-socket bus ``channel`` (module doc)."""

    def __init__(
        self,
        channel: Any,
        can_filters: can.typechecking.CanFilters | None = None,
        receive_own_messages: bool = False,
        hold_pdos: bool = False,
        **kwargs: object,
    ):
        self.directory = bus_directory(channel)
        self._channel = os.fspath(self.directory)
        self.channel_info = f"unix bus {self.directory}"
        self.receive_own_messages = receive_own_messages
        self.hold_pdos = bool(hold_pdos)
        #: Frames held (``hold_pdos``) and their total length [bytes].
        self._held: list[bytes | memoryview] = []
        self._held_size = 0
        #: Frames a peer could not take (its queue was full).
        self.dropped = 0
        #: Messages read (and own ones), not yet returned, oldest first.
        self._pending: deque[can.Message] = deque()
        self.directory.mkdir(mode=0o700, parents=True, exist_ok=True)
        self.path = self.directory / f"{os.getpid()}-{next(_counter)}"
        if len(os.fsencode(self.path)) > _PATH_MAX:
            raise can.CanInitializationError(f"unix bus: socket path too long: {self.path}")
        self._listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self._listener_fd = self._listener.fileno()
        self._listener.setblocking(False)
        self._epoll = select.epoll()
        self._peers: dict[int, socket.socket] = {}
        try:
            self._listener.bind(os.fspath(self.path))
            self._listener.listen(64)
            self._epoll.register(self._listener.fileno(), select.EPOLLIN)
            for entry in sorted(self.directory.iterdir()):
                if entry != self.path:
                    self._connect(entry)
        except OSError as exc:
            self._close_sockets()
            raise can.CanInitializationError(f"{self.channel_info}: {exc}") from exc
        super().__init__(channel=os.fspath(self.directory), can_filters=can_filters, **kwargs)

    @property
    def peers(self) -> int:
        """Other participants currently connected."""
        return len(self._peers)

    def fileno(self) -> int:
        return self._epoll.fileno()

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Send ``msg`` to every other participant (never blocks; see the module doc), or
        hold it (``hold_pdos``). Participants that joined since the last receive get it from
        the next one on."""
        if not (
            msg.is_extended_id or msg.is_remote_frame or msg.is_error_frame or msg.is_fd
            or msg.bitrate_switch or msg.error_state_indicator or self.receive_own_messages
        ):  # fmt: skip
            # A classic 11-bit data frame: the usual one, inline (a master's cycle sends dozens).
            data = msg.data
            can_id = msg.arbitration_id
            frame = _pack(can_id, 0, msg.dlc, len(data), msg.timestamp or time.time()) + data
            if self.hold_pdos and PDO_FIRST <= can_id <= PDO_LAST:
                if self._held_size + len(frame) > MAX_RECORD:
                    self.flush()
                self._held.append(frame)
                self._held_size += len(frame)
            else:
                self._send_record(frame)
            return
        frame = encode(msg)
        if self.receive_own_messages:
            self._pending.append(decode(frame, self._channel))
        if self.hold_pdos and PDO_FIRST <= msg.arbitration_id <= PDO_LAST:
            if not msg.is_extended_id:
                self._hold(frame)
                return
        self._send_record(frame)

    def flush(self) -> None:
        """Send the frames held (``hold_pdos``) now, as one record per peer."""
        if self._held:
            self._send_record(b"")

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        pending = self._pending
        if pending:
            return pending.popleft(), False
        if self._held:  # before waiting for an answer, the question goes out
            self.flush()
        if timeout == 0.0:  # a poll (a master draining its buses every cycle)
            self._messages(self._fill(0.0))
            return (pending.popleft() if pending else None), False
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            self._messages(self._fill(0.0))
            if pending:
                return pending.popleft(), False
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0.0:
                return None, False
            self._wait(left)

    def send_raw(self, can_id: int, data: bytes) -> None:
        """Send a classic 11-bit data frame without building a :class:`can.Message` (the
        emulator's fast path; same wire frame as :meth:`send`)."""
        frame = HEADER.pack(can_id, 0, len(data), len(data), time.time()) + data
        if self.hold_pdos and PDO_FIRST <= can_id <= PDO_LAST:
            self._hold(frame)
        else:
            self._send_record(frame)

    def hold_frames(self, encoded: bytes) -> None:
        """Send classic frames already in the wire format (:mod:`hal.can.unix_wire`), held
        with ``hold_pdos`` as :meth:`send_raw` would hold them one by one (the caller sends
        only PDOs this way: the emulator's compiled TPDOs), else at once as one record."""
        size = len(encoded)
        if self.hold_pdos and self._held_size + size <= MAX_RECORD:
            self._held.append(encoded)
            self._held_size += size
            return
        if not self.hold_pdos and size <= MAX_RECORD:
            self._send_record(encoded)
            return
        start = 0  # more than a record holds: frame by frame
        while start < size:
            end = start + HEADER.size + encoded[start + 6]
            if self.hold_pdos:
                self._hold(encoded[start:end])
            else:
                self._send_record(encoded[start:end])
            start = end

    def recv_raw(self) -> list[tuple[float, int, bytes]]:
        """Every waiting classic 11-bit data frame as ``(timestamp [s], identifier, data)``
        (the sender's ``time.time()``), without waiting and without :class:`can.Message`
        (the emulator's fast path). Other frames (extended, remote, error, FD) are dropped
        here, and frames already taken by ``recv``; filters do not apply."""
        if self._held:
            self.flush()
        out = []
        while records := self._fill(0.0):
            for record in records:
                try:
                    fields = frames(record)
                except ValueError as exc:
                    log.warning("%s: %s (dropped)", self.channel_info, exc)
                    continue
                out += [
                    (stamp, can_id, data) for can_id, flags, _, stamp, data in fields if not flags
                ]
        return out

    def recv_records(self, drain: bool = True) -> tuple[list[bytes], list[can.Message]]:
        """Records waiting, without waiting: ``(records, others)``, each record as received
        (frames in the wire format of :mod:`hal.can.unix_wire`, for a caller that decodes
        them itself: the CAN master's compiled path, :mod:`hal.can.cycle`), ``others`` the
        frames :meth:`recv` had read but not returned. Filters do not apply. ``drain``
        as :meth:`recv_frames`."""
        if self._held:  # before reading the answers, the question goes out
            self.flush()
        others: list[can.Message] = []
        if self._pending:
            others += self._pending
            self._pending.clear()
        if not drain:
            records: list[bytes] = []
            gone = []
            for fd, peer in self._peers.items():
                try:  # (inline: once per peer and cycle of a master)
                    record = peer.recv(MAX_RECORD)
                except BlockingIOError:
                    continue
                except OSError:
                    record = b""
                if record:
                    records.append(record)
                else:  # the peer closed its end
                    gone.append(fd)
            for fd in gone:
                self._forget(fd)
            return records or self._fill(0.0), others
        records = []
        while more := self._fill(0.0):
            records += more
        return records, others

    def recv_frames(self, drain: bool = True) -> tuple[list[tuple[int, bytes]], list[can.Message]]:
        """Frames waiting, without waiting: ``(classic, others)``, the classic 11-bit data
        frames as ``(identifier, data)`` without a :class:`can.Message` each (a master's
        fast path: :mod:`hal.can.cycle` uses it where a bus offers it), every other frame
        (extended, remote, error, FD; and frames :meth:`recv` had read but not returned)
        as messages, each list in the order received. Filters do not apply: for a bus
        without them.

        ``drain``: every frame waiting (an ``epoll`` per round of records, until one finds
        none). Else one record of each peer, read directly (one ``recv`` per peer, no
        ``epoll``; when no peer had one, one ``epoll`` round, which also accepts new
        participants): for a caller that waits on :meth:`fileno`, readable while more
        waits (``select`` over several buses at once: one system call for all of them)."""
        records, others = self.recv_records(drain)
        classic: list[tuple[int, bytes]] = []
        self._split(records, classic, others)
        return classic, others

    def send_record(self, record: bytes | memoryview) -> None:
        """Send whole frames in the wire format (:mod:`hal.can.unix_wire`, classic 11-bit
        data frames, at most :data:`~hal.can.unix_wire.MAX_RECORD` bytes with what is held)
        to every peer as one record, after the frames held: a sender that encodes its
        frames itself (the CAN master's RPDOs and SYNC of a bus, :mod:`hal.can.cycle`)."""
        if self._held:
            self._send_record(record)
            return
        gone = None
        for fd, peer in self._peers.items():
            try:
                peer.send(record)
            except BlockingIOError:
                self._dropped()
            except OSError:  # the peer went away
                gone = [*(gone or []), fd]
        for fd in gone or ():
            self._forget(fd)

    def shutdown(self) -> None:
        if self._held:
            self.flush()
        super().shutdown()
        self._close_sockets()
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass

    @staticmethod
    def _detect_available_configs() -> list[can.typechecking.AutoDetectedConfig]:
        return []

    # ---------------------------------------------------------------------------- internals

    def _hold(self, frame: bytes) -> None:
        """Keep ``frame`` for the next record (sending the held ones first if it is full)."""
        if self._held_size + len(frame) > MAX_RECORD:
            self.flush()
        self._held.append(frame)
        self._held_size += len(frame)

    def _send_record(self, frame: bytes | memoryview) -> None:
        """The frames held, then ``frame`` (may be empty), as one record to every peer."""
        if self._held:
            if self._held_size + len(frame) > MAX_RECORD:
                held = b"".join(self._held)
                self._held.clear()
                self._held_size = 0
                self._send_record(held)
            else:
                self._held.append(frame)
                frame = b"".join(self._held)
                self._held.clear()
                self._held_size = 0
        for fd, peer in list(self._peers.items()):
            try:
                peer.send(frame)
            except BlockingIOError:
                self._dropped()
            except OSError:  # the peer went away
                self._forget(fd)

    def _wait(self, timeout: float | None) -> None:
        """Wait up to ``timeout`` [s] (None: for ever) until a peer sends or joins (``select``
        on the epoll descriptor: microseconds, where ``epoll_wait`` rounds up to 1 ms)."""
        try:
            select.select([self._epoll], [], [], timeout)
        except InterruptedError:
            pass
        except (OSError, ValueError) as exc:
            raise can.CanOperationError(f"{self.channel_info}: {exc}") from exc

    def _fill(self, timeout: float) -> list[bytes]:
        """Wait up to ``timeout`` [s] (< 0: for ever; epoll's 1 ms resolution) for a peer;
        then one record of every ready peer (oldest first per peer), and accept new peers.
        Level-triggered: a peer with more records is ready again at the next call."""
        try:
            events = self._epoll.poll(timeout)
        except InterruptedError:
            return []
        except (OSError, ValueError) as exc:
            raise can.CanOperationError(f"{self.channel_info}: {exc}") from exc
        if not events:
            return []
        listener = self._listener_fd
        ready = [fd for fd, _ in events if fd != listener]
        if len(ready) < len(events):
            ready += self._accept()  # a new peer may have sent already
        records = []
        for fd in ready:
            peer = self._peers.get(fd)
            if peer is None:
                continue
            record = _read_record(peer)
            if record:
                records.append(record)
            elif record is not None:  # the peer closed its end
                self._forget(fd)
        return records

    def _messages(self, records: list[bytes]) -> None:
        """Decode ``records`` into :attr:`_pending` (malformed ones logged and dropped)."""
        pending, channel, header = self._pending, self._channel, HEADER.size
        unpack, make = HEADER.unpack_from, can.Message
        for received in records:
            record = bytearray(received)  # slices of it are what can.Message keeps (no copy)
            size, start = len(record), 0
            while start + header <= size:  # classic 11-bit data frames: the usual ones
                can_id, flags, dlc, length, stamp = unpack(record, start)
                end = start + header + length
                if flags or end > size:
                    break
                pending.append(make(stamp, can_id, False, False, False, channel, dlc,
                                    record[start + header : end]))  # fmt: skip
                start = end
            if start == size:
                continue
            try:  # the rest of the record: other kinds of frames, or malformed
                pending.extend(
                    message(*fields, channel) for fields in frames(bytes(record[start:]))
                )
            except ValueError as exc:
                log.warning("%s: %s (dropped)", self.channel_info, exc)

    def _split(
        self, records: list[bytes], classic: list[tuple[int, bytes]], others: list[can.Message]
    ) -> None:
        """The frames of ``records`` into ``classic`` and ``others`` (:func:`split`)."""
        for record in records:
            try:
                split(record, classic, others, self._channel)
            except ValueError as exc:
                log.warning("%s: %s (dropped)", self.channel_info, exc)

    def _dropped(self) -> None:
        self.dropped += 1
        if self.dropped in (1, 10, 100) or self.dropped % 1000 == 0:
            log.warning("%s: a peer is not reading (%d frames dropped)",
                        self.channel_info, self.dropped)  # fmt: skip

    def _connect(self, entry: Path) -> None:
        peer = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            peer.connect(os.fspath(entry))
        except (ConnectionRefusedError, FileNotFoundError):
            peer.close()
            try:  # a participant that died without closing: nobody listens there
                entry.unlink()
            except OSError:
                pass
            return
        except OSError as exc:
            peer.close()
            log.warning("%s: cannot join %s: %s", self.channel_info, entry.name, exc)
            return
        self._add(peer)

    def _accept(self) -> list[int]:
        """Accept every waiting peer; their descriptors."""
        added: list[int] = []
        while True:
            try:
                peer, _ = self._listener.accept()
            except (BlockingIOError, OSError):
                return added
            self._add(peer)
            added.append(peer.fileno())

    def _add(self, peer: socket.socket) -> None:
        peer.setblocking(False)
        try:
            peer.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER)
        except OSError:  # the kernel's default then
            pass
        self._peers[peer.fileno()] = peer
        self._epoll.register(peer.fileno(), select.EPOLLIN)

    def _forget(self, fd: int) -> None:
        peer = self._peers.pop(fd, None)
        if peer is not None:
            try:
                self._epoll.unregister(fd)
            except OSError:
                pass
            peer.close()

    def _close_sockets(self) -> None:
        for fd in list(self._peers):
            self._forget(fd)
        self._listener.close()
        self._epoll.close()


def register() -> None:
    """Make ``interface="unix"`` known to ``can.Bus`` where the package's ``can.interface``
    entry point is not installed (e.g. running from a source tree)."""
    from can import interfaces, util

    if INTERFACE in interfaces.BACKENDS:
        return
    interfaces.BACKENDS[INTERFACE] = (__name__, UnixBus.__name__)
    valid = frozenset((*interfaces.VALID_INTERFACES, INTERFACE))
    interfaces.VALID_INTERFACES = valid
    util.VALID_INTERFACES = valid
    can.VALID_INTERFACES = valid


def _read_record(peer: socket.socket) -> bytes | None:
    """One record from ``peer``: None when none is waiting, b"" when the peer closed (or
    failed)."""
    try:
        return peer.recv(MAX_RECORD)
    except BlockingIOError:
        return None
    except OSError:
        return b""

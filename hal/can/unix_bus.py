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
* ``fileno()`` is an epoll descriptor, readable while a frame (or a new peer) waits, so
  ``select``, :class:`can.Notifier` and asyncio work as on SocketCAN.
* A peer that cannot take a frame right away loses it, counted in :attr:`UnixBus.dropped`,
  as a CAN controller with a full receive FIFO would: its queue holds :data:`SEND_BUFFER`
  bytes (thousands of frames: a process held back for tens of ms by a busy host loses
  nothing). A peer that went away is forgotten. The sender never blocks.

Why not ``virtual``: it lives in one process. Not ``udp_multicast``: never on this project.
Not datagram sockets: Linux queues at most ``net.unix.max_dgram_qlen`` (often 10) datagrams
per unconnected receiver, less than one cycle of a bus. Not python-can-remote: two websockets
and four threads per frame (~3 ms per SYNC round trip here).

Frame on the wire: ``<IBBBxd`` (identifier, flags, dlc, data length, timestamp [s]) + data.
"""

from __future__ import annotations

import itertools
import logging
import os
import select
import socket
import struct
import tempfile
import time
from collections import deque
from pathlib import Path
from typing import Any

import can

log = logging.getLogger(__name__)

INTERFACE = "unix"
_HEADER = struct.Struct("<IBBBxd")
_MAX_FRAME = _HEADER.size + 64
_EXTENDED, _REMOTE, _ERROR, _FD, _BRS, _ESI = 1, 2, 4, 8, 16, 32
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


def encode(msg: can.Message) -> bytes:
    """One frame on the wire (module doc)."""
    flags = (
        (_EXTENDED if msg.is_extended_id else 0)
        | (_REMOTE if msg.is_remote_frame else 0)
        | (_ERROR if msg.is_error_frame else 0)
        | (_FD if msg.is_fd else 0)
        | (_BRS if msg.bitrate_switch else 0)
        | (_ESI if msg.error_state_indicator else 0)
    )
    data = bytes(msg.data or b"")
    stamp = msg.timestamp or time.time()
    return _HEADER.pack(msg.arbitration_id, flags, msg.dlc, len(data), stamp) + data


def decode(frame: bytes, channel: str) -> can.Message:
    """The message of a wire frame; ValueError if it is malformed."""
    if len(frame) < _HEADER.size:
        raise ValueError(f"unix bus {channel}: frame of {len(frame)} bytes")
    can_id, flags, dlc, size, stamp = _HEADER.unpack_from(frame)
    if len(frame) != _HEADER.size + size:
        raise ValueError(f"unix bus {channel}: frame length {len(frame)} != {_HEADER.size + size}")
    return can.Message(
        timestamp=stamp,
        arbitration_id=can_id,
        is_extended_id=bool(flags & _EXTENDED),
        is_remote_frame=bool(flags & _REMOTE),
        is_error_frame=bool(flags & _ERROR),
        is_fd=bool(flags & _FD),
        bitrate_switch=bool(flags & _BRS),
        error_state_indicator=bool(flags & _ESI),
        dlc=dlc,
        data=frame[_HEADER.size :],
        channel=channel,
    )


class UnixBus(can.BusABC):
    """One participant of the Unix-socket bus ``channel`` (module doc)."""

    def __init__(
        self,
        channel: Any,
        can_filters: can.typechecking.CanFilters | None = None,
        receive_own_messages: bool = False,
        **kwargs: object,
    ):
        self.directory = bus_directory(channel)
        self.channel_info = f"unix bus {self.directory}"
        self.receive_own_messages = receive_own_messages
        #: Frames a peer could not take (its queue was full).
        self.dropped = 0
        self._own: list[can.Message] = []
        #: Frames read from the peers, not yet returned (raw, oldest first).
        self._pending: deque[bytes] = deque()
        self.directory.mkdir(mode=0o700, parents=True, exist_ok=True)
        self.path = self.directory / f"{os.getpid()}-{next(_counter)}"
        if len(os.fsencode(self.path)) > _PATH_MAX:
            raise can.CanInitializationError(f"unix bus: socket path too long: {self.path}")
        self._listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
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
        """Send ``msg`` to every other participant (never blocks; see the module doc).
        Participants that joined since the last receive get it from the next one on."""
        frame = encode(msg)
        for fd, peer in list(self._peers.items()):
            try:
                peer.send(frame)
            except BlockingIOError:
                self._dropped()
            except OSError:  # the peer went away
                self._forget(fd)
        if self.receive_own_messages:
            own = decode(frame, os.fspath(self.directory))
            self._own.append(own)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if self._own:
            return self._own.pop(0), False
        channel = os.fspath(self.directory)
        pending = self._pending
        if not pending:
            self._fill(0.0)
            if not pending and timeout != 0.0:
                deadline = None if timeout is None else time.monotonic() + timeout
                while not pending:
                    left = -1.0 if deadline is None else deadline - time.monotonic()
                    if deadline is not None and left <= 0.0:
                        break
                    self._fill(left)
        while pending:
            try:
                return decode(pending.popleft(), channel), False
            except ValueError as exc:
                log.warning("%s", exc)
        return None, False

    def send_raw(self, can_id: int, data: bytes) -> None:
        """Send a classic 11-bit data frame without building a :class:`can.Message` (the
        emulator's fast path; same wire frame as :meth:`send`)."""
        frame = _HEADER.pack(can_id, 0, len(data), len(data), time.time()) + data
        for fd, peer in list(self._peers.items()):
            try:
                peer.send(frame)
            except BlockingIOError:
                self._dropped()
            except OSError:
                self._forget(fd)

    def recv_raw(self) -> list[tuple[float, int, bytes]]:
        """Every waiting classic 11-bit data frame as ``(timestamp [s], identifier, data)``
        (the sender's ``time.time()``), without waiting and without :class:`can.Message`
        (the emulator's fast path). Other frames (extended, remote, error, FD) are dropped
        here; filters do not apply."""
        self._fill(0.0)
        out = []
        pending = self._pending
        header = _HEADER
        while pending:
            frame = pending.popleft()
            if len(frame) < header.size:
                continue
            can_id, flags, _, size, stamp = header.unpack_from(frame)
            if not flags and len(frame) == header.size + size:
                out.append((stamp, can_id, frame[header.size :]))
        return out

    def shutdown(self) -> None:
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

    def _fill(self, timeout: float) -> None:
        """Wait up to ``timeout`` [s] (< 0: for ever) for a peer; then move every frame
        waiting on every ready peer to :attr:`_pending`, and accept new peers."""
        try:
            events = self._epoll.poll(timeout)
        except InterruptedError:
            return
        except (OSError, ValueError) as exc:
            raise can.CanOperationError(f"{self.channel_info}: {exc}") from exc
        listener = self._listener.fileno()
        pending = self._pending
        ready = [fd for fd, _ in events if fd != listener]
        if len(ready) < len(events):
            ready += self._accept()  # a new peer may have sent already
        for fd in ready:
            peer = self._peers.get(fd)
            if peer is None:
                continue
            while True:
                try:
                    frame = peer.recv(_MAX_FRAME)
                except BlockingIOError:
                    break
                except OSError:
                    frame = b""
                if not frame:  # the peer closed its end
                    self._forget(fd)
                    break
                pending.append(frame)

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

"""Bus set-up of the CAN master: python-can settings per bus, opening and closing the buses.

One :class:`Port` per bus of the drive profile: the python-can handle, the drives on it, the
COB-ID table of the frames decoded from it, its preallocated SYNC and heartbeat frames, and
its frame counters. Shared by the backend (:mod:`hal.can.backend`) and ``imotion-can``
(:mod:`hal.can.operations`).

Supervision keys may ride along with a bus's python-can settings (``hal_options.buses`` of the
daemon, e.g. ``{"arm_r": {"interface": "remote", "channel": "ws://...",
"tpdo_timeout_ms": 20}}``): :data:`SUPERVISION_KEYS` are taken out before the bus is opened
(:func:`split_supervision`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import can

from hal.can import pdo
from hal.can.drive_profile import DriveProfile
from hal.can.supervision import DriveError, Supervisor

log = logging.getLogger(__name__)

#: Per-bus supervision settings accepted among a bus's python-can overrides.
SUPERVISION_KEYS = ("tpdo_timeout_cycles", "tpdo_timeout_ms")
#: Errors python-can interfaces raise on send/receive.
BUS_ERRORS = (can.CanError, OSError, ValueError)
#: Interfaces without a bit rate setting (in-process or bridged buses).
NO_BITRATE = ("virtual", "remote", "stub")

#: ``(bus name, python-can keyword arguments) -> bus``.
BusFactory = Callable[[str, dict[str, Any]], can.BusABC]
#: ``(drain) -> (classic, others)``: frames waiting, without waiting, classic 11-bit data
#: frames as ``(identifier, data)``, the others as messages (a transport's fast path; with
#: ``drain`` False only what one read per peer brings, the rest keeps the descriptor
#: readable: :meth:`hal.can.unix_bus.UnixBus.recv_frames`).
FrameReader = Callable[[bool], tuple[list[tuple[int, bytes]], list[can.Message]]]
#: ``(drain) -> (records, others)``: whole records of frames in the ``unix`` wire format
#: (:mod:`hal.can.unix_wire`) waiting, and messages read before
#: (:meth:`hal.can.unix_bus.UnixBus.recv_records`); ``drain`` as :data:`FrameReader`.
RecordReader = Callable[[bool], tuple[list[bytes], list[can.Message]]]
#: ``(record)``: whole frames in the ``unix`` wire format sent as one record
#: (:meth:`hal.can.unix_bus.UnixBus.send_record`).
RecordWriter = Callable[[bytes | memoryview], None]


def open_bus(_name: str, kwargs: dict[str, Any]) -> can.BusABC:
    """A python-can bus from keyword arguments (``interface``, ``channel``, ...)."""
    return can.Bus(**kwargs)


def split_supervision(options: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``options`` -> (python-can settings, supervision settings of :data:`SUPERVISION_KEYS`)."""
    bus = {k: v for k, v in options.items() if k not in SUPERVISION_KEYS}
    supervision = {k: v for k, v in options.items() if k in SUPERVISION_KEYS}
    return bus, supervision


def bus_kwargs(
    profile: DriveProfile, name: str, overrides: dict[str, Any] | None = None
) -> dict[str, Any]:
    """python-can keyword arguments of bus ``name``: the profile's, then ``overrides``
    (supervision keys excluded); no bit rate for virtual/remote buses."""
    cfg = profile.buses[name]
    kwargs: dict[str, Any] = {
        "interface": cfg.interface,
        "channel": cfg.channel,
        "bitrate": cfg.bitrate,
    }
    if cfg.fd:
        kwargs.update(fd=True, data_bitrate=cfg.data_bitrate)
    kwargs.update(split_supervision(overrides or {})[0])
    if kwargs["interface"] in NO_BITRATE:
        kwargs.pop("bitrate", None)
        kwargs.pop("data_bitrate", None)
    return kwargs


@dataclass(eq=False)
class Port:
    """One bus: its python-can handle, the drives on it and its preallocated frames."""

    name: str
    bus: can.BusABC
    #: Drive indices on this bus.
    drives: list[int]
    #: COB-ID -> (kind, drive index) of the frames decoded from this bus.
    table: dict[int, tuple[pdo.Kind, int]]
    sync: can.Message
    heartbeat: can.Message
    kwargs: dict[str, Any] = field(default_factory=dict)
    failed: bool = False
    #: ``timeout`` argument of ``bus.send`` (0 on virtual buses: never block the loop).
    send_timeout: float | None = None
    #: Non-blocking receive -> (frame or None, filtered): python-can's ``_recv_internal``
    #: when the bus has no filters and keeps BusABC's ``recv`` (which only adds filtering
    #: and debug logging), else ``recv``.
    poll: Callable[[float], tuple[can.Message | None, bool]] = field(init=False)
    #: Every waiting frame at once, classic data frames as ``(identifier, data)`` and the
    #: others as messages (:meth:`hal.can.unix_bus.UnixBus.recv_frames`), on a bus that
    #: offers it and has no filters; else None (python-can's API: ``poll``).
    recv_frames: FrameReader | None = field(init=False)
    #: Whole records in and out (``unix`` buses without filters, stub buses that answer
    #: so), else None: :func:`record_io`.
    recv_records: RecordReader | None = field(init=False)
    send_record: RecordWriter | None = field(init=False)
    #: The bus's file descriptor to wait on (``select``), or None (``virtual``, stub buses).
    fd: int | None = field(init=False)
    frames_sent: int = 0
    frames_received: int = 0
    syncs_sent: int = 0
    #: Worst-case length of the frames sent and received [bit] (:mod:`hal.can.busload`).
    bits: int = 0

    def __post_init__(self) -> None:
        self.poll = poller(self.bus)
        self.recv_frames = frame_reader(self.bus)
        self.recv_records, self.send_record = record_io(self.bus)
        self.fd = descriptor(self.bus)


def frame_reader(bus: can.BusABC) -> FrameReader | None:
    """``bus.recv_frames`` (:data:`FrameReader`) where the interface has it (``unix``) and
    the bus has no filters (the reader does not apply them), else None."""
    reader = getattr(bus, "recv_frames", None)
    if reader is None or not callable(reader) or bus.filters is not None:
        return None
    return reader


def record_io(bus: can.BusABC) -> tuple[RecordReader | None, RecordWriter | None]:
    """``(bus.recv_records, bus.send_record)`` where the interface has both (``unix``) and
    the bus has no filters, else ``(None, None)``."""
    reader = getattr(bus, "recv_records", None)
    writer = getattr(bus, "send_record", None)
    if not (callable(reader) and callable(writer)) or bus.filters is not None:
        return None, None
    return reader, writer


def descriptor(bus: can.BusABC) -> int | None:
    """``bus.fileno()`` if the interface has one (socketcan, unix), else None."""
    try:
        fd = bus.fileno()
    except (NotImplementedError, OSError, AttributeError, ValueError):
        return None
    return fd if isinstance(fd, int) and fd >= 0 else None


def poller(bus: can.BusABC) -> Callable[[float], tuple[can.Message | None, bool]]:
    """``poll(0.0)`` -> (the next waiting frame of ``bus`` that passes its filters, or None;
    True), never blocking. Frames the filters drop are skipped (``bus.recv(0)`` would return
    None at the first one and end a drain early)."""
    internal = getattr(bus, "_recv_internal", None)
    if type(bus).recv is not can.BusABC.recv or internal is None:
        return lambda timeout: (bus.recv(timeout), True)
    if bus.filters is None:
        return internal
    matches = bus._matches_filters

    def poll(timeout: float) -> tuple[can.Message | None, bool]:
        while True:
            msg, filtered = internal(timeout)
            if msg is None or filtered or matches(msg):
                return msg, True

    return poll


def open_ports(
    profile: DriveProfile,
    buses: Sequence[str],
    node_ids: Sequence[int],
    drive_bus: Sequence[str],
    overrides: dict[str, dict[str, Any]] | None = None,
    factory: BusFactory = open_bus,
) -> list[Port]:
    """Open ``buses`` of ``profile``; drive ``i`` (node ``node_ids[i]``) is on ``drive_bus[i]``.

    Raises :class:`DriveError` (0x406 naming the bus) when a bus cannot be opened, after
    closing the ones already open."""
    ports: list[Port] = []
    overrides = overrides or {}
    try:
        for name in buses:
            kwargs = bus_kwargs(profile, name, overrides.get(name))
            try:
                bus = factory(name, kwargs)
            except Exception as exc:
                fault = Supervisor.bus_error(name, f"cannot open {kwargs}: {exc}")
                raise DriveError([fault]) from exc
            drives = [i for i, b in enumerate(drive_bus) if b == name]
            table = pdo.receive_table([node_ids[i] for i in drives])
            hb = can.Message(
                arbitration_id=pdo.HEARTBEAT + profile.master_node_id,
                data=bytes([pdo.NmtState.OPERATIONAL]),
                is_extended_id=False,
            )
            sync = can.Message(arbitration_id=pdo.SYNC, data=b"", is_extended_id=False)
            timeout = 0.0 if kwargs.get("interface") == "virtual" else None
            ports.append(
                Port(name, bus, drives, {c: (k, drives[j]) for c, (k, j) in table.items()},
                     sync, hb, kwargs, send_timeout=timeout)
            )  # fmt: skip
    except BaseException:
        close_ports(ports)
        raise
    return ports


def close_ports(ports: Sequence[Port]) -> None:
    """Shut every bus down (a broken bus does not keep the others open)."""
    for port in ports:
        try:
            port.bus.shutdown()
        except Exception as exc:
            log.warning("closing bus %s: %s", port.name, exc)

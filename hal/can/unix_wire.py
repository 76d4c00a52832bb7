"""The ``unix`` bus's wire format (:mod:`hal.can.unix_bus`): frames and records.

A frame is ``<IBBBxd`` (identifier, flags, dlc, data length, timestamp [s], 16 bytes) then
its data. A record (one ``send`` on a ``SOCK_SEQPACKET`` connection) holds one or more
frames back to back, at most :data:`MAX_RECORD` bytes; a receiver splits it. Flags: bit 0
extended identifier, 1 remote, 2 error frame, 3 FD, 4 bit-rate switch, 5 error state
indicator; 0 is a classic 11-bit data frame, the usual one, whose dlc is its data length.
"""

from __future__ import annotations

import struct
import time

import can

#: A frame's header (module doc).
HEADER = struct.Struct("<IBBBxd")
#: Largest record [bytes] (one ``send``): held frames beyond it go in another record.
MAX_RECORD = 4096
_EXTENDED, _REMOTE, _ERROR, _FD, _BRS, _ESI = 1, 2, 4, 8, 16, 32


def encode(msg: can.Message) -> bytes:
    """One frame on the wire (module doc)."""
    data = msg.data or b""
    if not (
        msg.is_extended_id or msg.is_remote_frame or msg.is_error_frame or msg.is_fd
        or msg.bitrate_switch or msg.error_state_indicator
    ):  # fmt: skip
        stamp = msg.timestamp or time.time()  # a classic 11-bit data frame: the usual one
        return HEADER.pack(msg.arbitration_id, 0, msg.dlc, len(data), stamp) + data
    flags = (
        (_EXTENDED if msg.is_extended_id else 0)
        | (_REMOTE if msg.is_remote_frame else 0)
        | (_ERROR if msg.is_error_frame else 0)
        | (_FD if msg.is_fd else 0)
        | (_BRS if msg.bitrate_switch else 0)
        | (_ESI if msg.error_state_indicator else 0)
    )
    stamp = msg.timestamp or time.time()
    return HEADER.pack(msg.arbitration_id, flags, msg.dlc, len(data), stamp) + bytes(data)


def frames(record: bytes) -> list[tuple[int, int, int, float, bytes]]:
    """``(identifier, flags, dlc, timestamp [s], data)`` of each frame of one record (module
    doc); ValueError if the record does not split exactly into frames."""
    out, start, size, header = [], 0, len(record), HEADER.size
    unpack = HEADER.unpack_from
    while start < size:
        if start + header > size:
            raise ValueError(f"record of {size} bytes cut at byte {start}")
        can_id, flags, dlc, length, stamp = unpack(record, start)
        end = start + header + length
        if end > size:
            raise ValueError(f"record of {size} bytes cut at byte {start}")
        out.append((can_id, flags, dlc, stamp, record[start + header : end]))
        start = end
    return out


def message(
    can_id: int, flags: int, dlc: int, stamp: float, data: bytes, channel: str
) -> can.Message:
    """The :class:`can.Message` of one frame's fields (:func:`frames`)."""
    if not flags:  # a classic 11-bit data frame: the usual one (positional: cheaper)
        return can.Message(stamp, can_id, False, False, False, channel, dlc, data)
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
        data=data,
        channel=channel,
    )


def decode(frame: bytes, channel: str) -> can.Message:
    """The message of a record holding one frame; ValueError if it is malformed."""
    if len(frame) < HEADER.size:
        raise ValueError(f"unix bus {channel}: frame of {len(frame)} bytes")
    size = HEADER.unpack_from(frame)[3]
    if len(frame) != HEADER.size + size:
        raise ValueError(f"unix bus {channel}: frame length {len(frame)} != {HEADER.size + size}")
    return message(*frames(frame)[0], channel)


def split(
    record: bytes,
    classic: list[tuple[int, bytes]],
    others: list[can.Message],
    channel: str,
) -> None:
    """Append the frames of ``record`` in order: classic 11-bit data frames to ``classic``
    as ``(identifier, data)`` (no :class:`can.Message`), the others to ``others`` as
    messages on ``channel``. ValueError if the record is cut; the whole frames before the
    cut are appended."""
    start, size, header = 0, len(record), HEADER.size
    unpack, append = HEADER.unpack_from, classic.append
    while start + header <= size:
        can_id, flags, dlc, length, stamp = unpack(record, start)
        data_start = start + header
        end = data_start + length
        if end > size:
            break
        if flags:
            others.append(message(can_id, flags, dlc, stamp, record[data_start:end], channel))
        else:
            append((can_id, record[data_start:end]))
        start = end
    if start != size:
        raise ValueError(f"record of {size} bytes cut at byte {start}")

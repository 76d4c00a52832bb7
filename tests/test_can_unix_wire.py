"""hal.can.unix_wire: the ``unix`` bus's frames and records."""

from __future__ import annotations

import can
import pytest

from hal.can.unix_wire import decode, encode, frames, split


def message(can_id: int, data: bytes = b"", **kwargs: object) -> can.Message:
    return can.Message(arbitration_id=can_id, data=data, is_extended_id=False, **kwargs)


def test_frame_fields_survive_the_wire():
    for msg in (
        can.Message(arbitration_id=0x1ABCDE, is_extended_id=True, data=b"\x01\x02"),
        can.Message(arbitration_id=0x123, is_extended_id=False, is_remote_frame=True, dlc=4),
        can.Message(arbitration_id=0x20000080, is_error_frame=True, data=bytes(8)),
        can.Message(arbitration_id=0x100, is_fd=True, bitrate_switch=True, data=bytes(range(64))),
    ):
        back = decode(encode(msg), "x")
        assert back.equals(msg, timestamp_delta=None, check_channel=False)
    with pytest.raises(ValueError, match="frame"):
        decode(b"\x00" * 3, "x")
    with pytest.raises(ValueError, match="length"):
        decode(encode(message(0x80, b"\x01")) + b"\x00", "x")


def test_split_keeps_classic_frames_raw_and_makes_messages_of_the_others():
    sent = [
        message(0x181, b"\x27\x06\x01\x02\x03\x04", timestamp=1.0),
        can.Message(arbitration_id=0x1ABCDE, is_extended_id=True, data=b"\x01", timestamp=2.0),
        message(0x080, timestamp=3.0),
        can.Message(arbitration_id=0x40, is_error_frame=True, data=bytes(8), timestamp=4.0),
        message(0x701, b"\x05", timestamp=5.0),
    ]
    record = b"".join(encode(m) for m in sent)
    assert len(frames(record)) == 5
    classic: list[tuple[int, bytes]] = [(0x7FF, b"before")]  # appended to
    others: list[can.Message] = []
    split(record, classic, others, "chan")
    assert classic == [
        (0x7FF, b"before"), (0x181, b"\x27\x06\x01\x02\x03\x04"), (0x080, b""), (0x701, b"\x05")
    ]  # fmt: skip
    assert [m.channel for m in others] == ["chan", "chan"]
    assert others[0].equals(sent[1], check_channel=False)
    assert others[1].equals(sent[3], check_channel=False)
    classic, others = [], []
    with pytest.raises(ValueError, match="cut at byte"):
        split(record[:-1], classic, others, "chan")  # the last frame is cut
    assert [c for c, _ in classic] == [0x181, 0x080] and len(others) == 2

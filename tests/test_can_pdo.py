"""hal.can.pdo: COB-IDs and frame codecs of the contract."""

from __future__ import annotations

from hal.can import pdo


def test_cob_ids_and_receive_table():
    table = pdo.receive_table([5, 9])
    assert table[0x185] == (pdo.Kind.TPDO1, 0)
    assert table[0x289] == (pdo.Kind.TPDO2, 1)
    assert table[0x709] == (pdo.Kind.HEARTBEAT, 1)
    assert table[0x085] == (pdo.Kind.EMCY, 0)
    assert 0x205 not in table  # RPDOs are the master's own
    assert pdo.split(0x18A) == (0x180, 0x0A)


def test_payload_layouts_are_little_endian():
    assert pdo.RPDO1_STRUCT.pack(0x000F, -2) == b"\x0f\x00\xfe\xff\xff\xff"
    assert pdo.TPDO1_STRUCT.unpack(b"\x27\x02\x10\x00\x00\x00") == (0x0227, 16)
    assert pdo.TPDO2_STRUCT.size == 4
    assert pdo.EMCY_STRUCT.unpack(b"\x11\x86\x80abcde")[:2] == (0x8611, 0x80)


def test_emcy_names():
    assert "following" in pdo.emcy_name(0x8611)
    assert pdo.emcy_name(0xFF42) == pdo.EMCY_NAMES[0xFF00]
    assert pdo.emcy_name(0x1234) == "unknown error"

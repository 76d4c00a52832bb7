"""COB-IDs and precompiled frame codecs of the CAN protocol contract (docs/can.md).

Standard CANopen predefined connection set, 11-bit identifiers::

    NMT 0x000   SYNC 0x080   EMCY 0x080+id   TPDO1 0x180+id   RPDO1 0x200+id
    TPDO2 0x280+id   SDO tx 0x580+id   SDO rx 0x600+id   heartbeat 0x700+id

Payloads, little-endian as CANopen:

* RPDO1 (master -> drive): controlword u16, target position i32 [counts]: 6 bytes.
* TPDO1 (drive -> master): statusword u16, position actual i32 [counts]: 6 bytes.
* TPDO2 (drive -> master): velocity actual i32 [counts/s]: 4 bytes.
* EMCY: error code u16, error register u8, 5 manufacturer bytes: 8 bytes.
* Heartbeat: NMT state u8 (0 boot-up, 4 stopped, 5 operational, 0x7F pre-operational).
* NMT command: command specifier u8, node id u8 (0 = all).
"""

from __future__ import annotations

import enum
import struct

NMT = 0x000
SYNC = 0x080
EMCY = 0x080
TPDO1 = 0x180
RPDO1 = 0x200
TPDO2 = 0x280
SDO_TX = 0x580
SDO_RX = 0x600
HEARTBEAT = 0x700

RPDO1_STRUCT = struct.Struct("<Hi")
TPDO1_STRUCT = struct.Struct("<Hi")
TPDO2_STRUCT = struct.Struct("<i")
EMCY_STRUCT = struct.Struct("<HB5s")
NMT_STRUCT = struct.Struct("<BB")


class NmtCommand(enum.IntEnum):
    START = 0x01
    STOP = 0x02
    PRE_OPERATIONAL = 0x80
    RESET_NODE = 0x81
    RESET_COMMUNICATION = 0x82


class NmtState(enum.IntEnum):
    """The state byte of a heartbeat."""

    BOOTUP = 0x00
    STOPPED = 0x04
    OPERATIONAL = 0x05
    PRE_OPERATIONAL = 0x7F


#: Function code (COB-ID & 0x780) of each kind of frame the master receives from a node.
class Kind(enum.IntEnum):
    EMCY = 0x080
    TPDO1 = 0x180
    TPDO2 = 0x280
    SDO_TX = 0x580
    HEARTBEAT = 0x700


def split(cob_id: int) -> tuple[int, int]:
    """``(function code, node id)`` of an 11-bit COB-ID."""
    return cob_id & 0x780, cob_id & 0x7F


def receive_table(node_ids: list[int]) -> dict[int, tuple[Kind, int]]:
    """COB-ID -> (kind, index into ``node_ids``) for every frame the master decodes."""
    table: dict[int, tuple[Kind, int]] = {}
    for i, node in enumerate(node_ids):
        for kind in (Kind.EMCY, Kind.TPDO1, Kind.TPDO2, Kind.HEARTBEAT):
            table[int(kind) + node] = (kind, i)
    return table


#: Names of EMCY error codes the drives send (CiA 301/402; the emulator's choice documented
#: in docs/can.md). Looked up by exact code, then by the high byte.
EMCY_NAMES: dict[int, str] = {
    0x0000: "error reset / no error",
    0x1000: "generic error",
    0x2310: "continuous over-current",
    0x3210: "DC link over-voltage",
    0x3220: "DC link under-voltage",
    0x4310: "drive over-temperature",
    0x5530: "manufacturer-specific hardware fault",
    0x6320: "parameter error",
    0x7300: "sensor (encoder) error",
    0x8110: "CAN overrun",
    0x8120: "CAN error passive",
    0x8130: "heartbeat / life guard error (master lost)",
    0x8140: "recovered from bus-off",
    0x8611: "following error",
    0xFF00: "device-specific error",
}


def emcy_name(code: int) -> str:
    """A readable name of an EMCY error code."""
    if code in EMCY_NAMES:
        return EMCY_NAMES[code]
    return EMCY_NAMES.get(code & 0xFF00, "unknown error")

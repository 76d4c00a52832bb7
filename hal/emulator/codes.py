"""Numbers of an emulated CiA 402 drive: NMT states and commands, EMCY codes, error register
bits, SDO abort codes (CiA 301 / CiA 402)."""

from __future__ import annotations

# NMT states (heartbeat byte) and commands.
NMT_BOOTUP = 0x00
NMT_STOPPED = 0x04
NMT_OPERATIONAL = 0x05
NMT_PRE_OPERATIONAL = 0x7F
NMT_START, NMT_STOP, NMT_PRE_OP, NMT_RESET_NODE, NMT_RESET_COMM = 0x01, 0x02, 0x80, 0x81, 0x82

# EMCY codes (CiA 301 / CiA 402) and error register bits.
EMCY_ERROR_RESET = 0x0000
EMCY_HEARTBEAT = 0x8130
EMCY_COMMUNICATION = 0x8100
EMCY_FOLLOWING_ERROR = 0x8611
EMCY_DEVICE_SPECIFIC = 0xFF00
ERR_GENERIC = 0x01
ERR_COMMUNICATION = 0x10
ERR_PROFILE = 0x20
ERR_MANUFACTURER = 0x80

CSP_MODE = 8
#: A fault reaction or quick stop no SYNC ends finishes after this long [s].
REACTION_TIMEOUT = 0.05
FOLLOWING_ERROR_OFF = 0xFFFF_FFFF
ABORT_VALUE_RANGE = 0x0609_0030
ABORT_WRITE_READ_ONLY = 0x0601_0002

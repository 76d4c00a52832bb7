"""Return codes (``ReturnID.id``), Spec A states and JARA_ARM state bits, as constants.

The codes are the originals' (see docs/client.md); ``-6`` means ``CANNOT_REACH_TARGET_ERR`` in
Spec A and ``NOT_IMPLEMENTED`` in JARA_ARM, which imotion never returns.
"""

from __future__ import annotations

from typing import NamedTuple

OK = 0
NG = -1
STATUS_ERR = -2
VALUE_ERR = -3
NOT_SV_ON_ERR = -4
FULL_MOTION_QUEUE_ERR = -5
CANNOT_REACH_TARGET_ERR = -6

#: Return code -> name.
RETURN_CODE_NAMES: dict[int, str] = {
    OK: "OK",
    NG: "NG",
    STATUS_ERR: "STATUS_ERR",
    VALUE_ERR: "VALUE_ERR",
    NOT_SV_ON_ERR: "NOT_SV_ON_ERR",
    FULL_MOTION_QUEUE_ERR: "FULL_MOTION_QUEUE_ERR",
    CANNOT_REACH_TARGET_ERR: "CANNOT_REACH_TARGET_ERR",
}

# Spec A getState statusId.
UNPOWERED = 0x010
SERVO_OFF = 0x011
READY = 0x012
BUSY = 0x013
PAUSE = 0x014
ALARM = 0x015

#: Spec A statusId -> name.
STATE_NAMES: dict[int, str] = {
    UNPOWERED: "Unpowered",
    SERVO_OFF: "ServoOff",
    READY: "Ready",
    BUSY: "Busy",
    PAUSE: "Pause",
    ALARM: "Alarm",
}

# JARA_ARM ManipulatorCommon getState bits.
JARA_SERVO_ON = 0x01
JARA_MOVING = 0x02
JARA_ALARM = 0x04
JARA_BUFFER_FULL = 0x08
JARA_PAUSED = 0x10

#: JARA_ARM state bit -> name.
JARA_STATE_BITS: dict[int, str] = {
    JARA_SERVO_ON: "servo on",
    JARA_MOVING: "moving",
    JARA_ALARM: "alarm",
    JARA_BUFFER_FULL: "motion buffer full",
    JARA_PAUSED: "paused",
}


def return_code_name(code: int) -> str:
    """``"OK"``, ``"VALUE_ERR"``, ...; ``"code <n>"`` for a code outside the table."""
    return RETURN_CODE_NAMES.get(code, f"code {code}")


def state_name(status_id: int) -> str:
    """Spec A state name of a statusId (``0x012`` -> ``"Ready"``)."""
    return STATE_NAMES.get(status_id, f"unknown state 0x{status_id:03X}")


def jara_state_names(bits: int) -> list[str]:
    """Names of the JARA_ARM state bits set in ``bits`` (empty list: servo off, idle)."""
    return [name for bit, name in JARA_STATE_BITS.items() if bits & bit]


class ReturnID(NamedTuple):
    """Result code of an operation and the daemon's explanation (always given)."""

    id: int
    comment: str

    @property
    def ok(self) -> bool:
        return self.id == OK

    @property
    def name(self) -> str:
        return return_code_name(self.id)

    def __str__(self) -> str:
        text = f"{self.name} ({self.id})"
        return f"{text}: {self.comment}" if self.comment else text

"""Return codes (``ReturnID.id``), Spec A states and JARA_ARM state bits, as constants
(the enums of :mod:`controller.vocabulary` under the names the client has always offered).

The codes are the originals' (see docs/client.md); ``-6`` means ``CANNOT_REACH_TARGET_ERR`` in
Spec A and ``NOT_IMPLEMENTED`` in JARA_ARM, which imotion never returns.
"""

from __future__ import annotations

from typing import NamedTuple

from controller.vocabulary import (
    JARA_STATE_NAMES,
    SPEC_A_STATE_NAMES,
    JaraState,
    ReturnCode,
    SpecAState,
)

OK = ReturnCode.OK
NG = ReturnCode.NG
STATUS_ERR = ReturnCode.STATUS_ERR
VALUE_ERR = ReturnCode.VALUE_ERR
NOT_SV_ON_ERR = ReturnCode.NOT_SV_ON_ERR
FULL_MOTION_QUEUE_ERR = ReturnCode.FULL_MOTION_QUEUE_ERR
CANNOT_REACH_TARGET_ERR = ReturnCode.CANNOT_REACH_TARGET_ERR

#: Return code -> name.
RETURN_CODE_NAMES: dict[int, str] = {c.value: c.name for c in ReturnCode}

# Spec A getState statusId.
UNPOWERED = SpecAState.UNPOWERED
SERVO_OFF = SpecAState.SERVO_OFF
READY = SpecAState.READY
BUSY = SpecAState.BUSY
PAUSE = SpecAState.PAUSE
ALARM = SpecAState.ALARM

#: Spec A statusId -> name.
STATE_NAMES: dict[int, str] = {s.value: name for s, name in SPEC_A_STATE_NAMES.items()}

# JARA_ARM ManipulatorCommon getState bits.
JARA_SERVO_ON = JaraState.SERVO_ON
JARA_MOVING = JaraState.MOVING
JARA_ALARM = JaraState.ALARM
JARA_BUFFER_FULL = JaraState.BUFFER_FULL
JARA_PAUSED = JaraState.PAUSED

#: JARA_ARM state bit -> name.
JARA_STATE_BITS: dict[int, str] = {b.value: name for b, name in JARA_STATE_NAMES.items()}


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

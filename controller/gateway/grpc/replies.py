"""Return codes, states and the reply plumbing shared by every servicer.

Codes as in interfaces.md. ``-6`` means CANNOT_REACH_TARGET_ERR in Spec A; JARA_ARM's
NOT_IMPLEMENTED is never returned (every operation is implemented).
"""

from __future__ import annotations

import enum

from controller.contract.snapshot import Snapshot


class Code(enum.IntEnum):
    OK = 0
    NG = -1
    STATUS_ERR = -2
    VALUE_ERR = -3
    NOT_SV_ON_ERR = -4
    FULL_MOTION_QUEUE_ERR = -5
    CANNOT_REACH_TARGET_ERR = -6


class Failure(Exception):
    """Ends an operation with ``code`` and a comment saying why (never a crash)."""

    def __init__(self, code: Code, comment: str):
        super().__init__(comment)
        self.code = code
        self.comment = comment


class SpecAState(enum.IntEnum):
    UNPOWERED = 0x010
    SERVO_OFF = 0x011
    READY = 0x012
    BUSY = 0x013
    PAUSE = 0x014
    ALARM = 0x015


_CORE_TO_SPEC_A = {
    "servo off": SpecAState.SERVO_OFF,
    "ready": SpecAState.READY,
    "busy": SpecAState.BUSY,
    "paused": SpecAState.PAUSE,
    "alarm": SpecAState.ALARM,
}

_STATE_TEXT = {
    SpecAState.UNPOWERED: "Unpowered: the hardware is not powered up (servoOn powers it)",
    SpecAState.SERVO_OFF: "ServoOff: powered, servos off",
    SpecAState.READY: "Ready: servos on, waiting for a command",
    SpecAState.BUSY: "Busy: executing a motion",
    SpecAState.PAUSE: "Pause: motion paused (resume or stop)",
    SpecAState.ALARM: "Alarm: clearAlarms, then servoOn",
}


def spec_a_state(s: Snapshot) -> tuple[SpecAState, str]:
    """Spec A ``getState`` (statusId, message) of a snapshot."""
    if s.core_state == "servo off" and s.hw_state in ("unconfigured", "finalized"):
        state = SpecAState.UNPOWERED
    else:
        state = _CORE_TO_SPEC_A[s.core_state]
    text = _STATE_TEXT[state]
    if state == SpecAState.BUSY and s.queue:
        text += f" ({s.queue} queued)"
    return state, text


# JARA_ARM getState bits
JARA_SERVO_ON = 0x01
JARA_MOVING = 0x02
JARA_ALARM = 0x04
JARA_BUFFER_FULL = 0x08
JARA_PAUSED = 0x10


def jara_state(s: Snapshot) -> int:
    """JARA_ARM ``getState`` bit set of a snapshot."""
    from controller.contract import snapshot as snap

    bits = 0
    if s.flags & snap.F_SERVO_ON:
        bits |= JARA_SERVO_ON
    if s.flags & snap.F_MOVING or s.queue:
        bits |= JARA_MOVING
    if s.core_state == "alarm":
        bits |= JARA_ALARM
    if s.flags & snap.F_QUEUE_FULL:
        bits |= JARA_BUFFER_FULL
    if s.core_state == "paused":
        bits |= JARA_PAUSED
    return bits


#: Control-process refusal names -> codes.
REFUSAL_CODES = {c.name: c for c in Code}

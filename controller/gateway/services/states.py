"""Spec A and JARA_ARM states of a snapshot (the codes themselves: controller.vocabulary).

JARA_ARM state bits (ruling, issue 15.9): 0x02 (moving) means the axes move: it is set while
a motion executes, including the deceleration into a pause, and clear once a pause has
brought the axes to rest (0x10 alone), even with motions still queued behind the paused one.
"""

from __future__ import annotations

from controller.contract.snapshot import Snapshot, StateHeader
from controller.vocabulary import CoreState, JaraState, SpecAState
from hal.interface import HardwareState

_CORE_TO_SPEC_A = {
    CoreState.SERVO_OFF: SpecAState.SERVO_OFF,
    CoreState.READY: SpecAState.READY,
    CoreState.BUSY: SpecAState.BUSY,
    CoreState.PAUSED: SpecAState.PAUSE,
    CoreState.ALARM: SpecAState.ALARM,
}

_STATE_TEXT = {
    SpecAState.UNPOWERED: "Unpowered: the hardware is not powered up (servoOn powers it)",
    SpecAState.SERVO_OFF: "ServoOff: powered, servos off",
    SpecAState.READY: "Ready: servos on, waiting for a command",
    SpecAState.BUSY: "Busy: executing a motion",
    SpecAState.PAUSE: "Pause: motion paused (resume or stop)",
    SpecAState.ALARM: "Alarm: clearAlarms, then servoOn",
}


_UNPOWERED = (HardwareState.UNCONFIGURED, HardwareState.FINALIZED)


def spec_a_state(s: Snapshot | StateHeader) -> tuple[SpecAState, str]:
    """Spec A ``getState`` (statusId, message) of a snapshot (or of its header alone)."""
    if s.core_state == CoreState.SERVO_OFF and s.hw_state in _UNPOWERED:
        state = SpecAState.UNPOWERED
    else:
        state = _CORE_TO_SPEC_A[s.core_state]
    text = _STATE_TEXT[state]
    if state == SpecAState.BUSY and s.queue:
        text += f" ({s.queue} queued)"
    return state, text


def jara_state(s: Snapshot | StateHeader) -> JaraState:
    """JARA_ARM ``getState`` bit set of a snapshot (or of its header alone)."""
    from controller.contract import snapshot as snap

    bits = JaraState(0)
    if s.flags & snap.F_SERVO_ON:
        bits |= JaraState.SERVO_ON
    paused = s.core_state == CoreState.PAUSED  # the core enters PAUSED once the axes rest
    gripper_only = s.flags & snap.F_MOVING and not s.flags & snap.F_MOTION
    if (not paused and (s.flags & snap.F_MOVING or s.queue)) or (paused and gripper_only):
        bits |= JaraState.MOVING
    if s.core_state == CoreState.ALARM:
        bits |= JaraState.ALARM
    if s.flags & snap.F_QUEUE_FULL:
        bits |= JaraState.BUFFER_FULL
    if paused:
        bits |= JaraState.PAUSED
    return bits

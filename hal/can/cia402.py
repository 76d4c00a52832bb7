"""CiA 402 power state machine, master side: statusword decoding and the controlword to send.

States and their statusword patterns (bits 0-3, 5 and 6; CiA 402 / IEC 61800-7-201)::

    state                    mask    value
    Not ready to switch on   0x004F  0x0000
    Switch on disabled       0x004F  0x0040
    Ready to switch on       0x006F  0x0021
    Switched on              0x006F  0x0023
    Operation enabled        0x006F  0x0027
    Quick stop active        0x006F  0x0007
    Fault reaction active    0x004F  0x000F
    Fault                    0x004F  0x0008

Controlword commands (bits 0-3 and 7): shutdown 0x06, switch on 0x07, enable operation 0x0F,
disable voltage 0x00, quick stop 0x02, disable operation 0x07, fault reset = bit 7 rising
edge (0x00 then 0x80).

:class:`DriveMaster` is non-blocking: each cycle it takes the drive's latest statusword and
returns the controlword that moves it one transition towards its :class:`Goal`. It never
waits; the caller sends the controlword (RPDO1) and the next SYNC.
"""

from __future__ import annotations

import enum


class State(enum.Enum):
    """CiA 402 power states (plus UNKNOWN before the first statusword)."""

    UNKNOWN = "unknown"
    NOT_READY_TO_SWITCH_ON = "not ready to switch on"
    SWITCH_ON_DISABLED = "switch on disabled"
    READY_TO_SWITCH_ON = "ready to switch on"
    SWITCHED_ON = "switched on"
    OPERATION_ENABLED = "operation enabled"
    QUICK_STOP_ACTIVE = "quick stop active"
    FAULT_REACTION_ACTIVE = "fault reaction active"
    FAULT = "fault"


# Controlword commands.
CW_DISABLE_VOLTAGE = 0x00
CW_QUICK_STOP = 0x02
CW_SHUTDOWN = 0x06
CW_SWITCH_ON = 0x07
CW_DISABLE_OPERATION = 0x07
CW_ENABLE_OPERATION = 0x0F
CW_FAULT_RESET = 0x80

# Statusword bits.
SW_FAULT = 0x0008
SW_WARNING = 0x0080
SW_REMOTE = 0x0200
SW_TARGET_REACHED = 0x0400
SW_FOLLOWING_ERROR = 0x2000  # CSP: bit 13

#: (mask, value, state), checked in order.
_PATTERNS: tuple[tuple[int, int, State], ...] = (
    (0x004F, 0x0000, State.NOT_READY_TO_SWITCH_ON),
    (0x004F, 0x0040, State.SWITCH_ON_DISABLED),
    (0x006F, 0x0021, State.READY_TO_SWITCH_ON),
    (0x006F, 0x0023, State.SWITCHED_ON),
    (0x006F, 0x0027, State.OPERATION_ENABLED),
    (0x006F, 0x0007, State.QUICK_STOP_ACTIVE),
    (0x004F, 0x000F, State.FAULT_REACTION_ACTIVE),
    (0x004F, 0x0008, State.FAULT),
)

#: The state of every possible statusword (precomputed over the 7 relevant bits).
_STATE_OF_BITS: dict[int, State] = {}
for _bits in range(0x80):
    _STATE_OF_BITS[_bits] = next(
        (s for mask, value, s in _PATTERNS if _bits & mask == value), State.UNKNOWN
    )


def decode(statusword: int) -> State:
    """The power state a statusword reports (UNKNOWN for a pattern the standard lacks)."""
    return _STATE_OF_BITS[statusword & 0x6F]


#: The statusword each state reports (bits 0-6 only; for emulators and tests).
STATUSWORD: dict[State, int] = {
    State.NOT_READY_TO_SWITCH_ON: 0x0000,
    State.SWITCH_ON_DISABLED: 0x0040,
    State.READY_TO_SWITCH_ON: 0x0021,
    State.SWITCHED_ON: 0x0023,
    State.OPERATION_ENABLED: 0x0027,
    State.QUICK_STOP_ACTIVE: 0x0007,
    State.FAULT_REACTION_ACTIVE: 0x000F,
    State.FAULT: 0x0008,
}


class Goal(enum.Enum):
    """Where the master wants a drive."""

    #: Quick stop, then stay disabled (Switch on disabled). Also the goal after any fault.
    OFF = "off"
    #: Operation enabled (cyclic synchronous position).
    ENABLED = "enabled"
    #: Clear a fault (bit-7 edge), then OFF.
    RESET = "reset"


class DriveMaster:
    """Per-drive, non-blocking master of the power state machine.

    Call :meth:`controlword` once per cycle with the latest statusword; send what it returns.
    """

    __slots__ = ("_last", "_reset_high", "goal", "state")

    def __init__(self) -> None:
        self.goal = Goal.OFF
        self.state = State.UNKNOWN
        self._reset_high = False
        #: (statusword, goal, controlword) of the last call outside RESET: the same inputs
        #: give the same controlword (the steady state of every cycle, no decoding).
        self._last: tuple[int | None, Goal, int] | None = None

    def controlword(self, statusword: int | None) -> int:
        """The controlword for this cycle given the latest statusword (None: none yet)."""
        goal = self.goal
        last = self._last
        if last is not None and last[0] == statusword and last[1] is goal:
            return last[2]
        state = self.state = State.UNKNOWN if statusword is None else decode(statusword)
        if goal is Goal.RESET:
            self._last = None
            if state is State.FAULT:
                # Edge: bit 7 low in one cycle, high in the next.
                self._reset_high = not self._reset_high
                return CW_FAULT_RESET if self._reset_high else CW_DISABLE_VOLTAGE
            self._reset_high = False
            if state is State.FAULT_REACTION_ACTIVE:
                return CW_DISABLE_VOLTAGE
            self.goal = goal = Goal.OFF
        self._reset_high = False
        cw = _ENABLE[state] if goal is Goal.ENABLED else _OFF[state]
        self._last = (statusword, goal, cw)
        return cw

    @property
    def enabled(self) -> bool:
        return self.state is State.OPERATION_ENABLED

    @property
    def faulted(self) -> bool:
        return self.state in (State.FAULT, State.FAULT_REACTION_ACTIVE)


#: Towards Operation enabled, one transition per cycle (numbers: the standard's transitions).
_ENABLE: dict[State, int] = {
    State.UNKNOWN: CW_DISABLE_VOLTAGE,
    State.NOT_READY_TO_SWITCH_ON: CW_DISABLE_VOLTAGE,  # wait (transition 1 is automatic)
    State.SWITCH_ON_DISABLED: CW_SHUTDOWN,  # 2
    State.READY_TO_SWITCH_ON: CW_SWITCH_ON,  # 3
    State.SWITCHED_ON: CW_ENABLE_OPERATION,  # 4
    State.OPERATION_ENABLED: CW_ENABLE_OPERATION,  # stay
    State.QUICK_STOP_ACTIVE: CW_DISABLE_VOLTAGE,  # 12, then 2-3-4 again
    State.FAULT_REACTION_ACTIVE: CW_DISABLE_VOLTAGE,  # wait (14 is automatic)
    State.FAULT: CW_DISABLE_VOLTAGE,  # stays in Fault: only a RESET goal clears it
}

#: Towards Switch on disabled through a quick stop.
_OFF: dict[State, int] = {
    State.UNKNOWN: CW_QUICK_STOP,
    State.NOT_READY_TO_SWITCH_ON: CW_DISABLE_VOLTAGE,
    State.SWITCH_ON_DISABLED: CW_DISABLE_VOLTAGE,  # stay
    State.READY_TO_SWITCH_ON: CW_QUICK_STOP,  # 7
    State.SWITCHED_ON: CW_QUICK_STOP,  # 10
    State.OPERATION_ENABLED: CW_QUICK_STOP,  # 11
    # Hold the quick stop: with 0x605A = 2 the drive decelerates and goes to Switch on
    # disabled by itself (12); with 5-8 it stays here, stopped.
    State.QUICK_STOP_ACTIVE: CW_QUICK_STOP,
    State.FAULT_REACTION_ACTIVE: CW_DISABLE_VOLTAGE,
    State.FAULT: CW_DISABLE_VOLTAGE,
}

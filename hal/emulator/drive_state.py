"""The slave side of the CiA 402 power state machine: controlword in, statusword out.

States and transitions follow CiA 402 (IEC 61800-7-201), numbered as in the standard::

    Start --0--> Not ready to switch on --1--> Switch on disabled
    Switch on disabled  --2  (shutdown)---------------> Ready to switch on
    Ready to switch on  --3  (switch on)--------------> Switched on
    Switched on         --4  (enable operation)-------> Operation enabled
    Operation enabled   --5  (disable operation)------> Switched on
    Switched on         --6  (shutdown)---------------> Ready to switch on
    Ready to switch on  --7  (disable voltage / quick stop)--> Switch on disabled
    Operation enabled   --8  (shutdown)---------------> Ready to switch on
    Operation enabled   --9  (disable voltage)--------> Switch on disabled
    Switched on         --10 (disable voltage / quick stop)--> Switch on disabled
    Operation enabled   --11 (quick stop)-------------> Quick stop active
    Quick stop active   --12 (disable voltage, or the quick stop ramp is done and the
                              quick stop option code is 0..4)--> Switch on disabled
    any                 --13 (fault)------------------> Fault reaction active
    Fault reaction active --14 (reaction done)--------> Fault
    Fault               --15 (fault reset: bit 7 rising edge)--> Switch on disabled
    Quick stop active   --16 (enable operation, option code 5..8)--> Operation enabled

"Switch on + enable operation" (0x0F) in Ready to switch on takes 3 and 4 at once, as the
standard allows. Timing is the emulator's: the fault reaction and the quick stop ramp end
(:meth:`DriveStateMachine.complete_reactions`) at the first SYNC after a TPDO has shown them,
so Fault reaction active and Quick stop active are each visible in exactly one TPDO (the
drive ends them after 50 ms when no SYNC comes, see :mod:`hal.emulator.drive`).

Statusword (0x6041) bits: 0 ready to switch on, 1 switched on, 2 operation enabled, 3 fault,
4 voltage enabled, 5 quick stop (1 in Ready to switch on, Switched on and Operation
enabled; 0 = quick stop active), 6 switch on disabled, 7 warning, 9 remote,
12 (CSP) drive follows the target, 13 (CSP) following error.

Pure logic, no CAN: :mod:`hal.emulator.drive` feeds it controlwords and faults.
"""

from __future__ import annotations

import enum
from collections import deque
from typing import Any

import numpy as np

from hal.emulator.bank import BoolField, IntField, own_row

#: Controlword bits.
CW_SWITCH_ON = 0x0001
CW_ENABLE_VOLTAGE = 0x0002
CW_QUICK_STOP = 0x0004  # 0 = quick stop requested
CW_ENABLE_OPERATION = 0x0008
CW_FAULT_RESET = 0x0080

#: Statusword bits.
SW_READY_TO_SWITCH_ON = 0x0001
SW_SWITCHED_ON = 0x0002
SW_OPERATION_ENABLED = 0x0004
SW_FAULT = 0x0008
SW_VOLTAGE_ENABLED = 0x0010
SW_QUICK_STOP = 0x0020
SW_SWITCH_ON_DISABLED = 0x0040
SW_WARNING = 0x0080
SW_REMOTE = 0x0200
SW_FOLLOWS_TARGET = 0x1000
SW_FOLLOWING_ERROR = 0x2000


class PowerState(enum.Enum):
    """CiA 402 power states, with the statusword pattern (bits 0-3, 5, 6) of each."""

    NOT_READY_TO_SWITCH_ON = 0x0000
    SWITCH_ON_DISABLED = 0x0040
    READY_TO_SWITCH_ON = 0x0021
    SWITCHED_ON = 0x0023
    OPERATION_ENABLED = 0x0027
    QUICK_STOP_ACTIVE = 0x0007
    FAULT_REACTION_ACTIVE = 0x000F
    FAULT = 0x0008

    @property
    def pattern(self) -> int:
        return int(self.value)


#: States in which the power stage drives the motor (servo on).
TORQUE_STATES = frozenset(
    {PowerState.OPERATION_ENABLED, PowerState.QUICK_STOP_ACTIVE, PowerState.FAULT_REACTION_ACTIVE}
)
#: States with voltage applied (statusword bit 4).
_VOLTAGE_STATES = frozenset(
    {
        PowerState.READY_TO_SWITCH_ON,
        PowerState.SWITCHED_ON,
        PowerState.OPERATION_ENABLED,
        PowerState.QUICK_STOP_ACTIVE,
    }
)

_MASK_STATE = 0x4F  # bits 0-3 and 6 identify most states
_MASK_STATE_QS = 0x6F  # bit 5 too, for the states the standard lists with it


def decode_statusword(statusword: int) -> PowerState | None:
    """The power state a statusword shows (None for a pattern outside the standard)."""
    for state in PowerState:
        if state in (
            PowerState.NOT_READY_TO_SWITCH_ON,
            PowerState.SWITCH_ON_DISABLED,
            PowerState.FAULT_REACTION_ACTIVE,
            PowerState.FAULT,
        ):
            if statusword & _MASK_STATE == state.pattern & _MASK_STATE:
                return state
        elif statusword & _MASK_STATE_QS == state.pattern:
            return state
    return None


class Command(enum.Enum):
    """Device control commands of CiA 402 (decoded from controlword bits 0-3 and 7)."""

    SHUTDOWN = "shutdown"  # 0xxx x110
    SWITCH_ON = "switch on"  # 0xxx 0111 (also "disable operation")
    ENABLE_OPERATION = "enable operation"  # 0xxx 1111 (also "switch on + enable")
    DISABLE_VOLTAGE = "disable voltage"  # 0xxx xx0x
    QUICK_STOP = "quick stop"  # 0xxx x01x


def decode_command(controlword: int) -> Command:
    """The device control command in ``controlword`` (bit 7 aside, see fault reset)."""
    if not controlword & CW_ENABLE_VOLTAGE:
        return Command.DISABLE_VOLTAGE
    if not controlword & CW_QUICK_STOP:
        return Command.QUICK_STOP
    if not controlword & CW_SWITCH_ON:
        return Command.SHUTDOWN
    if controlword & CW_ENABLE_OPERATION:
        return Command.ENABLE_OPERATION
    return Command.SWITCH_ON


_BY_PATTERN = {state.pattern: state for state in PowerState}


class StateField:
    """A :class:`PowerState` kept as its pattern in column ``name`` of the owner's bank row
    (:mod:`hal.emulator.bank`)."""

    def __init__(self, name: str):
        self.column = IntField(name).column

    def __get__(self, obj: Any, owner: type | None = None) -> PowerState:
        return _BY_PATTERN[int(obj._ints[self.column])]

    def __set__(self, obj: Any, value: PowerState) -> None:
        obj._ints[self.column] = value.pattern


class DriveStateMachine:
    """One drive's power state machine.

    ``quick_stop_option`` is 0x605A: 0..4 end the quick stop in Switch on disabled (12),
    5..8 stay in Quick stop active until enable operation (16) or disable voltage (12).
    Its values live in ``ints``, the drive's int row of a :class:`hal.emulator.bank.DriveBank`
    (default: a row of its own).
    """

    state = StateField("state")
    quick_stop_option = IntField("quick_stop_option")
    refuse_enable = BoolField("refuse_enable")
    warning = BoolField("warning")
    following_error = BoolField("following_error")
    _controlword = IntField("sm_controlword")

    def __init__(self, ints: np.ndarray | None = None) -> None:
        self._ints = own_row()[0] if ints is None else ints
        self.state = PowerState.NOT_READY_TO_SWITCH_ON
        #: The last transition numbers taken, oldest first (for tests and logs).
        self.transitions: deque[int] = deque(maxlen=64)
        self.quick_stop_option = 2
        #: Enable operation is refused (fault injection): transitions 4 and 16 do not happen.
        self.refuse_enable = False
        self.warning = False
        self.following_error = False
        self._controlword = 0
        self._fault_pending = False

    # ----------------------------------------------------------------------------- inputs

    def boot(self) -> None:
        """Power-up / NMT reset node: transitions 0 and 1 (self-test passes at once)."""
        self.state = PowerState.NOT_READY_TO_SWITCH_ON
        self._controlword = 0
        self._fault_pending = False
        self.following_error = False
        self.warning = False
        self._go(0, PowerState.NOT_READY_TO_SWITCH_ON)
        self._go(1, PowerState.SWITCH_ON_DISABLED)

    def controlword(self, value: int) -> None:
        """Apply a controlword (from an RPDO at SYNC or an SDO write)."""
        previous, self._controlword = self._controlword, value & 0xFFFF
        state = self.state
        if state is PowerState.FAULT:
            if value & CW_FAULT_RESET and not previous & CW_FAULT_RESET:
                self.following_error = False
                self._go(15, PowerState.SWITCH_ON_DISABLED)
            return
        if state in (PowerState.NOT_READY_TO_SWITCH_ON, PowerState.FAULT_REACTION_ACTIVE):
            return
        command = decode_command(value)
        if state is PowerState.SWITCH_ON_DISABLED:
            if command is Command.SHUTDOWN:
                self._go(2, PowerState.READY_TO_SWITCH_ON)
        elif state is PowerState.READY_TO_SWITCH_ON:
            if command is Command.SWITCH_ON:
                self._go(3, PowerState.SWITCHED_ON)
            elif command is Command.ENABLE_OPERATION:
                self._go(3, PowerState.SWITCHED_ON)
                self._enable(4)
            elif command in (Command.DISABLE_VOLTAGE, Command.QUICK_STOP):
                self._go(7, PowerState.SWITCH_ON_DISABLED)
        elif state is PowerState.SWITCHED_ON:
            if command is Command.ENABLE_OPERATION:
                self._enable(4)
            elif command is Command.SHUTDOWN:
                self._go(6, PowerState.READY_TO_SWITCH_ON)
            elif command in (Command.DISABLE_VOLTAGE, Command.QUICK_STOP):
                self._go(10, PowerState.SWITCH_ON_DISABLED)
        elif state is PowerState.OPERATION_ENABLED:
            if command is Command.SWITCH_ON:
                self._go(5, PowerState.SWITCHED_ON)
            elif command is Command.SHUTDOWN:
                self._go(8, PowerState.READY_TO_SWITCH_ON)
            elif command is Command.DISABLE_VOLTAGE:
                self._go(9, PowerState.SWITCH_ON_DISABLED)
            elif command is Command.QUICK_STOP:
                self._go(11, PowerState.QUICK_STOP_ACTIVE)
                if self.quick_stop_option == 0:  # disable drive function: no ramp
                    self._go(12, PowerState.SWITCH_ON_DISABLED)
        elif state is PowerState.QUICK_STOP_ACTIVE:
            if command is Command.DISABLE_VOLTAGE:
                self._go(12, PowerState.SWITCH_ON_DISABLED)
            elif command is Command.ENABLE_OPERATION and self.quick_stop_option >= 5:
                self._enable(16)

    def quick_stop(self) -> None:
        """An internal quick stop (e.g. abort connection option 3): as the command would."""
        if self.state is PowerState.OPERATION_ENABLED:
            self._go(11, PowerState.QUICK_STOP_ACTIVE)
            if self.quick_stop_option == 0:
                self._go(12, PowerState.SWITCH_ON_DISABLED)
        elif self.state in (PowerState.READY_TO_SWITCH_ON, PowerState.SWITCHED_ON):
            transition = 7 if self.state is PowerState.READY_TO_SWITCH_ON else 10
            self._go(transition, PowerState.SWITCH_ON_DISABLED)

    def disable_voltage(self) -> None:
        """An internal disable voltage (abort connection option 2)."""
        transition = {
            PowerState.READY_TO_SWITCH_ON: 7,
            PowerState.OPERATION_ENABLED: 9,
            PowerState.SWITCHED_ON: 10,
            PowerState.QUICK_STOP_ACTIVE: 12,
        }.get(self.state)
        if transition is not None:
            self._go(transition, PowerState.SWITCH_ON_DISABLED)

    def fault(self) -> bool:
        """A fault occurs: transition 13 (False when already in a fault state)."""
        if self.state in (PowerState.FAULT_REACTION_ACTIVE, PowerState.FAULT):
            return False
        self._go(13, PowerState.FAULT_REACTION_ACTIVE)
        return True

    def complete_reactions(self) -> None:
        """End of a cycle: the fault reaction (14) and the quick stop ramp (12) are done."""
        if self.state is PowerState.FAULT_REACTION_ACTIVE:
            self._go(14, PowerState.FAULT)
        elif self.state is PowerState.QUICK_STOP_ACTIVE and self.quick_stop_option <= 4:
            self._go(12, PowerState.SWITCH_ON_DISABLED)

    # ---------------------------------------------------------------------------- outputs

    @property
    def torque(self) -> bool:
        """True when the power stage drives the motor (servo on)."""
        return self.state in TORQUE_STATES

    @property
    def follows_target(self) -> bool:
        """True when the drive tracks the CSP target (Operation enabled)."""
        return self.state is PowerState.OPERATION_ENABLED

    @property
    def statusword(self) -> int:
        state = self.state
        word = state.pattern | SW_REMOTE
        if state in _VOLTAGE_STATES:
            word |= SW_VOLTAGE_ENABLED
        if self.warning:
            word |= SW_WARNING
        if state is PowerState.OPERATION_ENABLED:
            word |= SW_FOLLOWS_TARGET
        if self.following_error:
            word |= SW_FOLLOWING_ERROR
        return word

    # ---------------------------------------------------------------------------- helpers

    def _enable(self, transition: int) -> None:
        if not self.refuse_enable:
            self._go(transition, PowerState.OPERATION_ENABLED)

    def _go(self, transition: int, state: PowerState) -> None:
        self.transitions.append(transition)
        self.state = state

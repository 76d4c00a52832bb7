"""imotion's vocabulary: every code, state and enumeration, defined once.

The service (both processes), the command channel, the snapshot and the client use these;
integers cross the channel and the snapshot. Names as in the specifications
(interfaces.md); numbering as in the wire contract (``controller/rpc/imotion.proto``).
"""

from __future__ import annotations

from enum import Enum, IntEnum, IntFlag


class ReturnCode(IntEnum):
    """``ReturnID.id``. ``-6`` is CANNOT_REACH_TARGET_ERR in Spec A; JARA_ARM's -6
    (NOT_IMPLEMENTED) is never returned (every operation is implemented)."""

    OK = 0
    NG = -1
    STATUS_ERR = -2
    VALUE_ERR = -3
    NOT_SV_ON_ERR = -4
    FULL_MOTION_QUEUE_ERR = -5
    CANNOT_REACH_TARGET_ERR = -6


class SpecAState(IntEnum):
    """Spec A ``getState`` statusId."""

    UNPOWERED = 0x010
    SERVO_OFF = 0x011
    READY = 0x012
    BUSY = 0x013
    PAUSE = 0x014
    ALARM = 0x015


#: Spec A statusId -> the state's name as the specification writes it.
SPEC_A_STATE_NAMES: dict[SpecAState, str] = {
    SpecAState.UNPOWERED: "Unpowered",
    SpecAState.SERVO_OFF: "ServoOff",
    SpecAState.READY: "Ready",
    SpecAState.BUSY: "Busy",
    SpecAState.PAUSE: "Pause",
    SpecAState.ALARM: "Alarm",
}


class JaraState(IntFlag):
    """JARA_ARM ``ManipulatorCommon.getState`` bits."""

    SERVO_ON = 0x01
    MOVING = 0x02
    ALARM = 0x04
    BUFFER_FULL = 0x08
    PAUSED = 0x10


#: JARA_ARM state bit -> readable name.
JARA_STATE_NAMES: dict[JaraState, str] = {
    JaraState.SERVO_ON: "servo on",
    JaraState.MOVING: "moving",
    JaraState.ALARM: "alarm",
    JaraState.BUFFER_FULL: "motion buffer full",
    JaraState.PAUSED: "paused",
}


class CoreState(IntEnum):
    """State of the motion core (the control process); the snapshot carries its value."""

    SERVO_OFF = 0
    READY = 1
    BUSY = 2
    PAUSED = 3
    ALARM = 4

    @property
    def text(self) -> str:
        return self.name.lower().replace("_", " ")


class RightLeft(IntEnum):
    RIGHT = 0
    LEFT = 1


class FrameType(IntEnum):
    """Frame a pose is expressed in: world-fixed original frame or the moving body frame."""

    ORIGINAL_FRAME = 0
    CURRENT_FRAME = 1


class CommandFrameType(IntEnum):
    """Frame of a relative Cartesian command (Spec A)."""

    BASE_FRAME = 0  #: the original frame
    TOOL_FRAME = 1  #: the control-point frame


class UnitType(IntEnum):
    """Joint groups. ``LUMBER`` (sic) is the specification's spelling of the waist."""

    RIGHT_ARM = 0
    LEFT_ARM = 1
    LUMBER = 2
    VEHICLE = 3


class AlarmType(IntEnum):
    FAULT = 0
    WARNING = 1
    UNKNOWN = 2


class LumbarAxis(Enum):
    Rx = "Rx"
    Ry = "Ry"
    Rz = "Rz"

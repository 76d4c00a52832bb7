"""Enumerations shared by every interface family (names as in the specifications)."""

from enum import Enum, IntEnum


class RightLeft(IntEnum):
    RIGHT = 0
    LEFT = 1


class FrameType(IntEnum):
    """Frame a pose is expressed in: world-fixed original frame or the moving body frame."""

    ORIGINAL_FRAME = 0
    CURRENT_FRAME = 1


class UnitType(Enum):
    """Joint groups. ``LUMBER`` (sic) is the specification's spelling of the waist."""

    RIGHT_ARM = "RIGHT_ARM"
    LEFT_ARM = "LEFT_ARM"
    LUMBER = "LUMBER"
    VEHICLE = "VEHICLE"


class LumbarAxis(Enum):
    Rx = "Rx"
    Ry = "Ry"
    Rz = "Rz"

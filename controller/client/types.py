"""Python forms of the contract's enums and structs (imotion.v1), in spec units.

Struct fields carry the originals' lowerCamel names (the proto fields' JSON names), so
``CarPosWithElbow(carPos, elbow, structFlag)`` reads as in the IDL. An ``HgMatrix`` is a
3 x 4 ``numpy`` array ``[R | p]`` with ``p`` in [mm]. :data:`MESSAGE_TYPES` maps each proto
message name to its Python type; the converters in :mod:`controller.client.convert` use it.
"""

from __future__ import annotations

import enum
from typing import Any, NamedTuple

import numpy as np

from controller.vocabulary import AlarmType, CommandFrameType, FrameType, RightLeft, UnitType

RIGHT = RightLeft.RIGHT
LEFT = RightLeft.LEFT

#: Proto enum name -> Python enum.
ENUM_TYPES: dict[str, type[enum.IntEnum]] = {
    cls.__name__: cls for cls in (RightLeft, FrameType, CommandFrameType, UnitType, AlarmType)
}


class CartesianSpeed(NamedTuple):
    translation: float  # [mm/s]
    rotation: float  # [deg/s]


class CartesianAccel(NamedTuple):
    translation: float  # [mm/s²]
    rotation: float  # [deg/s²]


class CarPosWithElbow(NamedTuple):
    carPos: np.ndarray  # HgMatrix 3 x 4, p [mm]
    elbow: float = 0.0  # [deg]
    structFlag: int = 0


class LimitValue(NamedTuple):
    upper: float  # [deg] or [mm], per axis
    lower: float


class RedundantPos(NamedTuple):
    elbow: float = 0.0  # [deg]
    lumbarRx: float = 0.0  # [deg]
    lumbarRy: float = 0.0  # [deg]
    lumbarRz: float = 0.0  # [deg]
    vehicleX: float = 0.0  # [mm]
    vehicleY: float = 0.0  # [mm]
    vehicleTheta: float = 0.0  # [deg]


class RedundantSpeed(NamedTuple):
    elbow: float = 0.0  # [deg/s]
    lumbarRx: float = 0.0  # [deg/s]
    lumbarRy: float = 0.0  # [deg/s]
    lumbarRz: float = 0.0  # [deg/s]
    vehicleTranslation: float = 0.0  # [mm/s]
    vehicleRotation: float = 0.0  # [deg/s]


class RedundantAccel(NamedTuple):
    elbow: float = 0.0  # [deg/s²]
    lumbarRx: float = 0.0  # [deg/s²]
    lumbarRy: float = 0.0  # [deg/s²]
    lumbarRz: float = 0.0  # [deg/s²]
    vehicleTranslation: float = 0.0  # [mm/s²]
    vehicleRotation: float = 0.0  # [deg/s²]


class RedundantAxesMask(NamedTuple):
    elbow: bool = False
    lumbarRx: bool = False
    lumbarRy: bool = False
    lumbarRz: bool = False
    vehicleX: bool = False
    vehicleY: bool = False
    vehicleTheta: bool = False


class RedundantLimit(NamedTuple):
    rightElbow: LimitValue  # [deg]
    leftElbow: LimitValue  # [deg]
    lumbarRx: LimitValue  # [deg]
    lumbarRy: LimitValue  # [deg]
    lumbarRz: LimitValue  # [deg]
    vehicleX: LimitValue  # [mm]
    vehicleY: LimitValue  # [mm]
    vehicleTheta: LimitValue  # [deg]


class Alarm(NamedTuple):
    code: int
    type: AlarmType
    description: str
    moduleName: str = ""  # Spec A only


class ManipInfo(NamedTuple):
    manufactur: str  # (sic)
    type: str
    axisNum: int  # arm axes, gripper excluded
    cmdCycle: int  # [ms]
    isGripper: bool


class UnitJointPositions(NamedTuple):
    unit: UnitType
    position: list[float]  # arm/waist [deg]; VEHICLE x, y [mm], θ [deg]
    commanded: list[float]  # the controller's command, units of position
    names: list[str]  # joint names in position order (VEHICLE: x, y, theta)
    limits: list[LimitValue]  # position limits, units of position (VEHICLE: none)


class ControlPointPose(NamedTuple):
    arm: RightLeft
    pose: CarPosWithElbow  # original frame


class LatencyStats(NamedTuple):
    p50Us: float  # [µs]
    p99Us: float
    maxUs: float


class LoopStats(NamedTuple):
    cycles: int
    overruns: int
    compute: LatencyStats
    wakeLatency: LatencyStats


class MotionStatus(NamedTuple):
    active: bool  # an arm/body motion is running
    queued: int  # JARA motions waiting
    queueDepth: int
    started: int  # motions started since the daemon started
    finished: int


class StateSample(NamedTuple):
    """One Monitor.StreamState sample."""

    sequence: int
    stampS: float  # [s], daemon monotonic clock
    statusId: int  # Spec A state (0x010..0x015)
    statusMessage: str
    joints: list[UnitJointPositions]
    controlPoints: list[ControlPointPose]
    alarms: list[Alarm]
    loop: LoopStats
    wallTimeS: float  # [s] since the Unix epoch, daemon clock
    motion: MotionStatus


#: Proto message name -> Python struct type (HgMatrix is a numpy array, not listed).
MESSAGE_TYPES: dict[str, Any] = {
    cls.__name__: cls
    for cls in (
        CartesianSpeed,
        CartesianAccel,
        CarPosWithElbow,
        LimitValue,
        RedundantPos,
        RedundantSpeed,
        RedundantAccel,
        RedundantAxesMask,
        RedundantLimit,
        Alarm,
        ManipInfo,
        UnitJointPositions,
        ControlPointPose,
        LatencyStats,
        LoopStats,
        MotionStatus,
        StateSample,
    )
}

"""imotion's alarm table (Spec A ``Alarm``; codes 0x1-0x5 are the specification's own).

Codes from 0x400 are imotion's. Hardware backends raise the 0x400-0x40F range; the motion
core raises the 0x410 range. Every alarm stops motion; ``clearAlarms`` + ``servoOn``
recovers once the cause is gone.
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass, field


class AlarmType(enum.IntEnum):
    FAULT = 0
    WARNING = 1
    UNKNOWN = 2


class AlarmCode(enum.IntEnum):
    EMERGENCY_STOP = 0x1
    OVERLOAD = 0x2
    OVERSPEED = 0x3
    JOINT_SOFT_LIMIT = 0x4
    CARTESIAN_SOFT_LIMIT = 0x5
    # --- hardware layer (0x400-0x40F) ---
    DRIVE_FAULT = 0x400  #: a drive reports a fault (CiA 402 state Fault)
    HEARTBEAT_LOST = 0x401  #: no heartbeat from a drive within its consumer time
    BUS_OFF = 0x402  #: CAN controller bus-off
    FOLLOWING_ERROR = 0x403  #: actual position too far from the set-point
    EMCY = 0x404  #: an emergency (EMCY) message from a drive
    TPDO_TIMEOUT = 0x405  #: feedback (TPDO) missing or stale
    BUS_ERROR = 0x406  #: a frame could not be sent
    ENABLE_REFUSED = 0x407  #: a drive did not reach Operation enabled
    BUS_OVERLOAD = 0x408  #: planned bus load above 100 %
    HARDWARE_INVALID_COMMAND = 0x40F  #: non-finite set-point, or the simulation diverged
    # --- motion core (0x410-0x41F) ---
    QP_FAILURE = 0x410  #: the whole-body QP was infeasible or not solved
    LOOP_OVERRUN = 0x411  #: control cycles missed their deadline
    TRAJECTORY_FAILURE = 0x412  #: the time law could not be computed
    MOTION_INCOMPLETE = 0x413  #: (warning) a motion ended off its target or not at rest
    MOTION_BLOCKED = 0x414  #: (warning) collision rows held a motion back: stopped on its path


@dataclass(frozen=True)
class Alarm:
    code: int
    type: AlarmType
    description: str
    #: Which part raised it (Spec A ``moduleName``): a joint, a bus, "qp", "loop", ...
    module: str
    stamp: float = field(default_factory=time.time)

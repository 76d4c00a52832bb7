"""Every emulated drive's hot values in two NumPy rows: the state a SYNC round reads and writes.

A drive (:class:`hal.emulator.drive.EmulatedDrive`) and its power state machine
(:class:`hal.emulator.drive_state.DriveStateMachine`) keep the values a SYNC round touches
(power state, controlword, target, actual position, following-error supervision, PDO
configuration, ...) in one row of a :class:`DriveBank`: an int64 row (:data:`INT_COLUMNS`)
and a float64 row (:data:`FLOAT_COLUMNS`). Python code reads and writes them as plain
attributes through the descriptors below (:class:`IntField`, :class:`BoolField`, ...), so
the per-drive Python code is unchanged; the compiled SYNC round (:mod:`hal.emulator.kernels`)
works on the whole bank at once, for every drive of a bus in one call. One source of truth:
nothing is copied between the two.

A drive built alone (tests) gets a bank of its own (:func:`own_row`).
"""

from __future__ import annotations

import math
from typing import Any, Generic, TypeVar

import numpy as np

#: Columns of the int64 row (names of the attributes they back, where there is one).
INT_COLUMNS = (
    "state",  # DriveStateMachine.state (PowerState pattern)
    "warning",  # DriveStateMachine.warning
    "following_error",  # DriveStateMachine.following_error
    "sm_controlword",  # DriveStateMachine._controlword (the fault reset edge)
    "quick_stop_option",  # DriveStateMachine.quick_stop_option
    "refuse_enable",  # DriveStateMachine.refuse_enable
    "last_state",  # EmulatedDrive._last_state
    "controlword",  # EmulatedDrive._controlword (0x6040 as read)
    "target",  # 0x607A [counts]
    "actual",  # 0x6064 [counts], wrapped to 32 bits
    "velocity",  # 0x606C [counts/s]
    "hold",  # position held by a quick stop / fault reaction [counts]
    "syncs",  # SYNCs seen
    "reaction_cycles",  # samples taken in a fault reaction / quick stop
    "nmt_state",
    "silent",  # fault injection: the node neither receives nor sends
    "tpdo_delay",  # fault injection: TPDOs leave this many SYNCs late
    "delayed",  # TPDOs waiting in the delay queue
    "fe_window",  # 0x6065 [counts]
    "waiting",  # RPDOs other than the CSP one received since the last SYNC
    "rx_fresh",  # the CSP RPDO (controlword + target) was received since the last SYNC
    "rx_order",  # ... after this many others (its place in the order of arrival)
    "rx_controlword",  # ... its controlword
    "rx_target",  # ... its target [counts]
    "csp_rpdo",  # index of the RPDO mapped controlword + target (-1: none)
    "fast",  # the PDO configuration is one the compiled round handles (kernels)
    "tpdos",  # enabled TPDOs (at most 4), each kind / COB-ID / transmission type below
    "tpdo_kind0",
    "tpdo_kind1",
    "tpdo_kind2",
    "tpdo_kind3",
    "tpdo_cob0",
    "tpdo_cob1",
    "tpdo_cob2",
    "tpdo_cob3",
    "tpdo_type0",
    "tpdo_type1",
    "tpdo_type2",
    "tpdo_type3",
)
#: Columns of the float64 row.
FLOAT_COLUMNS = (
    "fe_time",  # 0x6066 [s]
    "outside_since",  # simulated time the following error left its window [s] (NaN: inside)
)
#: Column of each name in the int64 and the float64 rows.
INT = {name: k for k, name in enumerate(INT_COLUMNS)}
FLOAT = {name: k for k, name in enumerate(FLOAT_COLUMNS)}
#: TPDO kinds the compiled round encodes: statusword + position ``<Hi``, velocity ``<i``.
TPDO_STATUS_POSITION, TPDO_VELOCITY = 1, 2

T = TypeVar("T")


class DriveBank:
    """The rows of ``n`` drives (module doc); row ``k`` is the drive of plant index ``k``."""

    def __init__(self, n: int):
        self.ints = np.zeros((n, len(INT_COLUMNS)), dtype=np.int64)
        self.floats = np.zeros((n, len(FLOAT_COLUMNS)), dtype=np.float64)
        self.floats[:, FLOAT["outside_since"]] = math.nan
        self.ints[:, INT["csp_rpdo"]] = -1

    def rows(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Drive ``k``'s int and float rows (views)."""
        return self.ints[k], self.floats[k]


def own_row() -> tuple[np.ndarray, np.ndarray]:
    """The rows of a drive not in an emulator's bank (a bank of one)."""
    return DriveBank(1).rows(0)


class _Field(Generic[T]):
    """An attribute kept in column ``name`` of the owner's ``_ints`` (or ``_floats``) row."""

    def __init__(self, name: str):
        self.column = INT[name] if name in INT else FLOAT[name]

    def __set_name__(self, owner: type, attribute: str) -> None:
        self.attribute = attribute


class IntField(_Field[int]):
    def __get__(self, obj: Any, owner: type | None = None) -> int:
        return int(obj._ints[self.column])

    def __set__(self, obj: Any, value: int) -> None:
        obj._ints[self.column] = value


class BoolField(_Field[bool]):
    def __get__(self, obj: Any, owner: type | None = None) -> bool:
        return bool(obj._ints[self.column])

    def __set__(self, obj: Any, value: bool) -> None:
        obj._ints[self.column] = bool(value)


class FloatField(_Field[float]):
    def __get__(self, obj: Any, owner: type | None = None) -> float:
        return float(obj._floats[self.column])

    def __set__(self, obj: Any, value: float) -> None:
        obj._floats[self.column] = value


class OptionalFloatField(_Field["float | None"]):
    """A float that may be None (stored as NaN)."""

    def __get__(self, obj: Any, owner: type | None = None) -> float | None:
        value = float(obj._floats[self.column])
        return None if math.isnan(value) else value

    def __set__(self, obj: Any, value: float | None) -> None:
        obj._floats[self.column] = math.nan if value is None else value

"""One bound per quantity at the API edge, the same on every interface (units: mm, deg, s).

Every numeric argument of every request is checked against its quantity's bound before
anything is planned or moved (:mod:`controller.gateway.grpc.validation` walks each request):
NaN, ±inf and magnitudes beyond the bound are VALUE_ERR with a short comment. These bounds are
plausibility limits, far beyond any robot imotion drives, that keep absurd numbers out of
the planner (a 1e12 mm target used to allocate a path of 1e11 samples). The robot's own
limits (joint ranges, hardware speeds, arm reach, vehicle workspace) are checked afterwards,
still before anything moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from controller.errors import ArgumentError

#: Longest motion one request may ask for [s]: speeds so slow that a motion would take longer
#: are refused (VALUE_ERR), and so are durations beyond it. It also bounds the planning work
#: of a request (a CP-hold dry run simulates at most this long).
MAX_MOTION_TIME = 600.0


@dataclass(frozen=True)
class Quantity:
    """A physical quantity at the API edge: its unit there and the largest magnitude."""

    name: str
    unit: str  #: the interfaces' unit ("" for plain numbers)
    limit: float  #: largest accepted |value|, in ``unit``
    reason: str  #: why this bound (said in the comment of a refusal)


LENGTH = Quantity("length", "mm", 100_000.0, "100 m, beyond every arm reach and vehicle workspace")
ANGLE = Quantity("angle", "deg", 3_600.0, "ten turns, beyond every joint, elbow and heading")
LINEAR_SPEED = Quantity("linear speed", "mm/s", 10_000.0, "10 m/s, beyond every drive")
ANGULAR_SPEED = Quantity("angular speed", "deg/s", 3_600.0, "ten turns per second")
LINEAR_ACCEL = Quantity("linear acceleration", "mm/s²", 100_000.0, "10 g")
ANGULAR_ACCEL = Quantity("angular acceleration", "deg/s²", 36_000.0, "100 turns per s²")
TIME = Quantity("time", "s", MAX_MOTION_TIME, "the longest motion one request may ask for")
ACCEL_TIME = Quantity("acceleration time", "s", 10.0, "no drive needs longer to reach speed")
ROTATION_ENTRY = Quantity("rotation entry", "", 1.0 + 1e-3, "an entry of a rotation matrix")
#: Any other number (a field the table does not know yet): finite and not absurd.
NUMBER = Quantity("number", "", 100_000.0, "no field of the interfaces needs more")

#: Largest distance of a control point from its flange [mm] (a tool longer than that is a
#: typing error, not a tool); setControlPointOffset on every interface.
MAX_TOOL_OFFSET_MM = 2_000.0
#: Most values in any repeated field of a request (more than any robot's joints).
MAX_REPEATED = 64


def show(value: float) -> str:
    """A number for a comment: short even when huge (``1e+300``, never 300 digits)."""
    return f"{value:.6g}"


def bounded(value: float, quantity: Quantity, name: str) -> float:
    """``value`` if finite and within ``quantity``'s bound, else ArgumentError naming ``name``."""
    if not math.isfinite(value):
        raise ArgumentError(f"{name}: {value} is not a finite number")
    if abs(value) > quantity.limit:
        unit = f" {quantity.unit}" if quantity.unit else ""
        raise ArgumentError(
            f"{name}: {show(value)}{unit} is out of range (|{quantity.name}| <= "
            f"{show(quantity.limit)}{unit}: {quantity.reason})"
        )
    return float(value)


def motion_time(distance: float, speed: float, accel: float) -> float:
    """Time [s] a trapezoidal profile needs for ``distance`` at ``speed`` and ``accel`` (any
    consistent units; ``speed`` and ``accel`` > 0)."""
    distance = abs(distance)
    if distance == 0.0:
        return 0.0
    if distance > speed * speed / accel:
        return distance / speed + speed / accel
    return 2.0 * math.sqrt(distance / accel)


def require_duration(distance: float, speed: float, accel: float, name: str, unit: str) -> None:
    """Refuse (VALUE_ERR) a motion that would take longer than :data:`MAX_MOTION_TIME`.

    ``distance`` [unit], ``speed`` [unit/s], ``accel`` [unit/s²] in the interface's units,
    so the comment speaks them.
    """
    t = motion_time(distance, speed, accel)
    if t > MAX_MOTION_TIME:
        raise ArgumentError(
            f"{name}: {show(abs(distance))} {unit} at {show(speed)} {unit}/s and "
            f"{show(accel)} {unit}/s² would take {show(t)} s, longer than the longest motion "
            f"({MAX_MOTION_TIME:g} s): too slow"
        )

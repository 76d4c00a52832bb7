"""Drive counts <-> SI joint values: the one place this conversion lives (master and emulator).

A drive reports and takes positions in encoder [counts] of its motor (0x6064, 0x607A) and
velocities in [counts/s] (0x606C). With

* ``per_unit``: counts per motor revolution (revolute) or per metre of motor-side travel
  (prismatic),
* ``gear``: motor revolutions (metres) per joint revolution (metre),
* ``sign``: +1 or -1, the joint's positive direction as seen by the motor,
* ``offset``: the raw count at joint zero [counts],

the conversion is::

    si     = sign · (counts − offset) / (per_unit · gear) · unit     unit = 2π [rad] or 1 [m]
    counts = round(offset + sign · si · per_unit · gear / unit)

Positions on the wire are signed 32-bit and wrap (a wheel turning for long enough overflows):
:func:`wrap_i32` folds any integer into that range and :func:`delta_i32` is the difference
of two wrapped readings, for odometry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

I32_MIN = -(2**31)
I32_MAX = 2**31 - 1
_I32_SPAN = 2**32


def wrap_i32(value: int) -> int:
    """``value`` folded into the signed 32-bit range (two's complement wrap)."""
    return (int(value) - I32_MIN) % _I32_SPAN + I32_MIN


def delta_i32(new: int, old: int) -> int:
    """``new − old`` for two wrapped 32-bit readings, assuming |change| < 2³¹ [counts]."""
    return wrap_i32(int(new) - int(old))


@dataclass(frozen=True)
class Scaling:
    """Counts <-> SI conversion of one drive (see the module doc)."""

    #: Counts per motor revolution (revolute) or per motor-side metre (prismatic).
    per_unit: float
    #: Motor revolutions (or metres) per joint revolution (or metre).
    gear: float = 1.0
    #: +1 or -1.
    sign: int = 1
    #: Raw position at joint zero [counts].
    offset: int = 0
    #: True for a revolute joint (SI unit [rad]), False for a prismatic one ([m]).
    revolute: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.per_unit) and self.per_unit > 0):
            raise ValueError(f"counts per unit must be a positive number, got {self.per_unit!r}")
        if not (math.isfinite(self.gear) and self.gear > 0):
            raise ValueError(f"gear ratio must be a positive number, got {self.gear!r}")
        if self.sign not in (1, -1):
            raise ValueError(f"sign must be 1 or -1, got {self.sign!r}")

    @property
    def counts_per_si(self) -> float:
        """Counts per [rad] or per [m] of the joint, sign included."""
        unit = 2.0 * math.pi if self.revolute else 1.0
        return self.sign * self.per_unit * self.gear / unit

    def to_si(self, counts: int) -> float:
        """Position [counts] -> [rad] or [m]."""
        return (int(counts) - self.offset) / self.counts_per_si

    def velocity_to_si(self, counts_per_s: float) -> float:
        """Velocity [counts/s] -> [rad/s] or [m/s]."""
        return float(counts_per_s) / self.counts_per_si

    def to_counts(self, si: float) -> int:
        """Position [rad] or [m] -> [counts], rounded and wrapped to 32 bits."""
        return wrap_i32(round(self.offset + si * self.counts_per_si))

    def velocity_to_counts(self, si: float) -> int:
        """Velocity [rad/s] or [m/s] -> [counts/s], rounded and clamped to 32 bits."""
        return min(max(round(si * self.counts_per_si), I32_MIN), I32_MAX)

    def window_to_counts(self, si: float) -> int:
        """A tolerance [rad] or [m] -> unsigned [counts] (e.g. following error window)."""
        return min(round(abs(si * self.counts_per_si)), 2**32 - 1)


class ScalingArray:
    """Vectorised :class:`Scaling` for many drives (the per-cycle path)."""

    def __init__(self, scalings: list[Scaling]):
        self.factor = np.array([s.counts_per_si for s in scalings], dtype=float)
        self.offset = np.array([s.offset for s in scalings], dtype=float)

    def to_si(self, counts: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Positions [counts] -> [rad]/[m] (``out`` reused when given)."""
        out = np.subtract(counts, self.offset, out=out)
        return np.divide(out, self.factor, out=out)

    def velocity_to_si(self, counts_per_s: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Velocities [counts/s] -> [rad/s]/[m/s]."""
        return np.divide(counts_per_s, self.factor, out=out)

    def to_counts(self, si: np.ndarray) -> np.ndarray:
        """Positions [rad]/[m] -> [counts] as int64, *not yet* wrapped to 32 bits."""
        return np.rint(si * self.factor + self.offset).astype(np.int64)

"""CORBA values to the services' spec units and back, with the bounds of every number.

The services speak mm, deg, s and % (:mod:`controller.gateway.services`). An interface
family configured for SI (``corba.units``: m, rad, m/s, rad/s) is converted here, through
:mod:`controller.conversions`, before anything else; then every number is checked against
its quantity's bound (:mod:`controller.bounds`, the same bounds the gRPC bounds walk uses),
so NaN, ±inf and absurd magnitudes are VALUE_ERR naming the argument before a service
sees them. Sequence lengths beyond :data:`~controller.bounds.MAX_REPEATED` likewise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from controller.bounds import (
    ANGLE,
    ANGULAR_SPEED,
    LENGTH,
    LINEAR_SPEED,
    MAX_REPEATED,
    ROTATION_ENTRY,
    Quantity,
    bounded,
    show,
)
from controller.conversions import deg_to_rad, m_to_mm, mm_to_m, rad_to_deg
from controller.errors import ArgumentError


class Units:
    """Wire units of one interface family: ``si`` (m, rad) or not (mm, deg)."""

    def __init__(self, si: bool):
        self.si = si

    # ------------------------------------------------------------------ in (wire → spec)
    def scalar_in(self, value: float, quantity: Quantity, name: str) -> float:
        """One number in the spec unit of ``quantity`` (mm or deg based), bounded."""
        x = float(value)
        if self.si and quantity.unit.startswith(("mm", "deg")) and math.isfinite(x):
            with np.errstate(over="ignore"):
                x = float(m_to_mm(x) if quantity.unit.startswith("mm") else rad_to_deg(x))
            if not math.isfinite(x):
                raise ArgumentError(f"{name}: {show(float(value))} is out of range (SI units)")
        return bounded(x, quantity, name)

    def seq_in(self, values: Sequence[float], quantity: Quantity, name: str) -> list[float]:
        vals = list(values)
        if len(vals) > MAX_REPEATED:
            raise ArgumentError(f"{name}: {len(vals)} values is too many (at most {MAX_REPEATED})")
        return [self.scalar_in(v, quantity, f"{name}[{i}]") for i, v in enumerate(vals)]

    def hg_in(self, matrix: Sequence[Sequence[float]], name: str) -> list[float]:
        """An HgMatrix (3 x 4 nested) as 12 row-major numbers, position in [mm]."""
        rows = [list(r) for r in matrix]
        if len(rows) != 3 or any(len(r) != 4 for r in rows):
            raise ArgumentError(f"{name}: expected 3 x 4 numbers ([R | p], row-major)")
        out = []
        for i, row in enumerate(rows):
            for j, v in enumerate(row):
                q = LENGTH if j == 3 else ROTATION_ENTRY
                shown = f"{name}[{i}][{j}]"
                out.append(self.scalar_in(v, q, shown) if j == 3 else bounded(float(v), q, shown))
        return out

    def limits_in(
        self, limits: Sequence[Any], quantity: Quantity, name: str
    ) -> list[tuple[float, float]]:
        """LimitValue structs as (lower, upper) in spec units."""
        if len(limits) > MAX_REPEATED:
            raise ArgumentError(
                f"{name}: {len(limits)} values is too many (at most {MAX_REPEATED})"
            )
        return [self.limit_in(lv, quantity, f"{name}[{i}]") for i, lv in enumerate(limits)]

    def limit_in(self, lv: Any, quantity: Quantity, name: str) -> tuple[float, float]:
        return (
            self.scalar_in(lv.lower, quantity, f"{name}.lower"),
            self.scalar_in(lv.upper, quantity, f"{name}.upper"),
        )

    # ------------------------------------------------------------------ out (spec → wire)
    def length_out(self, value: float) -> float:
        return float(mm_to_m(value)) if self.si else float(value)

    def angle_out(self, value: float) -> float:
        return float(deg_to_rad(value)) if self.si else float(value)

    def angles_out(self, values: Sequence[float]) -> list[float]:
        return [self.angle_out(v) for v in values]

    def hg_out(self, hg_mm: Any) -> list[list[float]]:
        m = np.asarray(hg_mm, dtype=float).reshape(3, 4)
        return [[float(v) for v in m[i, :3]] + [self.length_out(m[i, 3])] for i in range(3)]


#: Quantities of the arguments, named as the interfaces do (see controller.bounds).
JOINT = ANGLE
JOINT_SPEED = ANGULAR_SPEED
CART_SPEED = (LINEAR_SPEED, ANGULAR_SPEED)

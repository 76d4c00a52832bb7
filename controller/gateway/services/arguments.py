"""Argument checks of the services (spec units; the comments name the argument as the
interfaces do, e.g. ``abs_pos[2]``). Every transport gets the same checks by calling the
services; the gRPC layer re-exports these for its message-level checks."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from controller.errors import ArgumentError
from controller.gateway.planning.robot_view import RobotView
from controller.vocabulary import RightLeft, UnitType


def finite_arg(value: float, name: str) -> float:
    """``value`` as a float; ArgumentError for NaN or ±inf."""
    if not math.isfinite(value):
        raise ArgumentError(f"{name}: {value} is not a finite number")
    return float(value)


def positive_arg(value: float, name: str, unit: str = "") -> float:
    """A finite ``value`` > 0 (``unit`` only for the comment)."""
    finite_arg(value, name)
    if value <= 0.0:
        raise ArgumentError(f"{name}: must be > 0{' ' + unit if unit else ''}, got {value:g}")
    return float(value)


def finite_values(values: Iterable[float], name: str) -> np.ndarray:
    """Every element finite (the comment names the first bad one as ``name[i]``)."""
    arr = np.array([float(v) for v in values], dtype=float)
    for i, v in enumerate(arr):
        finite_arg(float(v), f"{name}[{i}]")
    return arr


def side_arg(view: RobotView, value: int, name: str = "type") -> RightLeft:
    try:
        side = RightLeft(value)
    except ValueError:
        raise ArgumentError(f"{name}: {value} is not RIGHT (0) or LEFT (1)") from None
    if side not in view.arms:
        have = ", ".join(s.name for s in view.arms)
        raise ArgumentError(f"{name}: this robot has no {side.name} arm (it has {have})")
    return side


def unit_arg(view: RobotView, value: int, name: str = "unit") -> UnitType:
    names = ("RIGHT_ARM", "LEFT_ARM", "LUMBER", "VEHICLE")
    if not 0 <= value < len(names):
        raise ArgumentError(f"{name}: {value} is not a UnitType (0..3)")
    unit = UnitType[names[value]]
    if not view.has_unit(unit):
        raise ArgumentError(f"{name}: this robot has no {unit.name} unit")
    return unit


def ratio_arg(value: int, name: str) -> float:
    """A % ratio 0..100 as a fraction 0..1."""
    if not 0 <= value <= 100:
        raise ArgumentError(f"{name}: {value} % is outside 0..100 %")
    return value / 100.0


def require_gripper(view: RobotView, side: RightLeft, name: str = "type") -> None:
    if side.name not in view.robot.profile.grippers:
        raise ArgumentError(f"{name}: the {side.name} arm has no gripper")

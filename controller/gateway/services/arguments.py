"""Argument checks of the services (spec units; the comments name the argument as the
interfaces do, e.g. ``abs_pos[2]``). Every transport gets the same checks by calling the
services; the gRPC layer re-exports these for its message-level checks."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from controller.errors import ArgumentError


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

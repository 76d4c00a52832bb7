"""Redundant-axis ranges: the waist's reachable range per lumbar axis and the SI range of a
selectRedundantAxes limit."""

from __future__ import annotations

import math

from controller.errors import ArgumentError
from controller.gateway.planning.limits import require_range_in_workspace
from controller.model.redundant_axes import RedundantAxis
from controller.model.robot import Robot

Range = tuple[float, float]


def lumbar_range(robot: Robot, axis: RedundantAxis) -> Range:
    """Range [rad] a lumbar axis covers with its joints' limits (its weighted joints)."""
    weights = robot.profile.redundant_axes.lumbar[axis.lumbar.value]
    lo = hi = 0.0
    for joint, w in weights.items():
        spec = robot.joints[joint]
        a, b = w * spec.lower, w * spec.upper
        lo += min(a, b)
        hi += max(a, b)
    return lo, hi


def axis_range(robot: Robot, axis: RedundantAxis, lower: float, upper: float, name: str) -> Range:
    """A selectRedundantAxes range (SI: [m] for vehicle x/y, [rad] otherwise), checked:
    elbows within -180..180 deg, lumbar axes within the waist's range, vehicle axes within
    the vehicle workspace."""
    if upper < lower:
        raise ArgumentError(
            f"{name}: upper {_show(axis, upper)} is below lower {_show(axis, lower)}"
        )
    if axis.is_elbow:
        if lower < -math.pi - 1e-9 or upper > math.pi + 1e-9:
            raise ArgumentError(f"{name}: elbow ranges lie within -180..180 deg")
    elif axis.is_vehicle:
        require_range_in_workspace(robot, axis.vehicle_index, lower, upper, name)
    elif axis.is_lumbar:
        hw_lo, hw_hi = lumbar_range(robot, axis)
        if lower < hw_lo - 1e-9 or upper > hw_hi + 1e-9:
            raise ArgumentError(
                f"{name}: {math.degrees(lower):g}..{math.degrees(upper):g} deg is wider than the "
                f"waist allows ({math.degrees(hw_lo):.1f}..{math.degrees(hw_hi):.1f} deg)"
            )
    return lower, upper


def _show(axis: RedundantAxis, value: float) -> str:
    if axis in (RedundantAxis.VEHICLE_X, RedundantAxis.VEHICLE_Y):
        return f"{1e3 * value:g}"
    return f"{math.degrees(value):g}"

"""Relative targets: poses and elbow angles given relative to where the robot is (or will be
once the queued motions end). SI: [m], [rad].

Elbow angles (ruling, issue 16.11): the elbow angle is a direction (the angle of the elbow
plane about the shoulder-wrist line, reported within -180..180 deg). An absolute target is
taken modulo one turn and reached the short way round; it must lie within -360..360 deg (so
"the reported angle plus a few degrees" is always valid). A relative change is executed as
given, so it must lie within -180..180 deg (a larger one would go round the other way).
Outside these ranges: VALUE_ERR.
"""

from __future__ import annotations

import math

import pinocchio as pin

from controller.errors import ArgumentError

#: Largest absolute elbow target and largest elbow change [rad] (see the module docstring).
ELBOW_ABS_RANGE = 2.0 * math.pi
ELBOW_REL_RANGE = math.pi
_EPS = 1e-9


def relative_pose(current: pin.SE3, rel: pin.SE3, tool_frame: bool) -> pin.SE3:
    """Target of a relative move: in the control-point frame (TOOL) or in the original
    frame (BASE: translation added, rotation applied about the original axes)."""
    if tool_frame:
        return current * rel
    return pin.SE3(rel.rotation @ current.rotation, current.translation + rel.translation)


def elbow_goal(current: float, value: float, relative: bool, name: str) -> float:
    """Elbow target [rad] from an absolute angle or a relative change ``value`` [rad] (see
    the module docstring); ArgumentError outside the ruled ranges. An absolute target comes
    back as given (the elbow task wraps its error: the short way round); a relative one as
    ``current + value``."""
    limit = ELBOW_REL_RANGE if relative else ELBOW_ABS_RANGE
    if not -limit - _EPS <= value <= limit + _EPS:
        what = "an elbow change" if relative else "an elbow angle"
        span = "-180..180" if relative else "-360..360"
        raise ArgumentError(
            f"{name}: {math.degrees(value):.6g} deg is outside {span} deg ({what}; the elbow "
            "angle is a direction)"
        )
    return current + value if relative else value

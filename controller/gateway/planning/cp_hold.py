"""moveCPHold planning: redundant axes (elbow, waist, vehicle) to new targets while the
control point(s) stay where they are.

SI in (one :class:`AxisRequest` per axis the robot has): value [rad, m], speed, accel. Out:
a :class:`CPHoldPlan` (a checked spec, or none when nothing has to move, and the comment of
the answer), or ArgumentError / Refused(CANNOT_REACH_TARGET_ERR).

Rules: axes without a new target stay put (their joints are frozen; the vehicle's three axes
go together); the body moving under both hands holds both; a dry run with the daemon's own
IK refuses a target the held hand(s) cannot follow. Elbow values follow the ruling of
:mod:`controller.gateway.planning.relative`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from controller.bounds import require_duration
from controller.contract.motion_specs import CPHoldSpec
from controller.contract.snapshot import Snapshot
from controller.errors import ArgumentError, Refused
from controller.gateway.planning.limits import require_in_workspace
from controller.gateway.planning.planner import Planner
from controller.gateway.planning.redundancy import lumbar_range
from controller.gateway.planning.relative import elbow_goal
from controller.model.redundant_axes import RedundantAxis, available_axes, axis_value, elbow_axis
from controller.motion.motions import other_side
from controller.vocabulary import ReturnCode, RightLeft

#: A change smaller than this [rad or m] is no change.
STILL = 1e-9


@dataclass(frozen=True)
class AxisRequest:
    """One axis of a CP-hold request (SI) and the field names the comments use."""

    value: float  #: absolute target or relative change [rad, m]
    speed: float  #: [rad/s, m/s]
    accel: float  #: [rad/s², m/s²]
    field: str  #: e.g. "elbow", "vehicle_x"
    rate_field: str  #: the speed/accel field, e.g. "elbow", "vehicle_translation"


@dataclass
class CPHoldPlan:
    spec: CPHoldSpec | None  #: None: every axis already at its target
    q0: np.ndarray  #: configuration it starts from
    comment: str | None = None  #: the answer's comment (None: plain OK)


def _rate_unit(req: AxisRequest, accel: bool) -> tuple[float, str]:
    linear = req.rate_field == "vehicle_translation"
    scale = 1e3 if linear else 180.0 / math.pi
    unit = "mm/s" if linear else "deg/s"
    return scale, unit + ("²" if accel else "")


def _positive(req: AxisRequest, value: float, accel: bool) -> None:
    if value > 0.0:
        return
    scale, unit = _rate_unit(req, accel)
    kind = "accel" if accel else "speed"
    raise ArgumentError(f"{kind}.{req.rate_field}: must be > 0 {unit}, got {value * scale:g}")


def plan_cp_hold(
    planner: Planner,
    snap: Snapshot,
    side: RightLeft,
    axes: dict[RedundantAxis, AxisRequest],
    relative: bool,
    pos_name: str,
    absent: tuple[str, ...] = (),
) -> CPHoldPlan:
    """Plan a CP-hold move of ``side``'s control point (see the module docstring).

    ``absent``: fields the request set for axes this robot does not have (ignored; the
    comment says so)."""
    q0 = planner.base_q(snap, queued=False)
    targets: dict[RedundantAxis, float] = {}
    speeds: list[float] = []
    accels: list[float] = []
    moved: set[RedundantAxis] = set()  # axes the request actually changes
    with planner.view.at(snap, q0) as kin:
        for axis, req in axes.items():
            current = axis_value(kin, axis)
            if axis.is_elbow:
                goal = elbow_goal(current, req.value, relative, f"{pos_name}.{req.field}")
                delta = math.remainder(goal - current, math.tau)
            else:
                goal = current + req.value if relative else req.value
                delta = goal - current
            moving = abs(delta) > STILL
            if moving:
                _positive(req, req.speed, accel=False)
                _positive(req, req.accel, accel=True)
                scale, unit = _rate_unit(req, accel=False)
                distance = unit.removesuffix("/s")
                v, a = scale * req.speed, scale * req.accel
                require_duration(scale * delta, v, a, f"speed.{req.rate_field}", distance)
                if axis.is_vehicle:
                    name = f"{pos_name}.{req.field}"
                    require_in_workspace(planner.view.robot, axis.vehicle_index, goal, name)
            elif not axis.is_vehicle:
                continue  # not moving: held (its joints are frozen)
            if moving:
                moved.add(axis)
            if axis.is_lumbar:
                lo, hi = lumbar_range(planner.view.robot, axis)
                if not lo - STILL <= goal <= hi + STILL:
                    raise ArgumentError(
                        f"{pos_name}.{req.field}: {math.degrees(goal):.2f} deg is outside the "
                        f"waist's range {math.degrees(lo):.1f}..{math.degrees(hi):.1f} deg"
                    )
            targets[axis] = goal
            speeds.append(req.speed if req.speed > 0 else 1.0)
            accels.append(req.accel if req.accel > 0 else 1.0)
    if not any(a.is_vehicle for a in moved):  # the vehicle's three axes go together: hold them all
        keep = [k for k, a in enumerate(targets) if not a.is_vehicle]
        targets = {a: g for a, g in targets.items() if not a.is_vehicle}
        speeds = [speeds[k] for k in keep]
        accels = [accels[k] for k in keep]
    note = f"this robot has no {', '.join(absent)}: ignored" if absent else None
    if not targets:
        text = "every redundant axis is already at its target"
        return CPHoldPlan(None, q0, f"OK ({note}; {text})" if note else f"OK ({text})")
    held: tuple[RightLeft, ...] = (side,)
    other = other_side(side)
    body_moves = any(a.is_lumbar or a.is_vehicle for a in targets)
    if body_moves and other in planner.view.arms and elbow_axis(other) not in targets:
        held = (side, other)  # the body moves under both hands: hold both
    spec = planner.cp_hold(
        q0, held, targets, np.array(speeds), np.array(accels), label="CP-hold move"
    )
    reason = planner.dry_run(snap, q0, spec, commanded=moved)
    notes = [note] if note else []
    kin_axes = available_axes(planner.view.kin)
    held_elbows = [elbow_axis(s) for s in held if elbow_axis(s) in kin_axes]
    if reason is not None and held_elbows and not any(a in targets for a in held_elbows):
        # Axes without a target stay put, unless a held hand cannot follow the body with its
        # elbow held: then the elbow moves, and the answer says so (issue 16.4).
        spec.free_elbows = True
        if planner.dry_run(snap, q0, spec, commanded=moved) is None:
            names = ", ".join(a.value for a in held_elbows)
            notes.append(
                f"{names} left free to keep the held hand(s): with the elbow held, {reason}"
            )
            reason = None
    if reason is not None:
        raise Refused(ReturnCode.CANNOT_REACH_TARGET_ERR, reason)
    return CPHoldPlan(spec, q0, f"OK ({'; '.join(notes)})" if notes else None)

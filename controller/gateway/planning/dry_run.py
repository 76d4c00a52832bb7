"""Dry runs: a motion run on a planning copy of the kinematics with perfect drives at a coarse
step, with the daemon's own IK, to see whether it arrives (axis targets reached, held control
points kept). For motions whose reachability a path check cannot see (CP-hold: the body moves
under a held hand). A refusal names the commanded axis that stopped short and the joints that
ended at a limit (issue 16.9). A CP-hold motion longer than :data:`DRY_RUN_MAX_TIME` is run
faster (speeds × k, accelerations × k²: the same path in less time), so the planning time of
a request does not grow with the duration it asks for (issue 16.12).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from controller.bounds import MAX_MOTION_TIME, motion_time
from controller.contract.motion_specs import CPHoldSpec, MotionSpec
from controller.gateway.planning.clearance import ClearanceCheck
from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, axis_value
from controller.qp.ik import WholeBodyIK
from controller.qp.tasks import AxisTask, ControlPointTask, Task

#: Step of a dry run [s].
DRY_RUN_DT = 0.02
#: Longest motion a dry run simulates [s] (slower CP-hold motions are run faster).
DRY_RUN_MAX_TIME = 60.0
#: Arrival tolerances of a dry run: axis [m or rad], held control point [m].
AXIS_TOL = (0.005, math.radians(0.5))
HOLD_TOL = 0.002
#: A joint this close to a limit [rad or m] is "at its limit" in a refusal.
LIMIT_TOL = 1e-3


def arrival_problem(
    kin: Kinematics,
    tasks: list[Task],
    commanded: set[RedundantAxis] | None = None,
    at_limit: list[str] | None = None,
) -> str | None:
    """Why a dry run did not arrive (None: it did). Commanded axes are named first, then held
    control points, then axes only held along (the vehicle's other axes); the reason names
    the joints that ended at a limit."""
    binding = (
        f"joints at their limits: {', '.join(at_limit)}"
        if at_limit
        else "the arm's reach (no joint at a limit)"
    )
    axis_tasks: list[AxisTask] = [t for t in tasks if isinstance(t, AxisTask)]
    if commanded is not None:
        axis_tasks.sort(key=lambda t: t.axis not in commanded)
    held_axes: list[str] = []
    for axis_task in axis_tasks:
        err = abs(axis_task.error(kin))
        linear = axis_task.axis in (RedundantAxis.VEHICLE_X, RedundantAxis.VEHICLE_Y)
        if err <= (AXIS_TOL[0] if linear else AXIS_TOL[1]):
            continue
        shown = f"{1e3 * err:.0f} mm" if linear else f"{math.degrees(err):.1f} deg"
        if commanded is not None and axis_task.axis not in commanded:
            held_axes.append(f"{axis_task.axis.value} {shown}")
            continue
        return (
            f"in a dry run {axis_task.axis.value} stopped {shown} short of its target: the "
            f"held control point(s) cannot follow that far ({binding})"
        )
    for task in tasks:
        if isinstance(task, ControlPointTask):
            err = float(np.linalg.norm(task.error(kin)[:3]))
            if err > HOLD_TOL:
                return (
                    f"in a dry run the {task.side.name} control point moved {1e3 * err:.1f} mm "
                    f"while held: the arm cannot keep it there ({binding})"
                )
    if held_axes:
        return (
            f"in a dry run the axes held along drifted ({', '.join(held_axes)}) while the "
            f"held control point(s) followed ({binding})"
        )
    return None


def dry_run(
    kin: Kinematics,
    ik: WholeBodyIK,
    spec: MotionSpec,
    q0: np.ndarray,
    max_time: float = MAX_MOTION_TIME,
    commanded: set[RedundantAxis] | None = None,
    clearance: ClearanceCheck | None = None,
) -> str | None:
    """Run ``spec`` from ``q0`` on ``kin`` with ``ik`` (its joint box set by the caller) at
    :data:`DRY_RUN_DT`: None when it arrives, else why not. Leaves ``kin`` at the end.

    ``clearance``: the distances are checked at every step (the motion is refused when it
    would bring two bodies closer than the security distance)."""
    motion = time_scaled(kin, spec).build(kin, DRY_RUN_DT)
    setup = motion.setup()
    ik.tasks = setup.tasks
    ik.configure(setup.frozen, setup.allowed, setup.ranges)
    q, v = q0.copy(), np.zeros_like(q0)
    settle = 0
    if clearance is not None:
        clearance.start(q0)
        progress = _progress(kin, spec)
    for _ in range(int((max_time + 1.0) / DRY_RUN_DT)):  # + the settling second
        motion.advance()
        result = ik.solve(q, v)
        if not result.ok:
            return f"no joint motion can follow it: {result.message}"
        v = result.velocity
        q = q + v * DRY_RUN_DT
        kin.update(q)
        if clearance is not None:
            where = f"at {100 * progress():.0f} % of the way"
            reason = clearance.problem_at(q, where, "the motion")
            if reason is not None:
                return reason
        if motion.finished:
            settle += 1
            if settle * DRY_RUN_DT >= 1.0 or np.abs(v).max() < 1e-6:
                break
    at_limit = [
        kin.joint_names[i]
        for i in np.flatnonzero(~setup.frozen)
        if q[i] - ik.box.q_min[i] < LIMIT_TOL or ik.box.q_max[i] - q[i] < LIMIT_TOL
    ]
    return arrival_problem(kin, ik.tasks, commanded, at_limit)


def _progress(kin: Kinematics, spec: MotionSpec) -> Callable[[], float]:
    """How far along its axis targets the motion is, 0..1, from ``kin``'s state (the largest
    share over the moving axes; 1 for a motion other than CP-hold)."""
    targets = spec.targets if isinstance(spec, CPHoldSpec) else {}
    start = {axis: axis_value(kin, axis) for axis in targets}

    def share() -> float:
        best = 0.0
        for axis, goal in targets.items():
            total = goal - start[axis]
            done = axis_value(kin, axis) - start[axis]
            if axis.is_elbow:
                total, done = math.remainder(total, math.tau), math.remainder(done, math.tau)
            if abs(total) > 1e-9:
                best = max(best, min(1.0, done / total))
        return best if targets else 1.0

    return share


def time_scaled(kin: Kinematics, spec: MotionSpec) -> MotionSpec:
    """``spec``, or for a CP-hold motion longer than :data:`DRY_RUN_MAX_TIME` (from ``kin``'s
    state) the same motion time-scaled to that duration: same axis paths, so the same
    arrival verdict."""
    if not isinstance(spec, CPHoldSpec):
        return spec
    duration = max(
        (
            motion_time(goal - axis_value(kin, axis), float(v), float(a))
            for (axis, goal), v, a in zip(spec.targets.items(), spec.speed, spec.accel, strict=True)
        ),
        default=0.0,
    )
    if duration <= DRY_RUN_MAX_TIME:
        return spec
    k = duration / DRY_RUN_MAX_TIME
    return dataclasses.replace(spec, speed=spec.speed * k, accel=spec.accel * k * k)

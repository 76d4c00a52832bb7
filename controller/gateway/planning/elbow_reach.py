"""Can the elbow reach its target with the hand on its target? (issue 15.3)

The path check (:class:`ReachabilityChecker`) follows the control point only; a commanded
elbow angle turns the arm about the shoulder-wrist line (self-motion), which the joint limits
may stop short. :func:`reach_elbow` walks that self-motion from the path's end, the hand kept
on its pose, the arm's joints within their limits (a joint reaching a limit stays there, the
others go on), and returns the elbow angle it gets to and the joints that stopped it.
"""

from __future__ import annotations

import math

import numpy as np

from controller.model.kinematics import Kinematics
from controller.qp.tasks import pose_error
from controller.vocabulary import RightLeft, UnitType

#: Elbow error [rad] below which the target counts as reached.
ELBOW_TOL = math.radians(1.0)
#: Largest joint step of one iteration [rad].
MAX_STEP = 0.05
MAX_ITER = 200
#: The walk ends when the elbow error has not shrunk by PROGRESS [rad] in STALL_ITER steps.
PROGRESS = 1e-4
STALL_ITER = 8
DAMPING = 1e-4
#: Weight of the hand's pose against the elbow: the hand stays, the elbow gives way.
POSE_WEIGHT = 10.0
_AT_LIMIT = 1e-4


def reach_elbow(
    kin: Kinematics,
    side: RightLeft,
    q: np.ndarray,
    elbow: float,
    q_min: np.ndarray,
    q_max: np.ndarray,
) -> tuple[float, list[str]]:
    """Elbow angle [rad] reachable towards ``elbow`` from ``q`` with ``side``'s control point
    kept at its pose at ``q``, and the names of the arm joints at a limit when it stopped
    short (empty when it reached the target). Leaves ``kin`` at the final configuration."""
    arm = kin.unit_indices(UnitType[f"{side.name}_ARM"])
    q = q.copy()
    kin.update(q)
    pose = kin.pose(side).copy()
    blocked: list[int] = []
    best, stalled = math.inf, 0
    for _ in range(MAX_ITER):
        kin.update(q)
        err_elbow = math.remainder(elbow - kin.elbow_angle(side), math.tau)
        err_pose = pose_error(pose, kin.pose(side))
        if abs(err_elbow) < ELBOW_TOL * 0.1:
            return elbow, []
        if abs(err_elbow) < best - PROGRESS:
            best, stalled = abs(err_elbow), 0
        else:
            stalled += 1
            if stalled >= STALL_ITER:
                break  # the elbow no longer turns: a limit or the arm's geometry holds it
        free = np.array([i for i in arm if i not in blocked], dtype=int)
        if free.size == 0:
            break
        jac = np.vstack([POSE_WEIGHT * kin.jacobian(side)[:, free], kin.elbow_jacobian(side)[free]])
        err = np.concatenate([POSE_WEIGHT * err_pose, [err_elbow]])
        dq = jac.T @ np.linalg.solve(jac @ jac.T + DAMPING * np.eye(7), err)
        scale = min(1.0, MAX_STEP / max(float(np.abs(dq).max()), 1e-12))
        step = np.zeros_like(q)
        step[free] = dq * scale
        new = np.clip(q + step, q_min, q_max)
        hit = [
            int(i)
            for i in free
            if (new[i] - q_min[i] < _AT_LIMIT and step[i] < 0)
            or (q_max[i] - new[i] < _AT_LIMIT and step[i] > 0)
        ]
        if float(np.abs(new - q).max()) < 1e-7 and not hit:
            break  # stuck without a limit: the elbow cannot turn further (singular arm)
        q = new
        blocked.extend(i for i in hit if i not in blocked)
    kin.update(q)
    reached = kin.elbow_angle(side)
    if abs(math.remainder(elbow - reached, math.tau)) < ELBOW_TOL:
        return elbow, []
    names = [kin.joint_names[i] for i in arm if q[i] - q_min[i] < 1e-3 or q_max[i] - q[i] < 1e-3]
    return reached, names

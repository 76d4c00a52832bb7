"""Position-level IK of one pose under a motion's limits, its null space drawn to a posture.

One sample of the reachability check (:mod:`controller.motion.reachability`): from a start
configuration, damped Gauss-Newton steps on the control point's pose error (and a held
arm's, and an elbow angle's, best-effort) under the joint box, the frozen joints and the
redundant-axis rows, each step a small QP. In the tasks' null space the configuration is
drawn to a given posture in the metric of :func:`controller.motion.posture.limit_weights`
(:func:`~controller.motion.posture.null_step`): the objective the loop then follows. Also
what the constrained arm has left at a configuration: its redundancy and its conditioning
(the smallest singular value the check compares with MIN_SINGULAR).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, axis_jacobian, axis_value
from controller.motion.posture import limit_weights, null_step
from controller.qp.constraints import AxisRows
from controller.qp.constraints.axes import HOLD_MIN_ELBOW_OFFSET
from controller.qp.solver import ProxQPSolver
from controller.qp.tasks import pose_error
from controller.vocabulary import RightLeft

#: Accepted residual: position [m], orientation [rad].
POSITION_TOL = 1e-4
ANGLE_TOL = math.radians(0.05)
#: Largest joint step per iteration [rad or m] and iterations per solve.
MAX_STEP = 0.2
MAX_ITER = 60
DAMPING = 1e-6
#: Null-space objective: a pose is solved once its posture step is below NULL_TOL [rad or
#: m], or NULL_ITER iterations after the pose was reached; after MAX_ITER / 2 iterations
#: without the pose, the pose alone.
NULL_TOL = 1e-3
NULL_ITER = 8
#: Share of the posture step taken per iteration, and its largest joint step [rad or m]:
#: the full step overshoots where the weights grow (a joint nearing its limit) and the
#: iteration alternates between two configurations.
NULL_GAIN = 0.5
MAX_NULL_STEP = 0.05
#: Rotation rows are scaled by this length [m] to compare with translation rows.
ROTATION_SCALE = 0.3
#: Weight of the elbow row [m/rad] (the pose rows weigh 1) and its accepted residual [rad].
ELBOW_WEIGHT = 0.1
ELBOW_TOL = math.radians(0.1)


class PositionIK:
    """Solves poses on ``kin`` (a planning copy) within ``q_min``, ``q_max`` [rad, m] (the
    arrays are shared: the owner may narrow them in place) and ``rows``' axis constraints."""

    def __init__(self, kin: Kinematics, rows: AxisRows, q_min: np.ndarray, q_max: np.ndarray):
        self.kin = kin
        self.rows = rows
        self.q_min = q_min
        self.q_max = q_max
        self.solver = ProxQPSolver(kin.nv, rows.m)

    def solve(
        self,
        q: np.ndarray,
        side: RightLeft,
        target: pin.SE3,
        frozen: np.ndarray,
        hold: RightLeft | None,
        held: pin.SE3 | None,
        elbow: tuple[RedundantAxis, float] | None = None,
        posture: np.ndarray | None = None,
        held_axes: Sequence[RedundantAxis] = (),
    ) -> tuple[np.ndarray, str | None]:
        """Position-level IK toward ``target`` (and the held pose) from ``q``; ``elbow``: an
        elbow angle [rad] to approach as well, best-effort (retried without it when the pose
        cannot be reached with it). ``posture``: the configuration the null space of the
        tasks and the ``held_axes`` is drawn to (:mod:`controller.motion.posture`)."""
        kin = self.kin
        start = q
        free = ~frozen
        axis_rows: list[np.ndarray] = []
        reached = 0  # iterations with the pose reached
        on_pose: np.ndarray | None = None  # the last configuration that reached it
        weights: np.ndarray | None = None
        for k in range(MAX_ITER):
            if k == MAX_ITER // 2:
                posture = None  # not there yet: the pose alone from here on
            kin.update(q)
            jacs = [kin.jacobian(side)]
            errs = [pose_error(target, kin.pose(side))]
            if hold is not None and held is not None:
                jacs.append(kin.jacobian(hold))
                errs.append(pose_error(held, kin.pose(hold)))
            pos = max(float(np.linalg.norm(e[:3])) for e in errs)
            ang = max(float(np.linalg.norm(e[3:])) for e in errs)
            swing = 0.0
            if elbow is not None and kin.elbow_offset(elbow[0].side) > HOLD_MIN_ELBOW_OFFSET:
                swing = math.remainder(elbow[1] - axis_value(kin, elbow[0]), math.tau)
                jacs.append(ELBOW_WEIGHT * axis_jacobian(kin, elbow[0])[None, :])
                errs.append(np.array([ELBOW_WEIGHT * swing]))
            jac = np.vstack(jacs)
            null = None
            if posture is not None:
                if held_axes:  # held axes' rows move with the configuration
                    axis_rows = [axis_jacobian(kin, a)[None, :] for a in held_axes]
                if weights is None:  # once per sample: they change little within one
                    weights = limit_weights(q, self.q_min, self.q_max)
                null = null_step(np.vstack([jac, *axis_rows]), free, q, posture, weights)
                null *= NULL_GAIN / max(1.0, float(np.abs(null).max()) / MAX_NULL_STEP)
            if pos < POSITION_TOL and ang < ANGLE_TOL and abs(swing) < ELBOW_TOL:
                if null is None or reached >= NULL_ITER or float(np.abs(null).max()) < NULL_TOL:
                    return q, None
                reached += 1
                on_pose = q
            err = np.concatenate(errs)
            H = jac.T @ jac + DAMPING * np.eye(kin.nv)
            g = -jac.T @ err
            if null is not None:
                g -= DAMPING * null  # damped toward the posture step, not toward standing still
            lb = np.maximum(self.q_min - q, -MAX_STEP)
            ub = np.minimum(self.q_max - q, MAX_STEP)
            lb[frozen] = ub[frozen] = 0.0
            lb, ub = np.minimum(lb, 0.0), np.maximum(ub, 0.0)  # outside a limit: not worse
            C, lo, hi = self.rows.rows(kin, lb, ub)
            dq = self.solver.solve(H, g, C, lo, hi, lb, ub)
            if dq is None:
                if on_pose is not None:
                    kin.update(on_pose)
                    return on_pose, None
                why = self.describe(q, pos, ang, frozen)
                return q, f"{why} (no step keeps the limits and the held axes)"
            if float(np.abs(dq).max()) < 1e-9:
                break  # stuck
            q = q + np.clip(dq, lb, ub)
        if on_pose is not None:
            kin.update(on_pose)
            return on_pose, None  # the pose was reached; the posture as near as it got
        if elbow is not None:
            kin.update(q)
            errs = [pose_error(target, kin.pose(side))]
            if hold is not None and held is not None:
                errs.append(pose_error(held, kin.pose(hold)))
            if all(
                np.linalg.norm(e[:3]) < POSITION_TOL and np.linalg.norm(e[3:]) < ANGLE_TOL
                for e in errs
            ):
                return q, None  # the pose is reached; the elbow as near as it gets
            # The pose first: this sample again without the elbow.
            return self.solve(start, side, target, frozen, hold, held, None, posture, held_axes)
        return q, self.describe(q, pos, ang, frozen)

    def describe(self, q: np.ndarray, pos: float, ang: float, frozen: np.ndarray) -> str:
        at_limit = [
            name
            for i, name in enumerate(self.kin.joint_names)
            if not frozen[i] and (q[i] - self.q_min[i] < 1e-4 or self.q_max[i] - q[i] < 1e-4)
        ]
        text = f"closest pose is {pos * 1e3:.1f} mm and {math.degrees(ang):.2f} deg away"
        if at_limit:
            text += f"; joints at their limits: {', '.join(at_limit)}"
        return text

    def moving_axes(self, axes: Sequence[RedundantAxis], frozen: np.ndarray) -> list[RedundantAxis]:
        """The ``axes`` whose rows involve a joint that is not ``frozen`` at the last update
        (a vehicle or waist axis of a frozen unit, the other arm's elbow when that arm is
        frozen: its row would cost every iteration for nothing)."""
        free = ~frozen
        return [a for a in axes if np.abs(axis_jacobian(self.kin, a)[free]).max(initial=0.0) > 0.0]

    def redundancy(
        self,
        side: RightLeft,
        hold: RightLeft | None,
        frozen: np.ndarray,
        held_axes: list[RedundantAxis],
    ) -> int:
        """Degrees of freedom left over the control point(s) at the last update: free joints
        minus the held axes' rows minus 6 per control point (≤ 0: the constrained arm has no
        redundancy, so it cannot ride a joint limit and keep its line)."""
        free = ~frozen
        rows = [axis_jacobian(self.kin, a)[free] for a in held_axes]
        rows = [r for r in rows if np.abs(r).max(initial=0.0) > 0.0]
        rank = int(np.linalg.matrix_rank(np.vstack(rows))) if rows else 0
        return int(free.sum()) - rank - 6 * (1 if hold is None else 2)

    def conditioning(
        self,
        side: RightLeft,
        hold: RightLeft | None,
        frozen: np.ndarray,
        held_axes: list[RedundantAxis],
    ) -> float:
        """Smallest singular value [m/rad] of the control-point Jacobian(s) over the free
        joints, restricted to motions that keep the held axes (at the last update)."""
        kin = self.kin
        free = ~frozen
        sides = [side] if hold is None else [side, hold]
        jac = np.vstack([kin.jacobian(s)[:, free] for s in sides])
        for i in range(len(sides)):
            jac[6 * i + 3 : 6 * i + 6] *= ROTATION_SCALE
        rows = [axis_jacobian(kin, a)[free] for a in held_axes]
        rows = [r for r in rows if np.abs(r).max(initial=0.0) > 0.0]
        if rows:
            constraint = np.vstack(rows)
            _, sv, vt = np.linalg.svd(constraint)
            rank = int(np.sum(sv > 1e-9 * max(1.0, float(sv[0]))))
            jac = jac @ vt[rank:].T
        if jac.shape[1] < jac.shape[0]:
            return 0.0
        return float(np.linalg.svd(jac, compute_uv=False)[-1])

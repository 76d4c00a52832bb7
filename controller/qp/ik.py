"""The whole-body IK step: a strict two-level hierarchy of QPs over every joint velocity.

Level 1 (control points, and joint/vehicle targets of unit moves)::

    v₁ = argmin Σ_level1 ‖J v − e‖²_W + ε‖v − v_post‖² + λ‖v‖²   s.t. limits

Level 2 (redundant axes: elbow, waist, vehicle targets), only when such tasks are active::

    v₂ = argmin Σ_level2 ‖J v − e‖²_W + ε‖v − v_post‖² + λ‖v‖²   s.t. limits, J₁ v = J₁ v₁

Limits (both levels): joint box (velocity, acceleration, position with braking distance,
frozen joints) and redundant-axis rows (masks, RedundantLimit ranges, no sideways motion of a
differential base); see :mod:`controller.qp.limits`. ε is the posture weight (1e-7), λ = 1e-9.

Why a strict hierarchy and not weights: with weights, a redundant goal that the limits make
unreachable (SEED-Noid's ±5° wrist pitch boxes its null space in) pulls the control point
away in proportion to the weight ratio: measured 1 mm at a 1e-5 ratio. With the equality
``J₁ v = J₁ v₁`` the control points get exactly what level 1 achieved, whatever level 2 asks.
The second solve costs ~10 µs and runs only while redundant-axis tasks are active. Level 1
never fails for lack of redundancy (it has no equality), so the hierarchy keeps the
robustness of a single damped QP: at singularities λ and ε damp, the box bounds.

A failed or infeasible level-1 solve returns ``ok=False`` with zero velocity: the loop holds
position and raises a fault. A failed level 2 falls back to v₁ (safe: it satisfies every
limit) and says so in ``message``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from controller.kinematics import Kinematics
from controller.qp.limits import AxisRows, JointBox
from controller.qp.solver import make_solver
from controller.qp.tasks import Task
from controller.redundant_axes import available_axes

#: Tikhonov damping λ on the joint velocities.
DAMPING = 1e-9


@dataclass
class IKResult:
    """Joint velocities for this cycle [rad/s, m/s] (order of ``kin.joint_names``)."""

    velocity: np.ndarray
    ok: bool
    message: str = ""
    iterations: int = 0


def _cost(tasks: list[Task], kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
    """Hessian and gradient of Σ ‖J v − e‖²_W (+ λ‖v‖²)."""
    if not tasks:
        return DAMPING * np.eye(kin.nv), np.zeros(kin.nv)
    jacs, rates, weights = [], [], []
    for task in tasks:
        jac, rate = task.compute(kin)
        jacs.append(jac)
        rates.append(rate)
        weights.append(task.weight)
    jac = np.vstack(jacs)
    jtw = jac.T * np.concatenate(weights)
    H = jtw @ jac
    H.flat[:: kin.nv + 1] += DAMPING
    return H, -(jtw @ np.concatenate(rates))


class WholeBodyIK:
    """Builds and solves the cycle's QPs. Call ``kin.update(q_measured)`` before :meth:`solve`."""

    def __init__(self, kin: Kinematics, dt: float, solver: str = "proxqp"):
        self.kin = kin
        self.dt = dt
        self.axes = available_axes(kin)
        self.box = JointBox(kin, dt)
        self.rows = AxisRows(kin, self.axes, dt)
        #: Equality rows of level 2: 6 per control point.
        self.n_eq = 6 * len(kin.arms)
        self.solver = make_solver(solver, kin.nv, self.rows.m)
        self.solver2 = make_solver(solver, kin.nv, self.rows.m, self.n_eq)
        self.tasks: list[Task] = []
        self._A = np.zeros((self.n_eq, kin.nv))
        self._b = np.zeros(self.n_eq)

    def solve(self, q_cmd: np.ndarray, v_prev: np.ndarray) -> IKResult:
        """Velocities for the next cycle.

        ``q_cmd`` is the last commanded position (the limits apply to what is sent),
        ``v_prev`` the last commanded velocity (for the acceleration limit).
        """
        kin = self.kin
        regular = [t for t in self.tasks if t.level == 0]
        first = [t for t in self.tasks if t.level == 1]
        second = [t for t in self.tasks if t.level == 2]
        lb, ub = self.box.bounds(q_cmd, v_prev)
        C, lo, hi = self.rows.rows(kin)
        H, g = _cost(first + regular, kin)
        v1 = self.solver.solve(H, g, C, lo, hi, lb, ub)
        if v1 is None:
            return IKResult(np.zeros(kin.nv), False, "QP infeasible or not solved")
        iterations = self.solver.iterations
        if second:
            A, b = self._A, self._b
            A.fill(0.0)
            rows = 0
            for task in first:
                jac, _ = task.compute(kin)
                k = min(jac.shape[0], self.n_eq - rows)
                A[rows : rows + k] = jac[:k]
                rows += k
            np.matmul(A, v1, out=b)
            H2, g2 = _cost(second + regular, kin)
            v2 = self.solver2.solve(H2, g2, C, lo, hi, lb, ub, A, b)
            if v2 is None:
                v = np.clip(v1, lb, ub)
                return IKResult(v, True, "level 2 not solved: redundant axes held", iterations)
            v1 = v2
            iterations += self.solver2.iterations
        return IKResult(np.clip(v1, lb, ub), True, iterations=iterations)

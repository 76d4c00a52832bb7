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
The second solve runs only while redundant-axis tasks are active. Level 1 never fails for
lack of redundancy (it has no equality), so the hierarchy keeps the robustness of a single
damped QP: at singularities λ and ε damp, the box bounds.

Problem size: a frozen joint's velocity is fixed by the box (lb = ub: zero at rest, braking
while it still moves), so it is no variable. The QPs run over the free joints only, with the
frozen joints' share moved to the right-hand sides (``J v = J_f v_f + J_z v_z``); axis rows
that constrain nothing are left out, and a row whose coefficients all belong to frozen joints
(the differential drive's, with the base frozen) is checked instead of solved: it holds, or
the step fails as the infeasible QP would. Free set and rows
change only with the configuration — :meth:`WholeBodyIK.configure`, or assigning ``box.frozen``
and calling ``rows.configure`` (noticed at the next :meth:`~WholeBodyIK.solve`) — and every
problem shape keeps its own persistent, warm-started solver.

A failed or infeasible level-1 solve returns ``ok=False`` with zero velocity: the loop holds
position and raises a fault. A failed level 2 falls back to v₁ (safe: it satisfies every
limit) and says so in ``message``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, available_axes
from controller.qp.limits import INF, AxisRows, JointBox
from controller.qp.solver import DEFAULT_SOLVER, FEASIBILITY_TOL, QPSolver, make_solver
from controller.qp.tasks import Task

#: Tikhonov damping λ on the joint velocities.
DAMPING = 1e-9


@dataclass
class IKResult:
    """Joint velocities for this cycle [rad/s, m/s] (order of ``kin.joint_names``)."""

    velocity: np.ndarray
    ok: bool
    message: str = ""
    iterations: int = 0


class _Layout:
    """The QPs' structure for one configuration: the variables (free joints) and the rows."""

    def __init__(self, box: JointBox, rows: AxisRows):
        #: What the layout was made for: the frozen mask and the rows' configuration.
        self.frozen_key = box.frozen.tobytes()
        self.rows_version = rows.version
        frozen = np.asarray(box.frozen, dtype=bool)
        free = np.flatnonzero(~frozen)
        self.n = len(free)
        #: Frozen joints, and the free ones: a slice when contiguous (views, not copies).
        self.fixed = np.flatnonzero(frozen)
        self.has_fixed = len(self.fixed) > 0
        contiguous = self.n > 0 and free[-1] - free[0] + 1 == self.n
        self.free: slice | np.ndarray = slice(free[0], free[-1] + 1) if contiguous else free
        confined = rows.confined
        idle = [i for i in rows.active if i in confined and frozen[confined[i]].all()]
        #: Active rows: solved, or checked when only frozen joints have coefficients in them.
        self.checked = np.array(idle, dtype=int)
        self.rows = np.setdiff1d(rows.active, self.checked)
        #: No row to solve, and none to check while the frozen joints are at rest (C_z v_z = 0:
        #: a constant l ≤ 0 ≤ u holds for good).
        bounds = rows.constant_bounds
        self.no_rows_at_rest = not len(self.rows) and all(
            i in bounds and bounds[i][0] <= 0.0 <= bounds[i][1] for i in self.checked
        )
        self.damping = DAMPING * np.eye(self.n)
        self.no_rows = (np.zeros((0, self.n)), np.zeros(0), np.zeros(0))


class _Stack:
    """Some tasks' rows ``(J, e, w)`` stacked in fixed buffers, filled in place every cycle."""

    def __init__(self, tasks: list[Task], kin: Kinematics):
        self.tasks = tasks
        m = sum(len(t.weight) for t in tasks)
        # Column-major: the free joints' columns are one contiguous block BLAS takes as is.
        self.jac = np.zeros((m, kin.nv), order="F")
        self.rate = np.zeros(m)
        self.weight = np.zeros(m)
        #: ``weight`` spread over the columns (rebuilt when it changes): row scaling by a
        #: same-shape product, several times cheaper in NumPy than by broadcasting.
        self._wide_weight = np.zeros((m, kin.nv), order="F")
        self._weight_key: bytes | None = None
        #: Per task, views of its rows (made once: slicing every cycle costs); ``None`` for
        #: the Jacobian of a task whose J is constant, written here once.
        self.views: list[tuple[Task, np.ndarray | None, np.ndarray, np.ndarray]] = []
        a = 0
        for task in tasks:
            b = a + len(task.weight)
            jac: np.ndarray | None = self.jac[a:b]
            if task.constant_jacobian:
                task.compute_into(kin, jac, self.rate[a:b])
                jac = None
            self.views.append((task, jac, self.rate[a:b], self.weight[a:b]))
            a = b

    def fill(self, kin: Kinematics, count: int | None = None) -> None:
        """Compute the first ``count`` tasks (default: all) into their rows."""
        for task, jac, rate, weight in self.views if count is None else self.views[:count]:
            task.compute_into(kin, jac, rate)
            weight[...] = task.weight

    def cost(self, layout: _Layout, v_fixed: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Hessian and gradient of Σ ‖J v − e‖²_W + λ‖v‖² over the free joints; ``v_fixed``:
        the frozen joints' velocities (None when all zero)."""
        key = self.weight.tobytes()
        if key != self._weight_key:
            self._weight_key = key
            self._wide_weight[...] = self.weight[:, None]
        jac = self.jac[:, layout.free]
        wjac = jac * self._wide_weight[:, layout.free]
        rate = self.rate
        if v_fixed is not None:
            rate = rate - self.jac[:, layout.fixed].dot(v_fixed)
        H = wjac.T.dot(jac)
        H += layout.damping
        g = wjac.T.dot(rate)
        return H, np.negative(g, out=g)


class _Plan:
    """The tasks by level: level 1 with the regularisation, level 2 (if any) with it too."""

    def __init__(self, tasks: list[Task], kin: Kinematics):
        self.key = tuple(tasks)
        first = [t for t in tasks if t.level == 1]
        regular = [t for t in tasks if t.level == 0]
        second = [t for t in tasks if t.level == 2]
        self.level1 = _Stack(first + regular, kin)
        #: Rows of the level-1 tasks proper (the first rows of ``level1``).
        self.m1 = sum(len(t.weight) for t in first)
        self.n_second = len(second)
        self.level2 = _Stack(second + regular, kin) if second else None

    def fill(self, kin: Kinematics) -> None:
        """Every level's rows; level 2 copies the regularisation's rows from level 1."""
        one, two = self.level1, self.level2
        one.fill(kin)
        if two is not None:
            two.fill(kin, self.n_second)
            m2 = len(two.rate) - (len(one.rate) - self.m1)
            two.jac[m2:] = one.jac[self.m1 :]
            two.rate[m2:] = one.rate[self.m1 :]
            two.weight[m2:] = one.weight[self.m1 :]


class WholeBodyIK:
    """Builds and solves the cycle's QPs. Call ``kin.update(q_measured)`` before :meth:`solve`.

    Configure with :meth:`configure` (or set ``box.frozen`` and call ``rows.configure``), set
    ``tasks``; a task's number of rows must not change while it is in ``tasks``.
    """

    def __init__(self, kin: Kinematics, dt: float, solver: str = DEFAULT_SOLVER):
        self.kin = kin
        self.dt = dt
        self.axes = available_axes(kin)
        self.box = JointBox(kin, dt)
        self.rows = AxisRows(kin, self.axes, dt)
        #: Equality rows of level 2: at most 6 per control point.
        self.n_eq = 6 * len(kin.arms)
        self.solver_name = solver
        self._solvers: dict[tuple[int, int, int, int], QPSolver] = {}
        #: The last level-2 solver used (None before the first level-2 solve).
        self.solver2: QPSolver | None = None
        self.tasks: list[Task] = []
        self._plan = _Plan([], kin)
        self._layout = self._new_layout()

    def configure(
        self,
        frozen: np.ndarray,
        allowed: dict[RedundantAxis, bool] | None = None,
        ranges: dict[RedundantAxis, tuple[float, float] | None] | None = None,
    ) -> None:
        """Joints held still (``frozen``, a mask over ``kin.joint_names``), masked axes
        (``allowed`` False: held at their values in ``kin``'s last update) and axis ranges."""
        self.box.frozen = np.array(frozen, dtype=bool)
        self.rows.configure(self.kin, allowed or {}, ranges or {}, self.box.frozen)
        self._layout = self._new_layout()

    def solver_for(self, level: int = 1, p: int = 0) -> QPSolver:
        """The persistent solver of ``level`` for the current layout's shape (``p``
        equalities): one per shape, kept across configurations."""
        layout = self._layout
        key = (layout.n, len(layout.rows), p, level)
        solver = self._solvers.get(key)
        if solver is None:
            # No guard: the box never crosses (JointBox) and solve() checks its result.
            solver = self._solvers[key] = make_solver(self.solver_name, *key[:3], guard=False)
        return solver

    def _new_layout(self) -> _Layout:
        self._layout = layout = _Layout(self.box, self.rows)
        if layout.n:  # with every joint frozen there is nothing to solve (nor a QP to make)
            self.solver = self.solver_for()
        for (n, m, _, _), solver in self._solvers.items():
            if (n, m) == (layout.n, len(layout.rows)):
                solver.reset()  # a new problem: no warm start from another one
        return layout

    def _rows(
        self, layout: _Layout, v_fixed: np.ndarray | None, lb: np.ndarray, ub: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The solved rows over the free joints (frozen joints' share moved to the bounds),
        or None when a checked row does not hold."""
        C, lo, hi = self.rows.rows(self.kin, lb, ub)
        c = layout.checked
        if len(c):  # l ≤ C_z v_z ≤ u must hold as it is
            lo_c, hi_c = lo[c], hi[c]
            if v_fixed is not None:
                share = C[c][:, layout.fixed].dot(v_fixed)
                lo_c -= share
                hi_c -= share
            tol = FEASIBILITY_TOL
            if np.count_nonzero(lo_c > tol) or np.count_nonzero(hi_c < -tol):
                return None
        r = layout.rows
        if not len(r):
            return layout.no_rows
        Cr = C[r]
        lo_r, hi_r = lo[r], hi[r]
        if v_fixed is not None:
            share = Cr[:, layout.fixed].dot(v_fixed)
            lo_r -= share
            hi_r -= share
        return np.ascontiguousarray(Cr[:, layout.free]), lo_r, hi_r

    def solve(self, q_cmd: np.ndarray, v_prev: np.ndarray) -> IKResult:
        """Velocities for the next cycle.

        ``q_cmd`` is the last commanded position (the limits apply to what is sent),
        ``v_prev`` the last commanded velocity (for the acceleration limit).
        """
        kin = self.kin
        layout = self._layout
        if self.rows.version != layout.rows_version or (
            self.box.frozen.tobytes() != layout.frozen_key
        ):
            layout = self._new_layout()
        plan = self._plan
        if tuple(self.tasks) != plan.key:
            plan = self._plan = _Plan(self.tasks, kin)
        lb, ub = self.box.bounds(q_cmd, v_prev)
        v = lb.copy()  # frozen joints: lb = ub is their velocity; free ones are set below
        moving = None
        if layout.has_fixed:
            v_fixed = lb[layout.fixed]
            moving = v_fixed if np.count_nonzero(v_fixed) else None
        if moving is None and layout.no_rows_at_rest:
            rows: tuple[np.ndarray, np.ndarray, np.ndarray] | None = layout.no_rows
        else:
            rows = self._rows(layout, moving, lb, ub)
        if rows is None:
            return IKResult(np.zeros(kin.nv), False, "QP infeasible: rows of frozen joints")
        if not layout.n:
            return IKResult(v, True)
        C, lo, hi = rows
        lb, ub = lb[layout.free], ub[layout.free]
        try:
            plan.fill(kin)
        except ValueError:  # a task's row count changed: lay the rows out anew
            plan = self._plan = _Plan(self.tasks, kin)
            plan.fill(kin)
        H, g = plan.level1.cost(layout, moving)
        x = self.solver.solve(H, g, C, lo, hi, lb, ub)
        message = ""
        if x is None and len(lo):
            # Held axes and ranges against the box or each other (a held vehicle y against a
            # differential base's no-sideways row): relax them to "no further drift / no
            # further out" (bands that include 0) and try once more.
            lo, hi = np.minimum(lo, 0.0), np.maximum(hi, 0.0)
            x = self.solver.solve(H, g, C, lo, hi, lb, ub)
            message = "held axes and ranges relaxed to 'no further' this cycle"
            if x is None:
                # Nearly parallel equalities (held vehicle y and the no-sideways row at
                # heading ~0) can defeat the solver although v = 0 is feasible: keep only
                # the differential drive's row, which is physics, for this cycle.
                drive = layout.rows == self.rows.m - 1 if self.rows.differential else None
                keep = np.zeros(len(lo), dtype=bool) if drive is None else drive
                lo = np.where(keep, lo, -INF)
                hi = np.where(keep, hi, INF)
                x = self.solver.solve(H, g, C, lo, hi, lb, ub)
                message = "held axes and ranges not enforced this cycle (conflicting rows)"
        if x is None:
            return IKResult(np.zeros(kin.nv), False, "QP infeasible or not solved")
        iterations = self.solver.iterations
        if plan.level2 is not None:
            p = min(plan.m1, self.n_eq)
            A = np.ascontiguousarray(plan.level1.jac[:p, layout.free])
            H2, g2 = plan.level2.cost(layout, moving)
            self.solver2 = solver2 = self.solver_for(2, p)
            x2 = solver2.solve(H2, g2, C, lo, hi, lb, ub, A, A.dot(x))
            if x2 is None:
                message = "level 2 not solved: redundant axes held"
            else:
                x = x2
                iterations += solver2.iterations
        if isinstance(layout.free, slice):  # x may be the solver's own buffer: not in place
            np.minimum(np.maximum(x, lb), ub, out=v[layout.free])
        else:
            v[layout.free] = np.minimum(np.maximum(x, lb), ub)
        if not math.isfinite(v.dot(v)):  # NaN limits (a NaN position) pass the clip
            for solver in self._solvers.values():
                solver.reset()  # no warm start from garbage
            return IKResult(np.zeros(kin.nv), False, "QP result not finite")
        return IKResult(v, True, message, iterations)

"""The whole-body IK step: a strict two-level hierarchy of QPs over every joint velocity.

Level 1 (control points, and joint/vehicle targets of unit moves)::

    v₁ = argmin Σ_level1 ‖J v − e‖²_W + ε‖v − v_post‖² + λ‖v‖²   s.t. limits

Level 2 (redundant axes: elbow, waist, vehicle targets), only when such tasks are active::

    v₂ = argmin Σ_level2 ‖J v − e‖²_W + ε‖v − v_post‖² + λ‖v‖²   s.t. limits, J₁ v = J₁ v₁

Limits: the constraints of :mod:`controller.qp.constraints`, each in the levels it names: the
joint box (velocity, acceleration, position with braking distance, frozen joints), the
redundant-axis rows (masks, RedundantLimit ranges) and the differential drive's row (no
sideways motion), plus any constraint registered with :meth:`WholeBodyIK.add`.
ε is the posture weight (1e-7), λ = 1e-9.

Why a strict hierarchy and not weights: with weights, a redundant goal that the limits make
unreachable (SEED-Noid's ±5° wrist pitch boxes its null space in) pulls the control point
away in proportion to the weight ratio: measured 1 mm at a 1e-5 ratio. With the equality
``J₁ v = J₁ v₁`` the control points get exactly what level 1 achieved, whatever level 2 asks.
The second solve runs only while redundant-axis tasks are active. Level 1 never fails for
lack of redundancy (it has no equality), so the hierarchy keeps the robustness of a single
damped QP: at singularities λ and ε damp, the box bounds.

Problem size: the QPs run over the free joints only, and constraints whose rows involve
frozen joints only are checked instead of solved (:mod:`controller.qp.layout`). Free set and
rows change only with the configuration, :meth:`WholeBodyIK.configure` (the one way to set
it), and every problem shape keeps its own persistent, warm-started solver.

A motion start is cheap when its configuration was seen before: the layout comes back from
:attr:`WholeBodyIK.layouts`, the solvers keep the warm start of the last motion with that
layout (the same variables and rows) unless another layout of their shape came between, and
the task rows reuse the buffers of the last tasks with the same :func:`plan_signature`
(figures: docs/qp.md).

A level-1 QP without solution is retried with the constraints' relaxations
(:class:`~controller.qp.constraints.Relaxation`: first "no further", then without the
droppable rows); the step's ``message`` says what gave. A failed or infeasible level-1 solve
returns ``ok=False`` with zero velocity: the loop holds position and raises a fault. A failed
level 2 falls back to v₁ (safe: it satisfies every limit) and says so in ``message``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from controller.model import jit
from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, available_axes
from controller.qp.constraints import (
    AxisRows,
    Constraint,
    ConstraintSetup,
    CycleState,
    JointBox,
)
from controller.qp.cost_kernel import least_squares
from controller.qp.layout import Layout, LayoutCache
from controller.qp.solver import DEFAULT_SOLVER, QPSolver, make_solver
from controller.qp.tasks import Task

#: Tikhonov damping λ on the joint velocities.
DAMPING = 1e-9
#: No frozen joint moves: the compiled cost's empty ``fixed`` and ``v_fixed``.
_NONE_FIXED = np.zeros(0, dtype=np.int64)
_NO_VELOCITY = np.zeros(0)


@dataclass
class IKResult:
    """Joint velocities for this cycle [rad/s, m/s] (order of ``kin.joint_names``)."""

    velocity: np.ndarray
    ok: bool
    message: str = ""
    iterations: int = 0


class _Stack:
    """Some tasks' rows ``(J, e, w)`` stacked in fixed buffers, filled in place every cycle."""

    def __init__(self, tasks: list[Task], kin: Kinematics):
        m = sum(len(t.weight) for t in tasks)
        # Column-major: the free joints' columns are one contiguous block BLAS takes as is.
        self.jac = np.zeros((m, kin.nv), order="F")
        self.rate = np.zeros(m)
        self.weight = np.zeros(m)
        #: ``weight`` spread over the columns (rebuilt when it changes): row scaling by a
        #: same-shape product, several times cheaper in NumPy than by broadcasting.
        self._wide_weight = np.zeros((m, kin.nv), order="F")
        self._weight_key: bytes | None = None
        #: The compiled cost's outputs by number of free joints, and its scratch.
        self._normal: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._scratch = np.zeros((2, m))
        self._compiled = jit.available()
        self.bind(tasks, kin)

    def bind(self, tasks: list[Task], kin: Kinematics) -> None:
        """Lay ``tasks`` over the buffers (as many rows per task, in the same order, as
        the tasks the buffers were made for): views of each task's rows, and the Jacobian
        of a task whose J is constant written now."""
        self.tasks = tasks
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

    def cost(self, layout: Layout, v_fixed: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Hessian and gradient of Σ ‖J v − e‖²_W + λ‖v‖² over the free joints; ``v_fixed``:
        the frozen joints' velocities (None when all zero). Compiled
        (:mod:`controller.qp.cost_kernel`, into buffers of this stack that the next call
        overwrites) where numba is, else NumPy."""
        if self._compiled:
            n = layout.n
            out = self._normal.get(n)
            if out is None:
                out = self._normal[n] = (np.zeros((n, n)), np.zeros(n))
            H, g = out
            if v_fixed is None:
                fixed, v_fixed = _NONE_FIXED, _NO_VELOCITY
            else:
                fixed = layout.fixed
            least_squares(
                self.jac, self.rate, self.weight, layout.free_index, fixed, v_fixed,
                layout.damping_value, H, g, self._scratch,
            )  # fmt: skip
            return H, g
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


def plan_signature(tasks: list[Task]) -> tuple[tuple[int, int, bool], ...]:
    """What a plan's buffers are made for: per task, its level, rows and whether its
    Jacobian is constant. Tasks with the same signature fit the same buffers."""
    return tuple((t.level, len(t.weight), t.constant_jacobian) for t in tasks)


#: Plans (their buffers) :class:`WholeBodyIK` keeps by signature.
PLAN_CACHE_SIZE = 16


class _Plan:
    """The tasks by level: level 1 with the regularisation, level 2 (if any) with it too."""

    def __init__(self, tasks: list[Task], kin: Kinematics):
        first, regular, second = self._levels(tasks)
        self.level1 = _Stack(first + regular, kin)
        #: Rows of the level-1 tasks proper (the first rows of ``level1``).
        self.m1 = sum(len(t.weight) for t in first)
        self.n_second = len(second)
        self.level2 = _Stack(second + regular, kin) if second else None
        self.key = tuple(tasks)

    @staticmethod
    def _levels(tasks: list[Task]) -> tuple[list[Task], list[Task], list[Task]]:
        first = [t for t in tasks if t.level == 1]
        regular = [t for t in tasks if t.level == 0]
        second = [t for t in tasks if t.level == 2]
        return first, regular, second

    def bind(self, tasks: list[Task], kin: Kinematics) -> None:
        """Take ``tasks`` (of this plan's :func:`plan_signature`) into its buffers."""
        first, regular, second = self._levels(tasks)
        self.level1.bind(first + regular, kin)
        if self.level2 is not None:
            self.level2.bind(second + regular, kin)
        self.key = tuple(tasks)

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

    Configure with :meth:`configure`, set ``tasks``; a task's number of rows must not change
    while it is in ``tasks``. Constraints: :attr:`box` (the joint box), the redundant-axis
    rows of :attr:`rows`, and any :meth:`add` registers.
    """

    def __init__(self, kin: Kinematics, dt: float, solver: str = DEFAULT_SOLVER):
        self.kin = kin
        self.dt = dt
        self.axes = available_axes(kin)
        self.box = JointBox(kin, dt)
        #: The robot's redundant-axis constraints (configured by :meth:`configure` only).
        self.rows = AxisRows(kin, self.axes, dt)
        self._constraints: list[Constraint] = list(self.rows.constraints)
        #: Equality rows of level 2: at most 6 per control point.
        self.n_eq = 6 * len(kin.arms)
        self.solver_name = solver
        self._solvers: dict[tuple[int, int, int, int], QPSolver] = {}
        #: Level 2's equality rows and right-hand side by (rows, free joints), compiled path.
        self._equality: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        #: The last level-2 solve's equality count, solver and equality buffers, kept while
        #: the layout stays (a new layout clears it: another layout may have used the solver).
        self._level2: tuple[int, QPSolver, np.ndarray, np.ndarray] | None = None
        self._compiled = jit.available()
        #: Per solver (by key): the layout whose problem its warm start belongs to.
        self._warm_for: dict[tuple[int, int, int, int], Layout] = {}
        #: The layouts of recent configurations, and the plans of recent task signatures.
        self.layouts = LayoutCache(DAMPING)
        self._plans: dict[tuple[tuple[int, int, bool], ...], _Plan] = {}
        #: The last level-2 solver used (None before the first level-2 solve).
        self.solver2: QPSolver | None = None
        self.tasks: list[Task] = []
        self._plan = _Plan([], kin)
        self._cycle = CycleState(kin, np.zeros(kin.nv), np.zeros(kin.nv))
        self._setup = ConstraintSetup(np.zeros(kin.nv, dtype=bool))
        self.configure(self._setup.frozen)

    @property
    def solves(self) -> bool:
        """Whether :meth:`solve` runs a QP (some joint is free): else every joint is frozen
        and no row constraint is evaluated."""
        return self._layout.n > 0

    @property
    def constraints(self) -> tuple[Constraint, ...]:
        """The row constraints, in registration order."""
        return tuple(self._constraints)

    def set_period(self, dt: float) -> None:
        """This cycle's length [s] (the measured period when the loop runs late): the joint
        box and every constraint that has a period use it."""
        self.dt = dt
        self.box.dt = dt
        for constraint in self._constraints:
            if hasattr(constraint, "dt"):
                constraint.dt = dt

    def add(self, constraint: Constraint) -> None:
        """Register a row constraint (see :mod:`controller.qp.constraints.protocol`); it is
        configured at once with the current configuration, and at every :meth:`configure`."""
        self._constraints.append(constraint)
        constraint.configure(self.kin, self._setup)
        self.layouts.clear()  # they were made for the constraints before
        self._layout = self._new_layout()

    def configure(
        self,
        frozen: np.ndarray,
        allowed: dict[RedundantAxis, bool] | None = None,
        ranges: dict[RedundantAxis, tuple[float, float] | None] | None = None,
    ) -> None:
        """Joints held still (``frozen``, a mask over ``kin.joint_names``), masked axes
        (``allowed`` False: held at their values in ``kin``'s last update) and axis ranges.
        Tasks set before are laid out in their rows here (else at the next solve)."""
        self._setup = setup = ConstraintSetup(
            np.array(frozen, dtype=bool), allowed or {}, ranges or {}
        )
        self.box.configure(self.kin, setup)
        for constraint in self._constraints:
            constraint.configure(self.kin, setup)
        self._layout = self._new_layout()
        if tuple(self.tasks) != self._plan.key:  # set before: their rows now, not in a cycle
            self._plan = self._plan_for(self.tasks)

    def solver_for(self, level: int = 1, p: int = 0) -> QPSolver:
        """The persistent solver of ``level`` for the current layout's shape (``p``
        equalities): one per shape, kept across configurations. Its warm start is kept
        while it solves the problems of one layout, also when that layout comes back from
        :attr:`layouts` after others (a motion start with a configuration seen before
        starts from the working set the last motion with it ended with); the problem of
        another layout of the same shape starts cold."""
        layout = self._layout
        key = (layout.n, layout.m1 if level == 1 else layout.m2, p, level)
        solver = self._solvers.get(key)
        if solver is None:
            # No guard: the box never crosses (JointBox) and solve() checks its result.
            solver = self._solvers[key] = make_solver(self.solver_name, *key[:3], guard=False)
        elif self._warm_for.get(key) is not layout:
            solver.reset()  # another problem: no warm start from it
        self._warm_for[key] = layout
        return solver

    def _new_layout(self) -> Layout:
        """The layout of the current configuration (from :attr:`layouts` when seen
        before)."""
        self._layout = layout = self.layouts.get(self._setup.frozen, self._constraints)
        self._level2 = None
        if layout.n:  # with every joint frozen there is nothing to solve (nor a QP to make)
            self.solver = self.solver_for()
        return layout

    def _plan_for(self, tasks: list[Task]) -> _Plan:
        """A plan for ``tasks``: the buffers of an earlier plan with their signature when
        there is one (a motion start with the same kinds of tasks), else new ones."""
        signature = plan_signature(tasks)
        plan = self._plans.pop(signature, None)
        if plan is None:
            plan = _Plan(tasks, self.kin)
            if len(self._plans) >= PLAN_CACHE_SIZE:  # the least recently used goes
                del self._plans[next(iter(self._plans))]
        else:
            plan.bind(tasks, self.kin)
        self._plans[signature] = plan
        return plan

    def _equality_buffers(self, p: int, n: int) -> tuple[np.ndarray, np.ndarray]:
        buffers = self._equality.get((p, n))
        if buffers is None:
            buffers = self._equality[(p, n)] = (np.zeros((p, n)), np.zeros(p))
        return buffers

    def _cycle_at(
        self, q: np.ndarray, v_prev: np.ndarray, lb: np.ndarray, ub: np.ndarray
    ) -> CycleState:
        cycle = self._cycle
        cycle.q, cycle.v_prev, cycle.lb, cycle.ub = q, v_prev, lb, ub
        return cycle

    def solve(self, q_cmd: np.ndarray, v_prev: np.ndarray) -> IKResult:
        """Velocities for the next cycle.

        ``q_cmd`` is the last commanded position (the limits apply to what is sent),
        ``v_prev`` the last commanded velocity (for the acceleration limit).
        """
        kin = self.kin
        layout = self._layout
        plan = self._plan
        if tuple(self.tasks) != plan.key:
            plan = self._plan = self._plan_for(self.tasks)
        lb, ub = self.box.compute_qp_bounds(q_cmd, v_prev)
        v = lb.copy()  # frozen joints: lb = ub is their velocity; free ones are set below
        moving = None
        if layout.has_fixed:
            v_fixed = lb[layout.fixed]
            moving = v_fixed if np.count_nonzero(v_fixed) else None
        if layout.checked is not None and (moving is not None or not layout.checked_hold_at_rest):
            if not layout.check(self._cycle_at(q_cmd, v_prev, lb, ub), moving):
                return IKResult(np.zeros(kin.nv), False, "QP infeasible: rows of frozen joints")
        if not layout.n:
            return IKResult(v, True)
        if layout.m:
            layout.fill(self._cycle_at(q_cmd, v_prev, lb, ub), moving)
        C, lo, hi = layout.level1
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
            # Rows against the box or each other (a held vehicle y against a differential
            # base's no-sideways row): relax what may give to "no further" and try once more;
            # nearly parallel equalities (held vehicle y and the no-sideways row at heading
            # ~0) can still defeat the solver although v = 0 is feasible: then drop what may
            # be dropped for this cycle.
            message = layout.relax()
            x = self.solver.solve(H, g, C, lo, hi, lb, ub)
            if x is None:
                message = layout.drop()
                x = self.solver.solve(H, g, C, lo, hi, lb, ub)
        if x is None:
            return IKResult(np.zeros(kin.nv), False, "QP infeasible or not solved")
        iterations = self.solver.iterations
        if plan.level2 is not None:
            p = min(plan.m1, self.n_eq)
            level2 = self._level2
            if level2 is None or level2[0] != p:  # a new layout or count: look them up
                solver2 = self.solver_for(2, p)
                level2 = self._level2 = (p, solver2, *self._equality_buffers(p, layout.n))
            _, solver2, A, b = level2
            if self._compiled:  # the equalities A x = A x1 in one call, into kept buffers
                _equalities(plan.level1.jac, layout.free_index, x, A, b)
            else:
                A = np.ascontiguousarray(plan.level1.jac[:p, layout.free])
                b = A.dot(x)
            H2, g2 = plan.level2.cost(layout, moving)
            self.solver2 = solver2
            C2, lo2, hi2 = layout.level2
            x2 = solver2.solve(H2, g2, C2, lo2, hi2, lb, ub, A, b)
            if x2 is None:
                message = "level 2 not solved: redundant axes held"
            else:
                x = x2
                iterations += solver2.iterations
        if self._compiled:
            finite = _clip_into(x, lb, ub, layout.free_index, v)
        else:
            if isinstance(layout.free, slice):  # x may be the solver's own buffer
                np.minimum(np.maximum(x, lb), ub, out=v[layout.free])
            else:
                v[layout.free] = np.minimum(np.maximum(x, lb), ub)
            finite = math.isfinite(v.dot(v))
        if not finite:  # NaN limits (a NaN position) pass the clip
            for solver in self._solvers.values():
                solver.reset()  # no warm start from garbage
            return IKResult(np.zeros(kin.nv), False, "QP result not finite")
        return IKResult(v, True, message, iterations)


@jit.jit
def _equalities(
    jac: np.ndarray, free: np.ndarray, x: np.ndarray, A: np.ndarray, b: np.ndarray
) -> None:
    """Level 2's equalities ``A x = b``: the first ``len(b)`` rows of level 1's ``jac``
    over the ``free`` joints, and ``b = A x`` at level 1's minimiser ``x``."""
    p, n = A.shape
    for i in range(p):
        total = 0.0
        for k in range(n):
            a = jac[i, free[k]]
            A[i, k] = a
            total += a * x[k]
        b[i] = total


@jit.jit
def _clip_into(
    x: np.ndarray, lb: np.ndarray, ub: np.ndarray, free: np.ndarray, v: np.ndarray
) -> bool:
    """``v[free] = min(max(x, lb), ub)`` (NaN in, NaN out, as NumPy's), and whether
    ``v · v`` is finite (a NaN or an overflow anywhere in ``v``: not)."""
    for k in range(free.shape[0]):
        value, low, high = x[k], lb[k], ub[k]
        if value != value or low != low or high != high:
            value = math.nan
        elif value < low:
            value = low
        elif value > high:
            value = high
        v[free[k]] = value
    total = 0.0
    for j in range(v.shape[0]):
        total += v[j] * v[j]
    return math.isfinite(total)


if jit.available():  # compile (or load) at import, never in a control cycle
    for _order in ("F", "C"):  # a stack's rows are Fortran-ordered
        _jac = np.zeros((2, 3), order=_order)
        _equalities(_jac, np.arange(3), np.zeros(3), np.zeros((1, 3)), np.zeros(1))
    _clip_into(np.zeros(2), np.zeros(2), np.zeros(2), np.arange(2), np.zeros(3))

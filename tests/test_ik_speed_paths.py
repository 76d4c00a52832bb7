"""The IK's fast paths give the full problem's answer: frozen joints eliminated, idle rows
dropped, buffers reused, the DAQP back end and its iteration cap, the prepared joint box."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, axis_value, elbow_axis
from controller.qp.constraints import (
    ConstraintSetup,
    CycleState,
    JointBox,
    Level,
    Relaxation,
    RowBlock,
)
from controller.qp.ik import DAMPING, WholeBodyIK
from controller.qp.solver import (
    DEFAULT_SOLVER,
    DaqpSolver,
    ProxQPSolver,
    make_solver,
    within_limits,
)
from controller.qp.tasks import AxisTask, ControlPointTask, PostureTask, Task
from controller.vocabulary import RightLeft, UnitType
from tests.support import kinematics

DT = 0.002


# ------------------------------------------------------------------- the reference
def _cost(tasks: list[Task], kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
    H = DAMPING * np.eye(kin.nv)
    if not tasks:
        return H, np.zeros(kin.nv)
    jacs, rates = zip(*(t.compute(kin) for t in tasks), strict=True)
    jac = np.vstack(jacs)
    jtw = jac.T * np.concatenate([t.weight for t in tasks])
    return H + jtw @ jac, -(jtw @ np.concatenate(rates))


def stacked_rows(
    ik: WholeBodyIK, q: np.ndarray, v_prev: np.ndarray, lb: np.ndarray, ub: np.ndarray
) -> dict[Level, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Every registered constraint's rows this cycle over every joint, by the level they
    apply in (computed apart from the IK's buffers)."""
    kin = ik.kin
    cycle = CycleState(kin, q, v_prev, lb, ub)
    out = {}
    for level in (Level.FIRST, Level.SECOND):
        parts = [(np.zeros((0, kin.nv)), np.zeros(0), np.zeros(0))]
        for c in ik.constraints:
            if level in c.levels:
                m = c.max_rows
                rows = RowBlock(np.zeros((m, kin.nv)), np.zeros(m), np.zeros(m))
                k = c.compute_qp_inequalities(cycle, rows)
                parts.append((rows.C[:k], rows.lo[:k], rows.hi[:k]))
        C, lo, hi = (np.concatenate(p) for p in zip(*parts, strict=True))
        out[level] = (C, lo, hi)
    return out


def reference(ik: WholeBodyIK, q: np.ndarray, v_prev: np.ndarray) -> np.ndarray | None:
    """The documented two-level QP over every joint and every row, solved cold."""
    kin = ik.kin
    lb, ub = ik.box.compute_qp_bounds(q, v_prev)
    rows = stacked_rows(ik, q, v_prev, lb, ub)
    C, lo, hi = rows[Level.FIRST]
    regular = [t for t in ik.tasks if t.level == 0]
    first = [t for t in ik.tasks if t.level == 1]
    second = [t for t in ik.tasks if t.level == 2]
    H, g = _cost(first + regular, kin)
    v = DaqpSolver(kin.nv, len(lo)).solve(H, g, C, lo, hi, lb, ub)
    if v is None:
        return None
    if second:
        C, lo, hi = rows[Level.SECOND]
        A = np.vstack([t.compute(kin)[0] for t in first])[: ik.n_eq]
        H2, g2 = _cost(second + regular, kin)
        v2 = DaqpSolver(kin.nv, len(lo), len(A)).solve(H2, g2, C, lo, hi, lb, ub, A, A @ v)
        v = v if v2 is None else v2
    return np.clip(v, lb, ub)


def frozen_units(kin: Kinematics, moving: list[UnitType]) -> np.ndarray:
    frozen = np.ones(kin.nv, dtype=bool)
    for unit in moving:
        frozen[kin.unit_indices(unit)] = False
    return frozen


def shifted(pose: pin.SE3, dx: list[float], dr: list[float]) -> pin.SE3:
    return pin.SE3(pin.exp3(np.array(dr, float)) @ pose.rotation, pose.translation + dx)


def follow(ik: WholeBodyIK, q: np.ndarray, v: np.ndarray, steps: int, tol: float = 1e-7):
    """Closed loop on the IK's output, each cycle checked against the reference."""
    kin = ik.kin
    worst = 0.0
    for _ in range(steps):
        kin.update(q)
        ref = reference(ik, q, v)
        result = ik.solve(q, v)
        assert result.ok == (ref is not None), result.message
        if ref is None:
            return q, v, worst
        worst = max(worst, float(np.abs(result.velocity - ref).max()))
        v = result.velocity
        q = q + v * DT
    assert worst < tol
    return q, v, worst


def arm_tasks(kin: Kinematics, offset: float = 0.04) -> list[Task]:
    tasks: list[Task] = []
    for i, side in enumerate(kin.arms):
        s = 1.0 if i == 0 else -1.0
        target = shifted(kin.pose(side), [offset, s * offset, -offset], [0.1, 0, s * 0.1])
        tasks.append(ControlPointTask(side, target))
    tasks.append(PostureTask(kin.home(), np.arange(kin.nv)))
    return tasks


# ------------------------------------------------------------ elimination, rows
def test_qp_over_the_free_joints_gives_the_full_qps_answer(robot_id: str):
    kin = kinematics(robot_id)
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    arms = [UnitType[f"{s.name}_ARM"] for s in kin.arms]
    ik.configure(frozen_units(kin, arms))
    ik.tasks = arm_tasks(kin)
    assert ik.solver.n == sum(len(kin.unit_indices(u)) for u in arms)
    follow(ik, q, np.zeros(kin.nv), 300)


def test_frozen_joints_that_still_move_brake_as_in_the_full_qp():
    kin = kinematics("smartpal5")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    frozen = frozen_units(kin, [UnitType.RIGHT_ARM])
    ik.configure(frozen)
    ik.tasks = arm_tasks(kin)[:1]
    v = np.zeros(kin.nv)
    waist = kin.unit_indices(UnitType.LUMBER)
    v[waist] = 0.3 * ik.box.v_max[waist]  # the waist was moving when the arm motion began
    a_dt = ik.box.a_max[waist] * DT
    speeds = []
    for _ in range(400):
        kin.update(q)
        ref = reference(ik, q, v)
        result = ik.solve(q, v)
        assert result.ok and ref is not None
        assert np.abs(result.velocity - ref).max() < 1e-7
        speeds.append(np.abs(result.velocity[waist]))
        v = result.velocity
        q = q + v * DT
    speeds_arr = np.array(speeds)
    assert np.all(np.diff(speeds_arr, axis=0) <= 0.0)  # braking, never speeding up
    assert np.all(speeds_arr[0] == np.abs(0.3 * ik.box.v_max[waist]) - a_dt)
    assert np.all(speeds_arr[-1] == 0.0)  # then exactly still
    assert np.all(v[frozen] == 0.0) and not np.any(np.signbit(v[frozen]))


def test_masked_and_ranged_axes_give_the_full_qps_answer():
    kin = kinematics("smartpal5")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    frozen = frozen_units(kin, [UnitType.RIGHT_ARM, UnitType.LUMBER])
    ry = RedundantAxis.LUMBAR_RY
    x = axis_value(kin, ry)
    ik.configure(frozen, {RedundantAxis.RIGHT_ELBOW: False}, {ry: (x - 0.01, x + 0.01)})
    assert ik.solver.m == 2  # the masked elbow and the ranged waist pitch; idle rows left out
    hand = shifted(kin.pose(RightLeft.RIGHT), [0.1, 0, 0.1], [0, 0, 0])
    ik.tasks = [ControlPointTask(RightLeft.RIGHT, hand), PostureTask(kin.home(), np.arange(kin.nv))]
    q, _, _ = follow(ik, q, np.zeros(kin.nv), 400)
    kin.update(q)
    assert abs(axis_value(kin, ry) - x) <= 0.01 + 1e-9


def test_level_two_gives_the_full_qps_answer(robot_id: str):
    kin = kinematics(robot_id)
    side = RightLeft.RIGHT
    if not kin.has_elbow(side):
        pytest.skip(f"{robot_id} has no elbow angle")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.configure(frozen_units(kin, [UnitType.RIGHT_ARM]))
    axis = elbow_axis(side)
    elbow = AxisTask(axis, axis_value(kin, axis) + math.radians(5))
    ik.tasks = [ControlPointTask(side, kin.pose(side)), elbow, *arm_tasks(kin)[-1:]]
    follow(ik, q, np.zeros(kin.nv), 300, tol=1e-6)
    assert ik.solver2 is not None and ik.solver2.p == 6
    # Another layout of the same shape (the left arm instead): its level 2 is the solver
    # looked up for it, not the one kept from the last layout's solves.
    other = RightLeft.LEFT
    if kin.has_elbow(other):
        ik.configure(frozen_units(kin, [UnitType.LEFT_ARM]))
        axis = elbow_axis(other)
        elbow = AxisTask(axis, axis_value(kin, axis) + math.radians(5))
        ik.tasks = [ControlPointTask(other, kin.pose(other)), elbow, *arm_tasks(kin)[-1:]]
        ik.solve(q, np.zeros(kin.nv))
        assert ik._warm_for[level_two_key(ik)] is ik._layout  # looked up for this layout
        assert ik.solver2 is ik.solver_for(2, 6)


def level_two_key(ik: WholeBodyIK) -> tuple[int, int, int, int]:
    """The level-2 solver's key of the current layout (see WholeBodyIK.solver_for)."""
    return (ik._layout.n, ik._layout.m2, 6, 2)


def test_rows_of_frozen_joints_only_are_checked_not_solved():
    """RH's no-sideways row with the base frozen: at rest it holds; a base still rolling
    sideways when frozen makes the step fail, as the full QP is infeasible."""
    kin = kinematics("rh")
    q = kin.home()
    vx, vy, vt = kin.unit_indices(UnitType.VEHICLE)
    q[vt] = 0.7
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.configure(frozen_units(kin, [UnitType.RIGHT_ARM]))
    ik.tasks = arm_tasks(kin)
    assert ik.solver.m == 0
    follow(ik, q, np.zeros(kin.nv), 50)
    v = np.zeros(kin.nv)
    v[[vx, vy]] = 0.05, 0.0  # not along the heading: the row cannot hold while braking
    kin.update(q)
    assert reference(ik, q, v) is None
    result = ik.solve(q, v)
    assert not result.ok and np.array_equal(result.velocity, np.zeros(kin.nv))


def test_the_frozen_mask_changes_only_through_configure():
    """No second way to configure: the box's mask is read-only, ``configure`` sets it."""
    kin = kinematics("pa10")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.tasks = arm_tasks(kin)
    assert ik.solve(q, np.zeros(kin.nv)).ok
    with pytest.raises(ValueError, match="read-only"):
        ik.box.frozen[:3] = True
    with pytest.raises(AttributeError):
        ik.box.frozen = np.ones(kin.nv, dtype=bool)  # type: ignore[misc]
    frozen = np.zeros(kin.nv, dtype=bool)
    frozen[:3] = True
    ik.configure(frozen)
    assert np.array_equal(ik.box.frozen, frozen)
    result = ik.solve(q, np.zeros(kin.nv))
    assert result.ok and np.all(result.velocity[:3] == 0.0) and ik.solver.n == kin.nv - 3


def test_one_solver_per_problem_shape():
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    ik = WholeBodyIK(kin, DT)
    ik.configure(frozen_units(kin, [UnitType.RIGHT_ARM]))
    right = ik.solver
    ik.configure(frozen_units(kin, [UnitType.RIGHT_ARM, UnitType.LEFT_ARM]))
    both = ik.solver
    ik.configure(frozen_units(kin, [UnitType.LEFT_ARM]))  # same size as the right arm
    assert ik.solver is right and both is not right
    assert (right.n, right.m, both.n) == (7, 0, 14)


def test_a_task_whose_row_count_changes_is_laid_out_anew():
    class Growing(Task):
        level = 0

        def __init__(self, kin: Kinematics):
            self.kin = kin
            self.rows = 1
            self.weight = np.ones(1)

        def compute(self, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
            jac = np.zeros((self.rows, kin.nv))
            jac[np.arange(self.rows), np.arange(self.rows)] = 1.0
            return jac, np.full(self.rows, 0.01)

    kin = kinematics("pa10")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    task = Growing(kin)
    ik.tasks = [task]
    assert ik.solve(q, np.zeros(kin.nv)).ok
    task.rows, task.weight = 3, np.ones(3)
    result = ik.solve(q, np.zeros(kin.nv))
    assert result.ok
    assert np.abs(result.velocity - reference(ik, q, np.zeros(kin.nv))).max() < 1e-9


# ------------------------------------------------------------------------ the box
def test_assigning_a_limit_re_prepares_the_box():
    kin = kinematics("pa10")
    box = JointBox(kin, DT)
    q, v = kin.home(), np.zeros(kin.nv)
    assert np.array_equal(box.compute_qp_bounds(q, v)[1], box.a_max * DT)  # far from the limits
    box.a_max = box.a_max * 0.5
    assert np.array_equal(box.compute_qp_bounds(q, v)[1], box.a_max * DT)
    box.v_max = 0.25 * box.a_max * DT
    assert np.array_equal(box.compute_qp_bounds(q, v)[1], box.v_max)


def test_frozen_joints_at_rest_get_exactly_positive_zero():
    kin = kinematics("smartpal5")
    box = JointBox(kin, DT)
    box.configure(kin, ConstraintSetup(frozen_units(kin, [UnitType.RIGHT_ARM])))
    lb, ub = box.compute_qp_bounds(kin.home(), np.zeros(kin.nv))
    for bound in (lb, ub):
        assert np.all(bound[box.frozen] == 0.0) and not np.any(np.signbit(bound[box.frozen]))


# ---------------------------------------------------------------------- solvers
def random_qp(rng: np.random.Generator, n: int = 12, m: int = 4, p: int = 2):
    jac = rng.normal(size=(n + 3, n))
    H = jac.T @ jac + 1e-6 * np.eye(n)
    C = rng.normal(size=(m, n))
    lo, hi = np.full(m, -0.5), np.full(m, 0.5)
    lo[0] = hi[0] = 0.0
    A = rng.normal(size=(p, n))
    x0 = rng.uniform(-0.2, 0.2, n)
    x0 -= np.linalg.lstsq(C[:1], C[:1] @ x0, rcond=None)[0]  # C[0] x0 = 0
    return H, rng.normal(size=n), C, lo, hi, -np.ones(n), np.ones(n), A, A @ x0


def test_default_solver_is_daqp():
    assert DEFAULT_SOLVER == "daqp"
    assert isinstance(make_solver("daqp", 3, 1), DaqpSolver)
    assert isinstance(WholeBodyIK(kinematics("pa10"), DT).solver, DaqpSolver)


def test_daqp_agrees_with_proxqp_over_hot_started_solves():
    rng = np.random.default_rng(3)
    daqp_solver = DaqpSolver(12, 4, 2)
    ref = ProxQPSolver(12, 4, 2)
    H, g, C, lo, hi, lb, ub, A, b = random_qp(rng)
    for _ in range(50):
        g = g + 0.3 * rng.normal(size=g.size)
        x = daqp_solver.solve(H, g, C, lo, hi, lb, ub, A, b)
        y = ref.solve(H, g, C, lo, hi, lb, ub, A, b)
        assert x is not None and y is not None
        assert np.abs(x - y).max() < 1e-6
        assert within_limits(x, C, lo, hi, lb, ub, A, b)
        assert daqp_solver.iterations <= daqp_solver.max_iter


def test_daqp_failures_give_none_and_the_next_solve_recovers():
    rng = np.random.default_rng(4)
    solver = DaqpSolver(12, 4)
    H, g, C, lo, hi, lb, ub, _, _ = random_qp(rng)
    assert solver.solve(H, g, C, lo, hi, lb, ub) is not None
    C_bad = C.copy()
    C_bad[2] = C_bad[0]
    lo_bad, hi_bad = lo.copy(), hi.copy()
    lo_bad[2] = hi_bad[2] = 5.0  # contradicts row 0 (= 0)
    assert solver.solve(H, g, C_bad, lo_bad, hi_bad, lb, ub) is None
    assert solver.solve(-H, g, C, lo, hi, lb, ub) is None  # not convex
    assert solver.solve(H, g, C, lo, hi, lb, ub) is not None


def test_daqp_iteration_cap_bounds_the_work_and_keeps_only_feasible_iterates():
    rng = np.random.default_rng(5)
    H, g, C, lo, hi, lb, ub, _, _ = random_qp(rng)
    g = 50.0 * g  # drives many bounds active: a cold start needs several iterations
    free = DaqpSolver(12, 4)
    assert free.solve(H, g, C, lo, hi, lb, ub) is not None
    assert free.iterations > 2
    capped = DaqpSolver(12, 4, max_iter=2)
    x = capped.solve(H, g, C, lo, hi, lb, ub)
    assert capped.iterations <= 2
    assert x is None or within_limits(x, C, lo, hi, lb, ub, None, None)


def test_within_limits_checks_box_rows_and_equalities():
    C = np.array([[1.0, 1.0]])
    lo, hi = np.array([-1.0]), np.array([1.0])
    lb, ub = -np.ones(2), np.ones(2)
    A, b = np.array([[1.0, -1.0]]), np.array([0.0])
    assert within_limits(np.array([0.5, 0.5]), C, lo, hi, lb, ub, A, b)
    assert not within_limits(np.array([0.9, 0.9]), C, lo, hi, lb, ub, A, b)  # row
    assert not within_limits(np.array([0.5, 0.4]), C, lo, hi, lb, ub, A, b)  # equality
    assert not within_limits(np.array([1.5, 1.5]), C, lo, hi, lb, ub, None, None)  # box
    assert not within_limits(np.array([np.nan, 0.0]), C, lo, hi, lb, ub, None, None)


def test_proxqp_caps_its_inner_iterations_too():
    solver = ProxQPSolver(3, 1, max_iter=40)
    assert solver._qp.settings.max_iter == 40 and solver._qp.settings.max_iter_in == 40


def test_the_solvers_leave_the_callers_arrays_alone():
    rng = np.random.default_rng(6)
    problem = random_qp(rng)
    copies = [a.copy() for a in problem]
    for name in ("daqp", "proxqp"):
        solver = make_solver(name, 12, 4, 2)
        for _ in range(3):
            assert solver.solve(*problem) is not None
        assert all(np.array_equal(a, c) for a, c in zip(problem, copies, strict=True))


def test_daqp_refuses_an_empty_box_and_non_finite_data():
    rng = np.random.default_rng(7)
    H, g, C, lo, hi, lb, ub, _, _ = random_qp(rng)
    solver = DaqpSolver(12, 4)
    lb_bad = lb.copy()
    lb_bad[3] = ub[3] + 0.1
    assert solver.solve(H, g, C, lo, hi, lb_bad, ub) is None
    g_bad = g.copy()
    g_bad[0] = np.nan
    assert solver.solve(H, g_bad, C, lo, hi, lb, ub) is None
    assert solver.solve(H, g, C, lo, hi, lb, ub) is not None


def test_a_non_finite_position_gives_a_failed_step_not_nan():
    kin = kinematics("pa10")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.tasks = arm_tasks(kin)
    q_bad = q.copy()
    q_bad[2] = np.nan
    result = ik.solve(q_bad, np.zeros(kin.nv))
    assert not result.ok and np.array_equal(result.velocity, np.zeros(kin.nv))
    kin.update(q)
    assert ik.solve(q, np.zeros(kin.nv)).ok  # and the next cycle is fine again


def test_box_limits_cannot_be_changed_behind_its_back():
    box = JointBox(kinematics("pa10"), DT)
    with pytest.raises(ValueError, match="read-only"):
        box.v_max[0] = 0.0


# ----------------------------------------------------- motion starts (issue 14)
def _motion_setups(kin: Kinematics) -> list[tuple[np.ndarray, dict[RedundantAxis, bool]]]:
    """Configurations of SmartPal V's motions: right arm with the elbow held, both arms
    with the waist free, the right arm alone again."""
    right = frozen_units(kin, [UnitType.RIGHT_ARM])
    both = frozen_units(kin, [UnitType.RIGHT_ARM, UnitType.LEFT_ARM, UnitType.LUMBER])
    held = {elbow_axis(RightLeft.RIGHT): False}
    return [(right, held), (both, {}), (right, held)]


def test_a_configuration_seen_before_gets_its_layout_back_and_solves_as_the_reference():
    kin = kinematics("smartpal5")
    q, v = kin.home(), np.zeros(kin.nv)
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    layouts = []
    for frozen, allowed in _motion_setups(kin):
        kin.update(q)
        ik.tasks = arm_tasks(kin)  # a new motion: new tasks, as the motions make them
        ik.configure(frozen, allowed)
        layouts.append(ik._layout)
        q, v, _ = follow(ik, q, v, 15)
    assert layouts[2] is layouts[0] and layouts[1] is not layouts[0]
    assert ik.layouts.hits >= 1


def test_the_warm_start_stays_with_its_layout():
    kin = kinematics("smartpal5")
    q, v = kin.home(), np.zeros(kin.nv)
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.tasks = arm_tasks(kin)
    right = frozen_units(kin, [UnitType.RIGHT_ARM])
    ik.configure(right)
    q, v, _ = follow(ik, q, v, 5)
    solver = ik.solver
    assert isinstance(solver, DaqpSolver) and solver.warm
    ik.configure(np.ones(kin.nv, dtype=bool))  # held between two motions: nothing to solve
    ik.configure(right)
    assert ik.solver is solver and solver.warm  # the same problem: kept warm
    left = frozen_units(kin, [UnitType.LEFT_ARM])  # the same shape, another problem
    ik.configure(left)
    assert ik.solver is solver and not solver.warm  # cold
    follow(ik, q, v, 5)


def test_a_changed_configuration_never_reuses_a_stale_layout():
    kin = kinematics("smartpal5")
    q, v = kin.home(), np.zeros(kin.nv)
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.tasks = arm_tasks(kin)
    right = frozen_units(kin, [UnitType.RIGHT_ARM])
    ik.configure(right, {elbow_axis(RightLeft.RIGHT): False})
    held = ik._layout
    q, v, _ = follow(ik, q, v, 5)
    ik.configure(right)  # same joints, the elbow free: no held-axis row
    assert ik._layout is not held and ik._layout.m == held.m - 1
    q, v, _ = follow(ik, q, v, 5)
    ik.add(_NoRows())  # another constraint list: every layout laid out anew
    assert len(ik.layouts) == 1
    ik.configure(right, {elbow_axis(RightLeft.RIGHT): False})
    assert ik._layout is not held
    follow(ik, q, v, 5)


class _NoRows:
    """A constraint with no rows (changes the IK's constraint list, nothing else)."""

    name = "no rows"
    levels = Level.BOTH
    relaxation = Relaxation.HARD
    max_rows = 0
    joints = None
    holds_at_rest = True

    def configure(self, kin: Kinematics, setup: ConstraintSetup) -> None:
        pass

    def compute_qp_inequalities(self, cycle: CycleState, rows: RowBlock) -> int:
        return 0


def test_tasks_of_the_same_kinds_reuse_the_buffers_with_their_own_rows():
    kin = kinematics("smartpal5")
    q, v = kin.home(), np.zeros(kin.nv)
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.configure(frozen_units(kin, [UnitType.RIGHT_ARM, UnitType.LEFT_ARM]))
    ik.tasks = arm_tasks(kin)
    q, v, _ = follow(ik, q, v, 5)
    buffers = ik._plan.level1.jac
    ik.tasks = arm_tasks(kin, offset=-0.03)  # new tasks, same kinds: the same buffers
    q, v, _ = follow(ik, q, v, 5)
    assert ik._plan.level1.jac is buffers
    # A posture task over other joints (a constant J written once) gets its own rows.
    *cp, posture = arm_tasks(kin)
    arm = kin.unit_indices(UnitType.RIGHT_ARM)
    ik.tasks = [*cp, PostureTask(kin.home(), arm), posture]
    q, v, _ = follow(ik, q, v, 5)
    ik.tasks = [*cp, PostureTask(kin.home(), np.arange(len(arm))), posture]  # same rows
    assert ik._plan.level1.jac is not buffers
    follow(ik, q, v, 5)


def test_reconfiguring_the_box_with_the_same_frozen_joints_keeps_what_it_prepared():
    kin = kinematics("smartpal5")
    box = JointBox(kin, DT)
    q, v = kin.home(), np.full(kin.nv, 0.01)
    right = ConstraintSetup(frozen_units(kin, [UnitType.RIGHT_ARM]))
    box.configure(kin, right)
    box.compute_qp_bounds(q, v)
    prepared = box._off_q
    box.configure(kin, ConstraintSetup(right.frozen.copy()))
    left = ConstraintSetup(frozen_units(kin, [UnitType.LEFT_ARM]))
    box.configure(kin, left)  # other frozen joints: only their caps change
    lb, ub = box.compute_qp_bounds(q, v)
    assert box._off_q is prepared
    fresh = JointBox(kin, DT)
    fresh.configure(kin, left)
    for mine, theirs in zip((lb, ub), fresh.compute_qp_bounds(q, v), strict=True):
        assert np.array_equal(mine, theirs)
    box.dt = 2 * DT  # a limit input changed: everything anew
    fresh.dt = 2 * DT
    assert box.compute_qp_bounds(q, v)[1].tolist() == fresh.compute_qp_bounds(q, v)[1].tolist()
    assert box._off_q is not prepared

"""controller.qp.constraints.protocol in use: a constraint added to the IK with one class and
one registration, rows that come and go, levels, relaxation policies, checked rows."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import axis_value, elbow_axis
from controller.qp.constraints import (
    INF,
    ConstraintSetup,
    CycleState,
    Level,
    Relaxation,
    RowBlock,
)
from controller.qp.ik import WholeBodyIK
from controller.qp.tasks import AxisTask, ControlPointTask
from controller.vocabulary import RightLeft, UnitType
from tests.support import kinematics
from tests.test_ik_speed_paths import arm_tasks, follow, frozen_units

DT = 0.002


class JointRows:
    """Test constraint: row i bounds joint ``joints[i]``'s velocity [rad/s] to
    ``[v_prev + lo[i], v_prev + hi[i]]`` (``relative``) or ``[lo[i], hi[i]]``; the first
    ``count(cycle)`` rows are reported."""

    holds_at_rest = False

    def __init__(
        self,
        name: str,
        joints: list[int],
        lo: list[float],
        hi: list[float],
        levels: Level = Level.BOTH,
        relaxation: Relaxation = Relaxation.HARD,
        relative: bool = False,
    ):
        self.name = name
        self.levels = levels
        self.relaxation = relaxation
        self.max_rows = len(joints)
        self.joints: np.ndarray | None = None
        self._on = np.array(joints)
        self._lo, self._hi = np.array(lo), np.array(hi)
        self.relative = relative
        self.setups: list[ConstraintSetup] = []
        self.calls = 0

    def count(self, cycle: CycleState) -> int:
        return self.max_rows

    def configure(self, kin: Kinematics, setup: ConstraintSetup) -> None:
        self.setups.append(setup)

    def compute_qp_inequalities(self, cycle: CycleState, rows: RowBlock) -> int:
        self.calls += 1
        k = self.count(cycle)
        on = self._on[:k]
        rows.C[:k] = 0.0
        rows.C[np.arange(k), on] = 1.0
        base = cycle.v_prev[on] if self.relative else 0.0
        rows.lo[:k] = base + self._lo[:k]
        rows.hi[:k] = base + self._hi[:k]
        return k


class ComingAndGoing(JointRows):
    """Rows "keep your velocity" on the first joints, as many as the position dictates
    (0 to all, changing from cycle to cycle, the same for the IK and the reference)."""

    def __init__(self, joints: list[int]):
        zeros = [0.0] * len(joints)
        super().__init__("coasting joints", joints, zeros, zeros, relative=True)
        self.counts: list[int] = []

    def count(self, cycle: CycleState) -> int:
        k = int(1e6 * abs(float(cycle.q[-1]))) % (self.max_rows + 1)
        self.counts.append(k)
        return k


def test_an_added_constraint_is_enforced_as_in_the_full_qp():
    """A Cartesian limit in a few lines: the right hand may not move down."""

    class NoDescent:
        name = "hand never moves down"
        levels = Level.BOTH
        relaxation = Relaxation.NO_FURTHER
        max_rows = 1
        joints = None
        holds_at_rest = True

        def configure(self, kin: Kinematics, setup: ConstraintSetup) -> None:
            pass

        def compute_qp_inequalities(self, cycle: CycleState, rows: RowBlock) -> int:
            rows.C[0] = cycle.kin.jacobian(RightLeft.RIGHT)[2]  # vertical velocity [m/s]
            rows.lo[0], rows.hi[0] = 0.0, INF
            return 1

    kin = kinematics("pa10")
    q = kin.home()
    kin.update(q)
    start = kin.pose(RightLeft.RIGHT).translation.copy()
    ik = WholeBodyIK(kin, DT)
    ik.tasks = arm_tasks(kin, offset=0.04)  # the target is 4 cm below
    ik.add(NoDescent())
    assert ik.solver.m == 1
    q, _, _ = follow(ik, q, np.zeros(kin.nv), 400)
    kin.update(q)
    end = kin.pose(RightLeft.RIGHT).translation
    assert end[2] > start[2] - 1e-6  # held up (to second order of the linearisation)
    assert np.linalg.norm(end[:2] - start[:2]) > 0.03  # while moving sideways


def test_rows_that_come_and_go_keep_one_solver_and_the_full_qps_answer():
    kin = kinematics("pa10")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.tasks = arm_tasks(kin)
    rows = ComingAndGoing([0, 1, 2])
    ik.add(rows)
    solver = ik.solver
    assert solver.m == 3  # the most rows it can report
    follow(ik, q, np.zeros(kin.nv), 300)
    assert ik.solver is solver
    counts = set(rows.counts)
    assert counts == {0, 1, 2, 3}  # every count was seen, with fewer rows after more


def test_each_level_gets_the_rows_of_the_constraints_in_it():
    kin = kinematics("smartpal5")
    side = RightLeft.RIGHT
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.configure(frozen_units(kin, [UnitType.RIGHT_ARM]))
    arm = kin.unit_indices(UnitType.RIGHT_ARM)
    a = 0.5 * float(ik.box.a_max[arm].min()) * DT  # half the acceleration limit per cycle
    first = JointRows("first", [arm[0]], [-a], [a], Level.FIRST, relative=True)
    second = JointRows("second", [arm[1], arm[2]], [-a] * 2, [a] * 2, Level.SECOND, relative=True)
    both = JointRows("both", [arm[3]], [-a], [a], Level.BOTH, relative=True)
    for c in (second, both, first):
        ik.add(c)
    axis = elbow_axis(side)
    elbow = AxisTask(axis, axis_value(kin, axis) + math.radians(5))
    ik.tasks = [ControlPointTask(side, kin.pose(side)), elbow, *arm_tasks(kin)[-1:]]
    follow(ik, q, np.zeros(kin.nv), 200, tol=1e-6)
    assert ik.solver.m == 2  # first and both
    assert ik.solver2 is not None and ik.solver2.m == 3  # both and second


def relaxation_case(
    policy: Relaxation, other: tuple[float, float]
) -> tuple[WholeBodyIK, np.ndarray, float, int]:
    """Two constraints on one joint's velocity that conflict: "wish" [0.5a, 0.8a] with
    ``policy``, and a hard one ``other`` (in units of a = a_max·dt); one step from rest."""
    kin = kinematics("pa10")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.tasks = arm_tasks(kin)
    j = 1
    a = float(ik.box.a_max[j]) * DT
    ik.add(JointRows("wish", [j], [0.5 * a], [0.8 * a], relaxation=policy))
    ik.add(JointRows("hard", [j], [other[0] * a], [other[1] * a]))
    return ik, q, a, j


def test_a_no_further_constraint_is_widened_to_contain_rest():
    ik, q, a, j = relaxation_case(Relaxation.NO_FURTHER, (-0.8, 0.2))
    result = ik.solve(q, np.zeros(ik.kin.nv))
    assert result.ok and result.message == "wish relaxed to 'no further' this cycle"
    assert -1e-12 <= result.velocity[j] <= 0.2 * a + 1e-12


def test_a_no_further_constraint_is_never_dropped():
    ik, q, _, _ = relaxation_case(Relaxation.NO_FURTHER, (-0.8, -0.1))
    result = ik.solve(q, np.zeros(ik.kin.nv))
    assert not result.ok and np.array_equal(result.velocity, np.zeros(ik.kin.nv))


def test_a_droppable_constraint_is_left_out_when_widening_is_not_enough():
    ik, q, a, j = relaxation_case(Relaxation.NO_FURTHER_THEN_DROP, (-0.8, -0.1))
    result = ik.solve(q, np.zeros(ik.kin.nv))
    assert result.ok and result.message == "wish not enforced this cycle (conflicting rows)"
    assert -0.8 * a - 1e-12 <= result.velocity[j] <= -0.1 * a + 1e-12


def test_hard_constraints_never_give():
    ik, q, _, _ = relaxation_case(Relaxation.HARD, (-0.8, 0.2))
    result = ik.solve(q, np.zeros(ik.kin.nv))
    assert not result.ok and "infeasible" in result.message


@pytest.mark.parametrize("holds", [True, False])
def test_a_constraint_on_frozen_joints_only_is_checked_not_solved(holds: bool):
    kin = kinematics("pa10")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.tasks = arm_tasks(kin)
    # Joint 0 may only move forward: at rest that holds when 0 is allowed.
    rows = JointRows("forward", [0], [0.0 if holds else 0.1], [0.2])
    rows.joints = np.array([0])
    rows.holds_at_rest = holds
    ik.add(rows)
    frozen = np.zeros(kin.nv, dtype=bool)
    frozen[0] = True
    ik.configure(frozen)
    assert ik.solver.m == 0  # not in the QP
    calls = rows.calls
    result = ik.solve(q, np.zeros(kin.nv))
    assert result.ok == holds
    assert rows.calls == calls + (0 if holds else 1)  # at rest, holding: not evaluated
    if holds:  # joint 0 still rolling backward when frozen: the row cannot hold
        v = np.zeros(kin.nv)
        v[0] = -0.5 * ik.box.v_max[0]
        result = ik.solve(q, v)
        assert not result.ok and "frozen" in result.message


def test_registered_constraints_get_every_configuration():
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    ik = WholeBodyIK(kin, DT)
    frozen = frozen_units(kin, [UnitType.RIGHT_ARM])
    ik.configure(frozen)
    rows = JointRows("any", [0], [-1.0], [1.0])
    ik.add(rows)
    assert np.array_equal(rows.setups[-1].frozen, frozen)  # configured when added
    axis = elbow_axis(RightLeft.RIGHT)
    ik.configure(~frozen, {axis: False}, {})
    assert np.array_equal(rows.setups[-1].frozen, ~frozen)
    assert rows.setups[-1].allowed == {axis: False}
    assert ik.constraints[-1] is rows

"""controller.qp.constraints.collision: velocity-damper rows on the collision distances."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from controller.model.collision import CollisionDistances
from controller.model.profile import CollisionAvoidance as Settings
from controller.qp.constraints import INF, ConstraintSetup, CycleState, Level, Relaxation, RowBlock
from controller.qp.constraints.braking import BRAKING_SHARE
from controller.qp.constraints.collision import CollisionAvoidance, collision_avoidance
from controller.qp.ik import WholeBodyIK
from controller.qp.tasks import ControlPointTask
from controller.vocabulary import RightLeft
from tests.support import kinematics
from tests.test_collision import toy

#: Every test with the compiled kernels and with coal alone.
pytestmark = pytest.mark.usefixtures("jit_backend")

DT = 0.002
#: d_i, d_s [m], ξ [m/s] of the toy; its one joint accelerates at A [m/s²].
D_I, D_S, XI, A = 0.1, 0.01, 0.3, 2.0
SPAN = D_I - D_S


class Toy:
    """Two spheres on a slider: distance ``gap + q`` [m], ``d' = v`` (one joint, world base)."""

    def __init__(self, gap: float = 0.0, accel: float = A, **settings: Any):
        model, source = toy(gap)
        self.model = model
        self.dist = CollisionDistances(model, source, [("base", "slider")])
        kin: Any = SimpleNamespace(
            robot=SimpleNamespace(joints={"x": SimpleNamespace(acceleration=accel)}),
            joint_names=["x"],
        )
        values = {"influence": D_I, "security": D_S, "damping": XI, **settings}
        self.c = CollisionAvoidance(kin, self.dist, Settings(**values), DT)
        self.c.configure(kin, ConstraintSetup(np.zeros(1, dtype=bool)))
        self.rows = RowBlock(np.zeros((1, 1)), np.zeros(1), np.zeros(1))

    def step(self, q: float, v_prev: float, box: tuple[float, float] | None = None) -> int:
        """The rows at position ``q`` [m] after a commanded ``v_prev`` [m/s]."""
        self.dist.compute(np.array([q]))
        lb, ub = (None, None) if box is None else (np.array([box[0]]), np.array([box[1]]))
        cycle = CycleState(None, np.array([q]), np.array([v_prev]), lb, ub)  # type: ignore[arg-type]
        return self.c.compute_qp_inequalities(cycle, self.rows)

    @property
    def lo(self) -> float:
        return float(self.rows.lo[0])


def test_policy_levels_and_rest() -> None:
    c = Toy().c
    assert c.levels == Level.BOTH
    assert c.relaxation == Relaxation.NO_FURTHER  # never dropped
    assert c.holds_at_rest and c.max_rows == 1


def test_no_row_outside_the_influence_distance() -> None:
    t = Toy()
    assert t.step(D_I + 0.001, 0.0) == 0
    assert t.step(D_I - 0.001, 0.0) == 1
    np.testing.assert_allclose(t.rows.C, [[1.0]], atol=1e-12)  # d' = v
    assert t.rows.hi[0] == INF


@pytest.mark.parametrize("d", [0.09, 0.05, 0.02, 0.011])
def test_the_damper_at_rest(d: float) -> None:
    t = Toy()
    t.step(d, 0.0)
    assert t.lo == pytest.approx(-XI * (d - D_S) / SPAN, rel=1e-9)


def test_the_damper_gain_is_lowered_to_what_the_joints_can_decelerate() -> None:
    """ξ² / (d_i − d_s) is the damper's deceleration at d_i: it never exceeds a_k."""
    slow = 0.5  # m/s²: a_k = BRAKING_SHARE · 0.5
    t = Toy(accel=slow)
    t.step(0.05, 0.0)
    xi = math.sqrt(BRAKING_SHARE * slow * SPAN)
    assert xi < XI
    assert t.lo == pytest.approx(-xi * (0.05 - D_S) / SPAN, rel=1e-9)
    assert xi**2 / SPAN <= BRAKING_SHARE * slow * (1 + 1e-12)


def test_activation_never_infeasible_then_relaxes_back_at_the_deceleration_bound() -> None:
    """Entering at 1 m/s (the damper allows 0.3): the first row holds for the current
    velocity; then the allowance shrinks by at most a·dt per cycle, down to the damper,
    and with a deceleration that can stop the pair within d_i − d_s it stops before d_s."""
    accel = 20.0  # a = 10 m/s²: 1 m/s stops within 5 cm
    t = Toy(accel=accel)
    a = BRAKING_SHARE * accel
    q, v = D_I - 1e-4, -1.0
    t.step(q, v)
    assert t.lo == pytest.approx(v, abs=1e-12)  # v_prev satisfies the row exactly
    previous = t.lo
    cycles = 0
    while True:  # follow the row's bound exactly (the most approach it allows)
        v = t.lo
        q += v * DT
        t.step(q, v)
        assert t.lo >= previous - 1e-12  # never asks for more approach than before
        assert t.lo - previous <= a * DT + 1e-12  # never more deceleration than a
        assert q > D_S
        damper = -XI * (q - D_S) / SPAN
        if t.lo == pytest.approx(damper, abs=1e-12):
            break
        previous = t.lo
        cycles += 1
        assert cycles < 10_000
    assert cycles > 10  # it did relax gradually


def test_too_fast_for_half_the_deceleration_it_brakes_harder_within_the_joints_limit() -> None:
    """Entering at 0.5 m/s with 1 m/s² (half the joint's 2 m/s²) would need 12.5 cm: the
    allowance shrinks faster, never by more than the joint's own 2 m/s², and the pair
    stops before d_s."""
    t = Toy()
    q, v = D_I - 1e-4, -0.5
    t.step(q, v)
    previous = t.lo
    steps = []
    for _ in range(5000):
        v = t.lo
        q += v * DT
        assert q > D_S
        t.step(q, v)
        steps.append(t.lo - previous)
        previous = t.lo
    assert max(steps) <= A * DT + 1e-12
    assert max(steps) > BRAKING_SHARE * A * DT * 1.2  # it did brake harder than a
    assert t.lo == pytest.approx(0.0, abs=1e-4)


def test_a_slower_approach_lowers_the_allowance_at_once() -> None:
    t = Toy()
    t.step(0.09, -1.0)
    t.step(0.09 - 1e-3, -0.05)  # the robot slowed down by itself
    damper = XI * (0.089 - D_S) / SPAN
    assert t.lo == pytest.approx(-max(damper, 0.05), abs=1e-12)


@pytest.mark.parametrize("d", [D_S - 1e-9, D_S / 2, -0.01])
def test_below_the_security_distance_no_further_closer_never_pushed_apart(d: float) -> None:
    t = Toy()
    t.step(d, 0.0)
    assert t.lo == 0.0  # no further closer, moving apart allowed, not asked
    t = Toy()
    t.step(D_I - 1e-4, -0.2)
    q = D_I - 1e-4
    for _ in range(2000):
        assert t.lo <= 0.0  # never a push apart
        q = max(q + t.lo * DT, d)
        t.step(q, t.lo)
    assert t.lo == pytest.approx(0.0, abs=1e-5)  # at rest by d_s (or held at d)


def test_a_row_never_asks_what_the_joint_box_cannot_give() -> None:
    t = Toy()
    t.step(0.05, 0.0, box=(-1.0, -0.5))  # the box only allows approaching at ≥ 0.5 m/s
    assert -1.0 <= t.lo <= -0.5


def test_a_pair_that_leaves_and_comes_back_starts_afresh() -> None:
    t = Toy()
    t.step(0.09, -1.0)
    assert t.lo == pytest.approx(-1.0)
    assert t.step(0.2, 0.0) == 0
    t.step(0.09, 0.0)
    assert t.lo == pytest.approx(-XI * 0.08 / SPAN, rel=1e-9)


def test_more_pairs_than_rows_keeps_the_closest() -> None:
    k = kinematics("smartpal5")
    c = collision_avoidance(k, DT)
    assert c is not None
    c.max_rows = 3
    c.influence = 10.0  # every pair in range
    q = k.home()
    k.update(q)
    c.distances.update(k.data, k.q)
    nv = k.nv
    rows = RowBlock(np.zeros((3, nv)), np.zeros(3), np.zeros(3))
    assert c.compute_qp_inequalities(CycleState(k, q, np.zeros(nv)), rows) == 3
    d = c.distances.distances
    assert sorted(d[c.pairs]) == pytest.approx(sorted(d)[:3])
    np.testing.assert_allclose(rows.C, c.distances.jacobian(c.pairs), atol=1e-12)


def test_in_the_ik_a_hand_driven_into_the_other_stops_at_the_security_distance() -> None:
    """SmartPal V, both hands driven towards one point between them (ideal integration):
    the hands' shapes never come closer than d_s, the rows bind and name the pair."""
    k = kinematics("smartpal5")
    ik = WholeBodyIK(k, DT)
    c = collision_avoidance(k, DT)
    assert c is not None
    ik.add(c)
    settings = k.robot.profile.collision_avoidance
    q = k.home()
    k.update(q)
    right, left = k.pose(RightLeft.RIGHT), k.pose(RightLeft.LEFT)
    middle = 0.5 * (right.translation + left.translation)
    tasks = []
    for pose, side in ((right, RightLeft.RIGHT), (left, RightLeft.LEFT)):
        target = pose.copy()
        target.translation = middle
        tasks.append(ControlPointTask(side, target))
    ik.tasks = tasks
    ik.configure(np.zeros(k.nv, dtype=bool))
    v = np.zeros(k.nv)
    closest = np.inf
    bound = 0
    for _ in range(1500):
        k.update(q)
        c.distances.update(k.data, k.q)
        closest = min(closest, float(c.distances.distances.min()))
        result = ik.solve(q, v)
        assert result.ok, result.message
        v = result.velocity
        bound += c.binding(v) >= 0
        q = q + v * DT
    assert closest >= settings.security - 1e-4
    assert bound > 100
    pair = c.binding(v)
    assert pair >= 0
    assert c.distances.distances[pair] == pytest.approx(settings.security, abs=2e-3)


def test_collision_rows_cost_nothing_without_pairs_in_range() -> None:
    k = kinematics("pa10")
    c = collision_avoidance(k, DT)
    assert c is not None
    k.update(k.home())
    c.distances.update(k.data, k.q)
    rows = RowBlock(np.zeros((c.max_rows, k.nv)), np.zeros(c.max_rows), np.zeros(c.max_rows))
    n = int(np.count_nonzero(c.distances.distances < c.influence))
    assert c.compute_qp_inequalities(CycleState(k, k.q, np.zeros(k.nv)), rows) == n


def test_rows_and_box_always_have_a_common_solution() -> None:
    """Many pairs in range, random velocities: whatever the rows ask, one velocity of the
    cycle's joint box satisfies all of them (checked with an LP)."""
    from scipy.optimize import linprog

    from controller.qp.constraints import JointBox

    k = kinematics("smartpal5")
    c = collision_avoidance(k, DT)
    assert c is not None
    c.influence, c.max_rows = 0.3, 16  # many rows at once
    box = JointBox(k, DT)
    rng = np.random.default_rng(4)
    v_max = np.array([k.robot.joints[n].velocity for n in k.joint_names])
    rows = RowBlock(np.zeros((16, k.nv)), np.zeros(16), np.zeros(16))
    asked = 0
    for _ in range(60):
        q = k.home() + rng.normal(0.0, 0.3, k.nv)
        q = np.clip(q, box.q_min + 1e-3, box.q_max - 1e-3)
        v = rng.uniform(-v_max, v_max)
        lb, ub = box.compute_qp_bounds(q, v)
        k.update(q)
        c.distances.update(k.data, k.q)
        n = c.compute_qp_inequalities(CycleState(k, q, v, lb, ub), rows)
        live = rows.lo[:n] > -INF
        asked += int(np.count_nonzero(rows.lo[:n][live] > rows.C[:n][live].dot(v)))
        C, lo = rows.C[:n][live], rows.lo[:n][live]
        result = linprog(np.zeros(k.nv), A_ub=-C, b_ub=-lo, bounds=list(zip(lb, ub, strict=True)))
        assert result.status == 0, result.message
    assert asked > 20  # the rows did ask for braking beyond the current velocity

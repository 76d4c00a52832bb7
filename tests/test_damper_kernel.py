"""controller.qp.constraints.damper_kernel: the compiled rows equal the NumPy path's."""

from __future__ import annotations

import numpy as np
import pytest

from controller.model import jit
from controller.qp.constraints import ConstraintSetup, CycleState, JointBox, RowBlock
from controller.qp.constraints.collision import CollisionAvoidance, collision_avoidance
from tests.support import kinematics

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba not installed")

DT = 0.002
ROWS = 200  # more than the robots have pairs: nothing is cut


def pair(monkeypatch: pytest.MonkeyPatch, robot_id: str) -> tuple[CollisionAvoidance, ...]:
    """The same constraint twice: on compiled distances, and on coal's (the NumPy path)."""
    kin = kinematics(robot_id)
    compiled = collision_avoidance(kin, DT)
    monkeypatch.setenv("IMOTION_JIT", "0")
    numpy_path = collision_avoidance(kin, DT)
    monkeypatch.delenv("IMOTION_JIT")
    assert compiled is not None and numpy_path is not None
    assert compiled.distances.compiled and not numpy_path.distances.compiled
    compiled.screen = False  # every pair computed (the screen: test_collision_screen.py)
    return compiled, numpy_path


@pytest.mark.parametrize("robot_id", ["smartpal5", "seednoid"])
@pytest.mark.parametrize("with_box", [True, False])
def test_same_rows_pairs_and_allowances_over_a_walk(
    robot_id: str, with_box: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A random walk through many pairs in range (d_i 0.25 m), some joints frozen: every
    cycle the same count, rows, bounds, pairs in range and allowances. (Rows for every pair
    here: which of two pairs at the same distance is kept when rows run short may differ
    between the back ends, whose distances differ by ~1e-11 m.)"""
    kin = kinematics(robot_id)
    a, b = pair(monkeypatch, robot_id)
    frozen = np.zeros(kin.nv, dtype=bool)
    frozen[:3] = True  # the vehicle
    for c in (a, b):
        c.influence, c.max_rows = 0.25, ROWS
        c.configure(kin, ConstraintSetup(frozen))
    box = JointBox(kin, DT)
    rng = np.random.default_rng(7)
    v_max = np.array([kin.robot.joints[n].velocity for n in kin.joint_names])
    q = kin.home()
    v = np.zeros(kin.nv)
    rows_a = RowBlock(np.zeros((ROWS, kin.nv)), np.zeros(ROWS), np.zeros(ROWS))
    rows_b = RowBlock(np.zeros((ROWS, kin.nv)), np.zeros(ROWS), np.zeros(ROWS))
    reported = dropped = 0
    for step in range(150):
        if step % 30 == 0:  # now and then a jump: pairs leave and come back
            q = np.clip(kin.home() + rng.normal(0.0, 0.4, kin.nv), box.q_min, box.q_max)
        v = np.clip(v + rng.normal(0.0, 0.2, kin.nv), -0.5 * v_max, 0.5 * v_max)
        v[frozen] = 0.0
        q = np.clip(q + v * DT * 5, box.q_min, box.q_max)
        lb, ub = box.compute_qp_bounds(q, v) if with_box else (None, None)
        kin.update(q)
        counts = []
        for c, rows in ((a, rows_a), (b, rows_b)):
            c.distances.update(kin.data, kin.q)
            counts.append(c.compute_qp_inequalities(CycleState(kin, q, v, lb, ub), rows))
        n = counts[0]
        assert counts[1] == n
        np.testing.assert_array_equal(a.pairs, b.pairs)
        np.testing.assert_array_equal(a.row_pairs, b.row_pairs)
        np.testing.assert_allclose(rows_a.C[:n], rows_b.C[:n], atol=1e-9)
        np.testing.assert_allclose(rows_a.lo[:n], rows_b.lo[:n], atol=1e-7)
        np.testing.assert_array_equal(rows_a.hi[:n], rows_b.hi[:n])
        np.testing.assert_allclose(a.allowed, b.allowed, atol=1e-7)  # [m/s]
        for rows in (rows_a, rows_b):  # rows not reported are free
            assert (rows.lo[n : len(a.pairs)] <= -1e19).all()
        held = a.binding(v), b.binding(v)  # the closest binding pair (ties: either)
        assert (held[0] < 0) == (held[1] < 0)
        if held[0] >= 0:
            da, db = a.distances.distances[held[0]], b.distances.distances[held[1]]
            assert da == pytest.approx(db, abs=1e-9)
        reported += n
        dropped += len(a.pairs) - n
    assert reported > 100
    if with_box:
        assert dropped > 0  # rows the box implies were left out
    else:
        assert dropped == 0


def test_the_compiled_binding_pair_is_the_numpy_one() -> None:
    """damper_kernel.binding against CollisionAvoidance.binding's NumPy steps on random
    rows: ties go to the first row, NaN distances and slacks never bind."""
    from controller.qp.constraints.damper_kernel import binding

    rng = np.random.default_rng(9)
    tol = 1e-5
    found = 0
    for trial in range(300):
        k, nv, pairs = 6, 5, 12
        C = rng.normal(size=(8, nv))
        v = rng.normal(size=nv)
        low = rng.normal(size=8)
        lo = low + rng.choice([0.0, 1.0], size=8)
        lo[:k] = np.where(rng.random(k) < 0.5, (C[:k] @ v), lo[:k])  # some rows at their bound
        d = rng.choice([0.01, 0.02, 0.05, np.nan], size=pairs)
        row_pairs = rng.choice(pairs, size=8, replace=False).astype(np.int64)
        within = 0.04
        got = binding(C, k, v, lo, low, d, row_pairs, within, tol)
        slack = C[:k].dot(v) - lo[:k]
        tight = np.flatnonzero(
            (slack < tol) & (lo[:k] > low[:k] + tol) & (d[row_pairs[:k]] < within)
        )
        want = -1 if not len(tight) else int(row_pairs[tight][np.argmin(d[row_pairs[tight]])])
        assert got == want, trial
        found += want >= 0
    assert found > 30

"""controller.motion.posture: the null-space objective shared by the path check and the loop."""

from __future__ import annotations

import numpy as np
import pytest

from controller.motion.motions import follow_posture
from controller.motion.posture import (
    LIMIT_ZONE,
    MAX_WEIGHT,
    PosturePath,
    limit_weights,
    null_step,
    off_limits,
)
from controller.qp.tasks import PostureTask
from controller.vocabulary import RightLeft, UnitType
from tests.support import kinematics

LO, HI = np.array([-1.0, -1.0, -1.0, -1.0, -np.inf]), np.array([1.0, 1.0, 1.0, 1.0, np.inf])


def test_weights_are_one_at_mid_range_and_grow_toward_either_limit():
    w = limit_weights(np.array([0.0, 0.5, 0.9, -0.99, 7.0]), LO, HI)
    assert w[0] == pytest.approx(1.0)
    assert w[4] == 1.0  # no finite limits
    assert 1.0 < w[1] < w[2] < w[3] < MAX_WEIGHT
    mirrored = limit_weights(np.array([-0.5, -0.9]), LO[:2], HI[:2])
    np.testing.assert_allclose(mirrored, w[1:3])


def test_weights_at_or_beyond_a_limit_are_the_largest():
    w = limit_weights(np.array([1.0, -1.0, 1.5, 0.0, 0.0]), LO, HI)
    np.testing.assert_array_equal(w[:3], MAX_WEIGHT)


def test_the_null_step_keeps_the_tasks_and_moves_only_free_joints():
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    jac = kin.jacobian(RightLeft.RIGHT)
    free = np.zeros(kin.nv, dtype=bool)
    free[kin.unit_indices(UnitType.RIGHT_ARM)] = True
    rng = np.random.default_rng(3)
    target = kin.q + rng.normal(0.0, 0.1, kin.nv)
    step = null_step(jac, free, kin.q, target, np.ones(kin.nv))
    assert np.abs(jac @ step).max() < 1e-9
    assert np.all(step[~free] == 0.0)
    assert np.linalg.norm(step) > 1e-3  # a 7-axis arm has one degree of redundancy
    # Closest to the target in the null space: what is left is orthogonal to it.
    assert abs((target - kin.q - step)[free] @ step[free]) < 1e-9


def test_a_heavy_joint_keeps_nearer_its_posture():
    """The arm's posture asks joint ``a`` to move, which the self-motion can do only by
    moving ``b`` too; ``b`` heavy (near its limit) moves less, it stays nearer its posture.
    (Off home: there the wrist's first and last joints are in line, a second self-motion.)"""
    kin = kinematics("smartpal5")
    arm = kin.unit_indices(UnitType.RIGHT_ARM)
    q = kin.home()
    q[arm] += [0.1, -0.2, 0.2, 0.1, 0.3, 0.3, -0.2]
    kin.update(q)
    jac = kin.jacobian(RightLeft.RIGHT)
    free = np.zeros(kin.nv, dtype=bool)
    free[arm] = True
    swivel = null_step(jac, free, kin.q, kin.q + 1.0, np.ones(kin.nv))
    a, b = (int(arm[k]) for k in np.argsort(-np.abs(swivel[arm]))[:2])
    posture = kin.q.copy()
    posture[a] += 0.2
    even = null_step(jac, free, kin.q, posture, np.ones(kin.nv))
    weights = np.ones(kin.nv)
    weights[b] = 100.0
    heavy = null_step(jac, free, kin.q, posture, weights)
    assert abs(even[b]) > 1e-3
    assert abs(heavy[b]) < 0.1 * abs(even[b])


def test_no_redundancy_no_step_and_zero_rows_take_none_away():
    jac = np.eye(3)
    step = null_step(jac, np.ones(3, dtype=bool), np.zeros(3), np.ones(3), np.ones(3))
    np.testing.assert_allclose(step, 0.0, atol=1e-8)
    # 2 tasks on 3 joints, plus a row of zeros (a held axis of a frozen unit): one free
    # direction left, and the step takes it.
    rows = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    step = null_step(rows, np.ones(3, dtype=bool), np.zeros(3), np.ones(3), np.ones(3))
    np.testing.assert_allclose(step, [0.0, 0.0, 1.0], atol=1e-8)


def test_a_posture_path_interpolates_and_clamps():
    path = PosturePath(np.array([0.0, 0.5, 1.0]), np.array([[0.0, 0.0], [1.0, 2.0], [1.0, 4.0]]))
    np.testing.assert_allclose(path.at(0.25), [0.5, 1.0])
    np.testing.assert_allclose(path.at(0.75), [1.0, 3.0])
    np.testing.assert_allclose(path.at(-1.0), [0.0, 0.0])
    np.testing.assert_allclose(path.at(2.0), [1.0, 4.0])
    with pytest.raises(ValueError, match="increase"):
        PosturePath(np.array([0.0, 0.0]), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="two samples"):
        PosturePath(np.array([0.0]), np.zeros((1, 2)))


@pytest.mark.usefixtures("jit_backend")
def test_the_loop_posture_follows_the_path_then_stands():
    path = PosturePath(np.array([0.0, 1.0]), np.array([[0.0, 0.0], [1.0, -1.0]]))
    task = PostureTask(np.zeros(2), np.arange(2))
    follow_posture(task, path, 0.5, 0.6, 0.01)
    np.testing.assert_allclose(task.reference, [0.5, -0.5])
    np.testing.assert_allclose(task.rate, [10.0, -10.0])
    task.reference[:] = [0.7, 0.7]  # the core holds the posture it has at the end
    follow_posture(task, path, 1.0, 1.0, 0.01)
    np.testing.assert_allclose(task.reference, [0.7, 0.7])
    np.testing.assert_array_equal(task.rate, 0.0)


def test_the_compiled_follow_matches_the_python_one_on_every_segment_and_past_the_ends():
    rng = np.random.default_rng(7)
    grid = np.concatenate([[0.0], np.sort(rng.uniform(0.0, 1.0, 8)), [1.0]])
    path = PosturePath(grid, rng.normal(size=(len(grid), 5)))
    joints = np.array([4, 0, 2])
    for s0 in [-0.5, 0.0, *rng.uniform(0.0, 1.0, 20), 1.0]:
        s1 = s0 + 0.013
        out = []
        for compiled in (True, False):
            path._compiled = compiled
            reference, rate = np.zeros(5), np.zeros(3)
            path.follow(s0, s1, 0.004, joints, reference, rate)
            out.append((reference, rate))
        np.testing.assert_allclose(out[0][0], out[1][0], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(out[0][1], out[1][1], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(out[1][0], path.at(s0), rtol=1e-12, atol=1e-15)


def test_off_limits_draws_a_posture_out_of_the_zones_by_the_end_of_the_path():
    lo, hi = np.array([-1.0, -1.0, -np.inf]), np.array([1.0, 1.0, np.inf])
    q = np.array([0.95, 0.0, 3.0])  # 0.05 from the upper limit; mid-range; unbounded
    np.testing.assert_allclose(off_limits(q, 0.0, lo, hi), q)
    end = off_limits(q, 1.0, lo, hi)
    np.testing.assert_allclose(end, [1.0 - LIMIT_ZONE * 2.0, 0.0, 3.0])
    np.testing.assert_allclose(off_limits(q, 0.5, lo, hi), 0.5 * (q + end))

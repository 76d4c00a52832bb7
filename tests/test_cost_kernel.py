"""controller.qp.cost_kernel: the compiled Hessian and gradient against their NumPy form."""

from __future__ import annotations

import numpy as np
import pytest

from controller.model import jit
from controller.qp.cost_kernel import least_squares
from controller.qp.ik import WholeBodyIK
from controller.qp.layout import Layout
from controller.qp.tasks import ControlPointTask, PostureTask
from controller.vocabulary import RightLeft, UnitType
from tests.support import kinematics

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba not installed")


def reference(jac, rate, weight, free, fixed, v_fixed, damping):
    """H = J_fᵀ W J_f + λI, g = −J_fᵀ W (e − J_x v_x), in NumPy."""
    target = rate - (jac[:, fixed].dot(v_fixed) if len(fixed) else 0.0)
    wjac = jac[:, free] * weight[:, None]
    return wjac.T.dot(jac[:, free]) + damping * np.eye(len(free)), -wjac.T.dot(target)


@pytest.mark.parametrize("moving", [False, True])
def test_the_kernel_gives_the_normal_equations_over_the_free_columns(moving: bool):
    rng = np.random.default_rng(3)
    m, nv = 11, 9
    jac = np.asfortranarray(rng.normal(size=(m, nv)))
    rate, weight = rng.normal(size=m), rng.uniform(1e-7, 2.0, m)
    free = np.array([0, 2, 3, 7, 8], dtype=np.int64)  # not contiguous
    fixed = np.array([1, 4, 5, 6], dtype=np.int64) if moving else np.zeros(0, dtype=np.int64)
    v_fixed = rng.normal(size=len(fixed))
    H, g = np.full((5, 5), np.nan), np.full(5, np.nan)  # every entry written
    least_squares(jac, rate, weight, free, fixed, v_fixed, 1e-9, H, g, np.zeros((2, m)))
    H_ref, g_ref = reference(jac, rate, weight, free, fixed, v_fixed, 1e-9)
    np.testing.assert_allclose(H, H_ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(g, g_ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(H, H.T)


@pytest.mark.parametrize("moving", [False, True])
def test_the_ik_cost_is_the_same_compiled_and_in_numpy(moving: bool):
    """Both forms of the IK stack's cost, on SmartPal V's right hand over the right arm."""
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    ik = WholeBodyIK(kin, 0.001)
    frozen = np.ones(kin.nv, dtype=bool)
    frozen[kin.unit_indices(UnitType.RIGHT_ARM)] = False
    ik.configure(frozen)
    ik.tasks = [
        ControlPointTask(RightLeft.RIGHT, kin.pose(RightLeft.RIGHT)),
        PostureTask(kin.q.copy(), np.arange(kin.nv)),
    ]
    ik.solve(kin.q, np.zeros(kin.nv))
    stack, layout = ik._plan.level1, ik._layout
    assert isinstance(layout, Layout) and layout.has_fixed
    v_fixed = np.linspace(-0.1, 0.1, len(layout.fixed)) if moving else None
    stack._compiled = True
    H1, g1 = (a.copy() for a in stack.cost(layout, v_fixed))
    stack._compiled = False
    H0, g0 = stack.cost(layout, v_fixed)
    np.testing.assert_allclose(H1, H0, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(g1, g0, rtol=1e-12, atol=1e-15)

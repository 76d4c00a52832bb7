"""controller.qp.daqp_c: DAQP's C API against daqp's Python Model."""

from __future__ import annotations

import daqp
import numpy as np
import pytest

from controller.model import jit
from controller.qp import daqp_c

pytestmark = pytest.mark.skipif(not jit.available(), reason="compiled kernels are off")


def problem(rng: np.random.Generator, n: int, m: int, p: int):
    J = rng.normal(size=(n + 3, n))
    H = J.T @ J + 1e-6 * np.eye(n)
    g = rng.normal(size=n)
    C, A = rng.normal(size=(m, n)), rng.normal(size=(p, n))
    lo, hi = -rng.uniform(0.01, 0.3, m), rng.uniform(0.01, 0.3, m)
    lb, ub = -rng.uniform(0.1, 1.0, n), rng.uniform(0.1, 1.0, n)
    b = A.dot(rng.uniform(-0.05, 0.05, n))
    return H, g, lb, ub, C, lo, hi, A, b


def test_the_library_checks_out_here():
    """The structures match the installed daqp (the solver takes this path here)."""
    assert daqp_c.available()
    assert daqp_c._agrees_with_model()


@pytest.mark.parametrize(("n", "m", "p"), [(7, 5, 0), (16, 18, 12), (9, 0, 0), (6, 0, 2)])
def test_cold_then_warm_solves_equal_the_python_model(n: int, m: int, p: int):
    """Set up cold, then 30 warm updates of every part of the problem: the same exit flag,
    iterations and minimiser as daqp.Model with the same calls."""
    rng = np.random.default_rng(n * 100 + m * 10 + p)
    work = daqp_c.Workspace(n, m, p, 1e-9, 500)
    model = daqp.Model()
    for step in range(31):
        H, g, lb, ub, C, lo, hi, A, b = problem(rng, n, m, p)
        rows = np.ascontiguousarray(np.vstack([C, A]))
        bu, bl = np.concatenate([ub, hi, b]), np.concatenate([lb, lo, b])
        if step == 0:
            assert model.setup(H, g, rows, bu, bl, work.sense.copy())[0] >= 0
            model.settings = {"primal_tol": 1e-9, "iter_limit": 500}
            work.load(H, g, lb, ub, C, lo, hi, A, b)
            assert work.setup() >= 0 and work.ready
            work.solve()
        else:
            model.update(H=H, f=g, A=rows if m + p else None, bupper=bu, blower=bl)
            work.load(H, g, lb, ub, C, lo, hi, A, b)
            assert work.update_and_solve() >= 0
        x, _, flag, info = model.solve()
        assert work.result.exitflag == flag
        assert work.result.iter == info["iterations"]
        np.testing.assert_array_equal(work.x, x)
    work.close()


def test_a_workspace_set_up_again_and_closed_twice_frees_once():
    """setup() frees the last set-up first; close() is idempotent (no double free)."""
    rng = np.random.default_rng(3)
    work = daqp_c.Workspace(5, 3, 1, 1e-9, 100)
    for _ in range(200):
        work.load(*problem(rng, 5, 3, 1))
        assert work.setup() >= 0
        work.solve()
        assert work.result.exitflag > 0
    work.close()
    work.close()
    assert not work.ready

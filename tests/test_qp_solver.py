"""controller.qp.solver: ProxQP and qpsolvers back ends agree; failures give None."""

from __future__ import annotations

import numpy as np
import pytest

from controller.qp.solver import INF, ProxQPSolver, QpsolversSolver, make_solver


def random_qp(rng: np.random.Generator, n: int = 12, m: int = 4):
    jac = rng.normal(size=(n + 3, n))
    H = jac.T @ jac + 1e-6 * np.eye(n)
    g = rng.normal(size=n)
    C = rng.normal(size=(m, n))
    lo = np.full(m, -INF)
    hi = np.full(m, INF)
    lo[0] = hi[0] = 0.0  # an equality row
    lo[1], hi[1] = -0.2, 0.3
    lb, ub = -np.ones(n), np.ones(n)
    return H, g, C, lo, hi, lb, ub


def test_proxqp_and_qpsolvers_agree_over_warm_started_solves():
    rng = np.random.default_rng(7)
    prox = ProxQPSolver(12, 4)
    ref = QpsolversSolver(12, 4, "daqp")
    H, g, C, lo, hi, lb, ub = random_qp(rng)
    for _ in range(50):
        g = g + 0.05 * rng.normal(size=g.size)
        a = prox.solve(H, g, C, lo, hi, lb, ub)
        b = ref.solve(H, g, C, lo, hi, lb, ub)
        assert a is not None and b is not None
        assert np.abs(a - b).max() < 1e-6
        assert abs(C[0] @ a) < 1e-8
        assert np.all(a >= lb - 1e-8) and np.all(a <= ub + 1e-8)


@pytest.mark.parametrize("name", ["proxqp", "qpsolvers:daqp", "daqp", "daqp-ik"])
def test_infeasible_problem_returns_none_and_the_next_solve_recovers(name: str):
    """``daqp-ik``: the IK's DAQP solver (no guard: DAQP's C API where it checks out),
    which starts cold after a failure."""
    from controller.qp.solver import DaqpSolver

    rng = np.random.default_rng(8)
    solver = DaqpSolver(12, 4, guard=False) if name == "daqp-ik" else make_solver(name, 12, 4)
    H, g, C, lo, hi, lb, ub = random_qp(rng)
    assert solver.solve(H, g, C, lo, hi, lb, ub) is not None
    C_bad = C.copy()
    C_bad[2] = C_bad[0]
    lo_bad, hi_bad = lo.copy(), hi.copy()
    lo_bad[2] = hi_bad[2] = 5.0  # contradicts row 0 (= 0)
    assert solver.solve(H, g, C_bad, lo_bad, hi_bad, lb, ub) is None
    if isinstance(solver, DaqpSolver):
        assert not solver.warm  # set up again at the next solve
    x = solver.solve(H, g, C, lo, hi, lb, ub)
    assert x is not None and abs(C[0] @ x) < 1e-6


def test_unknown_solver_name_is_refused():
    with pytest.raises(ValueError, match="unknown QP solver"):
        make_solver("gurobi", 3, 1)


@pytest.mark.parametrize("p", [0, 2])
def test_daqp_gives_the_same_through_its_c_api_compiled_packing_and_numpy(p: int):
    """The IK's DAQP solvers (no guard) go through DAQP's C API (controller.qp.daqp_c);
    without it they pack bounds, rows and equalities in one compiled call for daqp.Model,
    or in NumPy: the same stacked arrays, iterations and minimiser, over warm-started
    solves."""
    from controller.model import jit
    from controller.qp import daqp_c
    from controller.qp.solver import DaqpSolver

    if not jit.available():
        pytest.skip("compiled kernels are off")
    rng = np.random.default_rng(2)
    direct, packed, plain = (DaqpSolver(12, 4, p, guard=False) for _ in range(3))
    assert daqp_c.available() and direct._c is not None
    packed._c = plain._c = None
    plain._compiled = False
    H, g, C, lo, hi, lb, ub = random_qp(rng)
    A = rng.normal(size=(p, 12))
    for _ in range(20):
        g = g + 0.05 * rng.normal(size=g.size)
        b = A @ rng.uniform(-0.1, 0.1, 12)
        eq = (A, b) if p else (None, None)
        xs = [s.solve(H, g, C, lo, hi, lb, ub, *eq) for s in (direct, packed, plain)]
        assert all(x is not None for x in xs)
        np.testing.assert_array_equal(packed._bu, plain._bu)
        np.testing.assert_array_equal(packed._bl, plain._bl)
        np.testing.assert_array_equal(packed._rows, plain._rows)
        np.testing.assert_array_equal(direct._c.bu, plain._bu)
        np.testing.assert_array_equal(direct._c.rows, plain._rows)
        np.testing.assert_array_equal(xs[0], xs[2])
        np.testing.assert_array_equal(xs[1], xs[2])
        assert direct.iterations == packed.iterations == plain.iterations

"""QP back ends with one interface: minimise ½xᵀHx + gᵀx
s.t. Ax = b, lo ≤ Cx ≤ hi, lb ≤ x ≤ ub.

:class:`ProxQPSolver` (default) keeps one ``proxsuite.proxqp.dense.QP`` for the life of the
controller, warm-started from the previous cycle, with native box constraints.
:class:`QpsolversSolver` goes through ``qpsolvers`` (any installed back end) and exists for
cross-checks in tests. Both return ``None`` when the problem is infeasible or the solve fails;
the caller then holds position and raises a fault.
"""

from __future__ import annotations

import abc

import numpy as np
import qpsolvers
from proxsuite import proxqp

#: Bounds beyond this magnitude are treated as absent (proxsuite takes finite numbers best).
INF = 1e20


class QPSolver(abc.ABC):
    """Solves a QP of fixed size: ``n`` variables, ``m`` two-sided rows, ``p`` equalities."""

    def __init__(self, n: int, m: int, p: int = 0):
        self.n = n
        self.m = m
        self.p = p
        #: Iterations of the last solve (0 where the back end does not say).
        self.iterations = 0

    @abc.abstractmethod
    def solve(
        self,
        H: np.ndarray,
        g: np.ndarray,
        C: np.ndarray,
        lo: np.ndarray,
        hi: np.ndarray,
        lb: np.ndarray,
        ub: np.ndarray,
        A: np.ndarray | None = None,
        b: np.ndarray | None = None,
    ) -> np.ndarray | None:
        """The minimiser, or None when infeasible / not solved (A, b: ``p`` rows or None)."""


class ProxQPSolver(QPSolver):
    """Persistent dense ProxQP with warm start and box constraints.

    ``eps_abs`` [same unit as x]: absolute tolerance on the residuals. The IK clips the result
    to the box afterwards, so the tolerance never turns into a limit violation.
    """

    def __init__(self, n: int, m: int, p: int = 0, eps_abs: float = 1e-9, max_iter: int = 200):
        super().__init__(n, m, p)
        self._qp = proxqp.dense.QP(n, p, m, True)
        self._no_a = np.zeros((0, n))
        self._no_b = np.zeros(0)
        self._qp.settings.eps_abs = eps_abs
        self._qp.settings.eps_rel = 0.0
        self._qp.settings.max_iter = max_iter
        self._qp.settings.verbose = False
        # The default (1e-4) is loose against one cycle's tiny boxes (a_max·dt ~ 1e-3) and
        # reports feasible problems as infeasible; 1e-12 still catches real contradictions.
        self._qp.settings.eps_primal_inf = 1e-12
        self._qp.settings.eps_dual_inf = 1e-12
        self._initialised = False

    def solve(
        self,
        H: np.ndarray,
        g: np.ndarray,
        C: np.ndarray,
        lo: np.ndarray,
        hi: np.ndarray,
        lb: np.ndarray,
        ub: np.ndarray,
        A: np.ndarray | None = None,
        b: np.ndarray | None = None,
    ) -> np.ndarray | None:
        qp = self._qp
        if A is None:
            A, b = self._no_a, self._no_b
        if not self._initialised:
            qp.init(H=H, g=g, A=A, b=b, C=C, l=lo, u=hi, l_box=lb, u_box=ub)
            qp.solve()
            # Warm start only once a first result exists (earlier, proxsuite 0.8 crashed here).
            qp.settings.initial_guess = proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
            self._initialised = True
        else:
            qp.update(H=H, g=g, A=A, b=b, C=C, l=lo, u=hi, l_box=lb, u_box=ub)
            qp.solve()
        info = qp.results.info
        self.iterations = int(info.iter)
        if info.status != proxqp.QPSolverOutput.PROXQP_SOLVED:
            self._initialised = False  # next cycle starts cold
            return None
        x: np.ndarray = qp.results.x
        return x if np.all(np.isfinite(x)) else None


class QpsolversSolver(QPSolver):
    """Any ``qpsolvers`` back end (default: the first installed); stateless, for tests."""

    def __init__(self, n: int, m: int, p: int = 0, solver: str | None = None):
        super().__init__(n, m, p)
        self.solver = solver or qpsolvers.available_solvers[0]

    def solve(
        self,
        H: np.ndarray,
        g: np.ndarray,
        C: np.ndarray,
        lo: np.ndarray,
        hi: np.ndarray,
        lb: np.ndarray,
        ub: np.ndarray,
        A: np.ndarray | None = None,
        b: np.ndarray | None = None,
    ) -> np.ndarray | None:
        rows_g = np.vstack([C, -C])
        rows_h = np.concatenate([hi, -lo])
        keep = np.abs(rows_h) < INF
        try:
            x = qpsolvers.solve_qp(
                H, g, G=rows_g[keep], h=rows_h[keep], A=A, b=b, lb=lb, ub=ub, solver=self.solver
            )
        except Exception:  # a back end that raises is a failed solve, never a crash
            return None
        return None if x is None or not np.all(np.isfinite(x)) else np.asarray(x)


def make_solver(name: str, n: int, m: int, p: int = 0) -> QPSolver:
    """``"proxqp"`` (default) or ``"qpsolvers:<backend>"`` / ``"qpsolvers"``."""
    if name == "proxqp":
        return ProxQPSolver(n, m, p)
    if name == "qpsolvers" or name.startswith("qpsolvers:"):
        backend = name.partition(":")[2] or None
        return QpsolversSolver(n, m, p, backend)
    raise ValueError(f"unknown QP solver {name!r}: use 'proxqp' or 'qpsolvers[:backend]'")

"""QP back ends with one interface: minimise ½xᵀHx + gᵀx
s.t. Ax = b, lo ≤ Cx ≤ hi, lb ≤ x ≤ ub.

:class:`DaqpSolver` (default, :data:`DEFAULT_SOLVER`) keeps one DAQP workspace (a dual
active-set method in C; the IK's solvers through DAQP's C API, :mod:`.daqp_c`, others through
``daqp.Model``) and hot-starts every solve from the previous working set: on the
IK's problems it needs one iteration per cycle, even with limits binding, and its result is
exact on the active constraints (no iterative residual). :class:`ProxQPSolver` keeps one
``proxsuite.proxqp.dense.QP``, warm-started from the previous result, with native box
constraints. :class:`QpsolversSolver` goes through ``qpsolvers`` (any installed back end) and
exists for cross-checks in tests.

All return ``None`` when the problem is infeasible or the solve fails; the caller then holds
position and raises a fault. The persistent back ends cap their iterations, so a solve's
worst-case time is bounded: on the cap, the last iterate is returned only if it satisfies the
box, the rows and the equalities within :data:`FEASIBILITY_TOL`, else ``None``.
"""

from __future__ import annotations

import abc
import math

import daqp
import numpy as np
import qpsolvers
from proxsuite import proxqp

from controller.model import jit
from controller.qp import daqp_c
from controller.qp.daqp_c import pack as _pack

#: Bounds beyond this magnitude are treated as absent (proxsuite takes finite numbers best).
INF = 1e20
#: The back end :func:`make_solver` and the IK use unless told otherwise.
DEFAULT_SOLVER = "daqp"
#: Largest violation [unit of x, of the rows] accepted from an iterate cut short by the cap.
FEASIBILITY_TOL = 1e-9
#: DAQP's sense flag of an equality row, and its exit flag on the iteration cap.
_DAQP_EQUALITY = 5
_DAQP_ITER_LIMIT = -4


def iteration_cap(n: int, m: int, p: int) -> int:
    """Iteration cap of an active-set solve over ``n`` bounds, ``m`` rows, ``p`` equalities.

    Hot-started solves need 1-10 iterations; a cold start adds about one per active
    constraint, more on a badly conditioned Hessian (λ = 1e-9 over 19 joints): measured 112
    on a cold SmartPal V step with 31 bounds and rows (both hands against the torso's
    collision rows, issue 10). Six passes over every constraint cover that.
    """
    return 6 * (n + m + p) + 10


def within_limits(
    x: np.ndarray,
    C: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    A: np.ndarray | None,
    b: np.ndarray | None,
    tol: float = FEASIBILITY_TOL,
) -> bool:
    """Whether ``x`` satisfies the box, the rows and the equalities within ``tol``."""
    if not np.all(np.isfinite(x)) or np.any(x < lb - tol) or np.any(x > ub + tol):
        return False
    if C.shape[0]:
        r = C.dot(x)
        if np.any(r < lo - tol) or np.any(r > hi + tol):
            return False
    return A is None or b is None or not A.shape[0] or bool(np.abs(A.dot(x) - b).max() <= tol)


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

    def reset(self) -> None:  # noqa: B027 - stateless back ends have nothing to forget
        """Forget the warm start: the next solve starts cold (a new problem structure)."""


class DaqpSolver(QPSolver):
    """Persistent DAQP workspace, hot-started from the previous cycle's working set.

    ``primal_tol`` [unit of x and of the rows]: violation accepted on inactive constraints
    (active ones hold to rounding). The IK clips the result to the box afterwards.
    ``guard``: refuse an empty box (``lb > ub`` somewhere: DAQP takes bound pairs as
    consistent) and a non-finite result. The IK turns it off: its box never crosses, and it
    checks its own result.
    """

    def __init__(
        self,
        n: int,
        m: int,
        p: int = 0,
        primal_tol: float = 1e-9,
        max_iter: int | None = None,
        guard: bool = True,
    ):
        super().__init__(n, m, p)
        self.guard = guard
        total = n + m + p
        self.max_iter = iteration_cap(n, m, p) if max_iter is None else max_iter
        self._settings = {"primal_tol": primal_tol, "iter_limit": self.max_iter}
        self._bu = np.zeros(total)
        self._bl = np.zeros(total)
        self._rows = np.zeros((m + p, n))
        self._sense = np.zeros(total, dtype=np.intc)
        self._sense[n + m :] = _DAQP_EQUALITY
        self._A = self._rows if m + p else None  # for updates: DAQP takes no empty A there
        self._model: daqp.Model | None = None  # None: set up afresh (cold) at the next solve
        #: The IK's solvers (no guard) pack their bounds and rows in one compiled call.
        self._compiled = not guard and jit.available()
        self._no_eq = (np.zeros((0, n)), np.zeros(0))
        #: The IK's solvers go through DAQP's C API where it checks out (:mod:`.daqp_c`).
        self._c = (
            daqp_c.Workspace(n, m, p, primal_tol, self.max_iter)
            if self._compiled and daqp_c.available()
            else None
        )

    def reset(self) -> None:
        self._model = None
        if self._c is not None:
            self._c.ready = False

    @property
    def warm(self) -> bool:
        """Whether the next solve starts from the last working set (else it sets up cold)."""
        return self._c.ready if self._c is not None else self._model is not None

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
        if self.guard and np.count_nonzero(lb > ub):
            return None
        if self._c is not None:
            return self._solve_c(self._c, H, g, C, lo, hi, lb, ub, A, b)
        n, m = self.n, self.m
        rows = self._rows
        if m + self.p and self._compiled:
            bu, bl = self._bu, self._bl
            eq_rows, eq_rhs = self._no_eq if A is None or b is None else (A, b)
            _pack(lb, ub, C, lo, hi, eq_rows, eq_rhs, bu, bl, rows)
        elif m + self.p:
            bu, bl = self._bu, self._bl
            bu[:n] = ub
            bl[:n] = lb
            bu[n : n + m] = hi
            bl[n : n + m] = lo
            rows[:m] = C
            if self.p:
                bu[n + m :] = bl[n + m :] = b
                rows[m:] = A
        else:  # bounds only: DAQP reads the caller's arrays
            bu, bl = ub, lb
        model = self._model
        if model is None:
            model = daqp.Model()
            if model.setup(H, g, rows, bu, bl, self._sense)[0] < 0:
                return None
            model.settings = self._settings
            self._model = model
        elif model.update(H=H, f=g, A=self._A, bupper=bu, blower=bl) < 0:
            self._model = None
            return None
        x, _, flag, info = model.solve()
        self.iterations = info["iterations"]
        return self._result(x, flag, C, lo, hi, lb, ub, A, b)

    def _solve_c(
        self,
        work: daqp_c.Workspace,
        H: np.ndarray,
        g: np.ndarray,
        C: np.ndarray,
        lo: np.ndarray,
        hi: np.ndarray,
        lb: np.ndarray,
        ub: np.ndarray,
        A: np.ndarray | None,
        b: np.ndarray | None,
    ) -> np.ndarray | None:
        """:meth:`solve` through DAQP's C API (the same steps and results as through
        ``daqp.Model``; the minimiser is the workspace's own array)."""
        eq_rows, eq_rhs = self._no_eq if A is None or b is None else (A, b)
        work.load(H, g, lb, ub, C, lo, hi, eq_rows, eq_rhs)
        if not work.solve_loaded():
            return None
        self.iterations = work.result.iter
        return self._result(work.x, work.result.exitflag, C, lo, hi, lb, ub, A, b)

    def _result(
        self,
        x: np.ndarray,
        flag: int,
        C: np.ndarray,
        lo: np.ndarray,
        hi: np.ndarray,
        lb: np.ndarray,
        ub: np.ndarray,
        A: np.ndarray | None,
        b: np.ndarray | None,
    ) -> np.ndarray | None:
        """The minimiser of a solve that ended with DAQP's exit ``flag``, or None; after a
        failure the next solve starts cold."""
        if flag > 0 and (not self.guard or math.isfinite(x.dot(x))):  # x·x: NaN/inf at once
            return x
        self.reset()  # the working set is no start for the next cycle
        if flag == _DAQP_ITER_LIMIT and within_limits(x, C, lo, hi, lb, ub, A, b):
            return x
        return None


class ProxQPSolver(QPSolver):
    """Persistent dense ProxQP with warm start and box constraints.

    ``eps_abs`` [same unit as x]: absolute tolerance on the residuals. The IK clips the result
    to the box afterwards, so the tolerance never turns into a limit violation. ``max_iter``
    caps the outer iterations and the inner ones of each (proxsuite's own inner cap, 1500, let
    a solve run 1510 iterations at max_iter 200). That bounds a solve by max_iter² inner
    iterations: bounded, but loosely, hence DAQP as the real-time default.
    """

    def __init__(self, n: int, m: int, p: int = 0, eps_abs: float = 1e-9, max_iter: int = 200):
        super().__init__(n, m, p)
        self._qp = proxqp.dense.QP(n, p, m, True)
        self._no_a = np.zeros((0, n))
        self._no_b = np.zeros(0)
        self._qp.settings.eps_abs = eps_abs
        self._qp.settings.eps_rel = 0.0
        self._qp.settings.max_iter = max_iter
        self._qp.settings.max_iter_in = max_iter
        self._qp.settings.verbose = False
        # The default (1e-4) is loose against one cycle's tiny boxes (a_max·dt ~ 1e-3) and
        # reports feasible problems as infeasible; 1e-12 still catches real contradictions.
        self._qp.settings.eps_primal_inf = 1e-12
        self._qp.settings.eps_dual_inf = 1e-12
        self._initialised = False

    def reset(self) -> None:
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
            qp.settings.initial_guess = proxqp.InitialGuess.EQUALITY_CONSTRAINED_INITIAL_GUESS
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
        x: np.ndarray = qp.results.x
        if info.status == proxqp.QPSolverOutput.PROXQP_SOLVED and np.all(np.isfinite(x)):
            return x
        self._initialised = False  # next cycle starts cold
        if info.status == proxqp.QPSolverOutput.PROXQP_MAX_ITER_REACHED and within_limits(
            x, C, lo, hi, lb, ub, A, b
        ):
            return x
        return None


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


def make_solver(name: str, n: int, m: int, p: int = 0, guard: bool = True) -> QPSolver:
    """``"daqp"`` (default), ``"proxqp"`` or ``"qpsolvers:<backend>"`` / ``"qpsolvers"``.

    ``guard`` False: the caller guarantees ``lb ≤ ub`` and checks the result's finiteness
    (see :class:`DaqpSolver`; the other back ends always check)."""
    if name == "daqp":
        return DaqpSolver(n, m, p, guard=guard)
    if name == "proxqp":
        return ProxQPSolver(n, m, p)
    if name == "qpsolvers" or name.startswith("qpsolvers:"):
        backend = name.partition(":")[2] or None
        return QpsolversSolver(n, m, p, backend)
    raise ValueError(f"unknown QP solver {name!r}: use 'daqp', 'proxqp' or 'qpsolvers[:backend]'")

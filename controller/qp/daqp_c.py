"""DAQP through its C API, for the IK's solves in the control cycle.

The ``daqp`` wheel exports DAQP's C API (``api.h``: ``setup_daqp``, ``daqp_update_ldp``,
``daqp_solve``). Its Python ``Model`` costs ~20 µs per update and solve hot (~40 in the
loop) on the IK's problems, of which DAQP's own work is a few: every call converts each
array to a typed memoryview and builds copies of the result and a dict. Here
:class:`Workspace` keeps one DAQP workspace and the problem in arrays of its own:
:func:`fill` (compiled) copies a cycle's data into them, and ``daqp_update_ldp`` and
``daqp_solve`` are called through ctypes with the addresses kept (~11 µs hot against ~20 on
a 16-variable problem with 18 rows), warm starting from the last working set exactly as
``Model.update`` does. (Calling the C functions from the compiled code would save ~5 µs
more, but numba then either cannot cache the kernel, or unboxes a function argument for
~60-150 µs a call.)

The structures below follow daqp 0.11.0's ``types.h`` and ``api.h`` (pinned in
``pyproject.toml``). :func:`available` checks them once per process: a set of problems
solved here and through daqp's ``Model`` must give the same exit flags, iterations and
minimisers; on any difference, or without numba, the solver uses ``Model``
(:class:`controller.qp.solver.DaqpSolver`).
"""

from __future__ import annotations

import ctypes
import functools
import logging

import daqp
import numpy as np

from controller.model import jit

log = logging.getLogger(__name__)

_int, _float, _ptr = ctypes.c_int, ctypes.c_double, ctypes.c_void_p
#: DAQP's update mask: the Hessian (R⁻¹), the rows (M), the linear term (v), the bounds (d).
UPDATE_ALL = 1 | 2 | 4 | 8
#: Bytes kept for a workspace: its structure (328 bytes on x86-64) with room to spare.
_WORKSPACE_BYTES = 2048


class Problem(ctypes.Structure):
    """``DAQPProblem``: n, m (bounds + rows), ms (simple bounds) and pointers to the data."""

    _fields_ = [
        ("n", _int), ("m", _int), ("ms", _int),
        ("H", _ptr), ("f", _ptr), ("A", _ptr), ("bupper", _ptr), ("blower", _ptr),
        ("sense", _ptr), ("break_points", _ptr), ("nh", _int), ("problem_type", _int),
    ]  # fmt: skip


class Settings(ctypes.Structure):
    """``DAQPSettings``."""

    _fields_ = [
        ("primal_tol", _float), ("dual_tol", _float), ("zero_tol", _float),
        ("pivot_tol", _float), ("progress_tol", _float), ("cycle_tol", _int),
        ("iter_limit", _int), ("fval_bound", _float), ("eps_prox", _float),
        ("eta_prox", _float), ("rho_soft", _float), ("rel_subopt", _float),
        ("abs_subopt", _float), ("sing_tol", _float), ("refactor_tol", _float),
        ("time_limit", _float), ("w_soft", _float), ("eq_reduction", _int), ("presolve", _int),
    ]  # fmt: skip


class Result(ctypes.Structure):
    """``DAQPResult``: pointers to x and λ (ours), the exit flag and the iterations."""

    _fields_ = [
        ("x", _ptr), ("lam", _ptr), ("fval", _float), ("soft_slack", _float),
        ("exitflag", _int), ("iter", _int), ("nodes", _int),
        ("solve_time", _float), ("setup_time", _float),
    ]  # fmt: skip


class WorkspaceHead(ctypes.Structure):
    """``DAQPWorkspace`` up to its settings pointer: what :class:`Workspace` reads or sets
    (the problem, the sizes, the settings). The C code owns the rest."""

    _fields_ = [
        ("qp", _ptr), ("n", _int), ("m", _int), ("ms", _int),
        *((name, _ptr) for name in (
            "M", "dupper", "dlower", "Rinv", "v", "sense", "scaling", "RinvD", "x", "xold",
            "lam", "lam_star", "u",
        )),
        ("fval", _float),
        *((name, _ptr) for name in ("L", "D", "xldl", "zldl")),
        ("reuse_ind", _int), ("WS", _ptr), ("n_active", _int), ("iterations", _int),
        ("sing_ind", _int), ("prox_mask", _ptr), ("n_prox", _int), ("soft_slack", _float),
        ("settings", _ptr),
    ]  # fmt: skip


@functools.cache
def _library() -> ctypes.CDLL:
    lib = ctypes.CDLL(daqp.__file__)
    lib.setup_daqp.argtypes = [_ptr, _ptr, _ptr]
    lib.setup_daqp.restype = _int
    lib.daqp_update_ldp.argtypes = [_int, _ptr, _ptr]
    lib.daqp_update_ldp.restype = _int
    lib.daqp_solve.argtypes = [_ptr, _ptr]
    lib.daqp_solve.restype = None
    lib.daqp_default_settings.argtypes = [_ptr]
    lib.daqp_default_settings.restype = None
    for name in ("free_daqp_workspace", "free_daqp_ldp"):
        getattr(lib, name).argtypes = [_ptr]
        getattr(lib, name).restype = None
    return lib


@jit.jit
def pack(
    lb: np.ndarray,
    ub: np.ndarray,
    C: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    bu: np.ndarray,
    bl: np.ndarray,
    rows: np.ndarray,
) -> None:
    """DAQP's stacked bounds ``[box; rows; equalities]`` and rows ``[C; A]`` in one call."""
    n, m, p = lb.shape[0], C.shape[0], A.shape[0]
    for i in range(n):
        bu[i] = ub[i]
        bl[i] = lb[i]
    for k in range(m):
        bu[n + k] = hi[k]
        bl[n + k] = lo[k]
        for j in range(n):
            rows[k, j] = C[k, j]
    for k in range(p):
        bu[n + m + k] = b[k]
        bl[n + m + k] = b[k]
        for j in range(n):
            rows[m + k, j] = A[k, j]


@jit.jit
def fill(
    H: np.ndarray,
    g: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    C: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    own_H: np.ndarray,
    own_g: np.ndarray,
    bu: np.ndarray,
    bl: np.ndarray,
    rows: np.ndarray,
) -> None:
    """A problem into a workspace's arrays (``own_H``, ``own_g``, ``bu``, ``bl``, ``rows``):
    one compiled call."""
    n = g.shape[0]
    for i in range(n):
        own_g[i] = g[i]
        for j in range(n):
            own_H[i, j] = H[i, j]
    pack(lb, ub, C, lo, hi, A, b, bu, bl, rows)


class Workspace:
    """One DAQP workspace for problems of ``n`` variables (bounded), ``m`` two-sided rows
    and ``p`` equalities, with the problem's arrays, x and λ of its own.

    :meth:`load`, then :meth:`solve_loaded`: :meth:`setup` and :meth:`solve` (cold) or,
    while :attr:`ready`, :meth:`update_and_solve` (warm). Not thread-safe.
    """

    def __init__(self, n: int, m: int, p: int, primal_tol: float, iter_limit: int):
        lib = self._lib = _library()
        self.n, self.m, self.p = n, m, p
        total = n + m + p
        self.H = np.zeros((n, n))
        self.g = np.zeros(n)
        self.rows = np.zeros((m + p, n))
        self.bu = np.zeros(total)
        self.bl = np.zeros(total)
        self.sense = np.zeros(total, dtype=np.intc)
        self.sense[n + m :] = 5  # DAQP's equality flag
        self.x = np.zeros(n)
        self.lam = np.zeros(total)
        self._problem = Problem(
            n, total, n, self.H.ctypes.data, self.g.ctypes.data,
            self.rows.ctypes.data if m + p else None,
            self.bu.ctypes.data, self.bl.ctypes.data, self.sense.ctypes.data, None, 0, 0,
        )  # fmt: skip
        self._settings = Settings()
        lib.daqp_default_settings(ctypes.byref(self._settings))
        self._settings.primal_tol = primal_tol
        self._settings.iter_limit = iter_limit
        self.result = Result(self.x.ctypes.data, self.lam.ctypes.data)
        self._memory = ctypes.create_string_buffer(_WORKSPACE_BYTES)
        self._head = WorkspaceHead.from_buffer(self._memory)
        #: Set up: the C workspace holds allocations (freed by :meth:`close`).
        self._allocated = False
        #: Set up and fit for a warm :meth:`update_and_solve`.
        self.ready = False
        self._update, self._solve, self._free = (
            lib.daqp_update_ldp, lib.daqp_solve, (lib.free_daqp_workspace, lib.free_daqp_ldp),
        )  # fmt: skip
        self._work, self._problem_at, self._result_at = (
            ctypes.addressof(self._memory), ctypes.addressof(self._problem),
            ctypes.addressof(self.result),
        )  # fmt: skip
        #: :func:`fill`'s last arguments.
        self.own_arrays = (self.H, self.g, self.bu, self.bl, self.rows)

    def load(
        self,
        H: np.ndarray,
        g: np.ndarray,
        lb: np.ndarray,
        ub: np.ndarray,
        C: np.ndarray,
        lo: np.ndarray,
        hi: np.ndarray,
        A: np.ndarray,
        b: np.ndarray,
    ) -> None:
        """Copy a problem into the workspace's arrays."""
        fill(H, g, lb, ub, C, lo, hi, A, b, *self.own_arrays)

    def setup(self) -> int:
        """Set DAQP up (cold) for the loaded problem: its flag (negative: failed)."""
        self.close()
        ctypes.memset(self._memory, 0, _WORKSPACE_BYTES)
        self._head.settings = ctypes.addressof(self._settings)  # ours: setup allocates none
        seconds = _float(0.0)
        flag = int(self._lib.setup_daqp(self._problem_at, self._work, ctypes.addressof(seconds)))
        self._allocated = True
        self.ready = flag >= 0
        return flag

    def solve(self) -> None:
        """Solve the set-up problem (exit flag and iterations in :attr:`result`)."""
        self._solve(self._result_at, self._work)

    def solve_loaded(self) -> bool:
        """Solve the loaded problem: warm (:meth:`update_and_solve`) while :attr:`ready`,
        else cold (:meth:`setup`, :meth:`solve`). False when DAQP refused the problem (the
        next call sets up again); the exit flag and iterations are in :attr:`result`."""
        if self.ready:
            if self.update_and_solve() < 0:
                self.ready = False
                return False
            return True
        if self.setup() < 0:
            return False
        self.solve()
        return True

    def update_and_solve(self) -> int:
        """Take the loaded problem into the set-up workspace (warm: its working set is
        kept) and solve it: the update's flag (negative: not solved)."""
        flag: int = self._update(UPDATE_ALL, self._work, self._problem_at)
        if flag >= 0:
            self._solve(self._result_at, self._work)
        return flag

    def close(self) -> None:
        """Free what DAQP allocated (the settings are ours: never freed by DAQP)."""
        if self._allocated:
            self._head.settings = None
            for free in self._free:
                free(self._work)
            self._allocated = False
        self.ready = False

    def __del__(self) -> None:
        self.close()


def _agrees_with_model() -> bool:
    """Problems solved cold then warm here and through daqp's ``Model``: the same flags,
    iterations and minimisers (the structures above match the installed library)."""
    rng = np.random.default_rng(5)
    for n, m, p in ((6, 4, 0), (7, 5, 2), (5, 0, 0), (8, 0, 3)):
        work = Workspace(n, m, p, 1e-9, 200)
        model = daqp.Model()
        sense = work.sense.copy()
        for step in range(4):
            J = rng.normal(size=(n + 3, n))
            H = J.T @ J + 1e-3 * np.eye(n)
            g = rng.normal(size=n)
            C, A = rng.normal(size=(m, n)), rng.normal(size=(p, n))
            lo, hi = -rng.uniform(0.05, 0.2, m), rng.uniform(0.05, 0.2, m)
            lb, ub = -np.ones(n), np.ones(n)
            b = A.dot(rng.uniform(-0.1, 0.1, n))
            rows = np.ascontiguousarray(np.vstack([C, A]))
            bu, bl = np.concatenate([ub, hi, b]), np.concatenate([lb, lo, b])
            if step == 0:
                if model.setup(H, g, rows, bu, bl, sense)[0] < 0:
                    return False
                model.settings = {"primal_tol": 1e-9, "iter_limit": 200}
                work.load(H, g, lb, ub, C, lo, hi, A, b)
                if work.setup() < 0:
                    return False
                work.solve()
            else:
                model.update(H=H, f=g, A=rows if m + p else None, bupper=bu, blower=bl)
                work.load(H, g, lb, ub, C, lo, hi, A, b)
                if work.update_and_solve() < 0:
                    return False
            x, _, flag, info = model.solve()
            same = (
                work.result.exitflag == flag
                and work.result.iter == info["iterations"]
                and np.array_equal(work.x, x)
                and work._head.n == n
                and work._head.settings == ctypes.addressof(work._settings)
            )
            if not same:
                return False
        work.close()
    return True


@functools.cache
def available() -> bool:
    """Whether the IK's DAQP solves go through this module: compiled kernels are on, the
    library exports the C API, and :func:`_agrees_with_model` (checked once, compiling the
    kernels at the same time: never in a control cycle)."""
    if not jit.available():
        return False
    try:
        ok = _agrees_with_model()
    except (OSError, AttributeError, ValueError) as exc:  # library or symbols missing
        log.warning("DAQP's C API is not usable (%s): using daqp.Model", exc)
        return False
    if not ok:
        log.warning("DAQP's C API gives other results than daqp.Model: using daqp.Model")
    return ok

"""The Hessian and gradient of stacked task rows, compiled (numba): one call per QP level.

For rows ``J`` (m x nv, every joint), rates ``e`` [rad/s, m/s] and weights ``w`` (m), over
the free joints ``f`` with the frozen joints ``x`` moving at ``v_x``::

    H = J_fᵀ W J_f + λ I        g = −J_fᵀ W (e − J_x v_x)

which is ``½ vᵀ H v + gᵀ v`` = Σ w ‖J v − e‖² + λ‖v‖² up to a constant. The NumPy form
(:meth:`controller.qp.ik._Stack.cost`) takes ~12 NumPy calls, each with its dispatch and a
temporary; this is one call into the caller's buffers, and the same numbers up to rounding
(the sums run in another order; tests compare both).
"""

from __future__ import annotations

import numpy as np

from controller.model import jit


@jit.jit
def least_squares(
    jac: np.ndarray,
    rate: np.ndarray,
    weight: np.ndarray,
    free: np.ndarray,
    fixed: np.ndarray,
    v_fixed: np.ndarray,
    damping: float,
    H: np.ndarray,
    g: np.ndarray,
    scratch: np.ndarray,
) -> None:
    """``H`` (n x n) and ``g`` (n) over the columns ``free`` (n indices) of ``jac``;
    ``fixed``/``v_fixed``: frozen columns and their velocities (empty: none moves);
    ``damping``: λ; ``scratch``: 2 x m."""
    m = jac.shape[0]
    n = free.shape[0]
    target = scratch[0]  # w · (e − J_x v_x), per row
    column = scratch[1]  # w · J[:, f_a], per row
    for r in range(m):
        e = rate[r]
        for k in range(fixed.shape[0]):
            e -= jac[r, fixed[k]] * v_fixed[k]
        target[r] = weight[r] * e
    for a in range(n):
        ca = free[a]
        s = 0.0
        for r in range(m):
            column[r] = weight[r] * jac[r, ca]
            s += jac[r, ca] * target[r]
        g[a] = -s
        for b in range(a, n):
            cb = free[b]
            s = 0.0
            for r in range(m):
                s += column[r] * jac[r, cb]
            H[a, b] = s
            H[b, a] = s
        H[a, a] += damping


if jit.available():  # compile (or load) at import, for the IK's buffers: never in a cycle
    _rows = np.zeros((2, 3), order="F")  # the stacks are column-major
    _none = np.zeros(0, dtype=np.int64)
    least_squares(
        _rows, np.zeros(2), np.ones(2), np.arange(3, dtype=np.int64), _none, np.zeros(0),
        1e-9, np.zeros((3, 3)), np.zeros(3), np.zeros((2, 2)),
    )  # fmt: skip

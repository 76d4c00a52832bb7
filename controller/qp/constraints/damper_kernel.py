"""The velocity-damper rows of :mod:`controller.qp.constraints.collision`, compiled (numba).

One call per cycle does what :meth:`CollisionAvoidance.compute_qp_inequalities` does with
NumPy (~45 small-array operations, ~70 µs on SmartPal V with 16 rows): choose the pairs in
range, write their distance-Jacobian rows, the damper/activation/relaxation allowance and the
common-velocity cap. Same arithmetic, same order of rows (ascending pair index); the module
docstring of :mod:`~controller.qp.constraints.collision` explains the rules. Used when the
distances come from the compiled kernels (:attr:`CollisionDistances.compiled`).
"""

from __future__ import annotations

import math

import numpy as np

from controller.model.collision_kernel import jacobian_rows
from controller.model.jit import jit


@jit
def select_pairs(
    d: np.ndarray,
    d_last: np.ndarray,
    key: np.ndarray,
    candidates: np.ndarray,
    influence: float,
    horizon: float,
    max_rows: int,
    near: np.ndarray,
    closing_cap: np.ndarray,
) -> int:
    """Pairs in range: closer than ``influence`` [m] or closing fast enough to get there
    within the look-ahead (``horizon`` = look-ahead / dt, the closing per cycle from
    ``d_last``, at most ``closing_cap`` [m]; NaN: not closing); more than ``max_rows``: the
    most urgent. Writes their indices, ascending, into ``near`` and returns how many;
    ``d_last`` := ``d``. ``key``, ``candidates``: scratch, one value per pair.
    ``closing_cap``: a bound on each pair's closing this cycle where the change from
    ``d_last`` overstates it (a pair back from the distances' screen, whose last distance
    was an upper bound: :mod:`controller.model.collision_screen`), else inf."""
    count = 0
    for p in range(d.shape[0]):
        closing = min(d_last[p] - d[p], closing_cap[p])
        if not closing > 0.0:  # NaN or opening
            closing = 0.0
        d_last[p] = d[p]
        urgency = d[p] - closing * horizon
        if urgency < influence:
            key[count] = urgency
            candidates[count] = p
            count += 1
    if count <= max_rows:
        for i in range(count):
            near[i] = candidates[i]
        return count
    order = np.argsort(key[:count], kind="mergesort")  # stable: ties to the lower index
    chosen = np.sort(candidates[:count][order[:max_rows]])
    for i in range(max_rows):
        near[i] = chosen[i]
    return max_rows


@jit
def collision_rows(
    d: np.ndarray,
    state: np.ndarray,
    closing_cap: np.ndarray,
    candidates: np.ndarray,
    settings: np.ndarray,
    support: np.ndarray,
    witness: np.ndarray,
    columns: np.ndarray,
    column_kind: np.ndarray,
    a_max: np.ndarray,
    low: np.ndarray,
    near: np.ndarray,
    row_pairs: np.ndarray,
    old_pairs: np.ndarray,
    v_prev: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    has_box: bool,
    C: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
) -> tuple[int, int]:
    """One cycle's rows: :func:`select_pairs` writes the ``k`` pairs in range into ``near``,
    then rows ``lo ≤ C v ≤ hi`` of those the box does not imply, their pairs in
    ``row_pairs`` and ``low`` (the least ``J_d v`` the box allows); returns ``(k, m)``, ``m``
    the rows reported. ``state`` rows: the distances of the last call, scratch, the
    approach speed ``allowed`` per pair [m/s] (``old_pairs``, last cycle's, back to inf
    unless still in range); ``closing_cap``: see :func:`select_pairs`. ``settings``:
    influence, look-ahead / dt, max rows, security, span, damping, dt, braking share,
    interior, brake margin, min reach, implied tolerance,
    the rows' infinity (:data:`~controller.qp.constraints.protocol.INF`). ``witness``,
    ``columns``: :attr:`CollisionDistances.witnesses`, :attr:`CompiledPairs.columns`. The
    arguments up to ``low`` are the constraint's own (the same arrays every cycle).
    No bounds checks: ``near``, ``row_pairs``, ``low`` and the rows must hold max rows."""
    d_last, allowed = state[0], state[2]
    influence, horizon, max_rows = settings[0], settings[1], int(settings[2])
    security, span, damping, dt = settings[3], settings[4], settings[5], settings[6]
    share, interior, margin, min_reach = settings[7], settings[8], settings[9], settings[10]
    implied, inf = settings[11], settings[12]
    k = select_pairs(
        d, d_last, state[1], candidates, influence, horizon, max_rows, near, closing_cap
    )
    nv = C.shape[1]
    jacobian_rows(near[:k], support, witness, columns, column_kind, C)
    now = np.empty(k)
    reach = np.empty(k)
    new = np.empty(k)
    for i in range(k):
        p = near[i]
        at, mid, rch, half = 0.0, 0.0, 0.0, 0.0
        for j in range(nv):
            c = C[i, j]
            at += c * v_prev[j]
            rch += abs(c) * a_max[j]
            if has_box:
                mid += c * (ub[j] + lb[j])
                half += abs(c) * (ub[j] - lb[j])
        a = share * rch
        xi = min(math.sqrt(a * span), damping)
        gap = max(d[p] - security, 0.0)
        damper = min(gap, span) * (xi / span)
        approach = -at
        prev = allowed[p]
        speed = min(prev, approach)
        need = speed * speed / (2.0 * gap + 1e-12)
        rate = min(max(need, a), rch) * dt
        new[i] = max(min(prev - rate, approach), damper)
        now[i] = at
        reach[i] = rch
        low[i] = 0.5 * (mid - half) if has_box else -inf
    for i in range(old_pairs.shape[0]):
        allowed[old_pairs[i]] = inf
    for i in range(k):
        allowed[near[i]] = new[i]
        lo[i] = -new[i]
    if has_box:
        # one velocity of the box for all rows: each joint accelerated at its limit in the
        # direction the rows short of v_prev want
        short = np.empty(k)
        for i in range(k):
            short[i] = max(lo[i] - now[i], 0.0) / max(reach[i], min_reach)
        star = np.empty(nv)
        for j in range(nv):
            s = 0.0
            for i in range(k):
                s += C[i, j] * short[i]
            sign = 1.0 if s > 0.0 else (-1.0 if s < 0.0 else 0.0)
            v = v_prev[j] + sign * a_max[j] * (1.0 - interior) * dt
            inset = interior * (ub[j] - lb[j])
            v = max(v, lb[j] + inset)
            star[j] = min(v, ub[j] - inset)
        for i in range(k):
            cap = -margin
            for j in range(nv):
                cap += C[i, j] * star[j]
            lo[i] = min(lo[i], cap)
    m = 0
    for i in range(k):
        if reach[i] < min_reach:
            lo[i] = -inf
        if has_box and not lo[i] > low[i] - implied:
            continue  # the box implies it
        if m != i:
            for j in range(nv):
                C[m, j] = C[i, j]
            lo[m] = lo[i]
            low[m] = low[i]
        row_pairs[m] = near[i]
        hi[m] = inf
        m += 1
    for i in range(m, k):
        lo[i] = -inf
        hi[i] = inf
    return k, m


@jit
def binding(
    C: np.ndarray,
    count: int,
    v: np.ndarray,
    lo: np.ndarray,
    low: np.ndarray,
    d: np.ndarray,
    row_pairs: np.ndarray,
    within: float,
    tol: float,
) -> int:
    """:meth:`CollisionAvoidance.binding` compiled: among the first ``count`` rows (pairs
    ``row_pairs``), those that ``v`` meets at their bound ``lo`` (slack under ``tol``), that
    restrict more than the box (``lo > low + tol``) and whose pair is closer than ``within``
    [m]: the pair with the smallest distance ``d`` (the first of equal ones); -1: none."""
    best, best_d = -1, math.inf
    for i in range(count):
        p = row_pairs[i]
        if not (d[p] < within and lo[i] > low[i] + tol):
            continue
        s = 0.0
        for j in range(C.shape[1]):
            s += C[i, j] * v[j]
        if s - lo[i] < tol and (best < 0 or d[p] < best_d):
            best, best_d = p, d[p]
    return best

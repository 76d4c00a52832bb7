"""The bounds of the redundant-axis rows (:class:`~controller.qp.constraints.axes.AxisLimit`),
compiled (numba): one call for every row instead of ~10 NumPy calls and a Python loop.

The rows ``C`` (n x nv) are filled by the caller; per row ``k`` its kind (:data:`HELD`,
:data:`FREE`, :data:`RANGED`) and values say what it asks for, exactly as the Python form in
:meth:`AxisLimit.compute_qp_inequalities <controller.qp.constraints.axes.AxisLimit.
compute_qp_inequalities>` (tests compare both): a held axis the rate that removes
HOLD_FRACTION of its drift per cycle, a ranged axis its braking band, each fitted into what
the cycle's joint box lets the row reach.
"""

from __future__ import annotations

import math

import numpy as np

from controller.model import jit
from controller.qp.constraints.braking import BRAKING_SHARE, compiled_braking_speed
from controller.qp.constraints.protocol import INF

#: Row kinds: held at a value; free this cycle (a held elbow nearly stretched); kept in a range.
HELD, FREE, RANGED = 0, 1, 2


def range_band(
    x: float, rmin: float, rmax: float, brake: float, dt: float, hold_fraction: float
) -> tuple[float, float]:
    """The rate band [unit/s] of an axis at ``x`` kept in [rmin, rmax] [rad, m]: inside,
    braking at ``brake`` [unit/s²] before each bound; outside (linearisation drift), pulled
    back in by ``hold_fraction`` of the gap per cycle of ``dt`` [s]. The Python rows and the
    compiled ones (:func:`axis_bounds`) both use it."""
    low = -compiled_braking_speed(x - rmin, brake, dt)
    high = compiled_braking_speed(rmax - x, brake, dt)
    if x < rmin:
        low = hold_fraction * (rmin - x) / dt
        high = max(high, low)
    elif x > rmax:
        high = hold_fraction * (rmax - x) / dt
        low = min(low, high)
    return low, high


def fit(low: float, high: float, r_lo: float, r_hi: float) -> tuple[float, float]:
    """[low, high] cut to the reachable [r_lo, r_hi]; the nearest reachable value when they
    do not overlap (the row then asks for the strongest correction the box allows)."""
    if high < r_lo:
        return r_lo, r_lo
    if low > r_hi:
        return r_hi, r_hi
    return max(low, r_lo), min(high, r_hi)


#: :func:`range_band` and :func:`fit` for compiled code.
compiled_range_band = jit.jit(range_band)
compiled_fit = jit.jit(fit)


@jit.jit
def axis_bounds(
    C: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    box: bool,
    kind: np.ndarray,
    wrap: np.ndarray,
    value: np.ndarray,
    first: np.ndarray,
    second: np.ndarray,
    a_max: np.ndarray,
    dt: float,
    hold_fraction: float,
    reach_margin: float,
    lo: np.ndarray,
    hi: np.ndarray,
) -> None:
    """``lo``/``hi`` of the ``len(kind)`` rows of ``C`` [unit/s]. ``value``: each axis now
    [rad, m]; ``first``/``second``: the held value (HELD) or the range's lower/upper bound
    (RANGED); ``wrap``: the error is an angle taken in (−π, π]; ``a_max`` [unit/s²] per
    joint; ``lb``/``ub``: the cycle's joint box (read only with ``box``)."""
    n, nv = kind.shape[0], C.shape[1]
    for k in range(n):
        reach_lo, reach_hi = -INF, INF
        if box:  # row · v over the box, shrunk by the margin at each end
            low = 0.0
            high = 0.0
            for j in range(nv):
                c = C[k, j]
                if c > 0.0:
                    low += c * lb[j]
                    high += c * ub[j]
                elif c < 0.0:
                    low += c * ub[j]
                    high += c * lb[j]
            margin = reach_margin * (high - low)
            reach_lo, reach_hi = low + margin, high - margin
        x = value[k]
        if kind[k] == FREE:
            lo[k], hi[k] = -INF, INF
        elif kind[k] == HELD:
            err = first[k] - x
            if wrap[k]:
                err -= 2.0 * math.pi * np.rint(err / (2.0 * math.pi))
            rate = hold_fraction * err / dt
            if box:
                rate = min(max(rate, reach_lo), reach_hi)
            lo[k] = rate
            hi[k] = rate
        else:
            rmin, rmax = first[k], second[k]
            best = 0.0
            for j in range(nv):
                best = max(best, abs(C[k, j]) * a_max[j])
            brake = BRAKING_SHARE * best
            low, high = compiled_range_band(x, rmin, rmax, brake, dt, hold_fraction)
            if box:
                low, high = compiled_fit(low, high, reach_lo, reach_hi)
            lo[k] = low
            hi[k] = high


if jit.available():  # compile (or load) at import, for the AxisLimit's buffers: never in a cycle
    _one = np.zeros(1)
    axis_bounds(
        np.zeros((1, 2)), np.zeros(2), np.zeros(2), True, np.zeros(1, dtype=np.int64),
        np.zeros(1, dtype=np.bool_), _one, _one, _one, np.ones(2), 0.001, 0.5, 0.01,
        np.zeros(1), np.zeros(1),
    )  # fmt: skip

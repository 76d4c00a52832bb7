"""The posture a Cartesian move keeps in its null space: one definition for the path check
and the control loop.

A 7-axis arm (or an arm with the waist or the vehicle) can follow a line of its control point
with many joint motions. Which one is the null-space objective's choice, and the reachability
check (:class:`~controller.motion.reachability.ReachabilityChecker`) must make the same choice
as the loop, or it checks one motion and the loop runs another: SmartPal V's hand 100 mm up
from home, checked with minimum-norm steps, rode r_arm_j6 to its limit where the check's
branch changed (11 deg of r_arm_j5 within one 1 cm sample) while the loop, pulling toward
its start posture, braked r_arm_j6 on its limit and ended 2 s late (MOTION_INCOMPLETE).

The objective, once: stay near the start posture ``q0`` in the metric of
:func:`limit_weights`, which grows as a joint nears a limit (the gradient of the joint-range
criterion of Chan and Dubey, IEEE T-RA 1995): joints far from their limits take the null-space
motion, a joint close to one is kept off it. The check solves every path sample for it,
warm-started from the previous sample (:func:`null_step`), so its joint path is continuous,
and the motion carries that path (:class:`PosturePath`): the loop's regularisation posture
follows it along the path parameter, so the loop's null space goes where the check went and
the line ends on the checked configuration.
"""

from __future__ import annotations

import bisect

import numpy as np

from controller.model import jit

#: Largest posture weight (a joint at or beyond a limit); the others are 1 at mid-range.
MAX_WEIGHT = 1e4
#: Share of a joint's range next to each limit that :func:`off_limits` draws postures out of.
LIMIT_ZONE = 0.1
#: Damping of :func:`null_step`'s inverse, relative to its trace.
RANK_TOL = 1e-10


def limit_weights(q: np.ndarray, q_min: np.ndarray, q_max: np.ndarray) -> np.ndarray:
    """Posture weight of each joint at ``q`` [rad, m]: ``1 + |∂H/∂q|`` with
    ``H = span² / (4·(q_max − q)·(q − q_min))`` (1 at mid-range, growing as the inverse square
    of the distance to the nearer limit), MAX_WEIGHT at or beyond a limit, 1 for a joint
    without finite limits."""
    lo = q - q_min
    hi = q_max - q
    with np.errstate(divide="ignore", invalid="ignore"):
        ab = lo * hi
        w = 1.0 + np.abs((lo + hi) ** 2 * (lo - hi) / (4.0 * ab * ab))
    w[~(ab > 0.0)] = MAX_WEIGHT  # at or beyond a limit (NaN: no finite limits, below)
    w[~np.isfinite(lo + hi)] = 1.0
    return np.minimum(w, MAX_WEIGHT)


def off_limits(q: np.ndarray, s: float, q_min: np.ndarray, q_max: np.ndarray) -> np.ndarray:
    """The posture ``q`` [rad, m] at path parameter ``s`` ∈ [0, 1], moved off the limits: a
    joint closer than LIMIT_ZONE × its range to a limit is drawn out of that zone by the end
    of the path (linearly in ``s``), so successive moves do not pile a joint up against a
    limit (each one drawn to its own start, a joint that every move brings nearer its limit
    ends there). Joints without finite limits are left as they are."""
    span = q_max - q_min
    zone = LIMIT_ZONE * np.where(np.isfinite(span), span, 0.0)
    inside = np.clip(q, q_min + zone, q_max - zone)
    out = q + s * (np.where(np.isfinite(span), inside, q) - q)
    return out


def null_step(
    rows: np.ndarray,
    free: np.ndarray,
    q: np.ndarray,
    q0: np.ndarray,
    weights: np.ndarray,
) -> np.ndarray:
    """The joint step [rad, m] toward ``q0`` that leaves ``rows`` (the task Jacobians and held
    axes, over every joint) unchanged, closest to ``q0 − q`` in the ``weights`` metric; only
    ``free`` joints (a mask) move. Zero when the tasks leave no redundancy.

    ``d = r − W⁻¹Aᵀ(AW⁻¹Aᵀ)⁻¹A r`` with ``r = q0 − q`` over the free joints (``A``: the rows),
    the inverse damped by :data:`RANK_TOL` of its trace (dependent or zero rows, singular
    arms: no redundancy left gives a step of rounding size)."""
    step = np.zeros_like(q)
    idx = np.flatnonzero(free)
    jac = rows.take(idx, axis=1)
    r = q0.take(idx) - q.take(idx)
    m = jac.shape[0]
    if m == 0:
        step[idx] = r
        return step
    inv_w = 1.0 / weights.take(idx)
    gram = (jac * inv_w).dot(jac.T)
    diagonal = gram.reshape(-1)[:: m + 1]  # a view
    diagonal += RANK_TOL * max(float(diagonal.sum()), 1e-12)
    step[idx] = r - inv_w * jac.T.dot(np.linalg.solve(gram, jac.dot(r)))
    return step


class PosturePath:
    """Joint configurations along a path, from the check (:attr:`s` increasing in [0, 1],
    :attr:`q` one row per sample, every joint [rad, m]); linear between samples."""

    def __init__(self, s: np.ndarray, q: np.ndarray):
        # Own contiguous copies: the compiled code is built for those (at import, not in a
        # control cycle).
        self.s = np.array(s, dtype=float)
        self.q = np.array(q, dtype=float)
        if self.s.ndim != 1 or self.q.shape[0] != len(self.s) or len(self.s) < 2:
            raise ValueError("a posture path needs two samples or more, one q per s")
        if np.any(np.diff(self.s) <= 0.0):
            raise ValueError("posture path parameters must increase")
        #: The samples' s as a list (``bisect`` on it beats ``np.searchsorted``'s dispatch),
        #: and each segment's change of q.
        self._grid: list[float] = self.s.tolist()
        self._dq = np.diff(self.q, axis=0)
        self._compiled = jit.available()

    def at(self, s: float) -> np.ndarray:
        """Configuration at path parameter ``s`` (clamped to the samples)."""
        grid = self._grid
        if s <= grid[0]:
            return self.q[0].copy()
        if s >= grid[-1]:
            return self.q[-1].copy()
        k = bisect.bisect_right(grid, s) - 1
        t = (s - grid[k]) / (grid[k + 1] - grid[k])
        return self.q[k] + t * self._dq[k]

    def follow(
        self,
        s0: float,
        s1: float,
        dt: float,
        joints: np.ndarray,
        reference: np.ndarray,
        rate: np.ndarray,
    ) -> None:
        """``reference`` := the configuration at ``s0`` (every joint), ``rate`` := the
        average rate [rad/s, m/s] of ``joints`` from ``s0`` to ``s1`` over ``dt`` [s]: a
        regularisation posture on the path, in one call every cycle (compiled where numba
        is)."""
        if self._compiled:
            _follow(self.s, self.q, self._dq, s0, s1, dt, joints, reference, rate)
            return
        now = self.at(s0)
        reference[...] = now
        rate[...] = (self.at(s1) - now)[joints] / dt


@jit.jit
def _interpolate(grid: np.ndarray, q: np.ndarray, dq: np.ndarray, s: float, out: np.ndarray):
    """:meth:`PosturePath.at` into ``out``."""
    n = grid.shape[0]
    if s <= grid[0]:
        out[:] = q[0]
        return
    if s >= grid[n - 1]:
        out[:] = q[n - 1]
        return
    k = np.searchsorted(grid, s, side="right") - 1
    t = (s - grid[k]) / (grid[k + 1] - grid[k])
    for j in range(out.shape[0]):
        out[j] = q[k, j] + t * dq[k, j]


@jit.jit
def _follow(
    grid: np.ndarray,
    q: np.ndarray,
    dq: np.ndarray,
    s0: float,
    s1: float,
    dt: float,
    joints: np.ndarray,
    reference: np.ndarray,
    rate: np.ndarray,
) -> None:
    """:meth:`PosturePath.follow` compiled."""
    _interpolate(grid, q, dq, s0, reference)
    nxt = np.empty(q.shape[1])
    _interpolate(grid, q, dq, s1, nxt)
    for i in range(joints.shape[0]):
        j = joints[i]
        rate[i] = (nxt[j] - reference[j]) / dt


if jit.available():  # compile (or load) at import, for the arrays a path owns: never in a cycle
    _follow(
        np.array([0.0, 1.0]), np.zeros((2, 1)), np.zeros((1, 1)), 0.2, 0.3, 1e-3,
        np.zeros(1, dtype=np.int64), np.zeros(1), np.zeros(1),
    )  # fmt: skip

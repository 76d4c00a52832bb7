"""Collision avoidance: velocity-damper rows on the distances of the checked pairs.

For every row of a :class:`~controller.model.collision.CollisionDistances` (self-collision
pairs, and whatever else it holds: static obstacles, held objects) closer than the influence
distance ``d_i``, one row on the distance rate ``d' = J_d v`` [m/s]::

    d' ≥ −s_k          s_k ≥ 0: the approach speed allowed to pair k this cycle [m/s]

with, ``g = d − d_s`` the gap to the security distance and ``a_k`` the deceleration of the
pair the joints can give (half of what the acceleration limits allow along ``J_d``,
``a_k = BRAKING_SHARE·Σ_j |J_d,j|·a_max,j``: the other half is the tasks' headroom, as for
the joints' braking distances):

* **damper**: ``s_k = ξ_k·max(g, 0)/(d_i − d_s)``, with ``ξ_k = min(ξ, √(a_k·(d_i − d_s)))``:
  the damper's own profile (an exponential approach, deceleration ``ξ_k²·g/(d_i − d_s)²``)
  never asks more than ``a_k``;
* **activation** (mc_rtc's rule, in speeds): a pair that comes into range approaching faster
  than its damper allows is allowed its current approach speed ``-J_d·v_prev``: the row holds
  for the velocity the robot has, never infeasible on entry;
* **relaxation back**: afterwards the allowance may only shrink by ``a_k·dt`` per cycle (or to
  the current approach speed, if slower), down to the damper's value: the rows never ask for
  more deceleration than ``a_k``;
* **below d_s**: the damper's value is 0, "no further closer" (after braking as above); the
  rows never push a pair apart (``lo ≤ 0``), so an overlap is never resolved violently;
* with the cycle's joint box, the rows never ask for more than one common velocity ``v*`` of
  the box gives them: each joint moved from ``v_prev`` by ``a_max·dt`` in the direction the
  rows asking for more than ``v_prev`` want (a single row gets its strongest braking). ``v*``
  satisfies every row and the box, so they are never infeasible together, however many
  pairs are in range.

Both levels; relaxation "no further" (``lo ≤ 0`` always holds: the rows are never dropped).
More pairs in range than ``max_rows``: the most urgent ones (equal urgency: the lower pair
index). A row the cycle's joint box implies (``min J_d v`` over the box at least its bound)
cannot bind and stays out of the QP (:attr:`CollisionAvoidance.row_pairs` lists the rows'
pairs, :attr:`~CollisionAvoidance.pairs` every pair in range).

With compiled distances (:attr:`CollisionDistances.compiled`) one call of
:mod:`~controller.qp.constraints.damper_kernel` does all of this; the NumPy code below is the
fallback and the reference the kernel is tested against.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from controller.model.collision import CollisionDistances
from controller.model.collision_pairs import robot_distances
from controller.model.kinematics import Kinematics
from controller.model.obstacles import Obstacle
from controller.model.profile import CollisionAvoidance as Settings
from controller.qp.constraints.braking import BRAKING_SHARE
from controller.qp.constraints.damper_kernel import binding as binding_kernel
from controller.qp.constraints.damper_kernel import collision_rows
from controller.qp.constraints.protocol import (
    INF,
    ConstraintSetup,
    CycleState,
    Level,
    Relaxation,
    RowBlock,
)

#: The common velocity stays this share of the box inside it, and each row's bound this far
#: [m/s] below what it gives: a feasible set that is only a corner defeats solvers.
INTERIOR = 0.05
BRAKE_MARGIN = 1e-6
#: Rows whose pair can decelerate less than this [m/s²] (``Σ_j |J_d,j|·a_max,j``) are left
#: free: the pair's distance does not depend on the (free) joints there.
MIN_REACH = 1e-6
#: The compiled rows (its first arguments come packed: :meth:`CollisionAvoidance._compiled`).
_rows_kernel: Callable[..., tuple[int, int]] = collision_rows
#: A row binds when ``J_d v`` is within this [m/s] of its bound.
BINDING_TOL = 1e-5
#: A row whose bound the cycle's joint box meets anyway (``min J_d v`` over the box at least
#: its bound, less this [m/s] for rounding) is left out of the QP: it cannot bind.
IMPLIED = 1e-9


class CollisionAvoidance:
    """Velocity-damper rows of the pairs of ``distances`` within the influence distance.

    ``distances`` must be updated once per cycle at the measured state, after the kinematics
    (the motion core does it), before the IK step. ``settings``: the profile's values.
    """

    name = "collision avoidance"
    #: With compiled distances, whether they compute only the pairs that may come within
    #: reach of the rows (:mod:`controller.model.collision_screen`): set when the rows'
    #: settings are next read.
    screen = True
    levels = Level.BOTH
    relaxation = Relaxation.NO_FURTHER
    joints = None
    holds_at_rest = True

    def __init__(
        self, kin: Kinematics, distances: CollisionDistances, settings: Settings, dt: float
    ):
        self.distances = distances
        self.dt = dt
        self.influence = settings.influence
        self.security = settings.security
        self.damping = settings.damping
        self.lookahead = settings.lookahead
        self.max_rows = min(settings.max_rows, len(distances))
        #: Per pair: the distance at the last call [m] (its change: the approach speed),
        #: scratch, the approach speed allowed at the last cycle [m/s] (INF: out of range).
        #: One array, as the kernel takes them.
        self._state = np.full((3, len(distances)), np.nan)
        self._d_last = self._state[0]
        self._a_max_all = np.array([kin.robot.joints[n].acceleration for n in kin.joint_names])
        nv = len(self._a_max_all)
        #: Scratch columns: (v_prev, ub + lb) and (a_max of the free joints, ub − lb).
        self._vm = np.zeros((nv, 2))
        self._ah = np.zeros((nv, 2))
        self._ah[:, 0] = self._a_max_all
        #: Approach speed allowed per pair at the last cycle [m/s] (INF: out of range).
        self.allowed = self._state[2]
        self.allowed[...] = INF
        #: The pairs in range this cycle (ascending), and those of the QP's rows (in row
        #: order: the pairs in range less those whose row the joint box implies).
        self.pairs = np.zeros(0, dtype=np.int64)
        self.row_pairs = np.zeros(0, dtype=np.int64)
        #: The QP rows' lower bounds [m/s].
        self._rows_lo = np.zeros(self.max_rows)
        #: The least ``J_d v / |J_d|`` the cycle's box allows, per row.
        self._low = np.zeros(self.max_rows)
        self._rows: RowBlock | None = None
        #: The compiled path's pair buffers (two: this cycle's and the last one's; see
        #: :func:`~controller.qp.constraints.damper_kernel.collision_rows`).
        self._buffers = self._pair_buffers(self.max_rows)
        #: See :func:`collision_rows`; the first seven are written at each call.
        self._settings = np.array(
            [0, 0, 0, 0, 0, 0, 0, BRAKING_SHARE, INTERIOR, BRAKE_MARGIN, MIN_REACH, IMPLIED, INF],
            dtype=float,
        )
        self._candidates = np.zeros(len(distances), dtype=np.int64)
        #: The values :attr:`_settings` holds and the kernel's own arguments (see
        #: :meth:`_compiled`).
        self._settings_of: tuple[float, ...] = ()
        self._own: tuple[Any, ...] = ()
        #: Acceleration limits of the joints, 0 for frozen ones [rad/s², m/s²] (contiguous).
        self._a_max = self._a_max_all.copy()
        if distances.kernel is not None:
            self._warm_up(nv)

    def _warm_up(self, nv: int) -> None:
        """Compile (or load from the cache) the rows kernel for the arrays a cycle passes, on
        scratch copies: the first control cycle must not wait for it."""
        rows = RowBlock(
            np.zeros((self.max_rows, nv)), np.zeros(self.max_rows), np.zeros(self.max_rows)
        )
        zero = np.zeros(nv)
        state, allowed = self._state.copy(), self.allowed.copy()
        for box in (False, True):
            cycle = CycleState(None, zero, zero, zero if box else None, zero if box else None)  # type: ignore[arg-type]
            self.compute_qp_inequalities(cycle, rows)
        self._state[...] = state
        self.allowed[...] = allowed
        self.pairs = self.row_pairs = np.zeros(0, dtype=np.int64)
        binding_kernel(
            rows.C, 0, zero, self._rows_lo, self._low, self.distances.distances,
            self._buffers[0][1][:0], 0.0, BINDING_TOL,
        )  # fmt: skip
        self._rows = None

    @staticmethod
    def _pair_buffers(size: int) -> list[tuple[np.ndarray, np.ndarray]]:
        """Two (pairs in range, pairs of the rows) buffers of ``size`` for the kernel."""
        return [(np.zeros(size, dtype=np.int64), np.zeros(size, dtype=np.int64)) for _ in "ab"]

    @property
    def span(self) -> float:
        """``d_i − d_s`` [m]: the damper's range."""
        return self.influence - self.security

    def configure(self, kin: Kinematics, setup: ConstraintSetup) -> None:
        """Frozen joints give no deceleration."""
        self._ah[:, 0] = np.where(setup.frozen, 0.0, self._a_max_all)
        self._a_max[...] = self._ah[:, 0]

    def compute_qp_inequalities(self, cycle: CycleState, rows: RowBlock) -> int:
        self._rows = rows
        if len(self._low) < self.max_rows:  # raised since (tests and tools do)
            self._buffers = self._pair_buffers(self.max_rows)
            self._low, self._rows_lo = np.zeros(self.max_rows), np.zeros(self.max_rows)
            self._settings_of = ()  # the kernel's arguments anew
        if self.distances.kernel is not None:
            return self._compiled(cycle, rows)
        dist = self.distances
        d = dist.distances
        # Pairs in range: closer than d_i, or closing in fast enough to get there within
        # the look-ahead (approach speed from the distances of the last call: every pair at
        # the cost of one subtraction); the most urgent first.
        closing = np.subtract(self._d_last, d)
        self._d_last[...] = d
        np.fmax(closing, 0.0, out=closing)  # NaN (no last call): not closing
        key = d - closing * (self.lookahead / self.dt)
        near = np.flatnonzero(key < self.influence)
        if len(near) > self.max_rows:
            # the most urgent; equal keys (symmetric shapes): the lower pair index
            urgent = np.argsort(key[near], kind="stable")[: self.max_rows]
            near = np.sort(near[urgent])
        k = len(near)
        if not k:
            self.allowed[self.pairs] = INF
            self.pairs = self.row_pairs = near
            return 0
        C, lo, hi = rows.C[:k], rows.lo[:k], rows.hi[:k]
        dist.jacobian_into(near, C)
        span, dt = self.span, self.dt
        # Two products per row give what the rows need: with mid = (ub + lb)/2 and
        # half = (ub − lb)/2, J_d v over the box spans J_d·mid ± |J_d|·half.
        vm, ah = self._vm, self._ah
        v_prev, lb, ub = cycle.v_prev, cycle.lb, cycle.ub
        vm[:, 0] = v_prev
        if lb is not None and ub is not None:
            np.add(ub, lb, out=vm[:, 1])
            np.subtract(ub, lb, out=ah[:, 1])
        else:
            vm[:, 1] = 0.0
            ah[:, 1] = INF
        signed = C.dot(vm)  # (k, 2): d' at v_prev, 2 J_d·mid
        spread = np.abs(C).dot(ah)  # (k, 2): most deceleration [m/s²], 2 |J_d|·half
        reach = spread[:, 0]
        a = BRAKING_SHARE * reach
        xi = np.sqrt(a * span)
        np.minimum(xi, self.damping, out=xi)
        gap = d[near] - self.security
        np.maximum(gap, 0.0, out=gap)
        damper = np.minimum(gap, span)
        damper *= xi / span  # ξ_k·g/(d_i − d_s), ξ_k beyond d_i
        approach = np.negative(signed[:, 0])  # current approach speed [m/s]
        prev = self.allowed[near]  # INF: the pair has just come into range
        speed = np.minimum(prev, approach)
        # Slow down at a, or faster (up to all the joints can) when a cannot stop the pair
        # by d_s any more: at the deceleration that stops it there, s²/(2g).
        need = speed * speed / (2.0 * gap + 1e-12)
        rate = np.maximum(need, a)  # (np.clip costs several times more)
        np.minimum(rate, reach, out=rate)
        rate *= dt
        # On entry (prev = INF) the current approach speed: satisfied as it is.
        allowed = np.minimum(prev - rate, approach)
        np.maximum(allowed, damper, out=allowed)
        self.allowed[self.pairs] = INF  # pairs that left the range start afresh
        self.pairs = near
        self.allowed[near] = allowed
        np.negative(allowed, out=lo)
        if lb is not None and ub is not None:
            self._common(C, lo, signed[:, 0], reach, v_prev, lb, ub)
        low = signed[:, 1] - spread[:, 1]
        # A pair whose distance hardly depends on the joints (|J_d| ~ 0) gets a free row.
        lo[reach < MIN_REACH] = -INF
        hi[...] = INF
        low *= 0.5
        self.row_pairs = near
        if lb is not None and ub is not None:  # rows the box implies stay out of the QP
            keep = np.flatnonzero(lo > low - IMPLIED)
            m = len(keep)
            if m < k:
                C[:m] = C[keep]
                lo[:m] = lo[keep]
                low = low[keep]
                lo[m:] = -INF
                hi[m:] = INF
                self.row_pairs = near[keep]
                k = m
        self._low[:k] = low
        self._rows_lo[:k] = lo[:k]  # before the IK shifts them (frozen joints' share)
        return k

    def _compiled(self, cycle: CycleState, rows: RowBlock) -> int:
        """:meth:`compute_qp_inequalities` in one compiled call (same rows, same order)."""
        dist = self.distances
        kernel = dist.kernel
        assert kernel is not None
        # this cycle's pair buffers: the pair of buffers last cycle's pairs are not in
        cap = min(self.max_rows, len(rows.lo))  # the kernel writes this many rows at most
        near, row_pairs = self._buffers[self.pairs.base is self._buffers[0][0]]
        box = cycle.lb is not None and cycle.ub is not None
        lb = cycle.v_prev if cycle.lb is None else cycle.lb  # v_prev: unread
        ub = cycle.v_prev if cycle.ub is None else cycle.ub
        # the settings of now (tests and tools change them), written when they change
        values = (
            self.influence, self.lookahead, self.dt, cap, self.security, self.damping,
            self.screen,
        )  # fmt: skip
        if values != self._settings_of:
            self._settings_of = values
            # the distances compute only the pairs that may come within reach of the rows
            if self.screen:
                kernel.screen.set(self.influence, self.lookahead / self.dt)
            else:
                kernel.screen.off()
            self._settings[:7] = (
                self.influence, self.lookahead / self.dt, cap, self.security, self.span,
                self.damping, self.dt,
            )  # fmt: skip
            self._own = (
                dist.distances, self._state, kernel.screen.cap, self._candidates,
                self._settings, dist.support,
                dist.witnesses, kernel.columns, kernel.column_kind, self._a_max, self._low,
            )  # fmt: skip
        k, m = _rows_kernel(
            *self._own, near, row_pairs, self.pairs, cycle.v_prev, lb, ub, box, rows.C,
            rows.lo, rows.hi,
        )  # fmt: skip
        self.pairs = near[:k]
        self.row_pairs = row_pairs[:m]
        self._rows_lo[:m] = rows.lo[:m]
        return int(m)

    def _common(
        self,
        C: np.ndarray,
        lo: np.ndarray,
        now: np.ndarray,
        reach: np.ndarray,
        v_prev: np.ndarray,
        lb: np.ndarray,
        ub: np.ndarray,
    ) -> None:
        """Lower ``lo`` to what one velocity in the box gives every row: ``v*``, each joint
        accelerated at its limit in the direction the rows short of ``v_prev`` want (their
        shortfalls weighted by 1/reach). One row alone gets its best braking; rows that
        disagree get what a common velocity gives: rows and box are never infeasible."""
        short = lo - now  # what each row asks beyond v_prev [m/s]
        np.maximum(short, 0.0, out=short)
        short /= np.maximum(reach, MIN_REACH)
        direction = np.sign(C.T.dot(short))
        direction *= self._ah[:, 0]
        direction *= (1.0 - INTERIOR) * self.dt
        direction += v_prev
        # Inside the box (a corner of the box and the rows is what solvers miss numerically).
        inset = INTERIOR * (ub - lb)
        np.maximum(direction, lb + inset, out=direction)
        np.minimum(direction, ub - inset, out=direction)
        cap = C.dot(direction)
        cap -= BRAKE_MARGIN
        np.minimum(lo, cap, out=lo)

    def binding(self, v: np.ndarray, within: float = INF) -> int:
        """The pair (index into ``distances``) whose row ``v`` [rad/s, m/s] meets at its
        bound, among those closer than ``within`` [m], the closest such pair; -1 when none.
        A row that allows all the joint box allows (the joints it involves are frozen or
        braking anyway) holds nothing back: it never binds."""
        k = len(self.row_pairs)
        if not k or self._rows is None:
            return -1
        if self.distances.kernel is not None:  # one compiled call (every cycle of a move)
            return int(
                binding_kernel(
                    self._rows.C, k, v, self._rows_lo, self._low, self.distances.distances,
                    self.row_pairs, within, BINDING_TOL,
                )
            )  # fmt: skip
        lo = self._rows_lo[:k]
        slack = self._rows.C[:k].dot(v) - lo
        close = self.distances.distances[self.row_pairs] < within
        restricts = lo > self._low[:k] + BINDING_TOL
        tight = np.flatnonzero((slack < BINDING_TOL) & restricts & close)
        if not len(tight):
            return -1
        pairs = self.row_pairs[tight]
        return int(pairs[np.argmin(self.distances.distances[pairs])])


def collision_avoidance(
    kin: Kinematics, dt: float, obstacles: Sequence[Obstacle] = ()
) -> CollisionAvoidance | None:
    """The robot's constraint on its checked pairs (``collision.yaml``) and the static
    ``obstacles`` of the daemon configuration (placed in the original frame of start-up),
    with its profile's settings; None when the profile disables it or there is no pair."""
    settings = kin.robot.profile.collision_avoidance
    if not settings.enabled:
        return None
    distances = robot_distances(kin, obstacles)
    if not len(distances):
        return None
    return CollisionAvoidance(kin, distances, settings, dt)

"""The joint box: per-joint velocity bounds of one cycle, the QP's box constraint.

The intersection of
  * velocity:      −v_max ≤ v ≤ v_max
  * acceleration:  v_prev − a_max·dt ≤ v ≤ v_prev + a_max·dt
  * position with braking distance (:mod:`~controller.qp.constraints.braking`): after this
    cycle the joint can still stop at a_b = BRAKING_SHARE·a_max before its limit; beyond a
    limit the bound is 0: never further out, moving back is allowed.
  * frozen joints: v = 0 (masked waist axes, units not taking part in the motion), applied
    as a velocity limit of 0.
Where these conflict (a joint already inside its braking distance, or frozen while moving),
the bound closest to "stop as fast as the acceleration limit allows" wins: the box never
crosses (``lb ≤ ub``), and a frozen joint's ``lb = ub`` is its velocity this cycle.
"""

from __future__ import annotations

import math

import numpy as np

from controller.model import jit
from controller.model.kinematics import Kinematics
from controller.qp.constraints.braking import BRAKING_SHARE
from controller.qp.constraints.protocol import ConstraintSetup, Level, Relaxation

#: Attributes of :class:`JointBox` its precomputed arrays derive from.
_BOX_INPUTS = frozenset({"dt", "q_min", "q_max", "v_max", "a_max", "a_brake"})


class JointBox:
    """Per-joint velocity bounds [rad/s, m/s] for one cycle of length ``dt`` [s].

    The braking bound ``√((a_b·dt)² + 2·a_b·d) − a_b·dt`` is computed on both sides at once,
    from arrays prepared when the limits are set: assigning ``dt``, ``q_min``, ``q_max``,
    ``v_max``, ``a_max`` or ``a_brake`` re-prepares them (the arrays are kept read-only:
    change them by assignment). The frozen mask is set by :meth:`configure` only; a new
    mask re-prepares only the velocity caps it sets (a motion start with the limits
    unchanged costs ~2 µs here, not the ~35 of preparing everything).
    """

    name = "joint box"
    levels = Level.BOTH
    relaxation = Relaxation.HARD

    def __init__(self, kin: Kinematics, dt: float):
        specs = [kin.robot.joints[n] for n in kin.joint_names]
        self.dt = dt
        self.q_min = np.array([s.lower for s in specs])  # [rad, m]
        self.q_max = np.array([s.upper for s in specs])
        self.v_max = np.array([s.velocity for s in specs])  # [rad/s, m/s]
        self.a_max = np.array([s.acceleration for s in specs])  # [rad/s², m/s²]
        #: Deceleration [rad/s², m/s²] the braking distance is planned with.
        self.a_brake = BRAKING_SHARE * self.a_max
        self._set_frozen(np.zeros(len(specs), dtype=bool))
        #: Bounds from the compiled kernel (:func:`box_bounds`), compiled (or loaded) now.
        self._compiled = jit.available()
        if self._compiled:
            self.compute_qp_bounds(np.zeros(len(specs)), np.zeros(len(specs)))

    def __setattr__(self, name: str, value: object) -> None:
        if name in _BOX_INPUTS:
            if name != "dt":  # a read-only copy: changing it in place would go unnoticed
                value = np.array(value, dtype=float)
                value.flags.writeable = False
            super().__setattr__("_prepared", False)
            super().__setattr__("_limits_prepared", False)
        super().__setattr__(name, value)

    @property
    def frozen(self) -> np.ndarray:
        """Joints held still (True = frozen); read-only, set by :meth:`configure`."""
        return self._frozen

    def configure(self, kin: Kinematics, setup: ConstraintSetup) -> None:
        """Take the motion's frozen joints."""
        self._set_frozen(setup.frozen)

    def _set_frozen(self, frozen: np.ndarray) -> None:
        mask = np.array(frozen, dtype=bool)
        current: np.ndarray | None = getattr(self, "_frozen", None)
        if current is not None and np.array_equal(mask, current):
            return  # the same mask: what was prepared for it holds
        mask.flags.writeable = False
        self._frozen = mask
        self._prepared = False

    def _prepare(self) -> None:
        """The arrays the bounds are computed from: those of the limits and ``dt`` when
        these changed, the velocity caps of the frozen mask always."""
        if not self._limits_prepared:
            self._prepare_limits()
        # A frozen joint has velocity limit 0: at rest that holds it, and while it still
        # moves faster than a·dt the limit conflicts with the acceleration one (see bounds).
        self._v_cap = np.where(self._frozen, 0.0, self._v_max2)
        self._prepared = True

    def _prepare_limits(self) -> None:
        dt, a_b = self.dt, self.a_brake
        n = len(self.a_max)
        self._a_dt = self.a_max * dt
        brake_dt = a_b * dt
        two_ab = 2.0 * a_b
        # Both sides at once, row 0 toward q_min and row 1 toward q_max, as upper bounds
        # (row 0 bounds −lb): same-shape operands avoid NumPy's slower broadcasting.
        self._two_ab = two_ab
        self._neg_two_ab = -two_ab
        with np.errstate(invalid="ignore"):  # 0·∞ for a zero deceleration: no bound
            off = np.stack([-two_ab * self.q_min, two_ab * self.q_max])
        #: 2·a_b·d + (a_b·dt)² = ±2·a_b·q + this; d ≤ 0 (at or beyond the limit) gives bound 0.
        self._floor = np.stack([brake_dt * brake_dt] * 2)
        self._off_q = np.where(np.isnan(off), np.inf, off) + self._floor
        self._brake_dt2 = np.stack([brake_dt] * 2)
        self._v_max2 = np.stack([self.v_max] * 2)
        self._up = np.empty((2, n))
        self._dist = np.empty((2, n))
        self._rows = (self._up[0], self._up[1], self._dist[0], self._dist[1])  # views, made once
        self._zero = np.zeros(n)
        self._limits_prepared = True

    def compute_qp_bounds(self, q: np.ndarray, v_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lb, ub) [rad/s, m/s] for commanded position ``q`` [rad, m] and previous velocity
        ``v_prev`` [rad/s, m/s]; new arrays, the caller's to keep."""
        if not self._prepared:
            self._prepare()
        if self._compiled:
            lb, ub = np.empty(len(q)), np.empty(len(q))
            box_bounds(
                q, v_prev, self._a_dt, self._v_cap, self._two_ab, self._off_q, self._floor,
                self._brake_dt2, lb, ub,
            )  # fmt: skip
            return lb, ub
        up, dist, a_dt = self._up, self._dist, self._a_dt
        up0, up1, dist0, dist1 = self._rows
        np.subtract(a_dt, v_prev, out=up0)  # acceleration: −lb ≤ a·dt − v_prev
        np.add(a_dt, v_prev, out=up1)  # ub ≤ a·dt + v_prev
        np.minimum(up, self._v_cap, out=up)
        np.multiply(self._two_ab, q, out=dist0)  # braking distance to q_min
        np.multiply(self._neg_two_ab, q, out=dist1)  # and to q_max
        dist += self._off_q
        np.maximum(dist, self._floor, out=dist)
        np.sqrt(dist, out=dist)
        dist -= self._brake_dt2
        np.minimum(up, dist, out=up)
        lb = np.subtract(self._zero, up0)  # not np.negative: a zero bound stays +0.0
        ub = up1.copy()
        # Conflicts (lb > ub): decelerate as hard as allowed, towards zero.
        hold = np.greater(lb, ub)
        if np.count_nonzero(hold):
            v = v_prev[hold]
            a_dt = a_dt[hold]
            lb[hold] = ub[hold] = np.minimum(np.maximum(v - a_dt, 0.0), v + a_dt)
        return lb, ub


@jit.jit
def box_bounds(
    q: np.ndarray,
    v_prev: np.ndarray,
    a_dt: np.ndarray,
    v_cap: np.ndarray,
    two_ab: np.ndarray,
    off_q: np.ndarray,
    floor: np.ndarray,
    brake_dt: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
) -> None:
    """:meth:`JointBox.compute_qp_bounds` joint by joint, compiled (same arithmetic as its
    NumPy code, NaN propagating as in NumPy's minimum/maximum: tests compare them). Arrays
    as :meth:`JointBox._prepare` makes them; writes ``lb`` and ``ub`` [rad/s, m/s]."""
    for i in range(q.shape[0]):
        toward_min = _minimum(a_dt[i] - v_prev[i], v_cap[0, i])  # bounds −lb
        toward_max = _minimum(a_dt[i] + v_prev[i], v_cap[1, i])
        room = math.sqrt(_maximum(two_ab[i] * q[i] + off_q[0, i], floor[0, i])) - brake_dt[0, i]
        toward_min = _minimum(toward_min, room)
        room = math.sqrt(_maximum(-two_ab[i] * q[i] + off_q[1, i], floor[1, i])) - brake_dt[1, i]
        toward_max = _minimum(toward_max, room)
        low, high = 0.0 - toward_min, toward_max  # 0 − x: a zero bound stays +0.0
        if low > high:  # conflict: decelerate as hard as allowed, towards zero
            low = high = min(max(v_prev[i] - a_dt[i], 0.0), v_prev[i] + a_dt[i])
        lb[i], ub[i] = low, high


@jit.jit
def _minimum(a: float, b: float) -> float:
    """NumPy's minimum: NaN if either is."""
    return a if a < b or a != a else b


@jit.jit
def _maximum(a: float, b: float) -> float:
    """NumPy's maximum: NaN if either is."""
    return a if a > b or a != a else b

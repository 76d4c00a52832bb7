"""Limits: the hard constraints of the cycle's QP, as bounds on ``v`` and linear rows.

Box bounds (per joint) — the intersection of
  * velocity:      −v_max ≤ v ≤ v_max
  * acceleration:  v_prev − a_max·dt ≤ v ≤ v_prev + a_max·dt
  * position with braking distance: after this cycle the joint can still stop at a_b before
    its limit: (q + v·dt) + v²/(2·a_b) ≤ q_max, i.e.
    v ≤ a_b·(−dt + √(dt² + 2·(q_max − q)/a_b)) (and the mirror image at q_min), with
    a_b = BRAKING_SHARE·a_max. By induction a limit is never crossed: decelerating at
    a_b ≤ a_max always stays feasible.
    Beyond a limit the bound is 0: never further out, moving back is allowed.
  * frozen joints: v = 0 (masked waist axes, units not taking part in the motion), applied
    as a velocity limit of 0.
Where these conflict (a joint already inside its braking distance, or frozen while moving),
the bound closest to "stop as fast as the acceleration limit allows" wins.

Linear rows ``l ≤ C v ≤ u``, one per redundant axis, plus the differential-drive row:
  * masked axis (not selected for Cartesian moves): held at its value when the motion
    started, ``J_axis v = 0.5·(x_hold − x)/dt`` exactly (the feedback removes the
    second-order drift a bare ``J_axis v = 0`` would accumulate); a held elbow rests while the
    arm is within 1 cm of full stretch, where the angle is undefined;
  * RedundantLimit range [lo, hi]: the axis rate toward a bound is limited by a braking
    distance, as for joints, at half the deceleration its best joint can give it
    (``a_axis = ½·max_j |J_axis,j|·a_max,j``); linearised at the measured value ``x``;
    outside (drift of the linearisation) it is pulled back in like a held axis;
  * differential drive: no sideways body velocity, ``−sinθ·ẋ + cosθ·ẏ = 0``.
"""

from __future__ import annotations

import math

import numpy as np

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, axis_jacobian, axis_joints, axis_value
from controller.vocabulary import UnitType

INF = 1e20
#: Braking distances are planned at this share of the acceleration limit. A joint that brakes
#: alone could use all of it, but a null-space motion braking at one joint's limit must
#: brake in every joint at once without the control point drifting: the rest of a_max is the
#: headroom the other joints need for that.
BRAKING_SHARE = 0.5
#: A held elbow angle is not enforced while the elbow is closer than this [m] to the
#: shoulder-wrist line: the angle is (nearly) undefined there and its Jacobian explodes.
HOLD_MIN_ELBOW_OFFSET = 0.01
#: Fraction of a masked axis's drift from its held value removed per cycle.
HOLD_FRACTION = 0.5


#: Attributes of :class:`JointBox` its precomputed arrays derive from.
_BOX_INPUTS = frozenset({"dt", "q_min", "q_max", "v_max", "a_max", "a_brake"})


class JointBox:
    """Per-joint velocity bounds for one cycle of length ``dt`` [s].

    The braking bound is computed as ``√((a_b·dt)² + 2·a_b·d) − a_b·dt`` (the same number as
    ``a_b·(−dt + √(dt² + 2·d/a_b))``), on both sides at once, from arrays prepared when the
    limits are set: assigning ``dt``, ``q_min``, ``q_max``, ``v_max``, ``a_max`` or ``a_brake``
    re-prepares them (the arrays are kept read-only: change them by assignment).
    """

    def __init__(self, kin: Kinematics, dt: float):
        specs = [kin.robot.joints[n] for n in kin.joint_names]
        self.dt = dt
        self.q_min = np.array([s.lower for s in specs])
        self.q_max = np.array([s.upper for s in specs])
        self.v_max = np.array([s.velocity for s in specs])
        self.a_max = np.array([s.acceleration for s in specs])
        #: Deceleration [unit/s²] the braking distance is planned with (see BRAKING_SHARE).
        self.a_brake = BRAKING_SHARE * self.a_max
        #: Joints held still this cycle (True = frozen).
        self.frozen = np.zeros(len(specs), dtype=bool)

    def __setattr__(self, name: str, value: object) -> None:
        if name in _BOX_INPUTS:
            if name != "dt":  # a read-only copy: changing it in place would go unnoticed
                value = np.array(value, dtype=float)
                value.flags.writeable = False
            super().__setattr__("_prepared", False)
        super().__setattr__(name, value)

    def _prepare(self) -> None:
        dt, a_b = self.dt, self.a_brake
        n = len(self.a_max)
        self._a_dt = self.a_max * dt
        self._brake_dt = a_b * dt
        two_ab = 2.0 * a_b
        # Both sides at once, row 0 toward q_min and row 1 toward q_max, as upper bounds
        # (row 0 bounds −lb): same-shape operands avoid NumPy's slower broadcasting.
        self._two_ab = two_ab
        self._neg_two_ab = -two_ab
        with np.errstate(invalid="ignore"):  # 0·∞ for a zero deceleration: no bound
            off = np.stack([-two_ab * self.q_min, two_ab * self.q_max])
        #: 2·a_b·d + (a_b·dt)² = ±2·a_b·q + this; d ≤ 0 (at or beyond the limit) gives bound 0.
        self._floor = np.stack([self._brake_dt * self._brake_dt] * 2)
        self._off_q = np.where(np.isnan(off), np.inf, off) + self._floor
        self._brake_dt2 = np.stack([self._brake_dt] * 2)
        self._v_max2 = np.stack([self.v_max] * 2)
        self._up = np.empty((2, n))
        self._dist = np.empty((2, n))
        self._rows = (self._up[0], self._up[1], self._dist[0], self._dist[1])  # views, made once
        self._frozen_key: bytes | None = None  # the frozen mask _v_cap was made for
        self._zero = np.zeros(n)
        self._prepared = True

    def braking_bound(self, distance: np.ndarray) -> np.ndarray:
        """Largest speed [unit/s] toward a limit ``distance`` away that can still stop.

        Infinite for unbounded joints; 0 at or beyond the limit (negative distance: noise, a
        changed profile), so the joint never moves further out but may move back.
        """
        if not self._prepared:
            self._prepare()
        d = np.maximum(distance, 0.0)
        bound: np.ndarray = np.sqrt(self._floor[0] + 2.0 * self.a_brake * d) - self._brake_dt
        return bound

    def bounds(self, q: np.ndarray, v_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lb, ub) [unit/s] for commanded position ``q`` and previous velocity ``v_prev``."""
        if not self._prepared:
            self._prepare()
        up, dist, a_dt = self._up, self._dist, self._a_dt
        up0, up1, dist0, dist1 = self._rows
        np.subtract(a_dt, v_prev, out=up0)  # acceleration: −lb ≤ a·dt − v_prev
        np.add(a_dt, v_prev, out=up1)  # ub ≤ a·dt + v_prev
        # A frozen joint has velocity limit 0: at rest that holds it, and while it still moves
        # faster than a·dt the limit conflicts with the acceleration one, handled below.
        key = self.frozen.tobytes()
        if key != self._frozen_key:
            self._frozen_key = key
            self._v_cap = np.where(self.frozen, 0.0, self._v_max2)
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


class AxisRows:
    """One linear row per redundant axis, plus the differential-drive row when needed.

    Rows that constrain nothing (axis allowed, no range, or every joint that moves it frozen)
    are left as zero rows with infinite bounds and not recomputed: :meth:`configure` decides,
    lists the others in :attr:`active` and counts its calls in :attr:`version` (the IK gives
    only the active rows to its solver).
    """

    def __init__(self, kin: Kinematics, axes: list[RedundantAxis], dt: float):
        self.axes = axes
        self.dt = dt
        vehicle = kin.robot.profile.vehicle
        self.differential = vehicle is not None and vehicle.type == "differential"
        self.m = len(axes) + (1 if self.differential else 0)
        self._C = np.zeros((self.m, kin.nv))
        self._l = np.full(self.m, -INF)
        self._u = np.full(self.m, INF)
        self._joints = [axis_joints(kin, a) for a in axes]
        self._a_max = np.array([kin.robot.joints[n].acceleration for n in kin.joint_names])
        self._vehicle = kin.unit_indices(UnitType.VEHICLE)
        self._vehicle_xyt = [int(i) for i in self._vehicle]
        self._frozen_rows: list[tuple[int, float]] = []
        self._range_rows: list[tuple[int, float, float]] = []
        #: Indices of the rows that constrain something, in increasing order.
        self.active = np.zeros(0, dtype=int)
        #: Rows whose coefficients are confined to some joints, and rows with constant bounds:
        #: the differential drive's row (vehicle x and y; ``0 ≤ C v ≤ 0``).
        drive = self.m - 1
        self.confined: dict[int, np.ndarray] = (
            {drive: self._vehicle[:2]} if self.differential else {}
        )
        self.constant_bounds = {drive: (0.0, 0.0)} if self.differential else {}
        #: Incremented by every :meth:`configure`.
        self.version = 0
        self.configure(kin, {}, {}, np.zeros(kin.nv, dtype=bool))

    def configure(
        self,
        kin: Kinematics,
        allowed: dict[RedundantAxis, bool],
        ranges: dict[RedundantAxis, tuple[float, float] | None],
        frozen_joints: np.ndarray,
    ) -> None:
        """Set which axes are frozen (``allowed`` False) and their ranges (SI); axes not named
        are allowed and unlimited. ``frozen_joints``: the joint box's frozen mask. Frozen axes
        are held at their values in ``kin``'s last update."""
        self._C.fill(0.0)
        self._l.fill(-INF)
        self._u.fill(INF)
        self._frozen_rows, self._range_rows = [], []
        for i, axis in enumerate(self.axes):
            if frozen_joints[self._joints[i]].all():
                continue  # cannot move anyway
            if not allowed.get(axis, True):
                self._frozen_rows.append((i, axis_value(kin, axis)))
            elif ranges.get(axis) is not None:
                lo, hi = ranges[axis]  # type: ignore[misc]
                self._range_rows.append((i, lo, hi))
        if self.differential:
            self._l[-1] = self._u[-1] = 0.0
        used = [i for i, _ in self._frozen_rows] + [i for i, _, _ in self._range_rows]
        used += [self.m - 1] if self.differential else []
        self.active = np.array(sorted(used), dtype=int)
        self.version += 1

    def rows(
        self, kin: Kinematics, lb: np.ndarray | None = None, ub: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(C, l, u)`` at the measured state of the last ``kin.update``.

        With the cycle's joint box ``lb``/``ub``, hold and range rows never ask for an axis
        rate the box cannot produce (interval arithmetic over the box): a hold wants the rate
        nearest its feedback, a range the strongest braking there is. Without it (callers
        that only need the geometry) the bounds are the plain ones.
        """
        C, lo, hi = self._C, self._l, self._u
        for i, hold in self._frozen_rows:
            axis = self.axes[i]
            C[i] = axis_jacobian(kin, axis)
            if axis.is_elbow and kin.elbow_offset(axis.side) < HOLD_MIN_ELBOW_OFFSET:
                lo[i], hi[i] = -INF, INF  # nearly stretched: no elbow angle to hold
                continue
            err = hold - axis_value(kin, axis)
            if axis.is_elbow:
                err = math.remainder(err, math.tau)
            rate = HOLD_FRACTION * err / self.dt
            if lb is not None and ub is not None:
                r_lo, r_hi = _reachable(C[i], lb, ub)
                rate = min(max(rate, r_lo), r_hi)
            lo[i] = hi[i] = rate
        for i, rmin, rmax in self._range_rows:
            axis = self.axes[i]
            C[i] = axis_jacobian(kin, axis)
            x = axis_value(kin, axis)
            brake = BRAKING_SHARE * float(np.max(np.abs(C[i]) * self._a_max))
            # Inside: brake before the bound. Outside (linearisation drift): pull back in.
            low = -_braking_speed(x - rmin, brake, self.dt)
            high = _braking_speed(rmax - x, brake, self.dt)
            if x < rmin:
                low = HOLD_FRACTION * (rmin - x) / self.dt
                high = max(high, low)
            elif x > rmax:
                high = HOLD_FRACTION * (rmax - x) / self.dt
                low = min(low, high)
            if lb is not None and ub is not None:
                low, high = _fit(low, high, *_reachable(C[i], lb, ub))
            lo[i], hi[i] = low, high
        if self.differential:
            x, y, heading = self._vehicle_xyt
            theta = float(kin.q[heading])
            C[-1, x] = -math.sin(theta)
            C[-1, y] = math.cos(theta)
        return C, lo, hi


def _braking_speed(distance: float, accel: float, dt: float) -> float:
    """Largest rate [unit/s] toward a bound ``distance`` away that can still stop at
    ``accel`` [unit/s²] (0 at or beyond the bound; unbounded when ``accel`` is 0)."""
    if distance <= 0.0:
        return 0.0
    if accel <= 0.0:
        return INF
    return accel * (math.sqrt(dt * dt + 2.0 * distance / accel) - dt)


def _fit(low: float, high: float, r_lo: float, r_hi: float) -> tuple[float, float]:
    """[low, high] cut to the reachable [r_lo, r_hi]; the nearest reachable value when they
    do not overlap (the row then asks for the strongest correction the box allows)."""
    if high < r_lo:
        return r_lo, r_lo
    if low > r_hi:
        return r_hi, r_hi
    return max(low, r_lo), min(high, r_hi)


#: Share of the reachable interval kept free at each end: a row asking for exactly the box's
#: extreme leaves only a corner of the box feasible, which solvers miss numerically.
REACH_MARGIN = 0.01


def _reachable(row: np.ndarray, lb: np.ndarray, ub: np.ndarray) -> tuple[float, float]:
    """``row · v`` over the box ``lb ≤ v ≤ ub``: its range shrunk by REACH_MARGIN each end."""
    pos = np.maximum(row, 0.0)
    neg = np.minimum(row, 0.0)
    low, high = float(pos @ lb + neg @ ub), float(pos @ ub + neg @ lb)
    margin = REACH_MARGIN * (high - low)
    return low + margin, high - margin

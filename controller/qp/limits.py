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
  * frozen joints: v = 0 (masked waist axes, units not taking part in the motion).
Where these conflict (a joint already inside its braking distance, or frozen while moving),
the bound closest to "stop as fast as the acceleration limit allows" wins.

Linear rows ``l ≤ C v ≤ u``, one per redundant axis, plus the differential-drive row:
  * masked axis (not selected for Cartesian moves): held at its value when the motion
    started, ``J_axis v = 0.5·(x_hold − x)/dt`` exactly (the feedback removes the
    second-order drift a bare ``J_axis v = 0`` would accumulate);
  * RedundantLimit range [lo, hi]: ``(lo − x)/dt ≤ J_axis v ≤ (hi − x)/dt``, linearised at
    the measured value ``x``; already outside, it may not get worse;
  * differential drive: no sideways body velocity, ``−sinθ·ẋ + cosθ·ẏ = 0``.
"""

from __future__ import annotations

import math

import numpy as np

from controller.enums import UnitType
from controller.kinematics import Kinematics
from controller.redundant_axes import RedundantAxis, axis_jacobian, axis_joints, axis_value

INF = 1e20
#: Braking distances are planned at this share of the acceleration limit. A joint that brakes
#: alone could use all of it, but a null-space motion braking at one joint's limit must
#: brake in every joint at once without the control point drifting: the rest of a_max is the
#: headroom the other joints need for that.
BRAKING_SHARE = 0.5
#: Fraction of a masked axis's drift from its held value removed per cycle.
HOLD_FRACTION = 0.5


class JointBox:
    """Per-joint velocity bounds for one cycle of length ``dt`` [s]."""

    def __init__(self, kin: Kinematics, dt: float):
        specs = [kin.robot.joints[n] for n in kin.joint_names]
        self.dt = dt
        self.q_min = np.array([s.lower for s in specs])
        self.q_max = np.array([s.upper for s in specs])
        self.v_max = np.array([s.velocity for s in specs])
        self.a_max = np.array([s.acceleration for s in specs])
        self._a_dt = self.a_max * dt
        #: Deceleration [unit/s²] the braking distance is planned with (see BRAKING_SHARE).
        self.a_brake = BRAKING_SHARE * self.a_max
        self._brake_dt = self.a_brake * dt
        self._two_over_brake = 2.0 / self.a_brake
        #: Joints held still this cycle (True = frozen).
        self.frozen = np.zeros(len(specs), dtype=bool)

    def braking_bound(self, distance: np.ndarray) -> np.ndarray:
        """Largest speed [unit/s] toward a limit ``distance`` away that can still stop.

        Infinite for unbounded joints; 0 at or beyond the limit (negative distance: noise, a
        changed profile), so the joint never moves further out but may move back.
        """
        d = np.maximum(distance, 0.0)
        bound: np.ndarray = (
            self.a_brake * np.sqrt(self.dt * self.dt + d * self._two_over_brake) - self._brake_dt
        )
        return bound

    def bounds(self, q: np.ndarray, v_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lb, ub) [unit/s] for commanded position ``q`` and previous velocity ``v_prev``."""
        acc_lo = v_prev - self._a_dt
        acc_hi = v_prev + self._a_dt
        lb = np.maximum(np.maximum(-self.v_max, acc_lo), -self.braking_bound(q - self.q_min))
        ub = np.minimum(np.minimum(self.v_max, acc_hi), self.braking_bound(self.q_max - q))
        frozen = self.frozen
        if frozen.any():
            stop = np.clip(0.0, acc_lo, acc_hi)
            lb = np.where(frozen, stop, lb)
            ub = np.where(frozen, stop, ub)
        bad = lb > ub
        if bad.any():  # conflicts: decelerate as hard as allowed, towards zero
            stop = np.clip(0.0, acc_lo, acc_hi)
            lb = np.where(bad, stop, lb)
            ub = np.where(bad, stop, ub)
        return lb, ub


class AxisRows:
    """One linear row per redundant axis, plus the differential-drive row when needed.

    Rows that constrain nothing (axis allowed, no range, or every joint that moves it frozen)
    are left as zero rows with infinite bounds and not recomputed: :meth:`configure` decides.
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
        self._vehicle = kin.unit_indices(UnitType.VEHICLE)
        self._frozen_rows: list[tuple[int, float]] = []
        self._range_rows: list[tuple[int, float, float]] = []
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

    def rows(self, kin: Kinematics) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(C, l, u)`` at the measured state of the last ``kin.update``."""
        C, lo, hi = self._C, self._l, self._u
        for i, hold in self._frozen_rows:
            axis = self.axes[i]
            C[i] = axis_jacobian(kin, axis)
            err = hold - axis_value(kin, axis)
            if axis.is_elbow:
                err = math.remainder(err, math.tau)
            lo[i] = hi[i] = HOLD_FRACTION * err / self.dt
        for i, rmin, rmax in self._range_rows:
            axis = self.axes[i]
            C[i] = axis_jacobian(kin, axis)
            x = axis_value(kin, axis)
            lo[i] = min((rmin - x) / self.dt, 0.0)
            hi[i] = max((rmax - x) / self.dt, 0.0)
        if self.differential:
            theta = kin.q[self._vehicle[2]]
            C[-1, self._vehicle[0]] = -np.sin(theta)
            C[-1, self._vehicle[1]] = np.cos(theta)
        return C, lo, hi

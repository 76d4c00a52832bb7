"""Redundant-axis rows: masked axes held where they were, axis ranges kept.

One row per redundant axis a motion masks or limits (axes are listed in
:mod:`controller.model.redundant_axes`), ``lo ≤ J_axis v ≤ hi``:
  * masked axis (not selected for Cartesian moves): held at its value when the motion was
    configured, ``J_axis v = 0.5·(x_hold − x)/dt`` exactly (the feedback removes the
    second-order drift a bare ``J_axis v = 0`` would accumulate); a held elbow rests while
    the arm is within 1 cm of full stretch, where the angle is undefined;
  * RedundantLimit range [lo, hi]: the axis rate toward a bound is limited by a braking
    distance, as for joints, at half the deceleration its best joint can give it
    (``a_axis = ½·max_j |J_axis,j|·a_max,j``); linearised at the measured value ``x``;
    outside (drift of the linearisation) it is pulled back in like a held axis.
With the cycle's joint box, a row never asks for an axis rate the box cannot produce
(interval arithmetic over the box): a hold wants the rate nearest its feedback, a range the
strongest braking there is.
"""

from __future__ import annotations

import math

import numpy as np

from controller.model import jit
from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, axis_joints, axis_value
from controller.qp.constraints import axes_kernel
from controller.qp.constraints.braking import BRAKING_SHARE
from controller.qp.constraints.drive import DifferentialDrive
from controller.qp.constraints.protocol import (
    INF,
    ConstraintSetup,
    CycleState,
    Level,
    Relaxation,
    RowBlock,
)
from controller.vocabulary import RightLeft

#: A held elbow angle is not enforced while the elbow is closer than this [m] to the
#: shoulder-wrist line: the angle is (nearly) undefined there and its Jacobian explodes.
HOLD_MIN_ELBOW_OFFSET = 0.01
#: Fraction of a masked axis's drift from its held value removed per cycle.
HOLD_FRACTION = 0.5
#: Share of the reachable interval kept free at each end: a row asking for exactly the box's
#: extreme leaves only a corner of the box feasible, which solvers miss numerically.
REACH_MARGIN = 0.01


class AxisLimit:
    """Rows of the held and the ranged redundant axes, in axis order.

    An axis whose joints are all frozen gets no row (it cannot move anyway); free axes
    without a range get none either. Held axes and ranges are preferences of the motion:
    relaxed to "no further" when the QP has no solution, then dropped for the cycle.
    """

    name = "held axes and ranges"
    levels = Level.BOTH
    relaxation = Relaxation.NO_FURTHER_THEN_DROP
    joints = None
    holds_at_rest = False

    def __init__(self, kin: Kinematics, axes: list[RedundantAxis], dt: float):
        self.axes = axes
        self.dt = dt
        self._joints = [axis_joints(kin, a) for a in axes]
        #: Per axis, its joints as a mask over every joint (one row per axis).
        self._joint_mask = np.zeros((len(axes), kin.nv), dtype=bool)
        for i, joints in enumerate(self._joints):
            self._joint_mask[i, joints] = True
        self._a_max = np.array([kin.robot.joints[n].acceleration for n in kin.joint_names])
        #: (row, axis, held value [rad, m], elbow side or None) and (row, axis, lower, upper
        #: [rad, m]).
        self._held: list[tuple[int, RedundantAxis, float, RightLeft | None]] = []
        self._ranged: list[tuple[int, RedundantAxis, float, float]] = []
        #: (row, axis) of every row, in row order.
        self._rows: list[tuple[int, RedundantAxis]] = []
        #: Index in ``axes`` of the axis of each row.
        self.active = np.zeros(0, dtype=int)
        self.max_rows = 0
        self._pos = self._neg = np.zeros((0, kin.nv))
        #: The compiled bounds (:mod:`.axes_kernel`) and their per-row arrays, set by
        #: :meth:`configure`: kind, angle wrap, value now, held value or range.
        self._compiled = jit.available()
        self._kind = np.zeros(0, dtype=np.int64)
        self._wrap = np.zeros(0, dtype=np.bool_)
        self._value = self._first = self._second = np.zeros(0)
        #: (row, side) of the held elbows (free while nearly stretched).
        self._held_elbows: list[tuple[int, RightLeft]] = []
        self._no_box = np.zeros(kin.nv)
        self._group_rows(kin)

    def configure(self, kin: Kinematics, setup: ConstraintSetup) -> None:
        """Masked axes are held at their values in ``kin``'s last update."""
        held: list[tuple[int, RedundantAxis, float, RightLeft | None]] = []
        ranged: list[tuple[int, RedundantAxis, float, float]] = []
        active: list[int] = []
        # Axes with a free joint, all at once (an axis whose joints are frozen cannot move).
        movable = np.logical_and(self._joint_mask, ~np.asarray(setup.frozen, dtype=bool))
        for i, can_move in enumerate(movable.any(axis=1).tolist()):
            if not can_move:
                continue
            axis = self.axes[i]
            limits = setup.ranges.get(axis)
            if not setup.allowed.get(axis, True):
                side = axis.side if axis.is_elbow else None
                held.append((len(active), axis, axis_value(kin, axis), side))
            elif limits is not None:
                ranged.append((len(active), axis, limits[0], limits[1]))
            else:
                continue
            active.append(i)
        self._held, self._ranged = held, ranged
        self._rows = [(k, self.axes[i]) for k, i in enumerate(active)]
        self.active = np.array(active, dtype=int)
        self.max_rows = n = len(active)
        if len(self._pos) != n:  # scratch of the rows' shape (its contents never matter)
            self._pos, self._neg = np.zeros((n, kin.nv)), np.zeros((n, kin.nv))
        kind = np.full(n, axes_kernel.RANGED, dtype=np.int64)
        first, second = np.zeros(n), np.zeros(n)
        wrap = np.zeros(n, dtype=np.bool_)
        for k, _, value, side in held:
            kind[k], first[k], wrap[k] = axes_kernel.HELD, value, side is not None
        for k, _, rmin, rmax in ranged:
            first[k], second[k] = rmin, rmax
        self._kind, self._wrap, self._first, self._second = kind, wrap, first, second
        self._value = np.zeros(n)
        self._held_elbows = [(k, side) for k, _, _, side in held if side is not None]
        self._group_rows(kin)

    def _group_rows(self, kin: Kinematics) -> None:
        """The rows by kind of axis, for :meth:`_fill` (a few array operations per kind, not
        two calls per row): elbows (row, side); waist angles (rows, their constant Jacobian
        rows); vehicle coordinates (rows, their index in the vehicle pose)."""
        self._elbow_rows = [(k, axis.side) for k, axis in self._rows if axis.is_elbow]
        lumbar = [(k, axis) for k, axis in self._rows if axis.is_lumbar]
        self._lumbar_at = np.array([k for k, _ in lumbar], dtype=np.intp)
        self._lumbar_matrix = np.array(
            [kin.lumbar_jacobian(axis.lumbar) for _, axis in lumbar]
        ).reshape(len(lumbar), kin.nv)
        self._lumbar_value = np.zeros(len(lumbar))
        vehicle = [(k, axis.vehicle_index) for k, axis in self._rows if axis.is_vehicle]
        self._vehicle_at = np.array([k for k, _ in vehicle], dtype=np.intp)
        self._vehicle_of = np.array([i for _, i in vehicle], dtype=np.intp)

    def _fill(self, kin: Kinematics, C: np.ndarray, value: np.ndarray) -> None:
        """Each row's Jacobian into ``C`` and its axis's value [rad, m] into ``value`` at
        ``kin``'s last update (what :func:`~controller.model.redundant_axes.axis_jacobian` and
        :func:`~controller.model.redundant_axes.axis_value` give)."""
        for k, side in self._elbow_rows:
            C[k] = kin.elbow_jacobian(side)
            value[k] = kin.elbow_angle(side)
        if len(self._lumbar_at):
            C[self._lumbar_at] = self._lumbar_matrix
            np.dot(self._lumbar_matrix, kin.q, out=self._lumbar_value)
            value[self._lumbar_at] = self._lumbar_value
        if len(self._vehicle_at):
            C[self._vehicle_at] = kin.vehicle_jacobian()[self._vehicle_of]
            value[self._vehicle_at] = kin.vehicle_pose()[self._vehicle_of]

    def compute_qp_inequalities(self, cycle: CycleState, rows: RowBlock) -> int:
        kin, lb, ub, dt = cycle.kin, cycle.lb, cycle.ub, self.dt
        C, lo, hi = rows
        n = self.max_rows
        if not n:
            return 0
        value = self._value  # each row's axis now
        self._fill(kin, C, value)
        if self._compiled:
            kind = self._kind
            for k, side in self._held_elbows:  # nearly stretched: no elbow angle to hold
                stretched = kin.elbow_offset(side) < HOLD_MIN_ELBOW_OFFSET
                kind[k] = axes_kernel.FREE if stretched else axes_kernel.HELD
            box = lb is not None and ub is not None
            axes_kernel.axis_bounds(
                C, self._no_box if lb is None else lb, self._no_box if ub is None else ub,
                box, kind, self._wrap, value, self._first, self._second, self._a_max, dt,
                HOLD_FRACTION, REACH_MARGIN, lo, hi,
            )  # fmt: skip
            return n
        # What the cycle's joint box lets each row reach, all rows at once.
        box = lb is not None and ub is not None
        if lb is not None and ub is not None:
            reach_lo, reach_hi = _reachable(C[:n], lb, ub, self._pos, self._neg)
        for k, _, hold, elbow_side in self._held:
            if elbow_side is not None:
                if kin.elbow_offset(elbow_side) < HOLD_MIN_ELBOW_OFFSET:
                    lo[k], hi[k] = -INF, INF  # nearly stretched: no elbow angle to hold
                    continue
                err = math.remainder(hold - value[k], math.tau)
            else:
                err = hold - value[k]
            rate = HOLD_FRACTION * err / dt
            if box:
                rate = min(max(rate, reach_lo[k]), reach_hi[k])
            lo[k] = hi[k] = rate
        if self._ranged:
            # Half the deceleration the axis's best joint gives it, per row.
            brake_all = BRAKING_SHARE * np.max(np.abs(C[:n]) * self._a_max, axis=1)
        for k, _, rmin, rmax in self._ranged:
            x = float(value[k])
            brake = float(brake_all[k])
            low, high = axes_kernel.range_band(x, rmin, rmax, brake, dt, HOLD_FRACTION)
            if box:
                low, high = axes_kernel.fit(low, high, reach_lo[k], reach_hi[k])
            lo[k], hi[k] = low, high
        return n


def _reachable(
    rows: np.ndarray, lb: np.ndarray, ub: np.ndarray, pos: np.ndarray, neg: np.ndarray
) -> tuple[list[float], list[float]]:
    """Per row, ``row · v`` over the box ``lb ≤ v ≤ ub``: its range shrunk by REACH_MARGIN
    each end. ``pos`` and ``neg``: scratch of the rows' shape."""
    np.maximum(rows, 0.0, out=pos)
    np.minimum(rows, 0.0, out=neg)
    low = pos.dot(lb) + neg.dot(ub)
    high = pos.dot(ub) + neg.dot(lb)
    margin = REACH_MARGIN * (high - low)
    return (low + margin).tolist(), (high - margin).tolist()


class AxisRows:
    """Every redundant-axis row of a robot at a fixed place, for callers that want the set
    at once (the reachability check): row i for ``axes[i]``, the differential drive's row
    last; rows that constrain nothing are zero with infinite bounds.

    The two constraints it holds, :attr:`limit` and :attr:`drive`, are what
    :class:`~controller.qp.ik.WholeBodyIK` registers (it configures them itself).
    """

    def __init__(self, kin: Kinematics, axes: list[RedundantAxis], dt: float):
        self.axes = axes
        self.limit = AxisLimit(kin, axes, dt)
        self.drive = DifferentialDrive(kin) if DifferentialDrive.applies(kin) else None
        self.differential = self.drive is not None
        self.m = len(axes) + (1 if self.differential else 0)
        self._C = np.zeros((self.m, kin.nv))
        self._l = np.full(self.m, -INF)
        self._u = np.full(self.m, INF)
        n = len(axes)
        self._scratch = RowBlock(np.zeros((n, kin.nv)), np.zeros(n), np.zeros(n))
        self._drive_rows = RowBlock(self._C[n:], self._l[n:], self._u[n:])
        self.configure(kin, {}, {}, np.zeros(kin.nv, dtype=bool))

    @property
    def constraints(self) -> list[AxisLimit | DifferentialDrive]:
        return [self.limit] if self.drive is None else [self.limit, self.drive]

    def configure(
        self,
        kin: Kinematics,
        allowed: dict[RedundantAxis, bool],
        ranges: dict[RedundantAxis, tuple[float, float] | None],
        frozen_joints: np.ndarray,
    ) -> None:
        """Set which axes are held (``allowed`` False: at their values in ``kin``'s last
        update) and their ranges [rad, m]; ``frozen_joints``: the frozen joints' mask."""
        setup = ConstraintSetup(frozen_joints, allowed, ranges)
        for constraint in self.constraints:
            constraint.configure(kin, setup)
        n = len(self.axes)
        self._C[:n] = 0.0
        self._l[:n] = -INF
        self._u[:n] = INF

    def rows(
        self, kin: Kinematics, lb: np.ndarray | None = None, ub: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(C, l, u)`` at the measured state of the last ``kin.update``; with the cycle's
        joint box ``lb``/``ub`` [rad/s, m/s] the rows fit in it (see the module), without it
        the bounds are the plain ones."""
        cycle = CycleState(kin, kin.q, np.zeros(kin.nv), lb, ub)
        k = self.limit.compute_qp_inequalities(cycle, self._scratch)
        rows = self.limit.active[:k]
        self._C[rows] = self._scratch.C[:k]
        self._l[rows] = self._scratch.lo[:k]
        self._u[rows] = self._scratch.hi[:k]
        if self.drive is not None:
            self.drive.compute_qp_inequalities(cycle, self._drive_rows)
        return self._C, self._l, self._u

"""Spec A (IntegratedMotion) service: whole-body motion with redundant axes, transport-
independent. Spec units in (mm, deg, s, %), converted here through
:mod:`controller.conversions`; SI to the planning functions.

Motion commands are accepted only in Ready (Spec A never queues: Busy/Pause → STATUS_ERR);
with the servos off they answer NOT_SV_ON_ERR where the original lists it (grippers,
movePTPCartesian*) and STATUS_ERR otherwise. Arguments are checked first (VALUE_ERR says
which and why), then the state, then reachability (CANNOT_REACH_TARGET_ERR), and only then
does anything move.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence

import numpy as np
import pinocchio as pin

from controller import __version__
from controller.bounds import MAX_MOTION_TIME
from controller.contract.snapshot import Snapshot
from controller.conversions import (
    deg_to_rad,
    finite_array,
    hg_to_se3,
    mm_to_m,
    rad_to_deg,
    se3_to_hg,
)
from controller.errors import ArgumentError, Refused
from controller.gateway.planning.cartesian import plan_linear, plan_ptp
from controller.gateway.planning.cp_hold import AxisRequest, plan_cp_hold
from controller.gateway.planning.limits import require_tool_offset, vehicle_workspace
from controller.gateway.planning.redundancy import Range, axis_range
from controller.gateway.planning.unit_moves import check_unit_rates, plan_unit_move
from controller.gateway.services.arguments import (
    finite_arg,
    finite_values,
    positive_arg,
    require_gripper,
    side_arg,
)
from controller.gateway.services.context import Context
from controller.gateway.services.states import spec_a_state
from controller.model.redundant_axes import RedundantAxis, available_axes, elbow_axis
from controller.vocabulary import FrameType, ReturnCode, RightLeft, SpecAState, UnitType

#: Longest movePTPCartesian time [s]: the longest motion of any request.
MAX_PTP_TIME = MAX_MOTION_TIME

#: RedundantPos fields (deg; vehicle x, y in mm) and the axis each sets.
POS_FIELDS: dict[str, tuple[RedundantAxis, ...]] = {
    "elbow": (RedundantAxis.RIGHT_ELBOW, RedundantAxis.LEFT_ELBOW),
    "lumbar_rx": (RedundantAxis.LUMBAR_RX,),
    "lumbar_ry": (RedundantAxis.LUMBAR_RY,),
    "lumbar_rz": (RedundantAxis.LUMBAR_RZ,),
    "vehicle_x": (RedundantAxis.VEHICLE_X,),
    "vehicle_y": (RedundantAxis.VEHICLE_Y,),
    "vehicle_theta": (RedundantAxis.VEHICLE_THETA,),
}
#: RedundantSpeed / RedundantAccel fields (deg/s; vehicle translation mm/s).
RATE_FIELDS = (
    "elbow",
    "lumbar_rx",
    "lumbar_ry",
    "lumbar_rz",
    "vehicle_translation",
    "vehicle_rotation",
)
#: RedundantAxesMask fields and RedundantLimit fields of each axis.
AXIS_FIELDS: dict[RedundantAxis, tuple[str, str]] = {
    RedundantAxis.RIGHT_ELBOW: ("elbow", "right_elbow"),
    RedundantAxis.LEFT_ELBOW: ("elbow", "left_elbow"),
    RedundantAxis.LUMBAR_RX: ("lumbar_rx", "lumbar_rx"),
    RedundantAxis.LUMBAR_RY: ("lumbar_ry", "lumbar_ry"),
    RedundantAxis.LUMBAR_RZ: ("lumbar_rz", "lumbar_rz"),
    RedundantAxis.VEHICLE_X: ("vehicle_x", "vehicle_x"),
    RedundantAxis.VEHICLE_Y: ("vehicle_y", "vehicle_y"),
    RedundantAxis.VEHICLE_THETA: ("vehicle_theta", "vehicle_theta"),
}
_LINEAR = (RedundantAxis.VEHICLE_X, RedundantAxis.VEHICLE_Y)


def require_ready(snap: Snapshot, sv_on_code: bool) -> None:
    """Spec A: motion only from Ready."""
    state, _ = spec_a_state(snap)
    if state in (SpecAState.UNPOWERED, SpecAState.SERVO_OFF):
        code = ReturnCode.NOT_SV_ON_ERR if sv_on_code else ReturnCode.STATUS_ERR
        raise Refused(code, "the servos are off: call servoOn first")
    if state == SpecAState.ALARM:
        raise Refused(ReturnCode.STATUS_ERR, "alarms are active: clearAlarms, then servoOn")
    if state in (SpecAState.BUSY, SpecAState.PAUSE):
        raise Refused(
            ReturnCode.STATUS_ERR,
            f"the robot is {'paused' if state == SpecAState.PAUSE else 'busy'}: this "
            "interface does not queue; wait for the motion to end, or stop it",
        )


def _si(axis: RedundantAxis, value: float, name: str) -> float:
    """A redundant-axis value in SI: mm → m for vehicle x/y, deg → rad otherwise."""
    return float(mm_to_m(value, name) if axis in _LINEAR else deg_to_rad(value, name))


def pose_arg(hg_mm: np.ndarray | Sequence[float], name: str) -> pin.SE3:
    """An HgMatrix (3 x 4 or 12 numbers, row-major, [mm]) as an SE3 [m]."""
    values = finite_array(hg_mm, name)
    if values.size != 12:
        raise ArgumentError(
            f"{name}: expected 12 numbers (3x4 row-major [R | p]), got {values.size}"
        )
    return hg_to_se3(values.reshape(3, 4), name)


class SpecAService:
    """The Spec A motions and their settings (selectRedundantAxes), one per daemon."""

    def __init__(self, ctx: Context):
        self.ctx = ctx
        self.axes = available_axes(ctx.planner.view.kin)
        #: selectRedundantAxes state: which axes Cartesian moves may use, and their ranges.
        self.allowed: dict[RedundantAxis, bool] = {a: a.is_elbow for a in self.axes}
        self.ranges: dict[RedundantAxis, Range | None] = {}
        self._settings = threading.Lock()

    # ------------------------------------------------------------------ queries
    def version(self) -> str:
        cfg = self.ctx.config
        return f"imotion {__version__} (robot {cfg.robot}, hal {cfg.hal})"

    def is_moving(self) -> bool:
        s = self.ctx.state()
        return bool(s.moving or s.queue > 0)

    def is_servo_on(self) -> bool:
        return bool(self.ctx.state().servo_on)

    def feedback_cartesian(
        self, side_value: int, frame_value: int, snap: Snapshot | None = None
    ) -> tuple[np.ndarray, float]:
        """getFeedbackPosCartesian: HgMatrix (3 x 4, [mm]) and elbow [deg] at ``snap`` (by
        default the latest snapshot)."""
        view = self.ctx.view
        side = side_arg(view, side_value)
        if frame_value not in (0, 1):
            raise ArgumentError(f"frame_type: {frame_value} is not a FrameType (0, 1)")
        snap = self.ctx.snapshot() if snap is None else snap
        pose, elbow = view.pose(snap, side, FrameType(frame_value))
        return se3_to_hg(pose), float(rad_to_deg(elbow))

    def gripper_pos(self, side_value: int) -> int:
        """getGripperPos: 0 % closed .. 100 % open."""
        side = side_arg(self.ctx.view, side_value)
        require_gripper(self.ctx.view, side)
        ratio = self.ctx.view.gripper_ratio(self.ctx.snapshot(), side)
        return round(100.0 * (ratio or 0.0))

    def gripper(self, side_value: int, ratio: float) -> None:
        """close/open/moveGripper: ``ratio`` 0 closed .. 1 open."""
        side = side_arg(self.ctx.view, side_value)
        require_gripper(self.ctx.view, side)
        self.ctx.call("gripper", side=side, ratio=ratio)

    # ------------------------------------------------------------------ settings
    def set_control_point_offset(
        self, side: RightLeft, offset_hg: np.ndarray | Sequence[float]
    ) -> None:
        """The control point in the flange frame: HgMatrix [mm], at most 2000 mm away."""
        offset = require_tool_offset(pose_arg(offset_hg, "offset"), "offset")
        self.ctx.call("set_control_point_offset", side=side, offset=offset.homogeneous)

    def select_redundant_axes(
        self, mask: Mapping[str, bool], limits: Mapping[str, tuple[float, float]]
    ) -> str | None:
        """Which redundant axes Cartesian moves may use (mask by RedundantAxesMask field) and
        their ranges (by RedundantLimit field: (lower, upper) in deg or mm; (0, 0): the
        hardware's). Returns the answer's comment (None: plain OK)."""
        allowed: dict[RedundantAxis, bool] = {}
        ranges: dict[RedundantAxis, Range | None] = {}
        ignored: list[str] = []
        for axis, (mask_field, limit_field) in AXIS_FIELDS.items():
            use = bool(mask.get(mask_field, False))
            lower, upper = limits.get(limit_field, (0.0, 0.0))
            name = f"limit.{limit_field}"
            finite_arg(upper, f"{name}.upper")
            finite_arg(lower, f"{name}.lower")
            if axis not in self.axes:
                # one mask bit for both elbows: a one-arm robot's missing left elbow is no news
                lone_arm = axis.is_elbow and any(a.is_elbow for a in self.axes)
                if use and not lone_arm and axis.value not in ignored:
                    ignored.append(axis.value)
                continue
            allowed[axis] = use
            if upper == 0.0 and lower == 0.0:
                ranges[axis] = None  # no range given: the hardware's
                continue
            ranges[axis] = axis_range(
                self.ctx.robot, axis, _si(axis, lower, name), _si(axis, upper, name), name
            )
        state, _ = spec_a_state(self.ctx.snapshot())
        if state in (SpecAState.BUSY, SpecAState.PAUSE):
            raise Refused(ReturnCode.STATUS_ERR, "not while a motion runs: stop it or wait")
        with self._settings:
            self.allowed, self.ranges = allowed, ranges
        return f"OK (this robot has no {', '.join(ignored)}: ignored)" if ignored else None

    def mask(self) -> tuple[dict[RedundantAxis, bool], dict[RedundantAxis, Range | None]]:
        """Usable axes and their ranges; a vehicle axis without a range keeps to the vehicle
        workspace."""
        with self._settings:
            allowed, ranges = dict(self.allowed), dict(self.ranges)
        workspace = vehicle_workspace(self.ctx.robot)
        if workspace is not None:
            for axis in allowed:
                if axis.is_vehicle and ranges.get(axis) is None:
                    i = axis.vehicle_index
                    ranges[axis] = (float(workspace[0][i]), float(workspace[1][i]))
        return allowed, ranges

    # ------------------------------------------------------------------ unit moves
    def move_unit(
        self,
        unit: UnitType,
        pos: Sequence[float],
        speed: Sequence[float],
        accel: Sequence[float],
        relative: bool,
    ) -> None:
        """moveUnitAbs/Rel: ``pos`` per joint [deg or mm], the vehicle (x [mm], y [mm],
        theta [deg]); speed and accel per joint (or one for all) [deg/s, deg/s²], the vehicle
        (translation, rotation) [mm/s, deg/s]."""
        ctx = self.ctx
        pos_name = "rel_pos" if relative else "abs_pos"
        names = ctx.robot.unit_joints(unit.name)
        n = 3 if unit == UnitType.VEHICLE else len(names)
        values = np.array([float(x) for x in pos])
        if values.size != n:
            raise ArgumentError(f"{pos_name}: {unit.name} takes {n} values, got {values.size}")
        finite_values(values, pos_name)
        if unit == UnitType.VEHICLE:
            v = self._pair(speed, "speed", "mm/s, deg/s")
            a = self._pair(accel, "accel", "mm/s², deg/s²")
            target = np.array([*mm_to_m(values[:2], pos_name), deg_to_rad(values[2], pos_name)])
            v_si = np.array([mm_to_m(v[0]), deg_to_rad(v[1])])
            a_si = np.array([mm_to_m(a[0]), deg_to_rad(a[1])])
        else:
            specs = [ctx.robot.joints[j] for j in names]
            v_si = np.array(
                [s.to_si(x) for s, x in zip(specs, self._per_joint(speed, n, "speed"), strict=True)]
            )
            a_si = np.array(
                [s.to_si(x) for s, x in zip(specs, self._per_joint(accel, n, "accel"), strict=True)]
            )
            target = np.array([s.to_si(x) for s, x in zip(specs, values, strict=True)])
        check_unit_rates(ctx.planner, unit, v_si, a_si)
        snap = ctx.snapshot()
        require_ready(snap, sv_on_code=False)
        with ctx.planner.lock:
            spec = plan_unit_move(ctx.planner, snap, unit, target, v_si, a_si, relative)
            ctx.call("start", sv_on_code=False, spec=spec)

    @staticmethod
    def _pair(values: Sequence[float], name: str, unit: str) -> tuple[float, float]:
        vals = list(values)
        if len(vals) != 2:
            raise ArgumentError(f"{name}: VEHICLE takes 2 values (translation, rotation) [{unit}]")
        return positive_arg(vals[0], f"{name}[0]", ""), positive_arg(vals[1], f"{name}[1]", "")

    @staticmethod
    def _per_joint(values: Sequence[float], n: int, name: str) -> np.ndarray:
        vals = [float(v) for v in values]
        if len(vals) == 1:
            vals = vals * n
        if len(vals) != n:
            raise ArgumentError(
                f"{name}: expected {n} values (one per joint) or 1, got {len(vals)}"
            )
        return np.array([positive_arg(v, f"{name}[{i}]", "") for i, v in enumerate(vals)])

    # ------------------------------------------------------------------ CP hold
    def move_cp_hold(
        self,
        side: RightLeft,
        pos: Mapping[str, float],
        speed: Mapping[str, float],
        accel: Mapping[str, float],
        relative: bool,
    ) -> str | None:
        """moveCPHoldAbs/Rel: redundant axes to new targets, ``side``'s control point held.
        ``pos`` by RedundantPos field [deg; vehicle x, y mm], ``speed``/``accel`` by
        RedundantSpeed/Accel field [deg/s, mm/s; /s²]. Returns the answer's comment."""
        ctx = self.ctx
        pos_name = "rel_pos" if relative else "abs_pos"
        for field in POS_FIELDS:  # every field is checked, whether or not the robot has it
            finite_arg(pos.get(field, 0.0), f"{pos_name}.{field}")
        for field in RATE_FIELDS:
            finite_arg(speed.get(field, 0.0), f"speed.{field}")
            finite_arg(accel.get(field, 0.0), f"accel.{field}")
        requests: dict[RedundantAxis, AxisRequest] = {}
        absent: list[str] = []
        own_elbow = elbow_axis(side)
        for field, axes in POS_FIELDS.items():
            value = float(pos.get(field, 0.0))
            axis = own_elbow if field == "elbow" else axes[0]
            if axis not in self.axes:
                if value != 0.0:
                    absent.append(field)
                continue
            rate = field
            if axis.is_vehicle:
                rate = (
                    "vehicle_rotation"
                    if axis == RedundantAxis.VEHICLE_THETA
                    else "vehicle_translation"
                )
            to_si = mm_to_m if rate == "vehicle_translation" else deg_to_rad
            requests[axis] = AxisRequest(
                value=_si(axis, value, f"{pos_name}.{field}"),
                speed=float(to_si(speed.get(rate, 0.0), f"speed.{rate}")),
                accel=float(to_si(accel.get(rate, 0.0), f"accel.{rate}")),
                field=field,
                rate_field=rate,
            )
        snap = ctx.snapshot()
        with ctx.planner.lock:
            plan = plan_cp_hold(
                ctx.planner, snap, side, requests, relative, pos_name, tuple(absent)
            )
            require_ready(snap, sv_on_code=False)
            if plan.spec is not None:
                ctx.call("start", sv_on_code=False, spec=plan.spec)
        return plan.comment

    # ------------------------------------------------------------------ Cartesian
    def move_linear(
        self,
        side: RightLeft,
        target_hg: np.ndarray | Sequence[float],
        speed: tuple[float, float],
        accel: tuple[float, float],
        hold_other: bool,
        tool_frame: bool | None,
        target_name: str,
    ) -> None:
        """moveLinearCartesianAbs (``tool_frame`` None) / Rel (False: BASE_FRAME, True:
        TOOL_FRAME): target
        HgMatrix [mm], speed (translation [mm/s], rotation [deg/s]), accel [/s²]."""
        ctx = self.ctx
        goal = pose_arg(target_hg, target_name)
        v = (
            float(mm_to_m(positive_arg(speed[0], "speed.translation", "mm/s"))),
            float(deg_to_rad(positive_arg(speed[1], "speed.rotation", "deg/s"))),
        )
        a = (
            float(mm_to_m(positive_arg(accel[0], "accel.translation", "mm/s²"))),
            float(deg_to_rad(positive_arg(accel[1], "accel.rotation", "deg/s²"))),
        )
        snap = ctx.snapshot()
        require_ready(snap, sv_on_code=False)
        allowed, ranges = self.mask()
        with ctx.planner.lock:
            spec = plan_linear(
                ctx.planner,
                snap,
                side,
                goal,
                v,
                a,
                tool_frame,
                allowed,
                ranges,
                hold_other,
                target_name,
            )
            ctx.call("start", sv_on_code=False, spec=spec)

    def move_ptp(
        self,
        side: RightLeft,
        target_hg: np.ndarray | Sequence[float],
        duration: float,
        hold_other: bool,
        relative: bool,
        target_name: str,
    ) -> None:
        """movePTPCartesianAbs/Rel: target HgMatrix [mm] reached in ``duration`` [s]."""
        ctx = self.ctx
        goal = pose_arg(target_hg, target_name)
        duration = positive_arg(duration, "time", "s")
        if duration > MAX_PTP_TIME:
            raise ArgumentError(f"time: {duration:g} s is longer than {MAX_PTP_TIME:g} s")
        snap = ctx.snapshot()
        require_ready(snap, sv_on_code=True)
        allowed, ranges = self.mask()
        with ctx.planner.lock:
            spec = plan_ptp(
                ctx.planner, snap, side, goal, duration, allowed, ranges, hold_other, relative
            )
            ctx.call("start", sv_on_code=True, spec=spec)

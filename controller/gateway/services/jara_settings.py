"""JARA_ARM settings and queries of one arm, transport-independent (spec units: mm, deg, s, %):
speeds and acceleration times, soft limits (joint and Cartesian), base and control-point
offsets, home, grippers and grasp force, joint feedback.

Settings that change what the control process enforces (joint soft limits, the Cartesian
box, offsets) are refused while the robot moves (STATUS_ERR).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from controller.contract.motion_specs import CartesianBox
from controller.conversions import (
    deg_to_rad,
    finite_array,
    hg_to_se3,
    m_to_mm,
    mm_to_m,
    rad_to_deg,
    se3_to_hg,
)
from controller.errors import ArgumentError, Refused
from controller.gateway.planning.jara_arm import NO_BOX_MM, ArmSettings
from controller.gateway.planning.limits import require_cartesian_speed, require_tool_offset
from controller.gateway.services.arguments import finite_arg, finite_values, positive_arg
from controller.gateway.services.jara_arm import JaraArmService
from controller.vocabulary import CoreState, ReturnCode, RightLeft, UnitType

Limit = tuple[float, float]  #: (lower, upper) in the unit of the quantity


def _hg(values: np.ndarray | Sequence[float], name: str) -> pin.SE3:
    arr = finite_array(values, name)
    if arr.size != 12:
        raise ArgumentError(f"{name}: expected 12 numbers (3x4 row-major [R | p]), got {arr.size}")
    return hg_to_se3(arr.reshape(3, 4), name)


class JaraSettingsService:
    """The settings half of JARA_ARM; motions are :class:`JaraArmService`'s."""

    def __init__(self, arms: JaraArmService):
        self.arms = arms
        self.ctx = arms.ctx

    def _arm(self, side: RightLeft) -> ArmSettings:
        return self.arms.arms[side]

    def _require_still(self) -> None:
        snap = self.ctx.snapshot()
        if snap.moving or snap.queue:
            raise Refused(ReturnCode.STATUS_ERR, "not while the robot moves")

    # ------------------------------------------------------------------ queries
    def joint_positions(self, side: RightLeft) -> list[float]:
        """The arm's joints [deg] and, with a gripper, its first joint [deg or mm]."""
        ctx = self.ctx
        snap = ctx.snapshot()
        view = ctx.view
        values = view.unit_positions(snap, UnitType[f"{side.name}_ARM"]).tolist()
        grippers = ctx.robot.profile.grippers
        if side.name in grippers:
            joint = grippers[side.name].joints[0]
            spec = ctx.robot.joints[joint]
            q = snap.q[view.hw_joints.index(joint)]
            values.append(float(rad_to_deg(q) if spec.kind == "revolute" else m_to_mm(q)))
        return values

    def feedback_cartesian(self, side: RightLeft) -> tuple[np.ndarray, float]:
        """Control point in the arm frame: HgMatrix (3 x 4, [mm]) and elbow [deg]."""
        pose, elbow = self.arms.feedback(self.ctx.snapshot(), side)
        return se3_to_hg(pose), float(rad_to_deg(elbow))

    def soft_limit_joint(self, side: RightLeft) -> list[Limit]:
        s = self._arm(side)
        return [(float(lo), float(hi)) for lo, hi in zip(s.soft_lower, s.soft_upper, strict=True)]

    def soft_limit_cartesian(self, side: RightLeft) -> list[Limit]:
        """(lower, upper) [mm] of x, y, z in the arm frame (±10 m: no limit set)."""
        s = self._arm(side)
        if s.soft_box is None:
            lo, hi = np.full(3, -NO_BOX_MM), np.full(3, NO_BOX_MM)
        else:
            lo, hi = s.soft_box
        return [(float(lo[i]), float(hi[i])) for i in range(3)]

    # ------------------------------------------------------------------ soft limits
    def set_soft_limit_joint(self, side: RightLeft, limits: Sequence[Limit]) -> None:
        """Per joint (lower, upper) [deg], within the hardware limits."""
        s = self._arm(side)
        n = len(s.joint_names)
        if len(limits) != n:
            raise ArgumentError(
                f"soft_limit: expected {n} limits (one per joint), got {len(limits)}"
            )
        lower, upper = np.empty(n), np.empty(n)
        for i, (lo, hi) in enumerate(limits):
            name = f"soft_limit[{i}] ({s.joint_names[i]})"
            upper[i] = finite_arg(hi, f"{name}.upper")
            lower[i] = finite_arg(lo, f"{name}.lower")
            if upper[i] < lower[i]:
                raise ArgumentError(f"{name}: upper {upper[i]:g} is below lower {lower[i]:g}")
            if lower[i] < s.hw_lower[i] - 1e-9 or upper[i] > s.hw_upper[i] + 1e-9:
                raise ArgumentError(
                    f"{name}: {lower[i]:g}..{upper[i]:g} deg is wider than the hardware limits "
                    f"{s.hw_lower[i]:g}..{s.hw_upper[i]:g} deg"
                )
        snap = self.ctx.snapshot()
        if snap.core_state == CoreState.ALARM:
            raise Refused(ReturnCode.STATUS_ERR, "alarms are active: clearAlarms first")
        self._require_still()
        joints = self.arms.joints(side)
        with self.arms.lock:
            self.ctx.call(
                "set_joint_limits", indices=joints, lower=deg_to_rad(lower), upper=deg_to_rad(upper)
            )
            self.ctx.planner.set_joint_limits(joints, deg_to_rad(lower), deg_to_rad(upper))
            s.soft_lower, s.soft_upper = lower, upper

    def set_soft_limit_cartesian(self, side: RightLeft, limits: Sequence[Limit]) -> None:
        """(lower, upper) [mm] of x, y, z in the arm frame; the control point must be inside."""
        s = self._arm(side)
        lo, hi = np.empty(3), np.empty(3)
        for i, n in enumerate(("x_limit", "y_limit", "z_limit")):
            hi[i] = finite_arg(limits[i][1], f"{n}.upper")
            lo[i] = finite_arg(limits[i][0], f"{n}.lower")
            if hi[i] < lo[i]:
                raise ArgumentError(f"{n}: upper {hi[i]:g} is below lower {lo[i]:g} mm")
        pose, _ = self.arms.feedback(self.ctx.snapshot(), side)
        p = m_to_mm(pose.translation)
        if np.any(p < lo) or np.any(p > hi):
            shown = ", ".join(f"{x:.1f}" for x in p)
            raise ArgumentError(
                f"the control point ({shown}) mm is outside the new limits: move it inside first"
            )
        self._require_still()
        with self.arms.lock:
            s.soft_box = (lo, hi)
            self._push_box(side)

    def _push_box(self, side: RightLeft) -> None:
        s = self._arm(side)
        box = None
        if s.soft_box is not None:
            box = CartesianBox(
                mm_to_m(s.soft_box[0]), mm_to_m(s.soft_box[1]), s.base_offset.homogeneous
            )
        self.ctx.call("set_cartesian_box", side=side, box=box)

    # ------------------------------------------------------------------ frames
    def base_offset(self, side: RightLeft) -> np.ndarray:
        """The arm frame in the robot frame: HgMatrix (3 x 4, [mm])."""
        return se3_to_hg(self._arm(side).base_offset)

    def set_base_offset(self, side: RightLeft, hg_mm: np.ndarray | Sequence[float]) -> None:
        offset = _hg(hg_mm, "offset")
        self._require_still()
        with self.arms.lock:
            self._arm(side).base_offset = offset
            self._push_box(side)

    def set_control_point_offset(self, side: RightLeft, hg_mm: np.ndarray | Sequence[float]):
        offset = require_tool_offset(_hg(hg_mm, "offset"), "offset")
        self.ctx.call("set_control_point_offset", side=side, offset=offset.homogeneous)

    # ------------------------------------------------------------------ speeds
    def set_max_speed_cartesian(self, side: RightLeft, translation: float, rotation: float):
        """[mm/s], [deg/s]; at most what the arm can do with every joint at its speed limit."""
        t = positive_arg(translation, "speed.translation", "mm/s")
        r = positive_arg(rotation, "speed.rotation", "deg/s")
        with self.ctx.view.at(self.ctx.snapshot()) as kin:
            require_cartesian_speed(kin, side, (t, r))
        self._arm(side).max_speed_cartesian = (t, r)

    def set_max_speed_joint(self, side: RightLeft, speeds: Sequence[float]) -> None:
        """Per joint [deg/s], within the hardware limits."""
        s = self._arm(side)
        n = len(s.joint_names)
        if len(speeds) != n:
            raise ArgumentError(f"speed: expected {n} speeds (one per joint), got {len(speeds)}")
        speed = finite_values(speeds, "speed")
        for i, v in enumerate(speed):
            positive_arg(float(v), f"speed[{i}]", "deg/s")
            if v > s.hw_speed[i] * (1 + 1e-9):
                raise ArgumentError(
                    f"speed[{i}] ({s.joint_names[i]}): {v:g} deg/s exceeds the hardware limit "
                    f"{s.hw_speed[i]:g} deg/s"
                )
        s.max_speed_joint = speed

    def set_min_accel_time_cartesian(self, side: RightLeft, seconds: float) -> None:
        s = self._arm(side)
        s.min_accel_time_cartesian = positive_arg(seconds, "acl_time", "s")
        s.accel_time_cartesian = max(s.accel_time_cartesian, s.min_accel_time_cartesian)

    def set_min_accel_time_joint(self, side: RightLeft, seconds: float) -> None:
        s = self._arm(side)
        t = positive_arg(seconds, "acl_time", "s")
        hw = s.hw_min_accel_time_joint
        if t < hw - 1e-9:
            raise ArgumentError(
                f"acl_time: {t:g} s is shorter than the drives allow at full speed ({hw:.3f} s)"
            )
        s.min_accel_time_joint = t
        s.accel_time_joint = max(s.accel_time_joint, t)

    def set_accel_time_cartesian(self, side: RightLeft, seconds: float) -> None:
        s = self._arm(side)
        t = positive_arg(seconds, "acl_time", "s")
        if t < s.min_accel_time_cartesian - 1e-12:
            raise ArgumentError(
                f"acl_time: {t:g} s is below the minimum {s.min_accel_time_cartesian:g} s"
            )
        s.accel_time_cartesian = t

    def set_accel_time_joint(self, side: RightLeft, seconds: float) -> None:
        s = self._arm(side)
        t = positive_arg(seconds, "acl_time", "s")
        if t < s.min_accel_time_joint - 1e-12:
            raise ArgumentError(
                f"acl_time: {t:g} s is below the minimum {s.min_accel_time_joint:g} s"
            )
        s.accel_time_joint = t

    @staticmethod
    def _ratio(value: int) -> int:
        if not 1 <= value <= 100:
            raise ArgumentError(f"spd_ratio: {value} % is outside 1..100 % (0 would never move)")
        return int(value)

    def set_speed_cartesian(self, side: RightLeft, ratio: int) -> None:
        self._arm(side).speed_ratio_cartesian = self._ratio(ratio)

    def set_speed_joint(self, side: RightLeft, ratio: int) -> None:
        self._arm(side).speed_ratio_joint = self._ratio(ratio)

    # ------------------------------------------------------------------ home
    def set_home(self, side: RightLeft, values: Sequence[float]) -> None:
        """Joint values [deg] within the soft limits."""
        s = self._arm(side)
        n = len(s.joint_names)
        if len(values) != n:
            raise ArgumentError(f"jointPoint: expected {n} joint values, got {len(values)}")
        home = finite_values(values, "jointPoint")
        for i, v in enumerate(home):
            if not s.soft_lower[i] - 1e-9 <= v <= s.soft_upper[i] + 1e-9:
                raise ArgumentError(
                    f"jointPoint[{i}] ({s.joint_names[i]}): {v:g} deg is outside "
                    f"{s.soft_lower[i]:g}..{s.soft_upper[i]:g} deg"
                )
        s.home = home

    def go_home(self, side: RightLeft) -> str | None:
        return self.arms.ptp_joint(side, self._arm(side).home, relative=False, label="go home")

    # ------------------------------------------------------------------ grippers
    def gripper(self, side: RightLeft, ratio: float) -> None:
        """Gripper to ``ratio`` (0 closed .. 1 open)."""
        if not self.arms.has_gripper(side):
            raise ArgumentError(f"arm: the {side.name} arm has no gripper")
        if not self.arms.hands_on:
            raise Refused(ReturnCode.STATUS_ERR, "the hands are servo off: call servoONHand first")
        self.ctx.call("gripper", side=side, ratio=ratio)

    def set_grasp_force(self, side: RightLeft, ratio: int) -> None:
        if not 0 <= ratio <= 100:
            raise ArgumentError(f"force_ratio: {ratio} % is outside 0..100 %")
        if not self.arms.has_gripper(side):
            raise ArgumentError(f"arm: the {side.name} arm has no gripper")
        self._arm(side).grasp_force = int(ratio)

    def gripper_ratio(self, side: RightLeft, value: float) -> float:
        """Opening 0..1 of a gripper value (getFeedbackPosJoint's unit: deg or mm)."""
        robot = self.ctx.robot
        g = next(v for k, v in robot.profile.grippers.items() if k == side.name)
        spec = robot.joints[g.joints[0]]
        si = float(deg_to_rad(value) if spec.kind == "revolute" else mm_to_m(value))
        lo, hi = spec.to_si(g.closed[0]), spec.to_si(g.open[0])
        ratio = (si - lo) / (hi - lo)
        if not -1e-6 <= ratio <= 1 + 1e-6:
            raise ArgumentError(f"jointPoints: gripper value {value:g} is outside its range")
        return float(np.clip(ratio, 0.0, 1.0))

    # ------------------------------------------------------------------ joint moves
    def move_joints(
        self, side: RightLeft, values: Sequence[float], relative: bool, stream: bool
    ) -> str | None:
        """movePTPJoint{Abs,Rel}[CmdCycle]: the arm's joints [deg]; an extra last value moves
        the gripper (same unit as getFeedbackPosJoint reports it). Every argument is checked
        before anything moves: a refused command leaves no trace (issue 17.3)."""
        s = self._arm(side)
        n = len(s.joint_names)
        has_gripper = self.arms.has_gripper(side)
        vals = [float(v) for v in values]
        ratio = None
        if len(vals) == n + 1 and has_gripper:
            extra = finite_arg(vals.pop(), f"jointPoints[{n}] (gripper)")
            ratio = self.gripper_ratio(side, extra)
        if len(vals) != n:
            what = f"{n} joint values ({n} joints)"
            if has_gripper:
                what = f"{n} or {n + 1} joint values ({n} joints, optionally + 1 gripper)"
            raise ArgumentError(f"jointPoints: expected {what}, got {len(values)}")
        arr = finite_values(vals, "jointPoints")
        if stream:
            result = self.arms.stream_joint(side, arr, relative)
        else:
            result = self.arms.ptp_joint(side, arr, relative)
        if ratio is not None:
            self.ctx.call("gripper", side=side, ratio=ratio)
        return result

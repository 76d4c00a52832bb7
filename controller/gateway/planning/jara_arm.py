"""JARA_ARM planning: per-arm settings, the arm frame, targets of absolute and relative moves.

JARA poses are in the *arm frame*: the robot (current) frame moved by the base offset
(identity by default). JARA moves use the arm's own joints only (waist and vehicle stay put,
the other arm is frozen); a 7-axis arm's elbow follows the CarPosWithElbow angle (ruling of
:mod:`controller.gateway.planning.relative`). Relative moves build on where the queued moves
leave the arm (the planner's queue tail), else on the measured state.

Settings are kept in spec units (mm, deg, s, %: what the get* operations answer); targets and
everything handed to the planner are SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from controller.conversions import deg_to_rad, m_to_mm, mm_to_m, rad_to_deg
from controller.errors import ArgumentError
from controller.gateway.planning.planner import Planner
from controller.gateway.planning.relative import elbow_goal, relative_pose
from controller.model.kinematics import Kinematics
from controller.model.robot import Robot
from controller.vocabulary import FrameType, RightLeft

Box = tuple[np.ndarray, np.ndarray]  # lower, upper [mm] in the arm frame
#: getSoftLimitCartesian before any setSoftLimitCartesian: no limit, shown as ±10 m.
NO_BOX_MM = 10000.0


@dataclass
class ArmSettings:
    """One arm's JARA_ARM settings (spec units: mm, deg, s, %)."""

    joint_names: tuple[str, ...]
    hw_speed: np.ndarray  #: joint speed limits [deg/s]
    hw_accel: np.ndarray  #: joint acceleration limits [deg/s²]
    hw_lower: np.ndarray  #: hardware joint limits [deg]
    hw_upper: np.ndarray
    speed_ratio_cartesian: int
    speed_ratio_joint: int
    max_speed_cartesian: tuple[float, float]  #: [mm/s, deg/s]
    min_accel_time_cartesian: float  #: [s]
    min_accel_time_joint: float
    max_speed_joint: np.ndarray = field(init=False)
    accel_time_cartesian: float = field(init=False)
    accel_time_joint: float = field(init=False)
    soft_lower: np.ndarray = field(init=False)  #: [deg]
    soft_upper: np.ndarray = field(init=False)
    base_offset: pin.SE3 = field(default_factory=pin.SE3.Identity)
    soft_box: Box | None = None
    home: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: [deg]
    grasp_force: int = 50

    def __post_init__(self) -> None:
        self.max_speed_joint = self.hw_speed.copy()
        self.accel_time_cartesian = self.min_accel_time_cartesian
        self.accel_time_joint = self.min_accel_time_joint
        self.soft_lower = self.hw_lower.copy()
        self.soft_upper = self.hw_upper.copy()

    @classmethod
    def for_arm(
        cls,
        robot: Robot,
        side: RightLeft,
        max_speed_cartesian: tuple[float, float],
        min_accel_time_cartesian: float,
        min_accel_time_joint: float,
    ) -> ArmSettings:
        """Defaults of ``side``'s arm: hardware limits, the profile's speed ratio and home."""
        names = robot.unit_joints(f"{side.name}_ARM")
        specs = [robot.joints[n] for n in names]
        settings = cls(
            joint_names=names,
            hw_speed=rad_to_deg([s.velocity for s in specs]),
            hw_accel=rad_to_deg([s.acceleration for s in specs]),
            hw_lower=rad_to_deg([s.lower for s in specs]),
            hw_upper=rad_to_deg([s.upper for s in specs]),
            speed_ratio_cartesian=robot.profile.speed_ratio,
            speed_ratio_joint=robot.profile.speed_ratio,
            max_speed_cartesian=max_speed_cartesian,
            min_accel_time_cartesian=min_accel_time_cartesian,
            min_accel_time_joint=min_accel_time_joint,
        )
        hw_min = settings.hw_min_accel_time_joint
        if settings.min_accel_time_joint < hw_min:
            settings.min_accel_time_joint = settings.accel_time_joint = hw_min
        home = robot.home()
        settings.home = np.array([specs[i].from_si(home.get(n, 0.0)) for i, n in enumerate(names)])
        return settings

    @property
    def hw_min_accel_time_joint(self) -> float:
        """Shortest joint acceleration time the drives allow at full speed [s]."""
        return float(np.max(self.hw_speed / self.hw_accel))

    def joint_speed(self, ratio: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Joint speed and acceleration for the current ratio [rad/s, rad/s²]."""
        share = (self.speed_ratio_joint if ratio is None else ratio) / 100.0
        v = deg_to_rad(self.max_speed_joint) * share
        return v, v / self.accel_time_joint

    def cartesian_speed(
        self, ratio: float | None = None
    ) -> tuple[tuple[float, float], tuple[float, float]]:
        """Cartesian speed and acceleration [m/s, rad/s], [m/s², rad/s²]."""
        share = (self.speed_ratio_cartesian if ratio is None else ratio) / 100.0
        v = (
            float(mm_to_m(self.max_speed_cartesian[0])) * share,
            float(deg_to_rad(self.max_speed_cartesian[1])) * share,
        )
        t = self.accel_time_cartesian
        return v, (v[0] / t, v[1] / t)


@dataclass
class CarPos:
    """A checked CarPosWithElbow: pose [m] and elbow [rad]."""

    pose: pin.SE3
    elbow: float


def to_arm_frame(kin: Kinematics, side: RightLeft, settings: ArmSettings) -> pin.SE3:
    """Control-point pose in the arm frame [m]."""
    return settings.base_offset.actInv(kin.pose(side, FrameType.CURRENT_FRAME))


def to_original(kin: Kinematics, settings: ArmSettings, pose: pin.SE3) -> pin.SE3:
    """Arm-frame pose → original frame."""
    return kin.original_frame.actInv(kin.body_pose() * settings.base_offset * pose)


def check_box(settings: ArmSettings, pose_arm: pin.SE3, name: str) -> None:
    """ArgumentError when ``pose_arm`` (arm frame) lies outside the Cartesian soft limit."""
    if settings.soft_box is None:
        return
    lo, hi = settings.soft_box
    p = m_to_mm(pose_arm.translation)
    if np.any(p < lo - 1e-6) or np.any(p > hi + 1e-6):
        shown = ", ".join(f"{x:.1f}" for x in p)
        raise ArgumentError(f"{name}: target ({shown}) mm is outside the Cartesian soft limit")


def cartesian_target(
    planner: Planner,
    kin: Kinematics,
    side: RightLeft,
    settings: ArmSettings,
    target: CarPos,
    relative: bool,
    name: str,
) -> tuple[pin.SE3, float | None]:
    """Target pose (original frame) and elbow [rad] (None for a 6-axis arm) of a JARA move;
    ``kin`` is at the configuration the move starts from."""
    current = to_arm_frame(kin, side, settings)
    queued_end = planner.tail_pose(side)
    if queued_end is not None:  # build on the queued move's commanded end pose
        current = settings.base_offset.actInv(
            kin.body_pose().actInv(kin.original_frame * queued_end)
        )
    goal = relative_pose(current, target.pose, tool_frame=False) if relative else target.pose
    check_box(settings, goal, name)
    elbow = None
    if kin.has_elbow(side):
        elbow = elbow_goal(kin.elbow_angle(side), target.elbow, relative, f"{name}.elbow")
    return to_original(kin, settings, goal), elbow


def joint_target(
    settings: ArmSettings,
    joints: np.ndarray,
    values: np.ndarray,
    q0: np.ndarray,
    relative: bool,
    name: str,
) -> np.ndarray:
    """An arm's joint target [rad] from joint values [rad] (absolute, or relative to ``q0``);
    ArgumentError outside the soft limits."""
    target = np.asarray(values, dtype=float) + (q0[joints] if relative else 0.0)
    lo, hi = deg_to_rad(settings.soft_lower), deg_to_rad(settings.soft_upper)
    for i, joint in enumerate(settings.joint_names):
        if not lo[i] - 1e-9 <= target[i] <= hi[i] + 1e-9:
            raise ArgumentError(
                f"{name}[{i}] ({joint}): {math.degrees(target[i]):.3f} deg is outside "
                f"the soft limit {settings.soft_lower[i]:g}..{settings.soft_upper[i]:g} deg"
            )
    return target

"""The robot profile (``config/robots/<id>/profile.yaml``): how imotion uses a robot's joints.

Units in the file: revolute joints in [deg], [deg/s], [deg/s²]; prismatic joints (vehicle x/y,
parallel grippers) in [m], [m/s], [m/s²]; offsets ``xyz`` [m] and ``rpy`` [deg]. Inside the
controller everything is SI: see :class:`controller.model.robot.Robot`.

A broken profile raises :class:`~controller.model.yaml_source.ConfigError` whose every line names
the file, the key and what is wrong.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from controller.bounds import ANGLE, LENGTH
from controller.model.model_source import ModelSource, StrictModel, Vec3
from controller.model.yaml_source import ConfigError, load_yaml_model

UnitName = Literal["RIGHT_ARM", "LEFT_ARM", "LUMBER", "VEHICLE"]
SideName = Literal["RIGHT", "LEFT"]
LumbarAxis = Literal["Rx", "Ry", "Rz"]
Positive = Annotated[float, Field(gt=0)]

ARM_UNIT: dict[str, str] = {"RIGHT": "RIGHT_ARM", "LEFT": "LEFT_ARM"}


class JointLimits(StrictModel):
    """Limits of one joint. ``None`` position limits mean unbounded (vehicle axes only)."""

    lower: float | None
    upper: float | None
    velocity: Positive
    acceleration: Positive

    @model_validator(mode="after")
    def _check_order(self) -> JointLimits:
        if (self.lower is None) != (self.upper is None):
            raise ValueError("lower and upper must both be numbers or both be null")
        if self.lower is not None and self.upper is not None and not self.lower < self.upper:
            raise ValueError(f"lower ({self.lower}) must be below upper ({self.upper})")
        return self


class Offset(StrictModel):
    """A rigid offset: translation [m] and roll-pitch-yaw [deg]."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)


class Arm(StrictModel):
    """One arm's control point: the flange frame and the default tool offset from it."""

    #: Link (frame) of the flange in the model.
    flange: str
    #: Default control point relative to the flange; settable at run time.
    tool_offset: Offset = Offset()


class ElbowReference(StrictModel):
    """Points and reference directions of an arm's elbow (swivel) angle.

    ``shoulder``, ``elbow`` and ``wrist`` are links whose origins are the three points.
    ``forward`` and ``down`` are directions in the frame of the arm's base link (the parent
    of its first joint): with the wrist straight along ``forward`` from the shoulder, the elbow
    angle is 0 when the elbow lies on the ``down`` side. See :mod:`controller.model.elbow`.
    """

    shoulder: str
    elbow: str
    wrist: str
    forward: Vec3 = (1.0, 0.0, 0.0)
    down: Vec3 = (0.0, 0.0, -1.0)

    @model_validator(mode="after")
    def _check_directions(self) -> ElbowReference:
        f, d = np.asarray(self.forward), np.asarray(self.down)
        if np.linalg.norm(f) < 1e-9 or np.linalg.norm(d) < 1e-9:
            raise ValueError("forward and down must be non-zero directions")
        cos = abs(f @ d) / (np.linalg.norm(f) * np.linalg.norm(d))
        if cos > 1e-6:
            raise ValueError("forward and down must be perpendicular")
        return self


class Gripper(StrictModel):
    """A gripper: its joints and their values when fully open (100 %) and closed (0 %)."""

    joints: tuple[str, ...] = Field(min_length=1)
    open: tuple[float, ...]
    closed: tuple[float, ...]

    @model_validator(mode="after")
    def _check_lengths(self) -> Gripper:
        n = len(self.joints)
        if len(self.open) != n or len(self.closed) != n:
            raise ValueError(f"open and closed need one value per joint ({n})")
        return self


class RedundantAxes(StrictModel):
    """Which redundant axes exist and how they map onto joints.

    The vehicle axes (vehicleX, vehicleY, vehicleTheta) exist exactly when the robot has a
    VEHICLE unit: they are the planar pose of the body frame in the original frame.
    """

    #: Elbow (swivel) angle per 7-axis arm.
    elbow: dict[SideName, ElbowReference] = Field(default_factory=dict)
    #: Composite waist angles: Σ weight × joint angle, e.g. SmartPal V lumbarRy = lower + upper.
    lumbar: dict[LumbarAxis, dict[str, float]] = Field(default_factory=dict)


class Wheels(StrictModel):
    """Wheel geometry, for the vehicle drives (hardware layer)."""

    kind: Literal["mecanum", "omni", "differential"]
    count: Annotated[int, Field(ge=2)]
    radius: Positive
    #: Lateral distance between left and right wheels [m] (or omni-wheel circle diameter).
    track: Positive
    #: Longitudinal distance between front and rear wheels [m] (mecanum only).
    wheelbase: Positive | None = None


Range = tuple[float, float]


class VehicleWorkspace(StrictModel):
    """Where the vehicle may take the body: its planar pose in the original frame, x and y
    [m], heading theta [deg] (unwrapped), each ``(lower, upper)`` around the original frame.

    Every vehicle target (moveUnit*, moveCPHold*, RedundantLimit ranges, Cartesian moves that
    let the vehicle move) must lie inside; resetOriginalFrame re-centres it on the body.
    """

    x: Range = (-10.0, 10.0)
    y: Range = (-10.0, 10.0)
    theta: Range = (-720.0, 720.0)

    @model_validator(mode="after")
    def _check(self) -> VehicleWorkspace:
        for name, (lo, hi), bound in (
            ("x", self.x, LENGTH.limit / 1000.0),
            ("y", self.y, LENGTH.limit / 1000.0),
            ("theta", self.theta, ANGLE.limit),
        ):
            if not lo < 0.0 < hi:
                raise ValueError(f"{name}: ({lo}, {hi}) must hold 0 (the original frame) inside")
            if max(-lo, hi) > bound:
                raise ValueError(f"{name}: ({lo}, {hi}) is beyond the interfaces' bound {bound:g}")
        return self

    def si(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners (x [m], y [m], theta [rad])."""
        lo = np.array([self.x[0], self.y[0], np.radians(self.theta[0])])
        hi = np.array([self.x[1], self.y[1], np.radians(self.theta[1])])
        return lo, hi


class Vehicle(StrictModel):
    type: Literal["omnidirectional", "differential"]
    wheels: Wheels
    workspace: VehicleWorkspace = VehicleWorkspace()


class CollisionAvoidance(StrictModel):
    """Self-collision avoidance in the whole-body QP (velocity dampers, docs/collision.md).

    Every checked pair of ``collision.yaml`` closer than ``influence`` (d_i) gets a row
    ``d' >= -damping * (d - security) / (influence - security)``: it may approach at most at
    ``damping`` [m/s] at d_i, slower and slower down to 0 at ``security`` (d_s).
    """

    #: Rows in the QP (False: no collision rows at all).
    enabled: bool = True
    #: Influence distance d_i [m]: pairs closer than this get a row.
    influence: float = Field(default=0.05, gt=0.0, le=0.5)
    #: Security distance d_s [m]: pairs never come closer (below: "no further closer").
    security: float = Field(default=0.005, ge=0.0)
    #: Damper gain ξ [m/s]: the approach speed allowed at d_i (lowered per pair so the
    #: damper never asks for more deceleration than the joints can give, see the docs).
    damping: float = Field(default=0.3, gt=0.0, le=5.0)
    #: Look-ahead [s]: a pair closing in faster than (d − d_i) / lookahead gets its row
    #: before d_i, early enough to brake (its allowance then starts at its approach speed).
    lookahead: float = Field(default=0.25, ge=0.0, le=2.0)
    #: Most rows per cycle (the most urgent pairs in range); the QP keeps this many rows.
    max_rows: int = Field(default=16, ge=1, le=200)
    #: Planning margin [m]: a Cartesian move whose path would come closer than
    #: ``security + plan_margin`` is refused before it starts, so that an accepted move is
    #: not slowed to a stop by the rows near d_s (docs/collision.md).
    plan_margin: float = Field(default=0.015, ge=0.0, le=0.2)

    @property
    def planning_distance(self) -> float:
        """Closest distance [m] a planned Cartesian path may bring two bodies to."""
        return self.security + self.plan_margin

    @model_validator(mode="after")
    def _check_order(self) -> CollisionAvoidance:
        if not self.security < self.influence:
            raise ValueError(
                f"security ({self.security}) must be below influence ({self.influence})"
            )
        return self


class RobotProfile(StrictModel):
    """Everything imotion needs to know about a robot beyond its kinematic tree."""

    id: str
    name: str
    manufacturer: str
    type: str
    #: The model file this profile goes with (relative to the profile).
    model: str = "model.yaml"
    #: Joints of each unit, in spec order.
    units: dict[UnitName, tuple[str, ...]]
    #: Limits of every unit joint and every gripper joint.
    joints: dict[str, JointLimits]
    #: Home pose; unit joints not named are 0.
    home: dict[str, float] = Field(default_factory=dict)
    arms: dict[SideName, Arm]
    grippers: dict[SideName, Gripper] = Field(default_factory=dict)
    #: Link whose origin and axes define the current frame (and the original frame at reset).
    body_frame: str
    redundant_axes: RedundantAxes = RedundantAxes()
    vehicle: Vehicle | None = None
    #: JARA_ARM initial speed ratio (setSpeedCartesian / setSpeedJoint) [%].
    speed_ratio: Annotated[int, Field(ge=1, le=100)] = 50
    #: Self-collision rows of the QP (distances in [m], damping in [m/s]).
    collision_avoidance: CollisionAvoidance = CollisionAvoidance()


def _cross_check(p: RobotProfile, model: ModelSource) -> list[str]:
    """Consistency between the profile's parts and with the model: ``key: problem`` lines."""
    errors: list[str] = []
    model_joints = {j.name: j for j in model.joints}
    links = set(model.link_names)
    moving = {j.name for j in model.joints if j.type != "fixed"}

    unit_of: dict[str, str] = {}
    for unit, names in p.units.items():
        for i, name in enumerate(names):
            key = f"units.{unit}[{i}]"
            if name not in model_joints or name not in moving:
                errors.append(f"{key}: {name!r} is not a moving joint of the model")
            elif name in unit_of:
                errors.append(f"{key}: {name!r} is already in unit {unit_of[name]}")
            else:
                unit_of[name] = unit
            if name not in p.joints:
                errors.append(f"{key}: {name!r} has no entry under 'joints' (limits)")
    gripper_joints = {n for g in p.grippers.values() for n in g.joints}
    for name in sorted(moving - set(unit_of) - gripper_joints):
        errors.append(f"units: model joint {name!r} belongs to no unit and no gripper")
    for name in sorted(set(p.joints) - set(unit_of) - gripper_joints):
        errors.append(f"joints.{name}: not a joint of any unit or gripper")

    for name, lim in p.joints.items():
        if lim.lower is None and unit_of.get(name) != "VEHICLE":
            errors.append(f"joints.{name}: only vehicle axes may be unbounded")

    for name, value in p.home.items():
        home_lim = p.joints.get(name)
        if name not in unit_of or home_lim is None:
            errors.append(f"home.{name}: not a unit joint")
        elif home_lim.lower is not None and home_lim.upper is not None:
            if not home_lim.lower <= value <= home_lim.upper:
                errors.append(
                    f"home.{name}: {value} is outside the limits "
                    f"[{home_lim.lower}, {home_lim.upper}]"
                )

    for side, arm in p.arms.items():
        if ARM_UNIT[side] not in p.units:
            errors.append(f"arms.{side}: the profile has no {ARM_UNIT[side]} unit")
        if arm.flange not in links:
            errors.append(f"arms.{side}.flange: {arm.flange!r} is not a link of the model")
    for unit in p.units:
        if unit.endswith("_ARM") and unit.removesuffix("_ARM") not in p.arms:
            errors.append(f"units.{unit}: no matching entry under 'arms'")

    for side, g in p.grippers.items():
        if side not in p.arms:
            errors.append(f"grippers.{side}: the robot has no {side} arm")
        for i, name in enumerate(g.joints):
            glim = p.joints.get(name)
            if name not in moving:
                errors.append(f"grippers.{side}.joints[{i}]: {name!r} is not a moving joint")
            elif glim is None:
                errors.append(f"grippers.{side}.joints[{i}]: {name!r} has no entry under 'joints'")
            elif name in unit_of:
                errors.append(f"grippers.{side}.joints[{i}]: {name!r} is also in a unit")
            elif glim.lower is not None and glim.upper is not None:  # else: reported above
                for what, v in (("open", g.open[i]), ("closed", g.closed[i])):
                    if not glim.lower <= v <= glim.upper:
                        errors.append(f"grippers.{side}.{what}[{i}]: {v} is outside the limits")

    if p.body_frame not in links:
        errors.append(f"body_frame: {p.body_frame!r} is not a link of the model")

    for side, ref in p.redundant_axes.elbow.items():
        key = f"redundant_axes.elbow.{side}"
        arm_unit = ARM_UNIT[side]
        if len(p.units.get(arm_unit, ())) != 7:  # type: ignore[call-overload]
            errors.append(f"{key}: an elbow angle needs a 7-axis {arm_unit}")
        for what in ("shoulder", "elbow", "wrist"):
            if getattr(ref, what) not in links:
                errors.append(f"{key}.{what}: {getattr(ref, what)!r} is not a link of the model")
    for axis, weights in p.redundant_axes.lumbar.items():
        for name in weights:
            if unit_of.get(name) != "LUMBER":
                errors.append(f"redundant_axes.lumbar.{axis}.{name}: not a LUMBER joint")

    vehicle_joints = p.units.get("VEHICLE", ())
    if (p.vehicle is None) != (not vehicle_joints):
        errors.append("vehicle: must be given exactly when the profile has a VEHICLE unit")
    if vehicle_joints:
        kinds = [model_joints[n].type for n in vehicle_joints if n in model_joints]
        if kinds != ["prismatic", "prismatic", "revolute"]:
            errors.append("units.VEHICLE: must be x (prismatic), y (prismatic), theta (revolute)")
    return errors


def load_profile(path: Path, model: ModelSource) -> RobotProfile:
    """Load ``profile.yaml`` and check it against ``model``; raises ConfigError on problems."""
    profile = load_yaml_model(path, RobotProfile)
    problems = _cross_check(profile, model)
    if problems:
        raise ConfigError("\n".join(f"{path}: {line}" for line in problems))
    return profile

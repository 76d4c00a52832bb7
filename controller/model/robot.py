"""A loaded robot: its profile and kinematic source, checked together, with SI joint data."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from config import ROBOTS_DIR
from controller.model.model_source import ModelSource, load_model_source
from controller.model.profile import RobotProfile, load_profile
from controller.model.yaml_source import ConfigError, read_yaml
from controller.vocabulary import UnitType


@dataclass(frozen=True)
class JointSpec:
    """One joint's limits in SI: [rad], [rad/s], [rad/s²] or [m], [m/s], [m/s²]."""

    name: str
    kind: str  # "revolute" or "prismatic"
    lower: float  # -inf when unbounded
    upper: float  # +inf when unbounded
    velocity: float
    acceleration: float

    def to_si(self, value: float) -> float:
        """Convert a profile value (deg for revolute, m for prismatic) to SI."""
        return math.radians(value) if self.kind == "revolute" else value

    def from_si(self, value: float) -> float:
        """Convert an SI value to profile units (deg for revolute, m for prismatic)."""
        return math.degrees(value) if self.kind == "revolute" else value


@dataclass(frozen=True)
class Robot:
    """Profile + model of one robot, and the paths of its generated URDF and MJCF."""

    directory: Path
    profile: RobotProfile
    model: ModelSource
    joints: dict[str, JointSpec]

    @property
    def id(self) -> str:
        return self.profile.id

    @property
    def urdf_path(self) -> Path:
        return self.directory / "robot.urdf"

    @property
    def mjcf_path(self) -> Path:
        return self.directory / "robot.xml"

    def unit_joints(self, unit: UnitType | str) -> tuple[str, ...]:
        """Joint names of a unit (a UnitType or its name) in spec order (empty when the robot
        lacks the unit)."""
        name = unit.name if isinstance(unit, UnitType) else UnitType[unit].name
        return self.profile.units.get(name, ())  # type: ignore[call-overload]

    @property
    def gripper_joints(self) -> tuple[str, ...]:
        return tuple(n for g in self.profile.grippers.values() for n in g.joints)

    def home(self) -> dict[str, float]:
        """Home pose in SI for every unit joint (0 where the profile names none)."""
        names = [n for joints in self.profile.units.values() for n in joints]
        return {n: self.joints[n].to_si(self.profile.home.get(n, 0.0)) for n in names}


def _joint_specs(profile: RobotProfile, model: ModelSource) -> dict[str, JointSpec]:
    specs = {}
    for name, lim in profile.joints.items():
        kind = model.joint(name).type
        spec = JointSpec(name, kind, -math.inf, math.inf, 0.0, 0.0)
        lower = -math.inf if lim.lower is None else spec.to_si(lim.lower)
        upper = math.inf if lim.upper is None else spec.to_si(lim.upper)
        specs[name] = JointSpec(
            name, kind, lower, upper, spec.to_si(lim.velocity), spec.to_si(lim.acceleration)
        )
    return specs


def robot_directory(robot: str | Path) -> Path:
    """The directory of a shipped robot id, or ``robot`` itself when it is a directory."""
    path = Path(robot)
    if path.is_dir():
        return path
    candidate = ROBOTS_DIR / str(robot)
    if not (candidate / "profile.yaml").is_file():
        shipped = ", ".join(sorted(p.name for p in ROBOTS_DIR.iterdir() if p.is_dir()))
        raise ConfigError(f"unknown robot {robot!r}: not a directory and not one of {shipped}")
    return candidate


def load_robot(robot: str | Path) -> Robot:
    """Load ``profile.yaml`` and its ``model.yaml`` from a robot id or directory."""
    directory = robot_directory(robot)
    raw = read_yaml(directory / "profile.yaml")
    model_name = raw.get("model", "model.yaml") if isinstance(raw, dict) else "model.yaml"
    model = load_model_source(directory / str(model_name))
    profile = load_profile(directory / "profile.yaml", model)
    return Robot(directory, profile, model, _joint_specs(profile, model))

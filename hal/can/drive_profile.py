"""The drive profile (``config/robots/<id>/drives.yaml``): how a robot's joints map to CAN drives.

One entry per bus (a python-can channel) and one per drive (a CiA 402 node). Units in the
file: positions [counts], windows in the joint's profile units ([deg] revolute, [m]
prismatic), times [ms], bitrates [bit/s]. Example::

    robot: smartpal5
    rate_hz: 500                 # the loop rate the bus split is planned for
    master_node_id: 127
    buses:
      arm_r: {interface: socketcan, channel: can0, bitrate: 1000000}
    drives:
      r_arm_j1: {bus: arm_r, node_id: 1, counts_per_rev: 131072, gear_ratio: 100, sign: 1}
    vehicle:                      # wheel drives of the VEHICLE unit, in the wheel order
      wheels: [wheel_1, wheel_2, wheel_3]

A drive name is a joint of ``profile.yaml`` (unit or gripper joint) or one of the wheels named
under ``vehicle.wheels``; the vehicle's x/y/θ joints are virtual (odometry, see
:mod:`hal.can.vehicle`) unless the profile lists them as drives itself (a stand-in for a base
that takes x/y/θ set-points directly).

A broken file raises :class:`~controller.model.yaml_source.ConfigError` naming file, key and
problem.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field, model_validator

from config import CONFIG_DIR
from controller.model.model_source import StrictModel
from controller.model.yaml_source import ConfigError, load_yaml_model
from hal.can.scaling import Scaling

if TYPE_CHECKING:
    from controller.model.robot import Robot

#: The shared object dictionary of imotion's drives (written with the drive emulator).
DEFAULT_EDS = CONFIG_DIR / "drives" / "imotion_cia402.eds"
#: Names of the virtual vehicle joints (profile.yaml VEHICLE unit).
VEHICLE_JOINTS = ("vehicle_x", "vehicle_y", "vehicle_theta")

NodeId = Annotated[int, Field(ge=1, le=127)]
PositiveInt = Annotated[int, Field(gt=0)]
Positive = Annotated[float, Field(gt=0)]
NonNegative = Annotated[float, Field(ge=0)]


class BusConfig(StrictModel):
    """One CAN bus: a python-can channel."""

    #: python-can interface name (``socketcan``, ``pcan``, ``virtual``, ``remote``, ...).
    interface: str = "socketcan"
    channel: str
    #: Nominal (arbitration) bitrate [bit/s].
    bitrate: PositiveInt = 1_000_000
    #: CAN FD (bit-rate switch in the data phase) instead of classic CAN.
    fd: bool = False
    #: Data-phase bitrate [bit/s] (CAN FD only).
    data_bitrate: PositiveInt | None = None
    #: TPDO timeout of the drives on this bus (None: the profile's), e.g. a bus bridged over
    #: a network whose TPDOs may come in a cycle late: cycles in a row, and [ms].
    tpdo_timeout_cycles: PositiveInt | None = None
    tpdo_timeout_ms: NonNegative | None = None

    @model_validator(mode="after")
    def _check_fd(self) -> BusConfig:
        if self.fd and self.data_bitrate is None:
            raise ValueError("a CAN FD bus needs data_bitrate")
        if not self.fd and self.data_bitrate is not None:
            raise ValueError("data_bitrate is for CAN FD buses only (set fd: true)")
        return self


class DriveConfig(StrictModel):
    """One CiA 402 drive (see :mod:`hal.can.scaling` for the conversion)."""

    bus: str
    node_id: NodeId
    #: Encoder counts per motor revolution (revolute joints and wheels).
    counts_per_rev: Positive | None = None
    #: Encoder counts per metre of motor-side travel (prismatic joints).
    counts_per_m: Positive | None = None
    #: Motor revolutions (metres) per joint revolution (metre).
    gear_ratio: Positive = 1.0
    sign: Literal[1, -1] = 1
    #: Raw position at joint zero [counts].
    offset: int = 0
    #: Map velocity actual (0x606C) into TPDO2; otherwise velocity is differenced.
    velocity_feedback: bool = False
    #: The drive's own EDS/DCF (relative to this file); default: the shared imotion EDS.
    eds: str | None = None

    @model_validator(mode="after")
    def _check_counts(self) -> DriveConfig:
        if (self.counts_per_rev is None) == (self.counts_per_m is None):
            raise ValueError("give exactly one of counts_per_rev (revolute) and counts_per_m")
        return self

    @property
    def revolute(self) -> bool:
        return self.counts_per_rev is not None

    def scaling(self) -> Scaling:
        per_unit = self.counts_per_rev if self.counts_per_rev is not None else self.counts_per_m
        assert per_unit is not None
        return Scaling(per_unit, self.gear_ratio, self.sign, self.offset, self.revolute)


class Heartbeat(StrictModel):
    """Heartbeat periods [ms] (CiA 301 0x1016/0x1017)."""

    #: Each drive's producer period (0x1017 of the drive).
    drive_producer_ms: PositiveInt = 100
    #: The master's producer period (node ``master_node_id``).
    master_producer_ms: PositiveInt = 100
    #: How long a drive waits for the master's heartbeat before it stops (drive 0x1016).
    drive_consumer_ms: PositiveInt = 300
    #: How long the master waits for a drive's heartbeat before it alarms (0x401).
    master_consumer_ms: PositiveInt = 300

    @model_validator(mode="after")
    def _check_order(self) -> Heartbeat:
        if self.drive_consumer_ms <= self.master_producer_ms:
            raise ValueError("drive_consumer_ms must exceed master_producer_ms")
        if self.master_consumer_ms <= self.drive_producer_ms:
            raise ValueError("master_consumer_ms must exceed drive_producer_ms")
        return self


class FollowingError(StrictModel):
    """Following-error supervision (drive 0x6065/0x6066 and the master's own check)."""

    #: Window for revolute joints and wheels [deg].
    window_deg: Positive = 5.0
    #: Window for prismatic joints [m].
    window_m: Positive = 0.01
    #: Time the error may stay outside the window [ms].
    time_ms: PositiveInt = 20


class VehicleDrives(StrictModel):
    """The wheel drives of the vehicle, in the wheel order of :mod:`hal.can.vehicle`."""

    wheels: tuple[str, ...] = Field(min_length=2)


class DriveProfile(StrictModel):
    """Every drive and bus of one robot."""

    robot: str
    #: The loop rate [Hz] this bus split is planned for (documentation; the daemon's rate
    #: decides, and the bus-load check runs at that rate).
    rate_hz: Positive
    master_node_id: NodeId = 127
    #: Default EDS of the drives (relative to this file); default: the shared imotion EDS.
    eds: str | None = None
    #: Stale feedback: a drive whose TPDO1 is missing this many cycles in a row alarms (0x405).
    tpdo_timeout_cycles: PositiveInt = 3
    #: ... and, when set, for at least this long [ms] (a time bound for late remote buses).
    tpdo_timeout_ms: NonNegative | None = None
    #: Quick stop (0x6007 abort connection option code) on a heartbeat loss.
    abort_connection_option: Annotated[int, Field(ge=-32768, le=32767)] = 3
    heartbeat: Heartbeat = Heartbeat()
    following_error: FollowingError = FollowingError()
    buses: dict[str, BusConfig] = Field(min_length=1)
    drives: dict[str, DriveConfig] = Field(min_length=1)
    vehicle: VehicleDrives | None = None

    @property
    def wheels(self) -> tuple[str, ...]:
        return self.vehicle.wheels if self.vehicle is not None else ()

    def drives_on(self, bus: str) -> dict[str, DriveConfig]:
        """The drives of ``bus`` in file order."""
        return {n: d for n, d in self.drives.items() if d.bus == bus}

    def following_window(self, name: str) -> float:
        """Following-error window of drive ``name`` in SI [rad] or [m]."""
        return self.following_window_of(self.drives[name])

    def following_window_of(self, drive: DriveConfig) -> float:
        """Following-error window of ``drive`` in SI [rad] or [m]."""
        if drive.revolute:
            return math.radians(self.following_error.window_deg)
        return self.following_error.window_m


def check_references(profile: DriveProfile) -> list[str]:
    """Buses, node ids and wheels that do not fit together: ``key: problem`` lines."""
    errors = []
    seen: dict[tuple[str, int], str] = {}
    for name, drive in profile.drives.items():
        if drive.bus not in profile.buses:
            errors.append(
                f"drives.{name}.bus: {drive.bus!r} is not one of the buses "
                f"({', '.join(profile.buses)})"
            )
        if drive.node_id == profile.master_node_id:
            errors.append(f"drives.{name}.node_id: {drive.node_id} is the master's node id")
        other = seen.setdefault((drive.bus, drive.node_id), name)
        if other != name:
            errors.append(
                f"drives.{name}.node_id: {drive.node_id} is already used by {other} "
                f"on bus {drive.bus}"
            )
    if profile.vehicle is not None:
        for i, wheel in enumerate(profile.vehicle.wheels):
            if wheel not in profile.drives:
                errors.append(f"vehicle.wheels[{i}]: {wheel!r} is not a drive")
            elif not profile.drives[wheel].revolute:
                errors.append(f"vehicle.wheels[{i}]: wheel {wheel!r} needs counts_per_rev")
        if len(set(profile.vehicle.wheels)) != len(profile.vehicle.wheels):
            errors.append("vehicle.wheels: a wheel is named twice")
    for name in profile.buses:
        if not profile.drives_on(name):
            errors.append(f"buses.{name}: no drive uses this bus")
    return errors


def eds_path(profile: DriveProfile, name: str, directory: Path) -> Path:
    """The EDS/DCF file of drive ``name`` (its own, else the profile's, else the shared one)."""
    own = profile.drives[name].eds or profile.eds
    return (directory / own).resolve() if own else DEFAULT_EDS


def cross_check(profile: DriveProfile, robot: Robot) -> list[str]:
    """Consistency with the robot: ``key: problem`` lines (empty when consistent)."""
    errors: list[str] = []
    if profile.robot != robot.id:
        errors.append(f"robot: {profile.robot!r} but the robot profile is {robot.id!r}")
    vehicle_joints = robot.unit_joints("VEHICLE")
    direct_vehicle = any(n in profile.drives for n in vehicle_joints)
    actuated = [n for joints in robot.profile.units.values() for n in joints]
    actuated += list(robot.gripper_joints)
    if vehicle_joints and not direct_vehicle:
        actuated = [n for n in actuated if n not in vehicle_joints]
        if profile.vehicle is None:
            errors.append("vehicle: the robot has a VEHICLE unit: name its wheel drives")
        elif robot.profile.vehicle is not None:
            want = robot.profile.vehicle.wheels.count
            if len(profile.vehicle.wheels) != want:
                errors.append(
                    f"vehicle.wheels: {len(profile.vehicle.wheels)} wheels, profile.yaml "
                    f"vehicle.wheels.count is {want}"
                )
    elif profile.vehicle is not None:
        if not vehicle_joints:
            errors.append("vehicle: the robot has no VEHICLE unit")
        else:
            errors.append("vehicle: give either wheel drives or vehicle_x/y/theta drives")
    for name in actuated:
        if name not in profile.drives:
            errors.append(f"drives: joint {name!r} has no drive")
    for name, drive in profile.drives.items():
        if name in profile.wheels:
            continue
        spec = robot.joints.get(name)
        if spec is None or name not in actuated:
            errors.append(f"drives.{name}: not an actuated joint of {robot.id} nor a wheel")
        elif drive.revolute != (spec.kind == "revolute"):
            field = "counts_per_rev" if spec.kind == "revolute" else "counts_per_m"
            errors.append(f"drives.{name}: a {spec.kind} joint needs {field}")
    return errors


def drives_path(robot: Robot) -> Path:
    """``config/robots/<id>/drives.yaml`` of ``robot``."""
    return robot.directory / "drives.yaml"


def load_drive_profile(path: Path, robot: Robot | None = None) -> DriveProfile:
    """Load ``drives.yaml`` (and check it against ``robot``); ConfigError on any problem."""
    profile = load_yaml_model(path, DriveProfile)
    errors = check_references(profile)
    if robot is not None and not errors:
        errors = cross_check(profile, robot)
    if errors:
        raise ConfigError("\n".join(f"{path}: {e}" for e in errors))
    return profile

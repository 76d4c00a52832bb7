"""Joints <-> drives of the CAN master: set-points to counts, feedback counts to SI joint state.

A robot's joints (unit joints in unit order, then grippers) map to drives of the profile by
name. The vehicle's virtual joints x, y [m] and θ [rad] map to the wheel drives through
:class:`hal.can.vehicle.VehicleMapping` (commands as wheel increments, feedback as
odometry) unless the profile lists them as drives. Scaling counts <-> SI is
:mod:`hal.can.scaling`; wheels turn without bound (their 32-bit positions are integrated as
wrapped differences).

Each cycle's :meth:`JointMap.update` and :meth:`JointMap.command` are one compiled call
each (:mod:`hal.can.kernels`) where :func:`controller.model.jit.available`, else the NumPy
code below (the same numbers up to rounding; tests compare both).
"""

from __future__ import annotations

import numpy as np

from controller.model import jit
from controller.model.robot import Robot
from hal.can import kernels
from hal.can.drive_profile import VEHICLE_JOINTS, DriveProfile
from hal.can.scaling import I32_MIN, ScalingArray, delta_i32
from hal.can.vehicle import VehicleMapping


def joint_names(robot: Robot) -> tuple[str, ...]:
    """The joints a CAN backend exposes: unit joints in unit order, then grippers."""
    units = [n for joints in robot.profile.units.values() for n in joints]
    return (*units, *robot.gripper_joints)


class JointMap:
    """Joints of ``robot`` on the drives of ``profile`` at loop period ``dt`` [s]."""

    def __init__(self, robot: Robot, profile: DriveProfile, dt: float):
        self.dt = dt
        self.joint_names = joint_names(robot)
        #: Drives in profile order.
        self.drive_names = list(profile.drives)
        cfgs = [profile.drives[n] for n in self.drive_names]
        self.scale = ScalingArray([d.scaling() for d in cfgs])
        n = len(cfgs)
        self.has_velocity = np.array([d.velocity_feedback for d in cfgs], dtype=bool)
        #: Drives with TPDO2 (velocity actual) and their counts per SI unit.
        self._vel_idx = [int(i) for i in np.flatnonzero(self.has_velocity)]
        self._vel_factor = self.scale.factor[self._vel_idx]
        wheels = profile.wheels
        self.wheel_idx = [self.drive_names.index(w) for w in wheels]
        self.vehicle: VehicleMapping | None = None
        self._vehicle_joints = np.zeros(0, dtype=int)
        if wheels:
            assert robot.profile.vehicle is not None
            self.vehicle = VehicleMapping(robot.profile.vehicle.wheels)
            self._vehicle_joints = np.array(
                [self.joint_names.index(j) for j in VEHICLE_JOINTS], dtype=int
            )
        # Joint joint_idx[k] <- drive joint_drive[k] for every joint that is a drive.
        joint_of = {name: i for i, name in enumerate(self.joint_names)}
        pairs = [(joint_of[d], k) for k, d in enumerate(self.drive_names) if d in joint_of]
        self.joint_idx = np.array([p[0] for p in pairs], dtype=int)
        self.joint_drive = np.array([p[1] for p in pairs], dtype=int)
        missing = set(self.joint_names) - {self.joint_names[i] for i in self.joint_idx}
        if self.vehicle is not None:
            missing -= set(VEHICLE_JOINTS)
        if missing:
            raise ValueError(f"{robot.id}: joints without a drive: {sorted(missing)}")
        #: Per drive [rad]/[m] (wheels as unbounded angles): measured, previous, velocity.
        self.pos = np.zeros(n)
        self.vel = np.zeros(n)
        self._prev = np.zeros(n)
        self._si = np.zeros(n)
        #: Set-point [SI] per drive sent before the last SYNC.
        self.target = np.zeros(n)
        self._wheel_raw = np.zeros(len(wheels), dtype=np.int64)
        self._wheel_seen = np.zeros(len(wheels), dtype=np.bool_)
        self._vehicle_started = False
        #: Every wheel reports its velocity (TPDO2): odometry twist from speeds.
        self._wheel_speeds = bool(wheels) and bool(self.has_velocity[self.wheel_idx].all())
        #: Joint state [rad]/[m] and [rad/s]/[m/s] in :attr:`joint_names` order.
        self.position = np.zeros(len(self.joint_names))
        self.velocity = np.zeros(len(self.joint_names))
        #: Compiled kernels (:mod:`hal.can.kernels`) for update() and command().
        self.compiled = jit.available()
        self._wheel_idx = np.array(self.wheel_idx, dtype=np.int64)
        self._vel_drives = np.array(self._vel_idx, dtype=np.int64)
        self._vehicle_flags = np.zeros(3, dtype=np.int64)  # has one, started, wheel speeds
        self._vehicle_flags[0] = self.vehicle is not None
        self._vehicle_flags[2] = self._wheel_speeds
        vehicle = self.vehicle or VehicleMapping.empty()
        self._odometry = (vehicle.pose, vehicle.velocity, vehicle._wheels,
                          np.ascontiguousarray(vehicle.inverse))  # fmt: skip
        self._command_arrays = (np.ascontiguousarray(vehicle.matrix), vehicle.command_pose,
                                vehicle.wheel_targets)  # fmt: skip
        self._vehicle_joints3 = (
            self._vehicle_joints if len(self._vehicle_joints) else np.zeros(3, dtype=np.int64)
        )
        self._counts = np.zeros(n, dtype=np.int64)

    def command(self, position: np.ndarray, out: np.ndarray) -> None:
        """Joint set-points [SI] -> :attr:`target` [SI] and ``out`` [counts] per drive."""
        target = self.target
        if self.compiled:
            matrix, command_pose, wheel_targets = self._command_arrays
            kernels.command(
                position, self.joint_idx, self.joint_drive, target, self.scale.factor,
                self.scale.offset, out, self._wheel_idx, matrix, command_pose,
                wheel_targets, self._vehicle_joints3,
            )  # fmt: skip
            return
        target[self.joint_drive] = position[self.joint_idx]
        if self.vehicle is not None:
            target[self.wheel_idx] = self.vehicle.command(position[self._vehicle_joints])
        counts = np.rint(target * self.scale.factor + self.scale.offset).astype(np.int64)
        counts -= I32_MIN
        counts %= 2**32
        counts += I32_MIN
        out[:] = counts

    def hold(self) -> None:
        """Set-point := measured (the targets in counts are the caller's: the raw actuals)."""
        self.target[:] = self.pos
        if self.vehicle is not None:
            self.vehicle.hold()

    def update(
        self,
        raw: np.ndarray,
        raw_velocity: np.ndarray,
        fresh: np.ndarray,
        seen: np.ndarray,
    ) -> None:
        """New SI state from the feedback [counts], [counts/s] of the drives (``seen``: ever
        sent a TPDO1, ``fresh``: sent one this cycle).

        Every cycle, 21 drives: few NumPy calls (each costs microseconds whatever its size),
        the flags tested as bytes; compiled: one call)."""
        if self.compiled:
            self._update_compiled(raw, raw_velocity, fresh, seen)
            return
        pos, prev, vel = self.pos, self._prev, self.vel
        prev[:] = pos
        si = np.subtract(raw, self.scale.offset, out=self._si)  # [counts] as float, exact
        np.divide(si, self.scale.factor, out=si)
        wheel_raw, wheel_seen, factor = self._wheel_raw, self._wheel_seen, self.scale.factor
        for k, i in enumerate(self.wheel_idx):
            # Wheels turn without bound: integrate wrapped count differences.
            if wheel_seen[k]:
                step = delta_i32(int(raw[i]), wheel_raw[k])
                si[i] = prev[i] + step / factor[i]
            if seen[i]:
                wheel_raw[k] = int(raw[i])
                wheel_seen[k] = True
        if 0 in seen.tobytes():
            np.copyto(pos, si, where=seen)
        else:
            pos[:] = si
        if 0 in fresh.tobytes():  # no new feedback: the last velocity stays
            np.copyto(vel, (pos - prev) / self.dt, where=fresh)
        else:
            np.subtract(pos, prev, out=vel)
            vel /= self.dt
        if self._vel_idx:
            vel[self._vel_idx] = [raw_velocity[i] for i in self._vel_idx] / self._vel_factor
        self.position[self.joint_idx] = pos[self.joint_drive]
        self.velocity[self.joint_idx] = vel[self.joint_drive]
        vehicle = self.vehicle
        if vehicle is not None and self._wheel_seen.all():
            wheels = pos[self.wheel_idx]
            speeds = self.vel[self.wheel_idx] if self._wheel_speeds else None
            if self._vehicle_started:
                vehicle.measure(wheels, speeds, self.dt)
            else:
                vehicle.start(wheels)
                self._vehicle_started = True
                self._vehicle_flags[1] = 1
            self.position[self._vehicle_joints] = vehicle.pose
            self.velocity[self._vehicle_joints] = vehicle.velocity

    def _update_compiled(
        self, raw: np.ndarray, raw_velocity: np.ndarray, fresh: np.ndarray, seen: np.ndarray
    ) -> None:
        """:meth:`update` as one kernel call (:func:`hal.can.kernels.feedback`)."""
        pose, twist, last, inverse = self._odometry
        start = kernels.feedback(
            raw, raw_velocity, fresh, seen, self.scale.offset, self.scale.factor, self.dt,
            self._wheel_idx, self._wheel_raw, self._wheel_seen, self._vel_drives, self.pos,
            self._prev, self.vel, self.joint_idx, self.joint_drive, self.position,
            self.velocity, self._vehicle_flags, pose, twist, last, inverse,
            self._vehicle_joints3,
        )  # fmt: skip
        if start == kernels.START_VEHICLE and self.vehicle is not None:
            self.vehicle.start(self.pos[self.wheel_idx])
            self._vehicle_started = True
            self._vehicle_flags[1] = 1
            self.position[self._vehicle_joints] = self.vehicle.pose
            self.velocity[self._vehicle_joints] = self.vehicle.velocity

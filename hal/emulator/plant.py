"""The robot in MuJoCo as its drives see it: one position and velocity per drive, in counts.

The physics is :class:`hal.mujoco_backend.MujocoBackend` (same model, servos and lockstep
timing as ``--hal sim``), advanced one period per :meth:`Plant.step`. Each drive powers its
joint's servo on its own (:meth:`MujocoBackend.set_servo_mask`); a joint whose drive has no
torque keeps only the damping (the stand-in for the drive's dynamic brake).

Conversion counts <-> SI is :mod:`hal.can.scaling`. Positions on the wire wrap at 32 bits;
the plant unwraps the targets (a wheel may turn for ever) and the drive wraps the actuals.

**Wheels.** When ``drives.yaml`` names wheel drives (``vehicle.wheels``), the MuJoCo model
still moves the base with its virtual x/y/θ joints, as the master's odometry does. The plant
uses the master's own :class:`hal.can.vehicle.VehicleMapping` both ways, so master and
emulator share one set of wheel kinematics:

* wheel targets -> commanded base pose: the odometry rule applied to the wheel *targets*
  (``measure``); the x/y/θ servos track that pose while every wheel drive has torque (the
  base is off as soon as one wheel drive is);
* measured base pose -> actual wheel angles: the command rule applied to the *measured* pose
  (``command``); wheel speeds are ``J · body twist``.

**Compiled** (``compiled``, where numba is): the arithmetic of a step, both vehicle rules
included, is three calls of :mod:`hal.emulator.plant_kernels` on the plant's and the
mappings' own arrays (the mappings' state is the same either way; only a base coming on
starts its odometry in Python), and the servo mask is compared with the last one set
without NumPy; the NumPy path (``IMOTION_JIT=0``) is the reference they are tested against
(``tests/test_emulator_kernels.py``: every step's state to 1e-12, the counts exactly).
"""

from __future__ import annotations

import math

import numpy as np

from controller.model.robot import Robot
from hal.can.drive_profile import DriveProfile
from hal.can.scaling import ScalingArray
from hal.can.vehicle import VehicleMapping
from hal.emulator import plant_kernels as kernels
from hal.interface import HardwareState, JointCommand
from hal.mujoco_backend import MujocoBackend

#: Largest distance a joint servo pulls from [rad] / [m] (see Plant.step).
_PULL_RAD = 0.2
_PULL_M = 0.05
_SPAN = 2**32
_HALF = 2**31


class Plant:
    """Simulated joints of ``robot`` for the drives of ``profile`` (in profile order).

    ``compiled``: :meth:`step`'s arithmetic, the vehicle mapping's included, in compiled
    calls (:mod:`hal.emulator.plant_kernels`), else NumPy.
    """

    def __init__(self, robot: Robot, profile: DriveProfile, period: float, compiled: bool = False):
        self.compiled = compiled
        self.names = tuple(profile.drives)
        wheels = profile.wheels
        self.period = float(period)
        self._joint_idx = np.array(
            [i for i, n in enumerate(self.names) if n not in wheels], dtype=np.intp
        )
        self._wheel_idx = np.array([self.names.index(n) for n in wheels], dtype=np.intp)
        joints = tuple(self.names[i] for i in self._joint_idx)
        vehicle: tuple[str, ...] = ()
        self._mapping_cmd: VehicleMapping | None = None
        self._mapping_act: VehicleMapping | None = None
        cmd = act = VehicleMapping.empty()  # the compiled kernels' arrays without a base
        if wheels:
            if robot.profile.vehicle is None:
                raise ValueError(f"{robot.id}: drives.yaml names wheels but there is no vehicle")
            vehicle = robot.unit_joints("VEHICLE")
            if len(vehicle) != 3:
                raise ValueError(f"{robot.id}: the VEHICLE unit needs x, y and θ joints")
            self._mapping_cmd = cmd = VehicleMapping(robot.profile.vehicle.wheels)
            self._mapping_act = act = VehicleMapping(robot.profile.vehicle.wheels)
        # The mappings' own arrays, which the compiled kernels update in place.
        self._odometry = (cmd.measured_wheels, np.ascontiguousarray(cmd.inverse), cmd.pose,
                          cmd.velocity)  # fmt: skip
        self._wheel_rule = (np.ascontiguousarray(act.matrix), act.command_pose, act.wheel_targets)
        self.backend = MujocoBackend(robot, self.period, joint_names=joints + vehicle)
        self._nj = len(joints)
        self._pull = np.array(
            [_PULL_RAD if robot.joints[n].kind == "revolute" else _PULL_M for n in joints]
        )
        self._scaling = ScalingArray([profile.drives[n].scaling() for n in self.names])
        n = len(self.names)
        self._target = np.zeros(n, dtype=np.int64)  # unwrapped targets [counts]
        self._last_raw = np.zeros(n, dtype=np.int64)
        self._started = np.zeros(n, dtype=bool)
        self._ref = np.zeros(n)  # servo references [rad]/[m]
        self._ref_prev = np.zeros(n)
        self._torque_prev = np.zeros(n, dtype=bool)
        self._vehicle_on = np.zeros(1, dtype=bool)
        self._mask = np.zeros(self._nj + len(vehicle), dtype=bool)
        self._mask_set = self._mask.copy()  # the backend's servo mask (compiled path)
        self._measured_pose = np.zeros(3)  # the base's, as of the last step [m, m, rad]
        self._position = np.zeros(n)  # measured [rad]/[m] (wheels: wheel angle)
        self._velocity = np.zeros(n)
        self._wheel_angle = np.zeros(len(wheels))
        self._sim_time = 0.0
        self._command = np.empty(self._mask.size)  # servo commands [rad]/[m] (compiled)
        self._command_velocity = np.zeros(self._mask.size)

    # ---------------------------------------------------------------------------- set-up

    def start(self) -> None:
        """Compile the model; every servo off; measured values of the initial pose."""
        backend = self.backend
        backend.configure()
        backend.activate()
        backend.set_servo_mask(self._mask)
        if self.compiled:  # compile (or load) the kernels now, not in the first SYNC round
            self._warm_up()
        self._measure()
        if self._mapping_act is not None:
            self._wheel_angle[:] = self._position[self._wheel_idx]
            self._mapping_act.start(self._wheel_angle, pose=self._pose())

    @property
    def sim_time(self) -> float:
        """Simulated time [s] (the backend's, as of the last step)."""
        return self._sim_time

    @property
    def position(self) -> np.ndarray:
        """Measured positions [rad, m] (wheels: wheel angle), drive order; updated in place."""
        return self._position

    @property
    def velocity(self) -> np.ndarray:
        """Measured velocities [rad/s, m/s], drive order; updated in place."""
        return self._velocity

    @property
    def scaling(self) -> ScalingArray:
        """The drives' scaling (counts <-> SI), drive order."""
        return self._scaling

    def position_counts(self) -> np.ndarray:
        """Measured positions [counts] (int64, not wrapped), drive order."""
        return self._scaling.to_counts(self._position)

    def velocity_counts(self) -> np.ndarray:
        """Measured velocities [counts/s] (int64), drive order."""
        return np.rint(self._velocity * self._scaling.factor).astype(np.int64)

    # ----------------------------------------------------------------------------- cycle

    def step(self, setpoints: np.ndarray, torque: np.ndarray) -> None:
        """One period: servo references from the drives' set-points [counts] (wrapped int32
        values are fine), servos on where ``torque``; then the measured values are updated."""
        raw = np.asarray(setpoints, dtype=np.int64)
        torque = np.asarray(torque, dtype=bool)
        if self.compiled:
            self._step_compiled(raw, torque)
            return
        delta = (raw - self._last_raw + _HALF) % _SPAN - _HALF
        self._target = np.where(self._started, self._target + delta, raw)
        self._started[:] = True
        self._last_raw[:] = raw
        self._scaling.to_si(self._target.astype(float), out=self._ref)
        # Velocity feed-forward: the set-point's own rate, where the drive had torque before.
        both = torque & self._torque_prev
        feed = np.where(both, (self._ref - self._ref_prev) / self.period, 0.0)
        nj = self._nj
        ji = self._joint_idx
        position = np.empty(self._mask.size)
        velocity = np.zeros(self._mask.size)
        measured = self._position[ji]
        # Torque saturation stand-in: the servo never pulls from further than _PULL away, so
        # a wild target (a following error to be) cannot blow the simulation up.
        pulled = measured + np.clip(self._ref[ji] - measured, -self._pull, self._pull)
        position[:nj] = np.where(torque[ji], pulled, measured)
        velocity[:nj] = feed[ji]
        self._mask[:nj] = torque[ji]
        self._ref_prev[:] = self._ref
        self._torque_prev[:] = torque
        self._drive(torque, position, velocity)

    def _step_compiled(self, raw: np.ndarray, torque: np.ndarray) -> None:
        """:meth:`step` with its arithmetic in one compiled call; the servo mask is set only
        when it changes (setting the same one again changes nothing)."""
        position, velocity = self._command, self._command_velocity
        kernels.plant_command(
            raw, torque, self._last_raw, self._target, self._started, self._scaling.offset,
            self._scaling.factor, self._ref, self._ref_prev, self._torque_prev, self.period,
            self._joint_idx, self._pull, self._position, position, velocity, self._mask,
        )  # fmt: skip
        self._drive(torque, position, velocity)

    def _drive(self, torque: np.ndarray, position: np.ndarray, velocity: np.ndarray) -> None:
        """The period's commands to MuJoCo: the vehicle's part, the servo mask (set only when
        it changes: setting the same one again changes nothing), one write, a diverged
        simulation put back at its initial pose; then the measured values."""
        backend = self.backend
        if self.compiled:
            changed = self._vehicle_compiled(torque, position, velocity)
        else:
            if self._mapping_cmd is not None:
                self._vehicle_step(torque, position, velocity)
            changed = not np.array_equal(self._mask, backend.servo_mask)
        if changed:
            backend.set_servo_mask(self._mask)
        backend.write(JointCommand(position=position, velocity=velocity))
        backend.advance()  # the period's physics now (a SYNC's answer needs it), then check
        if backend.state is HardwareState.FAULT:  # diverged: reset to the initial pose
            backend.reset_faults()
            backend.activate()
            backend.set_servo_mask(self._mask)
        self._measure()

    def _vehicle_step(self, torque: np.ndarray, position: np.ndarray, velocity: np.ndarray) -> None:
        cmd = self._mapping_cmd
        assert cmd is not None
        wi, nj = self._wheel_idx, self._nj
        on = bool(torque[wi].all())
        wheel_ref = self._ref[wi]
        if on and not self._vehicle_on[0]:
            cmd.start(wheel_ref, pose=self._pose())
        if on:
            previous = cmd.pose.copy()
            cmd.measure(wheel_ref, None, self.period)
            position[nj:] = cmd.pose
            velocity[nj:] = (cmd.pose - previous) / self.period
        else:
            position[nj:] = self._pose()
        self._mask[nj:] = on
        self._vehicle_on[0] = on

    def _vehicle_compiled(
        self, torque: np.ndarray, position: np.ndarray, velocity: np.ndarray
    ) -> bool:
        """:meth:`_vehicle_step` (an odometry started in Python when the base comes on) and
        whether the servo mask changed, compiled."""
        last, inverse, pose, twist = self._odometry
        args = (torque, self._wheel_idx, self._ref, last, inverse, pose, twist, self.period,
                self._measured_pose, position, velocity, self._mask, self._mask_set,
                self._vehicle_on)  # fmt: skip
        flags = kernels.vehicle_command(*args)
        if flags == kernels.START_VEHICLE:
            assert self._mapping_cmd is not None
            self._mapping_cmd.start(self._ref[self._wheel_idx], pose=self._measured_pose)
            self._vehicle_on[0] = True
            flags = kernels.vehicle_command(*args)
        return bool(flags & kernels.MASK_CHANGED)

    # --------------------------------------------------------------------------- helpers

    def _pose(self) -> np.ndarray:
        state = self.backend.read()
        return np.array(state.position[self._nj :], dtype=float)

    def _measure(self) -> None:
        state = self.backend.read()
        self._sim_time = state.stamp
        if self.compiled:
            matrix, command_pose, wheel_targets = self._wheel_rule
            kernels.plant_measure(
                state.position, state.velocity, self._joint_idx, self._wheel_idx, matrix,
                command_pose, wheel_targets, self._position, self._velocity, self._measured_pose,
            )  # fmt: skip
            return
        nj = self._nj
        self._position[self._joint_idx] = state.position[:nj]
        self._velocity[self._joint_idx] = state.velocity[:nj]
        act = self._mapping_act
        if act is None:
            return
        pose = np.array(state.position[nj:], dtype=float)
        self._wheel_angle[:] = act.command(pose)
        vx, vy, w = state.velocity[nj:]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        body = np.array((c * vx + s * vy, -s * vx + c * vy, w))
        self._position[self._wheel_idx] = self._wheel_angle
        self._velocity[self._wheel_idx] = act.matrix @ body

    def _warm_up(self) -> None:
        """Compile (or load) the kernels on scratch copies of the plant's arrays (the same
        types and layouts as in a step; nothing of the plant changes)."""
        n, m = self._target.size, self._mask.size
        scratch = np.copy
        kernels.plant_command(
            np.zeros(n, dtype=np.int64), np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64),
            np.zeros(n, dtype=np.int64), np.zeros(n, dtype=bool), self._scaling.offset,
            self._scaling.factor, np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool),
            self.period, self._joint_idx, self._pull, np.zeros(n), np.zeros(m), np.zeros(m),
            np.zeros(m, dtype=bool),
        )  # fmt: skip
        last, inverse, pose, twist = (scratch(a) for a in self._odometry)
        kernels.vehicle_command(
            np.zeros(n, dtype=bool), self._wheel_idx, np.zeros(n), last, inverse, pose, twist,
            self.period, np.zeros(3), np.zeros(m), np.zeros(m), np.zeros(m, dtype=bool),
            np.zeros(m, dtype=bool), np.zeros(1, dtype=bool),
        )  # fmt: skip
        state = self.backend.read()
        matrix, command_pose, wheel_targets = (scratch(a) for a in self._wheel_rule)
        kernels.plant_measure(
            scratch(state.position), scratch(state.velocity), self._joint_idx, self._wheel_idx,
            matrix, command_pose, wheel_targets, np.zeros(n), np.zeros(n), np.zeros(3),
        )  # fmt: skip

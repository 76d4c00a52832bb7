"""The emulator plant's arithmetic around each MuJoCo step, compiled (numba).

What :class:`hal.emulator.plant.Plant` does in NumPy each period, as one call per phase on
its preallocated arrays (a dozen NumPy calls of a few microseconds each on 3-21-element
arrays, and the vehicle mapping's small matrix products, otherwise):

* :func:`plant_command`: set-points [counts] -> servo references, velocity feed-forward and
  the joints' commands and servo mask (:meth:`Plant.step` before the vehicle);
* :func:`vehicle_command`: the wheel references -> the commanded base pose by the odometry
  rule of :meth:`hal.can.vehicle.VehicleMapping.measure` (the x/y/θ servos' command), the
  base's servo mask, and whether the mask changed since it was last set;
* :func:`plant_measure`: MuJoCo's measured joints -> the drives' values, the wheels' angles
  and speeds from the measured base pose and twist by the command rule of
  :meth:`VehicleMapping.command`.

The vehicle kernels work on :class:`~hal.can.vehicle.VehicleMapping`'s own arrays, so the
mapping's state is the same either way. Their matrix products are loops: equal to NumPy's
to rounding (``tests/test_emulator_kernels.py`` compares them to 1e-12 and the counts
exactly). Used where :func:`controller.model.jit.available` (not with ``IMOTION_JIT=0``).
"""

from __future__ import annotations

import math

import numpy as np

from controller.model import jit
from hal.can.kernels import odometry_step

_SPAN = 2**32
#: :func:`vehicle_command`'s result bits: every wheel drive has torque and the odometry has
#: not started (the caller starts it and calls again); the servo mask changed.
START_VEHICLE, MASK_CHANGED = 1, 2


@jit.jit
def plant_command(
    raw: np.ndarray,
    torque: np.ndarray,
    last_raw: np.ndarray,
    target: np.ndarray,
    started: np.ndarray,
    offset: np.ndarray,
    factor: np.ndarray,
    ref: np.ndarray,
    ref_prev: np.ndarray,
    torque_prev: np.ndarray,
    period: float,
    joint_idx: np.ndarray,
    pull: np.ndarray,
    measured: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    mask: np.ndarray,
) -> None:
    """:meth:`hal.emulator.plant.Plant.step` before the vehicle and MuJoCo: set-points
    ``raw`` [counts] (wrapped or not) unwrapped into ``target``, servo references ``ref``
    [rad, m] (``ref_prev`` := them after use), the velocity feed-forward where the drive had
    ``torque`` before too (``torque_prev`` := ``torque``), and per joint ``joint_idx[k]``
    the command ``position[k]`` (pulled from at most ``pull[k]`` away from ``measured``),
    ``velocity[k]`` and servo ``mask[k]``; ``velocity`` beyond the joints := 0."""
    n = raw.shape[0]
    half = 2**31
    for i in range(n):
        delta = (raw[i] - last_raw[i] + half) % _SPAN - half
        target[i] = target[i] + delta if started[i] else raw[i]
        started[i] = True
        last_raw[i] = raw[i]
    for k in range(velocity.shape[0]):
        velocity[k] = 0.0
    for k in range(joint_idx.shape[0]):
        i = joint_idx[k]
        value = (float(target[i]) - offset[i]) / factor[i]
        feed = (value - ref_prev[i]) / period if torque[i] and torque_prev[i] else 0.0
        here = measured[i]
        if torque[i]:
            position[k] = here + min(max(value - here, -pull[k]), pull[k])
        else:
            position[k] = here
        velocity[k] = feed
        mask[k] = torque[i]
    for i in range(n):
        ref[i] = (float(target[i]) - offset[i]) / factor[i]
        ref_prev[i] = ref[i]
        torque_prev[i] = torque[i]


@jit.jit
def vehicle_command(
    torque: np.ndarray,
    wheel_idx: np.ndarray,
    ref: np.ndarray,
    last: np.ndarray,
    inverse: np.ndarray,
    pose: np.ndarray,
    twist: np.ndarray,
    period: float,
    measured_pose: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    mask: np.ndarray,
    mask_set: np.ndarray,
    vehicle_on: np.ndarray,
) -> int:
    """The base's part of a period's command, as :meth:`Plant._vehicle_step`: while every
    wheel drive (``wheel_idx``) has ``torque``, the odometry of the wheel references ``ref``
    [rad] (:meth:`VehicleMapping.measure` on its ``last`` wheel angles, ``inverse``,
    ``pose``, ``twist``, over ``period`` [s]) is the x/y/θ command (``position``,
    ``velocity`` after the joints'), else the ``measured_pose`` held; the base's servo
    ``mask`` entries; ``vehicle_on[0]`` := whether it is on. Returns
    :data:`START_VEHICLE` (nothing done) when the base comes on with its odometry not
    started, else :data:`MASK_CHANGED` when ``mask`` differs from ``mask_set`` (then
    copied there: the caller sets the backend's mask), else 0. Without wheels only the
    mask is compared."""
    w = wheel_idx.shape[0]
    base = mask.shape[0] - 3
    if w:
        on = True
        for k in range(w):
            on = on and torque[wheel_idx[k]]
        if on and not vehicle_on[0]:
            return START_VEHICLE
        if on:
            p0, p1, p2 = pose[0], pose[1], pose[2]
            d0, d1, d2 = odometry_step(ref, wheel_idx, last, inverse, pose)
            t0, t1, t2 = d0 / period, d1 / period, d2 / period
            c, s = math.cos(pose[2]), math.sin(pose[2])
            twist[0] = c * t0 - s * t1
            twist[1] = s * t0 + c * t1
            twist[2] = t2
            position[base], position[base + 1], position[base + 2] = pose[0], pose[1], pose[2]
            velocity[base] = (pose[0] - p0) / period
            velocity[base + 1] = (pose[1] - p1) / period
            velocity[base + 2] = (pose[2] - p2) / period
        else:
            for k in range(3):
                position[base + k] = measured_pose[k]
        for k in range(3):
            mask[base + k] = on
        vehicle_on[0] = on
    changed = False
    for k in range(mask.shape[0]):
        if mask[k] != mask_set[k]:
            changed = True
            mask_set[k] = mask[k]
    return MASK_CHANGED if changed else 0


@jit.jit
def plant_measure(
    measured: np.ndarray,
    measured_velocity: np.ndarray,
    joint_idx: np.ndarray,
    wheel_idx: np.ndarray,
    matrix: np.ndarray,
    command_pose: np.ndarray,
    wheel_targets: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    measured_pose: np.ndarray,
) -> None:
    """MuJoCo's ``measured`` positions [rad, m] and ``measured_velocity`` (joints, then x,
    y, θ of a base) -> the drives' ``position`` and ``velocity``: joint ``k`` is drive
    ``joint_idx[k]``; with wheels (``wheel_idx``), the base pose (:meth:`VehicleMapping.command`
    on the mapping's ``matrix``, ``command_pose`` and ``wheel_targets``, updated) gives the
    wheel angles, the body twist times ``matrix`` their speeds; ``measured_pose`` := the
    base pose."""
    nj = joint_idx.shape[0]
    for k in range(nj):
        position[joint_idx[k]] = measured[k]
        velocity[joint_idx[k]] = measured_velocity[k]
    w = wheel_idx.shape[0]
    if not w:
        return
    p0, p1, p2 = measured[nj], measured[nj + 1], measured[nj + 2]
    measured_pose[0], measured_pose[1], measured_pose[2] = p0, p1, p2
    d0, d1, d2 = p0 - command_pose[0], p1 - command_pose[1], p2 - command_pose[2]
    heading = command_pose[2] + 0.5 * d2
    c, s = math.cos(heading), math.sin(heading)
    b0, b1 = c * d0 + s * d1, -s * d0 + c * d1
    for k in range(w):
        wheel_targets[k] += matrix[k, 0] * b0 + matrix[k, 1] * b1 + matrix[k, 2] * d2
    command_pose[0], command_pose[1], command_pose[2] = p0, p1, p2
    vx, vy, omega = measured_velocity[nj], measured_velocity[nj + 1], measured_velocity[nj + 2]
    c, s = math.cos(p2), math.sin(p2)
    b0, b1 = c * vx + s * vy, -s * vx + c * vy
    for k in range(w):
        position[wheel_idx[k]] = wheel_targets[k]
        velocity[wheel_idx[k]] = matrix[k, 0] * b0 + matrix[k, 1] * b1 + matrix[k, 2] * omega

"""The virtual vehicle joints (x, y, θ) on real wheel drives: wheel kinematics and odometry.

The kinematic model moves the base with three virtual joints: x, y [m] and θ [rad], the planar
pose of the body in the original frame. The drives are wheels. Body twist ``(vx, vy, ω)``
(body frame, [m/s], [rad/s]) maps to wheel speeds [rad/s] by a constant matrix ``J``
(``wheel = J · twist``), from ``profile.yaml`` ``vehicle.wheels`` (radius ``r``):

* **omni** (``count`` wheels on a circle of diameter ``track``, L = track/2): wheel ``i`` at
  angle ``αᵢ = 2π i / count`` from the front (+x), counter-clockwise, rolling tangentially:
  ``r·wᵢ = −sin αᵢ·vx + cos αᵢ·vy + L·ω``.
* **mecanum** (4 wheels: front-left, front-right, rear-left, rear-right; ``lx`` = wheelbase/2,
  ``ly`` = track/2, rollers at 45° in the usual X pattern):
  ``r·w = (vx − vy − (lx+ly)ω, vx + vy + (lx+ly)ω, vx + vy − (lx+ly)ω, vx − vy + (lx+ly)ω)``.
* **differential** (left, right; ``b`` = track/2): ``r·w = (vx − b·ω, vx + b·ω)``; no vy.

Positive wheel speed = the wheel rolls the robot forward along its rolling direction; a
motor mounted mirrored takes ``sign: -1`` in drives.yaml.

Commands: each cycle the change of the commanded pose is turned into the body frame (at the
mid-point heading) and into wheel angle increments ``Δw = J·Δbody``, added to the wheel
targets. Odometry is the inverse: ``Δbody = J⁺·Δw`` (least squares; for a differential base it
drops the sideways part), turned into the original frame at the mid-point heading and summed.
Both use the same mid-point rule, so wheels that follow their targets exactly reproduce the
commanded pose. Sideways commands to a differential base cannot be followed: the odometry
shows what the wheels did.
"""

from __future__ import annotations

import math

import numpy as np

from controller.model.profile import Wheels


def wheel_matrix(wheels: Wheels) -> np.ndarray:
    """``J`` [rad/m, rad/m, rad]: wheel speeds [rad/s] = J · (vx, vy, ω) (see the module doc)."""
    r = wheels.radius
    if wheels.kind == "omni":
        half = wheels.track / 2.0
        rows = []
        for i in range(wheels.count):
            a = 2.0 * math.pi * i / wheels.count
            rows.append((-math.sin(a), math.cos(a), half))
        return np.array(rows) / r
    if wheels.kind == "mecanum":
        if wheels.count != 4 or wheels.wheelbase is None:
            raise ValueError("a mecanum base needs 4 wheels and a wheelbase")
        k = wheels.wheelbase / 2.0 + wheels.track / 2.0
        return np.array([(1, -1, -k), (1, 1, k), (1, 1, -k), (1, -1, k)], dtype=float) / r
    if wheels.count != 2:
        raise ValueError("a differential base needs 2 wheels")
    b = wheels.track / 2.0
    return np.array([(1.0, 0.0, -b), (1.0, 0.0, b)]) / r


class VehicleMapping:
    """Wheel targets from the commanded pose; pose (odometry) from the measured wheels."""

    def __init__(self, wheels: Wheels):
        self.matrix = wheel_matrix(wheels)
        self.inverse = np.linalg.pinv(self.matrix)
        n = self.matrix.shape[0]
        #: Odometry: the measured pose (x [m], y [m], θ [rad]) and twist in the original frame.
        self.pose = np.zeros(3)
        self.velocity = np.zeros(3)
        self._wheels = np.zeros(n)  # last measured wheel angles [rad]
        #: The commanded pose and the wheel targets [rad] it corresponds to.
        self.command_pose = np.zeros(3)
        self.wheel_targets = np.zeros(n)

    @classmethod
    def empty(cls) -> VehicleMapping:
        """A mapping of no wheels: its arrays stand in where a robot has no base (the CAN
        master's compiled kernels take them either way)."""
        self = cls.__new__(cls)
        self.matrix = np.zeros((0, 3))
        self.inverse = np.zeros((3, 0))
        self.pose, self.velocity, self.command_pose = np.zeros(3), np.zeros(3), np.zeros(3)
        self._wheels, self.wheel_targets = np.zeros(0), np.zeros(0)
        return self

    @property
    def measured_wheels(self) -> np.ndarray:
        """The last measured wheel angles [rad] (the array itself, which compiled callers
        update in place as :meth:`measure` does)."""
        return self._wheels

    def start(self, wheels: np.ndarray, pose: np.ndarray | None = None) -> None:
        """Start odometry at ``pose`` (default: the origin) with wheels at ``wheels`` [rad]."""
        if pose is not None:
            self.pose[:] = pose
        self._wheels[:] = wheels
        self.velocity[:] = 0.0
        self.hold()

    def hold(self) -> None:
        """Command = measured: the wheel targets are the measured wheel angles."""
        self.command_pose[:] = self.pose
        self.wheel_targets[:] = self._wheels

    def measure(self, wheels: np.ndarray, wheel_speeds: np.ndarray | None, dt: float) -> None:
        """Integrate odometry from wheel angles [rad] (and speeds [rad/s], else differenced)."""
        delta = self.inverse @ (wheels - self._wheels)
        self._wheels[:] = wheels
        self.pose += _to_world(delta, self.pose[2] + 0.5 * delta[2])
        twist = self.inverse @ wheel_speeds if wheel_speeds is not None else delta / dt
        self.velocity[:] = _to_world(twist, self.pose[2])

    def command(self, pose: np.ndarray) -> np.ndarray:
        """Wheel targets [rad] for the commanded pose (x, y, θ) [m, m, rad]."""
        delta = pose - self.command_pose
        heading = self.command_pose[2] + 0.5 * delta[2]
        c, s = math.cos(heading), math.sin(heading)
        body = np.array((c * delta[0] + s * delta[1], -s * delta[0] + c * delta[1], delta[2]))
        self.wheel_targets += self.matrix @ body
        self.command_pose[:] = pose
        return self.wheel_targets


def _to_world(body: np.ndarray, heading: float) -> np.ndarray:
    c, s = math.cos(heading), math.sin(heading)
    return np.array((c * body[0] - s * body[1], s * body[0] + c * body[1], body[2]))

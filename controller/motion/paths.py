"""Geometric paths parameterised by s ∈ [0, 1], with their derivative d/ds.

* :class:`VectorPath`: a straight line between two vectors (joint PTP, unit moves, redundant
  axes of CP-hold moves, vehicle x/y/θ).
* :class:`LinePath`: a straight Cartesian line; position linear, orientation along the
  geodesic (constant angular velocity axis), both proportional to s so translation and
  rotation start and stop together.
* :class:`ArcPath`: a circular arc through a via point; orientation along the geodesic from
  start to end (the via pose's orientation is not used: switching geodesics there would
  make the angular velocity jump, which no acceleration limit allows).

``limits(...)`` turns axis speed/acceleration limits into limits on ṡ and s̈ (Euclidean for
translation and rotation, per axis for vectors).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from controller.model import jit

#: Extents below this count as "no motion" on that component.
TINY = 1e-12


def unit_clamp(s: float) -> float:
    """``s`` clamped to [0, 1]."""
    return 0.0 if s < 0.0 else 1.0 if s > 1.0 else s


def _ratio(limit: float, extent: float) -> float:
    return math.inf if extent < TINY else limit / extent


class VectorPath:
    """``x(s) = x0 + s·(x1 − x0)``."""

    def __init__(self, start: np.ndarray, end: np.ndarray):
        self.start = np.asarray(start, dtype=float)
        self.end = np.asarray(end, dtype=float)
        self.delta = self.end - self.start
        #: ``start`` and ``delta`` as floats, for paths of a few axes followed every cycle
        #: (:func:`controller.motion.motions.follow_vector`: no array per cycle).
        self.start_floats: list[float] = self.start.tolist()
        self.delta_floats: list[float] = self.delta.tolist()

    def at(self, s: float) -> np.ndarray:
        return self.start + unit_clamp(s) * self.delta

    def rate(self, s: float, sd: float) -> np.ndarray:
        """d/dt x for ṡ = ``sd``."""
        return self.delta * sd

    def limits(self, speed: np.ndarray, accel: np.ndarray) -> tuple[float, float]:
        """(ṡ_max, s̈_max) from per-axis speed and acceleration limits."""
        extent = np.abs(self.delta)
        v = min((_ratio(float(a), float(e)) for a, e in zip(speed, extent, strict=True)))
        a = min((_ratio(float(b), float(e)) for b, e in zip(accel, extent, strict=True)))
        return v, a

    @property
    def is_empty(self) -> bool:
        return bool(np.abs(self.delta).max(initial=0.0) < TINY)


class LinePath:
    """Straight line from pose ``start`` to pose ``end`` (same frame, SI)."""

    def __init__(self, start: pin.SE3, end: pin.SE3):
        self.start = start.copy()
        self.end = end.copy()
        self.dp = end.translation - start.translation
        self.omega = pin.log3(start.rotation.T @ end.rotation)  # in the start frame
        self.omega_world = start.rotation @ self.omega
        # The start as arrays (reading them from the SE3 converts every time).
        self._r0, self._p0 = start.rotation.copy(), start.translation.copy()
        #: Twist for ṡ = 1 [m, rad per unit of s]: linear then angular, world axes.
        self._twist_per_s = np.concatenate([self.dp, self.omega_world])
        #: :meth:`at` compiled (every cycle of a Cartesian move), into these buffers.
        self._compiled = jit.available()
        self._rotation = np.zeros((3, 3))
        self._position = np.zeros(3)

    @property
    def length(self) -> float:
        """Translation [m]."""
        return float(np.linalg.norm(self.dp))

    @property
    def angle(self) -> float:
        """Rotation [rad]."""
        return float(np.linalg.norm(self.omega))

    def at(self, s: float) -> pin.SE3:
        s = unit_clamp(s)
        if self._compiled:
            _line_pose(self._r0, self._p0, self.omega, self.dp, s, self._rotation, self._position)
            return pin.SE3(self._rotation, self._position)
        return pin.SE3(self._r0 @ pin.exp3(s * self.omega), self._p0 + s * self.dp)

    def rotation_at(self, s: float) -> np.ndarray:
        """The orientation at ``s`` (a 3x3 matrix)."""
        return self._r0 @ pin.exp3(unit_clamp(s) * self.omega)

    def twist(self, s: float, sd: float) -> np.ndarray:
        """Linear [m/s] and angular [rad/s] velocity (frame axes) for ṡ = ``sd``."""
        return self._twist_per_s * sd

    def average_twist(self, s0: float, s1: float, dt: float) -> np.ndarray:
        """The constant twist taking the pose at ``s0`` to the pose at ``s1`` in ``dt`` [s]
        (linear [m/s], angular [rad/s], world axes), in closed form: both components are
        proportional to s on a line, so it is the twist at the mean rate, with no log3 of
        the relative rotation (equal to it while the step turns less than π)."""
        return self._twist_per_s * ((unit_clamp(s1) - unit_clamp(s0)) / dt)

    def follow(
        self, s0: float, s1: float, dt: float, rotation: np.ndarray, position: np.ndarray,
        twist: np.ndarray,
    ) -> None:  # fmt: skip
        """A control point's target on the line, in place: the pose at ``s0`` into
        ``rotation`` (3x3) and ``position`` [m], the average twist toward ``s1`` in ``dt`` [s]
        into ``twist`` [m/s, rad/s] (what :meth:`at` and :meth:`average_twist` give, with no
        pose or array built: every cycle of a Cartesian move)."""
        s0, s1 = unit_clamp(s0), unit_clamp(s1)
        if self._compiled:
            _line_follow(
                self._r0, self._p0, self.omega, self.dp, self._twist_per_s, s0, s1, dt,
                rotation, position, twist,
            )  # fmt: skip
            return
        rotation[...] = self.rotation_at(s0)
        np.add(self._p0, s0 * self.dp, out=position)
        twist[...] = self.average_twist(s0, s1, dt)

    def limits(self, speed: tuple[float, float], accel: tuple[float, float]) -> tuple[float, float]:
        """(ṡ_max, s̈_max) from (translation, rotation) speed and acceleration limits."""
        v = min(_ratio(speed[0], self.length), _ratio(speed[1], self.angle))
        a = min(_ratio(accel[0], self.length), _ratio(accel[1], self.angle))
        return v, a

    def samples(self, step: float = 0.01, angle_step: float = math.radians(2)) -> list[float]:
        """Values of s at most ``step`` [m] / ``angle_step`` [rad] apart (ends included)."""
        n = max(2, math.ceil(max(self.length / step, self.angle / angle_step)) + 1)
        return [i / (n - 1) for i in range(n)]


@jit.jit
def _line_pose(
    r0: np.ndarray,
    p0: np.ndarray,
    omega: np.ndarray,
    dp: np.ndarray,
    s: float,
    rotation: np.ndarray,
    position: np.ndarray,
) -> None:
    """:meth:`LinePath.at` compiled: ``rotation`` := r0 · exp3(s·omega) (Rodrigues),
    ``position`` := p0 + s·dp."""
    wx, wy, wz = s * omega[0], s * omega[1], s * omega[2]
    theta2 = wx * wx + wy * wy + wz * wz
    theta = math.sqrt(theta2)
    if theta < 1e-4:  # sin θ/θ and (1 − cos θ)/θ² by their series
        a = 1.0 - theta2 / 6.0
        b = 0.5 - theta2 / 24.0
    else:
        a = math.sin(theta) / theta
        b = (1.0 - math.cos(theta)) / theta2
    e = np.empty((3, 3))
    e[0, 0] = 1.0 - b * (wy * wy + wz * wz)
    e[1, 1] = 1.0 - b * (wx * wx + wz * wz)
    e[2, 2] = 1.0 - b * (wx * wx + wy * wy)
    e[0, 1] = b * wx * wy - a * wz
    e[1, 0] = b * wx * wy + a * wz
    e[0, 2] = b * wx * wz + a * wy
    e[2, 0] = b * wx * wz - a * wy
    e[1, 2] = b * wy * wz - a * wx
    e[2, 1] = b * wy * wz + a * wx
    for i in range(3):
        for j in range(3):
            rotation[i, j] = r0[i, 0] * e[0, j] + r0[i, 1] * e[1, j] + r0[i, 2] * e[2, j]
        position[i] = p0[i] + s * dp[i]


@jit.jit
def _line_follow(
    r0: np.ndarray,
    p0: np.ndarray,
    omega: np.ndarray,
    dp: np.ndarray,
    twist_per_s: np.ndarray,
    s0: float,
    s1: float,
    dt: float,
    rotation: np.ndarray,
    position: np.ndarray,
    twist: np.ndarray,
) -> None:
    """:meth:`LinePath.follow` compiled (``s0``, ``s1`` already in [0, 1])."""
    _line_pose(r0, p0, omega, dp, s0, rotation, position)
    rate = (s1 - s0) / dt
    for i in range(6):
        twist[i] = twist_per_s[i] * rate


class ArcPath:
    """Circular arc from ``start`` through the position of ``via`` to ``end``.

    Position: the circle through the three points, at constant speed in s. Orientation: the
    geodesic from the start to the end orientation, proportional to s, so translation and
    rotation start and stop together. The three positions must not be collinear.
    """

    def __init__(self, start: pin.SE3, via: pin.SE3, end: pin.SE3):
        p0, p1, p2 = start.translation, via.translation, end.translation
        a, b = p1 - p0, p2 - p0
        normal = np.cross(a, b)
        nn = float(np.linalg.norm(normal))
        if nn < 1e-9 * max(1.0, float(np.linalg.norm(a) * np.linalg.norm(b))):
            raise ValueError("start, via and end points are collinear: no unique arc")
        # Circumcentre of the triangle p0, p1, p2.
        centre = p0 + (np.dot(a, a) * np.cross(b, normal) + np.dot(b, b) * np.cross(normal, a)) / (
            2.0 * nn * nn
        )
        self.centre = centre
        self.normal = normal / nn
        self.radius = float(np.linalg.norm(p0 - centre))
        self._e1 = (p0 - centre) / self.radius
        self._e2 = np.cross(self.normal, self._e1)
        self.sweep = self._angle_of(p2)
        self.s_via = self._angle_of(p1) / self.sweep
        self._rotation = LinePath(start, end)
        self.start, self.end = start.copy(), end.copy()

    def _angle_of(self, p: np.ndarray) -> float:
        d = p - self.centre
        ang = math.atan2(float(d @ self._e2), float(d @ self._e1))
        return ang if ang > 0 else ang + 2 * math.pi

    @property
    def length(self) -> float:
        return self.radius * self.sweep

    @property
    def angle(self) -> float:
        return self._rotation.angle

    def at(self, s: float) -> pin.SE3:
        s = unit_clamp(s)
        return pin.SE3(self._rotation.rotation_at(s), self._position(s))

    def average_twist(self, s0: float, s1: float, dt: float) -> np.ndarray:
        """The constant twist taking the pose at ``s0`` to the pose at ``s1`` in ``dt`` [s]:
        the chord over ``dt`` for the position, the rotation's closed form (as on a line)."""
        out = self._rotation.average_twist(s0, s1, dt)
        out[:3] = (self._position(s1) - self._position(s0)) / dt
        return out

    def follow(
        self, s0: float, s1: float, dt: float, rotation: np.ndarray, position: np.ndarray,
        twist: np.ndarray,
    ) -> None:  # fmt: skip
        """As :meth:`LinePath.follow`: the pose at ``s0`` and the average twist toward
        ``s1`` in ``dt`` [s], into the given buffers."""
        pose = self.at(s0)
        rotation[...] = pose.rotation
        position[...] = pose.translation
        twist[...] = self.average_twist(s0, s1, dt)

    def _position(self, s: float) -> np.ndarray:
        phi = unit_clamp(s) * self.sweep
        return self.centre + self.radius * (math.cos(phi) * self._e1 + math.sin(phi) * self._e2)

    def twist(self, s: float, sd: float) -> np.ndarray:
        phi = unit_clamp(s) * self.sweep
        out = np.empty(6)
        tangent = -math.sin(phi) * self._e1 + math.cos(phi) * self._e2
        out[:3] = self.radius * self.sweep * sd * tangent
        out[3:] = self._rotation.omega_world * sd
        return out

    def limits(self, speed: tuple[float, float], accel: tuple[float, float]) -> tuple[float, float]:
        """(ṡ_max, s̈_max); the centripetal acceleration v²/r is kept within the translation
        acceleration limit too."""
        v = min(_ratio(speed[0], self.length), _ratio(speed[1], self.angle))
        # Centripetal: (ṡ·L)²/r ≤ a_t  ->  ṡ ≤ √(a_t·r)/L.
        v = min(v, _ratio(math.sqrt(accel[0] * self.radius), self.length))
        a = min(_ratio(accel[0], self.length), _ratio(accel[1], self.angle))
        return v, a

    def samples(self, step: float = 0.01, angle_step: float = math.radians(2)) -> list[float]:
        n = max(3, math.ceil(max(self.length / step, self.angle / angle_step)) + 1)
        return [i / (n - 1) for i in range(n)]


if jit.available():  # compile (or load) at import, never in a control cycle: for the arrays
    # the cycles pass (numba compiles again for another layout, a second or more of CPU)
    _line_pose(np.eye(3), np.zeros(3), np.zeros(3), np.zeros(3), 0.5, np.zeros((3, 3)), np.zeros(3))
    _target = pin.SE3.Identity()  # a task's target: Pinocchio's column-major rotation
    _line_follow(
        np.eye(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(6), 0.5, 0.5, 1.0,
        _target.rotation, _target.translation, np.zeros(6),
    )  # fmt: skip
    del _target

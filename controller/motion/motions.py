"""Motions: a path, its time law and the IK tasks that follow it.

A motion says, when it starts, which joints the IK may move (``frozen``), which redundant
axes Cartesian tracking may use (``allowed``) and within which ranges, and which tasks to
solve; every cycle :meth:`Motion.advance` steps the time law and moves the task targets.
All values are SI and poses are in the original frame.

Discrete-time tracking: each cycle the tasks get the path point *for the current
measurement* (s_k) as target and the *average* velocity to the next point,
(x(s_{k+1}) − x(s_k))/dt, as feed-forward. With perfect drives the error then decays as
(1 − gain·dt)^k with no steady lag; an instantaneous rate, or the next point as target,
would leave a lag proportional to the speed or the acceleration.

===================  =====================================================================
motion               use
===================  =====================================================================
JointMotion          joint-space PTP of some joints (unit moves, PTP to an IK solution)
CartesianMotion      control point along a line or arc; other arm held or frozen
DualCartesianMotion  both control points along lines, starting and stopping together
CPHoldMotion         redundant axes move, control point(s) held in the original frame
VehicleMotion        vehicle unit move (omnidirectional: straight; differential: turn,
                     drive, turn)
===================  =====================================================================
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass, field

import numpy as np

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, available_axes, axis_value, elbow_axis
from controller.motion.paths import ArcPath, LinePath, VectorPath, unit_clamp
from controller.motion.posture import PosturePath
from controller.motion.profile import PathProfile, ProfileState
from controller.qp.tasks import AxisTask, ControlPointTask, PostureTask, Task
from controller.vocabulary import RightLeft, UnitType

Range = tuple[float, float]


@dataclass
class IKSetup:
    """What a motion asks of the IK while it runs."""

    tasks: list[Task]
    #: Joints the IK must not move (True = frozen), indexed like ``q``.
    frozen: np.ndarray
    #: Redundant axes Cartesian tracking may use (False: held at their start value).
    allowed: dict[RedundantAxis, bool] = field(default_factory=dict)
    #: RedundantLimit ranges (SI); missing = unlimited.
    ranges: dict[RedundantAxis, Range | None] = field(default_factory=dict)


def other_side(side: RightLeft) -> RightLeft:
    return RightLeft.LEFT if side == RightLeft.RIGHT else RightLeft.RIGHT


def arm_joints(kin: Kinematics, side: RightLeft) -> np.ndarray:
    return kin.unit_indices(UnitType[f"{side.name}_ARM"])


class Motion(abc.ABC):
    """A motion in progress."""

    profile: PathProfile
    kin: Kinematics
    #: What :meth:`prepare` made (None: not yet).
    _ik_setup: IKSetup | None = None
    #: The regularisation task :meth:`setup` puts at the posture of the moment (None: the
    #: motion keeps its own, or has none).
    _start_posture: PostureTask | None = None

    def _make_setup(self) -> IKSetup:
        """The motion's :class:`IKSetup`, made once (see :meth:`prepare`)."""
        raise NotImplementedError

    def prepare(self) -> None:
        """Make the part of :meth:`setup` that does not depend on the state at the start
        (frozen joints, axes, ranges, the tasks): in the planning step, before the motion
        reaches the control loop (:meth:`setup` does it when it was not done)."""
        if self._ik_setup is None:
            setup = self._make_setup()
            setup.frozen.flags.writeable = False  # shared by every setup() call
            self._ik_setup = setup

    def setup(self) -> IKSetup:
        """Tasks and constraints when the motion starts (and when it resumes from a
        pause): what :meth:`prepare` made, the regularisation posture set to the state of
        the moment (the measured one, at a start)."""
        self.prepare()
        assert self._ik_setup is not None
        posture = self._start_posture
        if posture is not None:
            posture.reference[...] = self.kin.q
            posture.rate[...] = 0.0
        return self._ik_setup

    @abc.abstractmethod
    def apply(self, s0: float, s1: float, dt: float) -> None:
        """Targets at path parameter ``s0`` (now), feed-forward toward ``s1`` (in ``dt``)."""

    def advance(self, dt: float | None = None) -> None:
        """One cycle of ``dt`` [s] (default: the nominal period): step the time law, move
        the targets."""
        s0 = self.profile.s
        self.profile.step(dt)
        self.apply(s0, self.profile.s, self.profile.dt)

    @property
    def finished(self) -> bool:
        return self.profile.finished

    @property
    def paused(self) -> bool:
        return self.profile.state == ProfileState.PAUSED

    def respect_limits(  # noqa: B027 (an optional hook: most motions need nothing)
        self, q_min: np.ndarray, q_max: np.ndarray, a_brake: np.ndarray
    ) -> None:
        """Fit the time law to the joint box the IK will enforce (position limits ``q_min``,
        ``q_max`` [rad, m], planned braking deceleration ``a_brake`` [rad/s², m/s²], all
        indexed like ``q``). Called once, before the motion starts; default: nothing to do."""

    def stop(self) -> None:
        self.profile.stop()

    def pause(self) -> None:
        self.profile.pause()

    def resume(self) -> None:
        self.profile.resume()


def follow_vector(tasks: list[AxisTask], path: VectorPath, s0: float, s1: float, dt: float):
    """Axis tasks on ``path``: target at ``s0``, average rate toward ``s1`` (the arithmetic
    of :meth:`VectorPath.at`, on floats)."""
    a, b = unit_clamp(s0), unit_clamp(s1)
    for task, x0, d in zip(tasks, path.start_floats, path.delta_floats, strict=True):
        now = x0 + a * d
        task.set_target(now, (x0 + b * d - now) / dt)


def follow_posture(task: PostureTask, path: PosturePath, s0: float, s1: float, dt: float):
    """The regularisation ``task`` on the checked joint ``path``: reference at ``s0``,
    average rate toward ``s1``. While the path parameter stands still (the time law has
    ended, or stopped on the path) the reference is left alone (the core holds the posture
    the robot has then, see :func:`controller.motion.arrival.hold_posture`) and the rate is
    zero."""
    if s1 <= s0:
        task.rate[...] = 0.0
        return
    path.follow(s0, s1, dt, task.joints, task.reference, task.rate)


def _posture(kin: Kinematics) -> PostureTask:
    """Regularisation toward the posture at the start of the motion (:meth:`Motion.setup`
    moves it to the posture of the start)."""
    return PostureTask(kin.q.copy(), np.arange(kin.nv))


class JointMotion(Motion):
    """Joint-space straight line for ``joints`` (indices in q) to ``target`` (same order).

    ``speed``/``accel`` per joint [rad/s, m/s, …]; ``duration`` [s] forces the time (Spec A
    ``time``). ``hold`` arms keep their control points fixed: their joints follow the hold
    task alone (given among ``joints`` or not, they get no joint-space target: a straight
    joint-space line of the held arm would not keep its hand in place while the body moves).
    """

    def __init__(
        self,
        kin: Kinematics,
        dt: float,
        joints: np.ndarray,
        target: np.ndarray,
        speed: np.ndarray,
        accel: np.ndarray,
        duration: float | None = None,
        hold: tuple[RightLeft, ...] = (),
    ):
        self.kin = kin
        self.dt = dt
        self.duration = duration
        joints = np.asarray(joints, dtype=int)
        target = np.asarray(target, dtype=float)
        speed, accel = np.asarray(speed, dtype=float), np.asarray(accel, dtype=float)
        if hold:
            held = np.concatenate([arm_joints(kin, side) for side in hold])
            keep = ~np.isin(joints, held)
            joints, target, speed, accel = joints[keep], target[keep], speed[keep], accel[keep]
        self.joints = joints
        self.path = VectorPath(kin.q[self.joints], target)
        v, a = self.path.limits(speed, accel)
        if self.path.is_empty:
            v, a = 1.0, 1.0
        #: Limits of the path parameter [1/s, 1/s²].
        self.profile_limits = (v, a)
        self.profile = PathProfile(dt, v, a, duration)
        self.track = PostureTask(kin.q.copy(), self.joints, gain=20.0, weight=1.0, level=1)
        self.hold = [ControlPointTask(side, kin.pose(side)) for side in hold]

    def respect_limits(self, q_min: np.ndarray, q_max: np.ndarray, a_brake: np.ndarray) -> None:
        """Lower the path acceleration where a joint's target lies closer to its limit than
        its braking distance (see :func:`braking_safe_accel`): the IK brakes such a joint at
        ``a_brake`` toward the limit, so a time law planned at the full acceleration would
        leave it behind, and the feedback catching up would carry it past the target."""
        if self.path.is_empty or self.profile.s > 0.0:
            return
        v, a = self.profile_limits
        j = self.joints
        fitted = braking_safe_accel(self.path, v, a, q_min[j], q_max[j], a_brake[j])
        if fitted < a:
            self.profile_limits = (v, fitted)
            self.profile = PathProfile(self.dt, v, fitted, self.duration)

    def _make_setup(self) -> IKSetup:
        frozen = np.ones(self.kin.nv, dtype=bool)
        frozen[self.joints] = False
        for task in self.hold:
            frozen[arm_joints(self.kin, task.side)] = False
        self._start_posture = _posture(self.kin)
        return IKSetup([self.track, *self.hold, self._start_posture], frozen)

    def apply(self, s0: float, s1: float, dt: float) -> None:
        now = self.path.at(s0)
        self.track.reference[self.joints] = now
        self.track.rate = (self.path.at(s1) - now) / dt


#: Share of the planned braking deceleration a joint-space time law may use when it ends
#: within braking distance of a limit (room for the discrete braking bound and the jerk
#: ramps).
BRAKING_FIT = 0.9


def braking_safe_accel(
    path: VectorPath,
    v: float,
    a: float,
    q_min: np.ndarray,
    q_max: np.ndarray,
    a_brake: np.ndarray,
) -> float:
    """Largest path acceleration ≤ ``a`` [1/s²] (path rate ``v`` [1/s]) whose final
    deceleration never asks a joint to be faster than its braking bound toward the limit
    beyond its target: with margin ``m`` from target to limit, peak joint speed ``w`` and
    braking deceleration ``b``, a joint decelerating at ``α`` from ``w`` needs
    ``α·d ≤ b·(d + m)`` for every remaining distance ``d ≤ w²/(2α)``, i.e.
    ``α ≤ w²·b / (w² − 2·b·m)`` when ``w² > 2·b·m`` (no bound otherwise)."""
    delta = path.delta
    for i, d in enumerate(delta):
        extent = abs(float(d))
        if extent < 1e-12:
            continue
        margin = float(q_max[i] - path.end[i]) if d > 0 else float(path.end[i] - q_min[i])
        margin = max(margin, 0.0)
        b = BRAKING_FIT * float(a_brake[i])
        w2 = (v * extent) ** 2
        if w2 > 2.0 * b * margin:
            a = min(a, w2 * b / (w2 - 2.0 * b * margin) / extent)
    return a


class CartesianMotion(Motion):
    """Control point of ``side`` along ``path`` (a LinePath or ArcPath in the original frame).

    ``speed``/``accel``: (translation, rotation) limits [m/s, rad/s] / [m/s², rad/s²].
    ``allowed``: redundant axes tracking may use (others held); ``hold_other``: keep the other
    arm's control point fixed (else its joints are frozen). ``elbow``: target elbow angle
    [rad] reached along the path (JARA CarPosWithElbow), or None. ``path_limits``: bounds on
    the path parameter's rate [1/s] and acceleration [1/s²] from the joints' limits along
    this path (see ReachabilityChecker.path_parameter_limits). ``posture``: the checked joint
    path, which the regularisation posture follows along the path parameter (the null space
    goes where the check went, :mod:`controller.motion.posture`); None: the start posture.
    """

    def __init__(
        self,
        kin: Kinematics,
        dt: float,
        side: RightLeft,
        path: LinePath | ArcPath,
        speed: tuple[float, float],
        accel: tuple[float, float],
        allowed: dict[RedundantAxis, bool],
        ranges: dict[RedundantAxis, Range | None] | None = None,
        hold_other: bool = False,
        elbow: float | None = None,
        duration: float | None = None,
        path_limits: tuple[float, float] | None = None,
        posture: PosturePath | None = None,
    ):
        self.kin = kin
        self.side = side
        self.path = path
        self.posture_path = posture
        self.posture = _posture(kin)
        if posture is not None:
            self.posture.reference[:] = posture.at(0.0)
        self.elbow: AxisTask | None = None
        #: Elbow angle [rad] along the path (None: the elbow is not commanded).
        self.elbow_path: VectorPath | None = None
        if elbow is not None and kin.has_elbow(side):
            axis = elbow_axis(side)
            start = axis_value(kin, axis)
            goal = start + math.remainder(elbow - start, math.tau)
            self.elbow_path = VectorPath(np.array([start]), np.array([goal]))
            self.elbow = AxisTask(axis, start)
        v, a = path.limits(speed, accel)
        if self.elbow_path is not None:  # the elbow swing is timed like the rotation
            ve, ae = self.elbow_path.limits(np.array([speed[1]]), np.array([accel[1]]))
            v, a = min(v, ve), min(a, ae)
        if path_limits is not None:  # what the joints allow along this path
            v, a = min(v, path_limits[0]), min(a, path_limits[1])
        if not math.isfinite(v):  # zero-length path
            v, a = 1.0, 1.0
        #: Limits of the path parameter [1/s, 1/s²].
        self.profile_limits = (v, a)
        self.profile = PathProfile(dt, v, a, duration)
        self.task = ControlPointTask(side, path.at(0.0))
        self.allowed = dict(allowed)
        self.ranges = dict(ranges or {})
        other = other_side(side)
        self.hold = (
            ControlPointTask(other, kin.pose(other)) if hold_other and other in kin.arms else None
        )
        if self.elbow is not None:
            self.allowed[self.elbow.axis] = True

    def _make_setup(self) -> IKSetup:
        kin = self.kin
        frozen = np.zeros(kin.nv, dtype=bool)
        other = other_side(self.side)
        if self.hold is None and other in kin.arms:
            frozen[arm_joints(kin, other)] = True
        lumbar = [a for a in RedundantAxis if a.is_lumbar and a.lumbar in kin.lumbar_axes()]
        if lumbar and not any(self.allowed.get(a, False) for a in lumbar):
            frozen[kin.unit_indices(UnitType.LUMBER)] = True
        vehicle = [RedundantAxis.VEHICLE_X, RedundantAxis.VEHICLE_Y, RedundantAxis.VEHICLE_THETA]
        if kin.has_vehicle and not any(self.allowed.get(a, False) for a in vehicle):
            frozen[kin.unit_indices(UnitType.VEHICLE)] = True
        tasks: list[Task] = [self.task]
        if self.hold is not None:
            tasks.append(self.hold)
        if self.elbow is not None:
            tasks.append(self.elbow)
        tasks.append(self.posture)
        allowed = {a: self.allowed.get(a, False) for a in RedundantAxis}
        return IKSetup(tasks, frozen, allowed, self.ranges)

    def apply(self, s0: float, s1: float, dt: float) -> None:
        # The pose at s0 and the feed-forward toward s1 (the path's closed form), written
        # into the task's target in place.
        self.path.follow(s0, s1, dt, *self.task.target_buffers)
        if self.elbow is not None and self.elbow_path is not None:
            e0, e1 = float(self.elbow_path.at(s0)[0]), float(self.elbow_path.at(s1)[0])
            self.elbow.set_target(e0, (e1 - e0) / dt)
        if self.posture_path is not None:
            follow_posture(self.posture, self.posture_path, s0, s1, dt)


class DualCartesianMotion(Motion):
    """Both control points along their own straight lines, on one time law (JARA_ARM_DUAL):
    they start and stop together. Waist and vehicle are frozen; ``elbows`` are optional
    target elbow angles [rad] per arm. ``speed``/``accel`` as for :class:`CartesianMotion`,
    met by the arm with the longer path."""

    def __init__(
        self,
        kin: Kinematics,
        dt: float,
        paths: dict[RightLeft, LinePath],
        speed: tuple[float, float],
        accel: tuple[float, float],
        elbows: dict[RightLeft, float | None] | None = None,
        duration: float | None = None,
        path_limits: tuple[float, float] | None = None,
    ):
        self.kin = kin
        self.arms = {
            side: CartesianMotion(
                kin, dt, side, path, speed, accel, {}, None, False, (elbows or {}).get(side)
            )
            for side, path in paths.items()
        }
        v = min(m.profile_limits[0] for m in self.arms.values())
        a = min(m.profile_limits[1] for m in self.arms.values())
        if path_limits is not None:
            v, a = min(v, path_limits[0]), min(a, path_limits[1])
        self.profile = PathProfile(dt, v, a, duration)

    def _make_setup(self) -> IKSetup:
        kin = self.kin
        frozen = np.ones(kin.nv, dtype=bool)
        tasks: list[Task] = []
        allowed: dict[RedundantAxis, bool] = {a: False for a in RedundantAxis}
        for side, motion in self.arms.items():
            frozen[arm_joints(kin, side)] = False
            tasks.append(motion.task)
            if motion.elbow is not None:
                tasks.append(motion.elbow)
                allowed[elbow_axis(side)] = True
        self._start_posture = _posture(kin)
        tasks.append(self._start_posture)
        return IKSetup(tasks, frozen, allowed, {})

    def apply(self, s0: float, s1: float, dt: float) -> None:
        for motion in self.arms.values():
            motion.apply(s0, s1, dt)


VEHICLE_AXES = (RedundantAxis.VEHICLE_X, RedundantAxis.VEHICLE_Y, RedundantAxis.VEHICLE_THETA)


def is_differential(kin: Kinematics) -> bool:
    vehicle = kin.robot.profile.vehicle
    return vehicle is not None and vehicle.type == "differential"


def drivable_waypoints(
    kin: Kinematics, axes: list[RedundantAxis], start: np.ndarray, goal: np.ndarray
) -> list[np.ndarray]:
    """Waypoints from ``start`` to ``goal`` (values of ``axes``) the base can drive.

    Omnidirectional (or no vehicle motion): one straight segment. Differential drive, when
    x/y change: turn toward the goal, drive straight, turn to the final heading (backwards
    when the goal is behind, which turns less); the other axes advance a third per segment.
    ``axes`` must then hold vehicleX, vehicleY and vehicleTheta.
    """
    if not is_differential(kin) or not set(VEHICLE_AXES[:2]) & set(axes):
        return [start, goal]
    ix, iy, it = (axes.index(a) for a in VEHICLE_AXES)
    dxy = goal[[ix, iy]] - start[[ix, iy]]
    if float(np.linalg.norm(dxy)) < 1e-6:
        return [start, goal]
    heading = start[it] + math.remainder(math.atan2(dxy[1], dxy[0]) - start[it], math.tau)
    if abs(heading - start[it]) > math.pi / 2:
        heading -= math.copysign(math.pi, heading - start[it])
    turn = start + (goal - start) / 3
    turn[[ix, iy, it]] = start[ix], start[iy], heading
    drive = start + 2 * (goal - start) / 3
    drive[[ix, iy, it]] = goal[ix], goal[iy], heading
    return [start, turn, drive, goal]


class AxisPathMotion(Motion):
    """Redundant axes along straight segments through waypoints (see drivable_waypoints).

    ``speed``/``accel`` per axis; vehicleX and vehicleY carry the translation limits, taken
    on the Euclidean (x, y) distance. Each segment has its own time law; stop and pause act
    on the current one.
    """

    def __init__(
        self,
        kin: Kinematics,
        dt: float,
        targets: dict[RedundantAxis, float],
        speed: np.ndarray,
        accel: np.ndarray,
        level: int,
    ):
        self.kin = kin
        self.dt = dt
        self.axes = list(targets)
        self.speed = np.asarray(speed, dtype=float)
        self.accel = np.asarray(accel, dtype=float)
        start = np.array([axis_value(kin, a) for a in self.axes])
        goal = np.array(
            [
                start[i] + math.remainder(targets[a] - start[i], math.tau)
                if a.is_elbow
                else targets[a]
                for i, a in enumerate(self.axes)
            ]
        )
        self.waypoints = drivable_waypoints(kin, self.axes, start, goal)
        self.tasks = [
            AxisTask(axis, float(start[i]), weight=1.0, level=level)
            for i, axis in enumerate(self.axes)
        ]
        self._segment = 0
        self._start_segment()

    def _start_segment(self) -> None:
        a, b = self.waypoints[self._segment], self.waypoints[self._segment + 1]
        self.path = VectorPath(a, b)
        v = acc = math.inf
        xy = [i for i, axis in enumerate(self.axes) if axis in VEHICLE_AXES[:2]]
        if xy:
            lin = float(np.linalg.norm(b[xy] - a[xy]))
            if lin > 1e-12:
                v, acc = self.speed[xy[0]] / lin, self.accel[xy[0]] / lin
        for i in range(len(self.axes)):
            extent = abs(float(b[i] - a[i]))
            if i not in xy and extent > 1e-12:
                v = min(v, self.speed[i] / extent)
                acc = min(acc, self.accel[i] / extent)
        if not math.isfinite(v):
            v, acc = 1.0, 1.0
        self.profile = PathProfile(self.dt, v, acc)

    def apply(self, s0: float, s1: float, dt: float) -> None:
        follow_vector(self.tasks, self.path, s0, s1, dt)

    def advance(self, dt: float | None = None) -> None:
        super().advance(dt)
        if dt is not None:
            self.dt = dt  # the next segment's time law starts at the current period
        last = len(self.waypoints) - 2
        if self.profile.finished and not self.profile.stopped and self._segment < last:
            self._segment += 1
            self._start_segment()

    @property
    def finished(self) -> bool:
        last = self._segment == len(self.waypoints) - 2
        return self.profile.finished and (last or self.profile.stopped)


class CPHoldMotion(AxisPathMotion):
    """Redundant axes to ``targets`` (SI) with the control points of ``held`` fixed.

    ``speed``/``accel`` per axis in ``targets`` order (vehicleX/Y: the translation limits).
    Only the axes in ``targets`` move: the joints of arms neither held nor carrying a moved
    elbow are frozen, and so are the waist and the vehicle when none of their axes is a
    target; every other redundant axis (the elbow of a held arm, the waist axes without a
    target) is held at its value by the IK's axis rows. ``free_elbows``: the elbows of the
    held arms are left free instead (when holding them would keep a hand from following
    the body; the service says so in its answer). On a differential base the vehicle turns,
    drives and turns (vehicleTheta is added, held at its value, when the targets do not
    name it).
    """

    def __init__(
        self,
        kin: Kinematics,
        dt: float,
        held: tuple[RightLeft, ...],
        targets: dict[RedundantAxis, float],
        speed: np.ndarray,
        accel: np.ndarray,
        free_elbows: bool = False,
    ):
        self.free_elbows = free_elbows
        targets = dict(targets)
        spd, acc = [float(x) for x in speed], [float(x) for x in accel]
        if is_differential(kin) and set(VEHICLE_AXES[:2]) & set(targets):
            # The turn-drive-turn plan needs x, y and θ: add the missing ones, held.
            k = next(k for k, a in enumerate(targets) if a in VEHICLE_AXES[:2])
            theta = kin.robot.joints[kin.robot.unit_joints("VEHICLE")[2]]
            limits = {
                VEHICLE_AXES[0]: (spd[k], acc[k]),
                VEHICLE_AXES[1]: (spd[k], acc[k]),
                VEHICLE_AXES[2]: (0.5 * theta.velocity, 0.5 * theta.acceleration),
            }
            for axis, (v, a) in limits.items():
                if axis not in targets:
                    targets[axis] = axis_value(kin, axis)
                    spd.append(v)
                    acc.append(a)
        super().__init__(kin, dt, targets, np.array(spd), np.array(acc), level=2)
        self.hold = [ControlPointTask(side, kin.pose(side)) for side in held]

    def _make_setup(self) -> IKSetup:
        kin = self.kin
        frozen = np.zeros(kin.nv, dtype=bool)
        moving = {t.side for t in self.hold} | {a.side for a in self.axes if a.is_elbow}
        for side in kin.arms:
            if side not in moving:
                frozen[arm_joints(kin, side)] = True
        # Waist and vehicle move only when one of their axes has a target: an elbow swing
        # must not be helped along by the base.
        if not any(a.is_lumbar for a in self.axes):
            frozen[kin.unit_indices(UnitType.LUMBER)] = True
        if not any(a.is_vehicle for a in self.axes):
            frozen[kin.unit_indices(UnitType.VEHICLE)] = True
        # Axes without a target stay put (axes of frozen units are skipped by the rows).
        allowed = {a: a in self.axes for a in available_axes(kin)}
        if self.free_elbows:
            allowed.update({a: True for a in allowed if a.is_elbow})
        self._start_posture = _posture(kin)
        return IKSetup([*self.hold, *self.tasks, self._start_posture], frozen, allowed)


class VehicleMotion(AxisPathMotion):
    """Vehicle unit move to ``target`` = (x [m], y [m], θ [rad]) in the original frame.

    ``speed``/``accel``: (translation, rotation). Omnidirectional: one straight line in
    (x, y) with θ turning along, translation limited on the Euclidean distance. Differential
    drive: turn toward the goal, drive straight, turn to the final heading, so the base never
    moves sideways.
    """

    def __init__(
        self,
        kin: Kinematics,
        dt: float,
        target: np.ndarray,
        speed: tuple[float, float],
        accel: tuple[float, float],
    ):
        targets = {a: float(target[i]) for i, a in enumerate(VEHICLE_AXES)}
        super().__init__(
            kin,
            dt,
            targets,
            np.array([speed[0], speed[0], speed[1]]),
            np.array([accel[0], accel[0], accel[1]]),
            level=1,
        )

    def _make_setup(self) -> IKSetup:
        frozen = np.ones(self.kin.nv, dtype=bool)
        frozen[self.kin.unit_indices(UnitType.VEHICLE)] = False
        self._start_posture = _posture(self.kin)
        return IKSetup([*self.tasks, self._start_posture], frozen)

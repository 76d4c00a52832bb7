"""Planning in the gateway: SI requests → checked motion specs for the control process.

Runs outside the control process so reachability checks (a position-level IK along the
sampled path) never compete with the loop. One plan at a time (a lock): two clients cannot
plan from the same state and both start.

For the JARA queue the planner remembers where the queued motions will leave the robot
(:attr:`Planner.tail`), so a command queued behind others is planned, checked and made
relative from there, not from where the robot happens to be now.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from controller.bounds import MAX_MOTION_TIME
from controller.contract.motion_specs import (
    CartesianMoveSpec,
    CPHoldSpec,
    JointMoveSpec,
    MotionSpec,
    VehicleMoveSpec,
)
from controller.contract.snapshot import F_MOTION, Snapshot
from controller.errors import Refused
from controller.gateway.planning.clearance import ClearanceCheck
from controller.gateway.planning.dry_run import DRY_RUN_DT, dry_run
from controller.gateway.planning.elbow_reach import ELBOW_TOL, reach_elbow
from controller.gateway.planning.reach import out_of_reach
from controller.gateway.planning.robot_view import RobotView
from controller.model.kinematics import Kinematics
from controller.model.obstacles import Obstacle
from controller.model.redundant_axes import RedundantAxis
from controller.motion.motions import other_side
from controller.motion.reachability import ReachabilityChecker
from controller.qp.ik import WholeBodyIK
from controller.vocabulary import ReturnCode, RightLeft

Range = tuple[float, float]


class Planner:
    def __init__(self, view: RobotView, dt: float, obstacles: Sequence[Obstacle] = ()):
        """``obstacles``: the daemon's static obstacles (:mod:`controller.model.obstacles`),
        kept clear of like the robot's own bodies (:mod:`.clearance`)."""
        self.view = view
        self.dt = dt
        self.obstacles = tuple(obstacles)
        self._clearance: ClearanceCheck | None = None
        #: Path parameters and configurations of the last :meth:`cartesian` path.
        self.last_path: tuple[list[float], list[np.ndarray]] = ([], [])
        self.checker = ReachabilityChecker(view.kin)
        self.lock = threading.RLock()
        self.tail: np.ndarray | None = None
        self._dry_ik: WholeBodyIK | None = None
        self.tail_poses: dict[RightLeft, pin.SE3] = {}

    # ------------------------------------------------------------------ base state
    def base_q(self, snap: Snapshot, queued: bool) -> np.ndarray:
        """Configuration a new motion starts from: the measured one, or (queued behind
        running/queued motions) the planned end of the queue."""
        # No motion (running or paused), nothing moving, nothing queued, whatever the state
        # (a stop, then a pause while idle leaves no motion behind): the robot stays where it
        # is, and relative moves build on the measured state (issue 15.1).
        idle = not snap.flags & F_MOTION and not snap.moving and snap.queue == 0
        if idle:
            self.forget_queue()
        if queued:
            if not idle and self.tail is not None:
                return self.tail.copy()
            self.tail_poses.clear()  # nothing queued: plan from the measured state
        return self.view.measured_q(snap).copy()

    def forget_queue(self) -> None:
        """Nothing the gateway queued is left (stop, abort, servo off, alarm, or the queue
        ran out): relative moves build on the measured state again."""
        self.tail = None
        self.tail_poses.clear()

    def remember(self, q_end: np.ndarray, poses: dict[RightLeft, pin.SE3] | None = None) -> None:
        """The end of the queue: configuration, and the exact target poses (original frame)
        of the arms a Cartesian move commanded (the IK end configuration is only as exact as
        the reachability check; relative moves queued behind build on the commanded pose)."""
        self.tail = q_end.copy()
        for side, pose in (poses or {}).items():
            self.tail_poses[side] = pose.copy()

    def tail_pose(self, side: RightLeft) -> pin.SE3 | None:
        """Commanded end pose of ``side`` of the queued motions (None: use the kinematics)."""
        return self.tail_poses.get(side)

    @property
    def clearance(self) -> ClearanceCheck:
        """The distance check along paths (built on first use: one per planner)."""
        if self._clearance is None:
            self._clearance = ClearanceCheck(self.view.kin, self.obstacles)
        return self._clearance

    def require_clearance(self, s: Sequence[float], qs: Sequence[np.ndarray]) -> None:
        """Refused(CANNOT_REACH_TARGET_ERR) when the sampled path ``qs`` (at parameters ``s``,
        from where the move starts) would bring two bodies closer than the security distance;
        the comment names them."""
        with self.lock:
            reason = self.clearance.sampled_path_problem(s, qs)
        if reason is not None:
            raise Refused(ReturnCode.CANNOT_REACH_TARGET_ERR, reason)

    def require_joint_line_clearance(self, q0: np.ndarray, q1: np.ndarray) -> None:
        """:meth:`require_clearance` along the joint-space line ``q0`` → ``q1``."""
        with self.lock:
            reason = self.clearance.joint_line_problem(q0, q1)
        if reason is not None:
            raise Refused(ReturnCode.CANNOT_REACH_TARGET_ERR, reason)

    def set_joint_limits(self, indices: np.ndarray, lower: np.ndarray, upper: np.ndarray):
        self.checker.q_min[indices] = lower
        self.checker.q_max[indices] = upper

    def require_reach(
        self, kin: Kinematics, side: RightLeft, target: pin.SE3, allowed: dict[RedundantAxis, bool]
    ) -> None:
        """Refused(CANNOT_REACH_TARGET_ERR) for a target beyond any reach of the arm (checked
        in microseconds, before a path to it is sampled)."""
        vehicle = self.view.robot.profile.vehicle
        workspace = vehicle.workspace.si() if vehicle is not None else None
        reason = out_of_reach(kin, side, target, allowed, workspace)
        if reason is not None:
            raise Refused(ReturnCode.CANNOT_REACH_TARGET_ERR, reason)

    # ------------------------------------------------------------------ motions
    def cartesian(
        self,
        snap: Snapshot,
        q0: np.ndarray,
        side: RightLeft,
        target: pin.SE3,
        speed: tuple[float, float],
        accel: tuple[float, float],
        allowed: dict[RedundantAxis, bool],
        ranges: dict[RedundantAxis, Range | None],
        hold_other: bool,
        elbow: float | None = None,
        via: pin.SE3 | None = None,
        duration: float | None = None,
        label: str = "Cartesian move",
        clearance: bool = True,
    ) -> tuple[CartesianMoveSpec, np.ndarray]:
        """A checked straight-line (or arc) move; Refused(CANNOT_REACH_TARGET_ERR) if not.

        ``clearance``: check the path's distances (:mod:`.clearance`); a caller moving
        several arms together checks their combined paths itself (:attr:`last_path`)."""
        spec = CartesianMoveSpec(
            side=side,
            target=target.homogeneous.copy(),
            speed=speed,
            accel=accel,
            allowed=dict(allowed),
            ranges=dict(ranges),
            hold_other=hold_other and other_side(side) in self.view.arms,
            elbow=elbow,
            via=None if via is None else via.homogeneous.copy(),
            duration=duration,
            planned_from=q0.copy(),
            label=label,
        )
        with self.lock, self.view.at(snap, q0) as kin:
            for point in (target, via):
                if point is not None:
                    self.require_reach(kin, side, point, allowed)
            motion = spec.build(kin, self.dt)
            hold = other_side(side) if spec.hold_other else None
            elbow_path = getattr(motion, "elbow_path", None)
            reason = self.checker.check(kin, side, motion.path, motion.setup(), hold, elbow_path)  # type: ignore[attr-defined]
            self.last_path = (list(self.checker.path_s), list(self.checker.path_q))
            if reason is None and clearance:
                reason = self.clearance.sampled_path_problem(*self.last_path)
            q_end = self.checker.last_q.copy()
            limits = self.checker.path_parameter_limits()
            if reason is None and elbow is not None:
                self._check_elbow(side, q_end, elbow)
            v, a = motion.profile_limits  # type: ignore[attr-defined]
            v, a = min(v, limits[0]), min(a, limits[1])
            cap, worst = self.checker.braking_speed_limit(side, v, a)
        if reason is not None:
            raise Refused(ReturnCode.CANNOT_REACH_TARGET_ERR, reason)
        if worst is not None:
            if cap < MIN_SPEED_SHARE * v:
                name, s, dist = worst
                raise Refused(
                    ReturnCode.CANNOT_REACH_TARGET_ERR,
                    f"the path at {100 * s:.0f} % runs {name} toward its limit "
                    f"({_show(dist, name, self.view)} left): the arm could not stay on the "
                    "line at any useful speed; choose another target or allow more "
                    "redundant axes",
                )
            limits = (cap, limits[1])  # slower, so the joint never has to brake off the line
        if math.isfinite(limits[0]):
            spec.path_limits = limits
        path_s, path_q = self.last_path
        if len(path_s) > 1:
            spec.posture = (np.array(path_s), np.array(path_q))
        return spec, q_end

    def _check_elbow(self, side: RightLeft, q_end: np.ndarray, elbow: float) -> None:
        """VALUE_ERR when the elbow cannot reach ``elbow`` [rad] with the hand on the path's
        end pose (configuration ``q_end`` of the checker); the comment names the joints."""
        checker = self.checker
        reached, at_limit = reach_elbow(
            checker.kin, side, q_end, elbow, checker.q_min, checker.q_max
        )
        if not at_limit and abs(math.remainder(reached - elbow, math.tau)) < ELBOW_TOL:
            return
        why = (
            f"limited by {', '.join(at_limit)} at {'its' if len(at_limit) == 1 else 'their'} "
            "limit" + ("" if len(at_limit) == 1 else "s")
            if at_limit
            else "the arm cannot turn its elbow further there"
        )
        raise Refused(
            ReturnCode.VALUE_ERR,
            f"elbow: {math.degrees(elbow):.2f} deg is out of reach with the hand on the target: "
            f"the elbow gets to {math.degrees(reached):.2f} deg ({why})",
        )

    def pose_goal(
        self,
        snap: Snapshot,
        q0: np.ndarray,
        side: RightLeft,
        target: pin.SE3,
        allowed: dict[RedundantAxis, bool],
        ranges: dict[RedundantAxis, Range | None],
        hold_other: bool,
        clearance: bool = True,
    ) -> tuple[np.ndarray, np.ndarray, tuple[RightLeft, ...]]:
        """IK solution of ``target`` under the mask and ranges: the configuration, the joints
        a move there uses and the arms it must hold; Refused(CANNOT_REACH_TARGET_ERR) if none,
        or (``clearance``) if the joint-space line there comes too close (:mod:`.clearance`)."""
        probe = CartesianMoveSpec(
            side=side,
            target=target.homogeneous.copy(),
            speed=(1.0, 1.0),
            accel=(1.0, 1.0),
            allowed=dict(allowed),
            ranges=dict(ranges),
            hold_other=hold_other and other_side(side) in self.view.arms,
        )
        with self.lock, self.view.at(snap, q0) as kin:
            self.require_reach(kin, side, target, allowed)
            setup = probe.build(kin, self.dt).setup()
            hold = other_side(side) if probe.hold_other else None
            q_goal, reason = self.checker.solve_pose(kin, side, target, setup, hold)
            if reason is None and clearance:
                reason = self.clearance.joint_line_problem(q0, q_goal)
        if reason is not None:
            raise Refused(ReturnCode.CANNOT_REACH_TARGET_ERR, reason)
        return q_goal, np.flatnonzero(~setup.frozen), (() if hold is None else (hold,))

    def ptp_cartesian(
        self,
        snap: Snapshot,
        q0: np.ndarray,
        side: RightLeft,
        target: pin.SE3,
        allowed: dict[RedundantAxis, bool],
        ranges: dict[RedundantAxis, Range | None],
        hold_other: bool,
        duration: float | None,
        speed_share: float = 1.0,
        accel_share: float = 0.5,
        label: str = "PTP Cartesian move",
    ) -> tuple[JointMoveSpec, np.ndarray]:
        """Joint-space move to the IK solution of ``target`` under the mask and ranges.

        The arguments (the duration) are checked before the path's clearance."""
        q_goal, joints, hold = self.pose_goal(
            snap, q0, side, target, allowed, ranges, hold_other, clearance=False
        )
        spec = self.joint(
            q0, joints, q_goal[joints], speed_share, accel_share, duration, hold=hold, label=label
        )
        self.require_joint_line_clearance(q0, q_goal)
        return spec, q_goal

    def joint(
        self,
        q0: np.ndarray,
        joints: np.ndarray,
        target: np.ndarray,
        speed: float | np.ndarray,
        accel: float | np.ndarray,
        duration: float | None = None,
        hold: tuple[RightLeft, ...] = (),
        label: str = "joint move",
        absolute: bool = False,
    ) -> JointMoveSpec:
        """Joint move; ``speed``/``accel`` are shares of the joints' limits unless
        ``absolute`` (then SI per joint). Targets outside the limits are VALUE_ERR.

        ``duration``: the move takes exactly this long; too short for the joints' limits is
        VALUE_ERR."""
        kin = self.view.kin
        names = [kin.joint_names[i] for i in joints]
        specs = [self.view.robot.joints[n] for n in names]
        lo = self.checker.q_min[joints]
        hi = self.checker.q_max[joints]
        for name, value, a, b in zip(names, target, lo, hi, strict=True):
            if not a - 1e-9 <= value <= b + 1e-9:
                raise Refused(
                    ReturnCode.VALUE_ERR,
                    f"{name}: target {_show(value, name, self.view)} is outside its limits "
                    f"[{_show(a, name, self.view)}, {_show(b, name, self.view)}]",
                )
        v_lim = np.array([s.velocity for s in specs])
        a_lim = np.array([s.acceleration for s in specs])
        if absolute:
            v = np.asarray(speed, dtype=float)
            a = np.asarray(accel, dtype=float)
        else:
            v = v_lim * speed
            a = a_lim * accel
        if duration is not None:
            need = min_duration(np.abs(target - q0[joints]), v_lim, a)
            if duration + 1e-9 < need:
                raise Refused(
                    ReturnCode.VALUE_ERR,
                    f"time: {duration:g} s is too short, the joints need at least {need:.3f} s",
                )
            v = v_lim
        return JointMoveSpec(
            joints=np.asarray(joints),
            target=np.asarray(target, dtype=float),
            speed=v,
            accel=a,
            duration=duration,
            hold=hold,
            planned_from=q0.copy(),
            label=label,
        )

    def dry_run(
        self,
        snap: Snapshot,
        q0: np.ndarray,
        spec: MotionSpec,
        max_time: float = MAX_MOTION_TIME,
        commanded: set[RedundantAxis] | None = None,
    ) -> str | None:
        """Run ``spec`` on the planning copy with perfect drives and the daemon's own IK
        (:func:`controller.gateway.planning.dry_run.dry_run`): None when it arrives, else why
        not. For motions whose reachability the path check cannot see (CP-hold: the body
        moves under a held hand). ``commanded``: the axes the request changes."""
        with self.lock, self.view.at(snap, q0) as kin:
            if self._dry_ik is None:
                self._dry_ik = WholeBodyIK(kin, DRY_RUN_DT)
            ik = self._dry_ik
            ik.box.q_min, ik.box.q_max = self.checker.q_min.copy(), self.checker.q_max.copy()
            # No clearance here: a CP-hold into a body or an obstacle is not refused; the
            # collision rows stop it on its path and say so (MOTION_BLOCKED, issue 10).
            return dry_run(kin, ik, spec, q0, max_time, commanded)

    def cp_hold(
        self,
        q0: np.ndarray,
        held: tuple[RightLeft, ...],
        targets: dict[RedundantAxis, float],
        speed: np.ndarray,
        accel: np.ndarray,
        label: str = "CP-hold move",
    ) -> CPHoldSpec:
        return CPHoldSpec(
            held=held,
            targets=targets,
            speed=speed,
            accel=accel,
            planned_from=q0.copy(),
            label=label,
        )

    def vehicle(
        self,
        q0: np.ndarray,
        target: np.ndarray,
        speed: tuple[float, float],
        accel: tuple[float, float],
    ) -> VehicleMoveSpec:
        return VehicleMoveSpec(
            target=np.asarray(target, dtype=float),
            speed=speed,
            accel=accel,
            planned_from=q0.copy(),
            label="vehicle move",
        )


#: A linear move is refused when its joints near their limits would slow it below this
#: share of its requested speed (see ReachabilityChecker.braking_speed_limit).
MIN_SPEED_SHARE = 0.05


def min_duration(distance: np.ndarray, v_max: np.ndarray, a_max: np.ndarray) -> float:
    """Shortest time [s] a trapezoidal profile needs for the slowest joint."""
    worst = 0.0
    for d, v, a in zip(distance, v_max, a_max, strict=True):
        if d <= 0.0:
            continue
        t = d / v + v / a if d > v * v / a else 2.0 * math.sqrt(d / a)
        worst = max(worst, t)
    return worst


def _show(value: float, joint: str, view: RobotView) -> str:
    spec = view.robot.joints[joint]
    if spec.kind == "revolute":
        return f"{math.degrees(value):.3f} deg"
    return f"{1e3 * value:.1f} mm"

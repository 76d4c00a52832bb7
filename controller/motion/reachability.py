"""Reachability check before a Cartesian motion is accepted.

The path is sampled (every 1 cm and 2°) and followed with a position-level IK from the
current configuration, under the same constraints the motion will run with: joint position
limits, frozen joints (units that do not take part), masked redundant axes held, RedundantLimit
ranges. A sample whose pose cannot be reached within tolerance makes the whole motion
unreachable, with a reason the service returns as the comment of CANNOT_REACH_TARGET_ERR.

Reachable is not enough: near a singular configuration of the constrained arm (a 7-axis arm
with its elbow held is a 6-axis arm) a pose can be reached but not followed at speed within
the joint velocity and acceleration limits. Each sample's smallest singular value of the
control-point Jacobian (rotation rows scaled by 0.3 m, over the free joints, inside the null
space of the held axes) must stay above :data:`MIN_SINGULAR`. Measured on SmartPal V: paths
that tracked within 0.01 mm stayed above 0.08 m/rad; one that lost 2 mm went down to 0.021.

Runs on its own :class:`~controller.model.kinematics.Kinematics` (the loop owns the live one).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import (
    RedundantAxis,
    available_axes,
    axis_jacobian,
    axis_value,
    elbow_axis,
)
from controller.motion.motions import IKSetup
from controller.motion.paths import ArcPath, LinePath, VectorPath
from controller.motion.posture import limit_weights, null_step
from controller.qp.constraints import BRAKING_SHARE, AxisRows
from controller.qp.constraints.axes import HOLD_MIN_ELBOW_OFFSET
from controller.qp.solver import ProxQPSolver
from controller.qp.tasks import pose_error
from controller.vocabulary import RightLeft, UnitType

#: Accepted residual at every sample: position [m], orientation [rad].
POSITION_TOL = 1e-4
ANGLE_TOL = math.radians(0.05)
#: Largest joint step per iteration [rad or m] and iterations per sample.
MAX_STEP = 0.2
MAX_ITER = 60
#: Samples at most this far apart along the path.
SAMPLE_STEP = 0.01
SAMPLE_ANGLE = math.radians(2)
DAMPING = 1e-6
#: Most samples one check follows (100 m at 1 cm): bounds the time and memory of a request;
#: a longer path is refused (the gateway's reach check refuses far targets before this).
MAX_SAMPLES = 10_000
#: Smallest singular value [m/rad] of the constrained control-point Jacobian along a path.
MIN_SINGULAR = 0.04
#: Rotation rows are scaled by this length [m] to compare with translation rows.
ROTATION_SCALE = 0.3
#: A Cartesian path may not take a joint of the moving arm (any free joint, when the
#: constrained arm has no redundancy left) closer than this to a limit [rad] / [m] unless it
#: started there: the live IK brakes the joint before its limit and the rest cannot make up
#: for it at speed, so the hand leaves the line (issue 16.2, SmartPal V: 6.5 mm off the line
#: with r_arm_j6 on its limit; 1.8 mm with it 0.05 deg from its limit, elbow free). Waist
#: and vehicle joints riding their limits are made up for by the arm.
LIMIT_MARGIN = math.radians(0.2)
LIMIT_MARGIN_M = 0.2e-3
#: Null-space objective (:mod:`controller.motion.posture`): a sample is solved once its
#: posture step is below NULL_TOL [rad or m], or NULL_ITER iterations after its pose was.
NULL_TOL = 1e-3
NULL_ITER = 8
#: Share of the posture step taken per iteration, and its largest joint step [rad or m]:
#: the full step overshoots where the weights grow (a joint nearing its limit) and the
#: iteration alternates between two configurations.
NULL_GAIN = 0.5
MAX_NULL_STEP = 0.05
#: Continuity: a joint may move at most this much [rad] / [m] between consecutive samples;
#: a larger step is split in halves, up to MAX_SPLITS times (1 cm down to 0.3 mm); a step
#: still larger then is a jump between branches of the IK, which the loop cannot follow.
JUMP_ANGLE = math.radians(5.0)
JUMP_LENGTH = 0.02
MAX_SPLITS = 5
#: A sample's IK starts from the previous one's solution moved on along the path, unless
#: that comes closer than this [rad or m] to a limit.
PREDICT_MARGIN = math.radians(2.0)
#: A path that jumps between branches is checked again with the posture passing through
#: the configuration after the jump, at most this many times.
ANCHORS = 2
#: Weight of the elbow row [m/rad] (the pose rows weigh 1) and its accepted residual [rad].
ELBOW_WEIGHT = 0.1
ELBOW_TOL = math.radians(0.1)


class ReachabilityChecker:
    """Follows candidate paths with a position-level IK on a planning copy of the robot."""

    def __init__(self, kin: Kinematics):
        self.kin = Kinematics(kin.robot)
        self.axes = available_axes(self.kin)
        self.rows = AxisRows(self.kin, self.axes, 1.0)
        self.solver = ProxQPSolver(self.kin.nv, self.rows.m)
        specs = [self.kin.robot.joints[n] for n in self.kin.joint_names]
        self.q_min = np.array([s.lower for s in specs])
        self.q_max = np.array([s.upper for s in specs])
        #: Configuration at the last sample :meth:`check` solved (the path's end on success).
        self.last_q = np.zeros(self.kin.nv)
        #: Path parameter and configuration at every sample :meth:`check` solved.
        self.path_s: list[float] = []
        self.path_q: list[np.ndarray] = []
        specs_all = specs
        self._jump_bound = np.array(
            [JUMP_ANGLE if sp.kind == "revolute" else JUMP_LENGTH for sp in specs]
        )
        self._coarse_error = ""
        self.v_max = np.array([sp.velocity for sp in specs_all])
        self.a_max = np.array([sp.acceleration for sp in specs_all])

    def check(
        self,
        live: Kinematics,
        side: RightLeft,
        path: LinePath | ArcPath,
        setup: IKSetup,
        hold: RightLeft | None = None,
        elbow: VectorPath | None = None,
    ) -> str | None:
        """None when every sample of ``path`` is reachable from ``live.q``; else why not.

        ``elbow``: the elbow angle [rad] of ``side`` along the path (JARA CarPosWithElbow),
        followed best-effort at every sample (the pose comes first), so the joint motion
        recorded for :meth:`path_parameter_limits` includes the elbow swing."""
        too_long = _too_long(path, SAMPLE_STEP, SAMPLE_ANGLE)
        if too_long is not None:
            return too_long
        q0, held = self._start(live, setup, hold)
        samples = path.samples(SAMPLE_STEP, SAMPLE_ANGLE)
        axis = elbow_axis(side) if elbow is not None and self.kin.has_elbow(side) else None
        if axis is not None and elbow is not None:
            swing = abs(float(elbow.delta[0]))
            n = max(len(samples), math.ceil(swing / SAMPLE_ANGLE) + 1)
            samples = [i / (n - 1) for i in range(n)]
        held_axes = [a for a in self.axes if not setup.allowed.get(a, True)]
        rigid = self._redundancy(side, hold, setup.frozen, held_axes) <= 0
        # The posture the null space is drawn to moves from the start toward the end
        # configuration (found first in coarse steps) along the path, so the null-space
        # motion a joint limit asks for is spread over the path instead of swung through
        # where the limit comes near (there the posture nearest the start changes branch).
        q1 = None if axis is not None else self._coarse(q0, side, path, setup, hold, held)
        anchors = [(0.0, q0), (1.0, q0 if q1 is None else q1)]
        for attempt in range(ANCHORS + 1):
            self.kin.update(q0)
            why, jump = self._follow(
                q0, side, path, samples, setup, hold, held, held_axes, rigid, anchors, axis, elbow
            )
            if jump is None or attempt == ANCHORS:
                return why
            # A change of branch where the posture's nearest configuration swings over:
            # again, with the posture passing through the far side of the swing, so the
            # null-space motion starts early and the path stays continuous.
            anchors.append(jump)
            anchors.sort(key=lambda anchor: anchor[0])
        return why  # pragma: no cover (the loop returns)

    def _follow(
        self,
        q: np.ndarray,
        side: RightLeft,
        path: LinePath | ArcPath,
        samples: Sequence[float],
        setup: IKSetup,
        hold: RightLeft | None,
        held: pin.SE3 | None,
        held_axes: list[RedundantAxis],
        rigid: bool,
        anchors: list[tuple[float, np.ndarray]],
        axis: RedundantAxis | None,
        elbow: VectorPath | None,
    ) -> tuple[str | None, tuple[float, np.ndarray] | None]:
        """One pass of :meth:`check` from ``q`` along ``samples`` of ``path``, the null space
        drawn to the posture through ``anchors`` (path parameter, configuration; linear in
        between). Returns why the path is refused (None: it is not) and, when the reason is
        a jump between branches, the path parameter and configuration after the first one."""
        self.last_q = q
        self.path_s = [float(samples[0])]
        self.path_q = [q.copy()]
        grid = np.array([anchor[0] for anchor in anchors])
        poses = np.array([anchor[1] for anchor in anchors])
        #: The first sample that takes a joint close to its limit, and the first jump
        #: between branches (reported if nothing else is wrong with the path).
        near: tuple[str, str, str] | None = None
        jumped: tuple[str, float, np.ndarray] | None = None

        def solve(q_from: np.ndarray, s: float) -> tuple[np.ndarray, str | None]:
            goal = None
            if axis is not None and elbow is not None:
                goal = (axis, float(elbow.at(s)[0]))
            k = min(int(np.searchsorted(grid, s, side="right")) - 1, len(grid) - 2)
            t = (s - grid[k]) / (grid[k + 1] - grid[k])
            posture = poses[k] + t * (poses[k + 1] - poses[k])
            start = q_from if goal is not None else self._predict(q_from, s)
            return self._solve(
                start, side, path.at(s), setup.frozen, hold, held, goal, posture, held_axes
            )

        s_prev = float(samples[0])
        for s_next in samples[1:]:
            for s, q_s, err in self._segment(q, s_prev, float(s_next), solve):
                jump = self._jump(q, q_s)
                q = q_s
                self.last_q = q
                self.path_s.append(s)
                self.path_q.append(q.copy())
                where = "the target" if s >= 1.0 else f"the path at {100 * s:.0f} %"
                if err is not None:
                    return f"{where} is not reachable: {err}", None
                if jump is not None and jumped is None:
                    name, shown = jump
                    jumped = (
                        f"{where} needs {name} to jump {shown} between two points "
                        f"{100 * (s - self.path_s[-2]):.2f} % of the path apart: the arm "
                        "changes its configuration there and could not follow the path; "
                        "choose another target or allow more redundant axes",
                        s,
                        q.copy(),
                    )
            s_prev = float(s_next)
            where = "the target" if s_prev >= 1.0 else f"the path at {100 * s_prev:.0f} %"
            if near is None:
                # Without redundancy any free joint counts, else the moving arm's own.
                watched = ~setup.frozen if rigid else self._arm_mask(side)
                close = self._near_limit(q, self.path_q[0], watched)
                if close is not None:
                    near = (where, *close)
            sigma = self.conditioning(side, hold, setup.frozen, held_axes)
            if sigma < MIN_SINGULAR:
                return (
                    f"{where} is too close to a singular configuration (smallest singular "
                    f"value {sigma:.3f} m/rad, need {MIN_SINGULAR}): it could not be followed "
                    "at speed; allow more redundant axes or choose another target"
                ), None
        if jumped is not None:
            return jumped[0], (jumped[1], jumped[2])
        if near is not None:
            where, name, gap = near
            return (
                f"{where} needs {name} within {gap} of its limit: the arm could not follow "
                "the line there (the joint brakes before its limit); choose another target "
                "or allow more redundant axes"
            ), None
        return None, None

    def _segment(
        self,
        q: np.ndarray,
        s0: float,
        s1: float,
        solve: Callable[[np.ndarray, float], tuple[np.ndarray, str | None]],
        depth: int = 0,
    ) -> list[tuple[float, np.ndarray, str | None]]:
        """The samples ``(s, q, why not)`` from ``s0`` (solved: ``q``) to ``s1``: one, or
        halves (up to MAX_SPLITS times) while a joint moves more than the jump bound between
        them, so a continuous joint path is sampled densely where it is fast and a jump left
        at the finest split is a change of branch (:meth:`_jump`)."""
        q1, err = solve(q, s1)
        if depth >= MAX_SPLITS or (err is None and self._jump(q, q1) is None):
            return [(s1, q1, err)]
        mid = 0.5 * (s0 + s1)
        first = self._segment(q, s0, mid, solve, depth + 1)
        _, q_mid, err_mid = first[-1]
        if err_mid is not None:
            return first
        return first + self._segment(q_mid, mid, s1, solve, depth + 1)

    def _predict(self, q: np.ndarray, s: float) -> np.ndarray:
        """Where the IK starts for the sample at ``s`` from ``q``: ``q`` moved on along the
        last recorded step when ``q`` is the last recorded sample (a continuous path goes on
        much as it went: the IK then starts within a fraction of a degree of its solution)
        and that takes no joint closer than PREDICT_MARGIN to a limit; else ``q``."""
        if len(self.path_q) < 2 or not np.array_equal(q, self.path_q[-1]):
            return q
        ds = self.path_s[-1] - self.path_s[-2]
        if ds <= 0.0:
            return q
        ahead = q + (q - self.path_q[-2]) * ((s - self.path_s[-1]) / ds)
        gap = np.minimum(ahead - self.q_min, self.q_max - ahead)
        if np.any((gap < PREDICT_MARGIN) & (gap < np.minimum(q - self.q_min, self.q_max - q))):
            return q  # toward a limit: the IK finds where the path leaves it
        return ahead

    def _jump(self, a: np.ndarray, b: np.ndarray) -> tuple[str, str] | None:
        """The joint moving most beyond its jump bound (JUMP_ANGLE, JUMP_LENGTH) from ``a``
        to ``b``, with the distance shown in deg or mm; None if none does."""
        over = np.abs(b - a) / self._jump_bound
        j = int(np.argmax(over))
        if over[j] <= 1.0:
            return None
        name = self.kin.joint_names[j]
        d = abs(float(b[j] - a[j]))
        revolute = self.kin.robot.joints[name].kind == "revolute"
        return name, f"{math.degrees(d):.1f} deg" if revolute else f"{d * 1e3:.1f} mm"

    def _redundancy(
        self,
        side: RightLeft,
        hold: RightLeft | None,
        frozen: np.ndarray,
        held_axes: list[RedundantAxis],
    ) -> int:
        """Degrees of freedom left over the control point(s) at the last update: free joints
        minus the held axes' rows minus 6 per control point (≤ 0: the constrained arm has no
        redundancy, so it cannot ride a joint limit and keep its line)."""
        free = ~frozen
        rows = [axis_jacobian(self.kin, a)[free] for a in held_axes]
        rows = [r for r in rows if np.abs(r).max(initial=0.0) > 0.0]
        rank = int(np.linalg.matrix_rank(np.vstack(rows))) if rows else 0
        return int(free.sum()) - rank - 6 * (1 if hold is None else 2)

    def _arm_mask(self, side: RightLeft) -> np.ndarray:
        mask = np.zeros(self.kin.nv, dtype=bool)
        mask[self.kin.unit_indices(UnitType[f"{side.name}_ARM"])] = True
        return mask

    def _near_limit(
        self, q: np.ndarray, start: np.ndarray, watched: np.ndarray
    ) -> tuple[str, str] | None:
        """The first ``watched`` joint within LIMIT_MARGIN of a limit at ``q`` that was not
        there at ``start``: its name and the gap shown in deg or mm; None if none."""
        gap = np.minimum(q - self.q_min, self.q_max - q)
        was = np.minimum(start - self.q_min, self.q_max - start)
        margin = np.array(
            [
                LIMIT_MARGIN if self.kin.robot.joints[n].kind == "revolute" else LIMIT_MARGIN_M
                for n in self.kin.joint_names
            ]
        )
        bad = (gap < margin) & (was >= margin) & watched
        if not bad.any():
            return None
        j = int(np.flatnonzero(bad)[0])
        name = self.kin.joint_names[j]
        revolute = self.kin.robot.joints[name].kind == "revolute"
        shown = f"{math.degrees(gap[j]):.2f} deg" if revolute else f"{gap[j] * 1e3:.1f} mm"
        return name, shown

    def path_parameter_limits(self, share: float = 0.8) -> tuple[float, float]:
        """Limits on the path parameter's rate [1/s] and acceleration [1/s²] that keep every
        joint within ``share`` of its speed limit and of its braking deceleration
        (BRAKING_SHARE × its acceleration limit) along the last checked path, from the joint
        motion per unit of path (dq/ds) between samples. ``(inf, inf)`` for a still path."""
        if len(self.path_q) < 2:
            return math.inf, math.inf
        q = np.array(self.path_q)
        ds = np.diff(np.array(self.path_s))
        ok = ds > 1e-12
        if not ok.any():
            return math.inf, math.inf
        slope = np.max(np.abs(np.diff(q, axis=0)[ok] / ds[ok, None]), axis=0)  # per joint
        moving = slope > 1e-12
        if not moving.any():
            return math.inf, math.inf
        v = share * float(np.min(self.v_max[moving] / slope[moving]))
        a = share * BRAKING_SHARE * float(np.min(self.a_max[moving] / slope[moving]))
        return v, a

    def braking_speed_limit(
        self, side: RightLeft, v: float, a: float, share: float = 0.8
    ) -> tuple[float, tuple[str, float, float] | None]:
        """Path rate [1/s] ≤ ``v`` at which no joint on the last checked path outruns the
        IK's braking bound toward its limit, and the worst joint ``(name, s, distance)``
        (None when nothing binds). ``a`` [1/s²]: the path acceleration.

        A joint at distance ``d`` from the limit it moves toward, at ``dq/ds`` per unit of
        path, can go at most ``√(2·share·a_b·d)`` (a_b = BRAKING_SHARE × its acceleration
        limit): the live IK brakes it there whatever the path asks, the hand then leaves the
        line and the arm may fold into another configuration. Likewise a joint whose path
        bends (``d²q/ds²``) needs ``|d²q/ds²|·ṡ²`` of acceleration to follow it: at most
        ``share·a_b``. The time law's own ramps bound ṡ by ``√(2·a·min(s, 1 − s))`` near the
        ends, so only samples where that is higher constrain ``v``. Only the joints of
        ``side``'s arm count, and only where they are farther than LIMIT_MARGIN from the limit
        (closer is the near-limit rule of :meth:`check`; waist and vehicle riding their
        limits are made up for by the arm)."""
        if len(self.path_q) < 3:
            return v, None
        q = np.array(self.path_q)
        s = np.array(self.path_s)
        if np.any(np.diff(s) <= 0.0):
            return v, None
        slope = np.gradient(q, s, axis=0)
        dist = np.where(slope > 0.0, self.q_max - q, q - self.q_min)
        brake = share * BRAKING_SHARE * self.a_max
        speed = np.abs(slope)
        bend = np.abs(np.gradient(slope, s, axis=0))
        with np.errstate(divide="ignore", invalid="ignore"):
            cap = np.where(
                speed > 1e-9, np.sqrt(2.0 * brake * np.maximum(dist, 0.0)) / speed, np.inf
            )
            cap = np.minimum(cap, np.where(bend > 1e-9, np.sqrt(brake / bend), np.inf))
        ramp = np.sqrt(2.0 * a * np.minimum(s, 1.0 - s))[:, None]
        arm = self._arm_mask(side)[None, :] & (dist > LIMIT_MARGIN)
        cap = np.where(arm & (cap < np.minimum(ramp, v)), cap, np.inf)
        k, j = np.unravel_index(int(np.argmin(cap)), cap.shape)
        if not math.isfinite(float(cap[k, j])):
            return v, None
        return float(cap[k, j]), (self.kin.joint_names[j], float(s[k]), float(dist[k, j]))

    def solve_pose(
        self,
        live: Kinematics,
        side: RightLeft,
        target: pin.SE3,
        setup: IKSetup,
        hold: RightLeft | None = None,
    ) -> tuple[np.ndarray, str | None]:
        """Joint configuration putting ``side``'s control point on ``target`` (original frame)
        from ``live.q`` under ``setup``'s limits, masks and ranges (for PTP-Cartesian moves).

        Returns ``(q, None)``, or ``(closest q, reason)`` when out of reach. The joint path
        from ``live.q`` to ``q`` is not checked (a PTP move interpolates joints, not poses).
        """
        q, held = self._start(live, setup, hold)
        # Approach in steps so the local IK does not fold the arm through a limit.
        path = LinePath(self.kin.pose(side), target)
        too_long = _too_long(path, 0.05, math.radians(10))
        if too_long is not None:
            return q, too_long
        end = self._coarse(q, side, path, setup, hold, held)
        if end is None:
            return self.last_q, f"the target is not reachable: {self._coarse_error}"
        return end, None

    def _coarse(
        self,
        q: np.ndarray,
        side: RightLeft,
        path: LinePath | ArcPath,
        setup: IKSetup,
        hold: RightLeft | None,
        held: pin.SE3 | None,
    ) -> np.ndarray | None:
        """The end of ``path`` solved from ``q`` in coarse steps (5 cm, 10 deg: the local IK
        does not fold the arm through a limit), the null space drawn to ``q``; None when a
        step fails (:attr:`last_q` and :attr:`_coarse_error` say where and why)."""
        q0 = q.copy()
        held_axes = [a for a in self.axes if not setup.allowed.get(a, True)]
        for s in path.samples(0.05, math.radians(10))[1:]:
            q, err = self._solve(q, side, path.at(s), setup.frozen, hold, held, None, q0, held_axes)
            if err is not None:
                self.last_q, self._coarse_error = q, err
                return None
        return q

    def _start(
        self, live: Kinematics, setup: IKSetup, hold: RightLeft | None
    ) -> tuple[np.ndarray, pin.SE3 | None]:
        """Planning copy at ``live``'s state under ``setup``; the held arm's pose, if any."""
        kin = self.kin
        kin.copy_frames_from(live)
        q = live.q.copy()
        kin.update(q)
        self.rows.configure(kin, setup.allowed, setup.ranges, setup.frozen)
        return q, (kin.pose(hold) if hold is not None else None)

    def conditioning(
        self,
        side: RightLeft,
        hold: RightLeft | None,
        frozen: np.ndarray,
        held_axes: list[RedundantAxis],
    ) -> float:
        """Smallest singular value [m/rad] of the control-point Jacobian(s) over the free
        joints, restricted to motions that keep the held axes (at the last update)."""
        kin = self.kin
        free = ~frozen
        sides = [side] if hold is None else [side, hold]
        jac = np.vstack([kin.jacobian(s)[:, free] for s in sides])
        for i in range(len(sides)):
            jac[6 * i + 3 : 6 * i + 6] *= ROTATION_SCALE
        rows = [axis_jacobian(kin, a)[free] for a in held_axes]
        rows = [r for r in rows if np.abs(r).max(initial=0.0) > 0.0]
        if rows:
            constraint = np.vstack(rows)
            _, sv, vt = np.linalg.svd(constraint)
            rank = int(np.sum(sv > 1e-9 * max(1.0, float(sv[0]))))
            jac = jac @ vt[rank:].T
        if jac.shape[1] < jac.shape[0]:
            return 0.0
        return float(np.linalg.svd(jac, compute_uv=False)[-1])

    def _solve(
        self,
        q: np.ndarray,
        side: RightLeft,
        target: pin.SE3,
        frozen: np.ndarray,
        hold: RightLeft | None,
        held: pin.SE3 | None,
        elbow: tuple[RedundantAxis, float] | None = None,
        posture: np.ndarray | None = None,
        held_axes: Sequence[RedundantAxis] = (),
    ) -> tuple[np.ndarray, str | None]:
        """Position-level IK toward ``target`` (and the held pose) from ``q``; ``elbow``: an
        elbow angle [rad] to approach as well, best-effort (retried without it when the pose
        cannot be reached with it). ``posture``: the configuration the null space of the
        tasks and the ``held_axes`` is drawn to (:mod:`controller.motion.posture`)."""
        kin = self.kin
        start = q
        free = ~frozen
        # Held axes whose rows involve a free joint (the others cannot move anyway).
        held_axes = [a for a in held_axes if np.abs(axis_jacobian(kin, a)[free]).max() > 0.0]
        axis_rows: list[np.ndarray] = []
        reached = 0  # iterations with the pose reached
        on_pose: np.ndarray | None = None  # the last configuration that reached it
        weights: np.ndarray | None = None
        for k in range(MAX_ITER):
            if k == MAX_ITER // 2:
                posture = None  # not there yet: the pose alone from here on
            kin.update(q)
            jacs = [kin.jacobian(side)]
            errs = [pose_error(target, kin.pose(side))]
            if hold is not None and held is not None:
                jacs.append(kin.jacobian(hold))
                errs.append(pose_error(held, kin.pose(hold)))
            pos = max(float(np.linalg.norm(e[:3])) for e in errs)
            ang = max(float(np.linalg.norm(e[3:])) for e in errs)
            swing = 0.0
            if elbow is not None and kin.elbow_offset(elbow[0].side) > HOLD_MIN_ELBOW_OFFSET:
                swing = math.remainder(elbow[1] - axis_value(kin, elbow[0]), math.tau)
                jacs.append(ELBOW_WEIGHT * axis_jacobian(kin, elbow[0])[None, :])
                errs.append(np.array([ELBOW_WEIGHT * swing]))
            jac = np.vstack(jacs)
            null = None
            if posture is not None:
                if held_axes:  # held axes' rows move with the configuration
                    axis_rows = [axis_jacobian(kin, a)[None, :] for a in held_axes]
                if weights is None:  # once per sample: they change little within one
                    weights = limit_weights(q, self.q_min, self.q_max)
                null = null_step(np.vstack([jac, *axis_rows]), free, q, posture, weights)
                null *= NULL_GAIN / max(1.0, float(np.abs(null).max()) / MAX_NULL_STEP)
            if pos < POSITION_TOL and ang < ANGLE_TOL and abs(swing) < ELBOW_TOL:
                if null is None or reached >= NULL_ITER or float(np.abs(null).max()) < NULL_TOL:
                    return q, None
                reached += 1
                on_pose = q
            err = np.concatenate(errs)
            H = jac.T @ jac + DAMPING * np.eye(kin.nv)
            g = -jac.T @ err
            if null is not None:
                g -= DAMPING * null  # damped toward the posture step, not toward standing still
            lb = np.maximum(self.q_min - q, -MAX_STEP)
            ub = np.minimum(self.q_max - q, MAX_STEP)
            lb[frozen] = ub[frozen] = 0.0
            lb, ub = np.minimum(lb, 0.0), np.maximum(ub, 0.0)  # outside a limit: not worse
            C, lo, hi = self.rows.rows(kin, lb, ub)
            dq = self.solver.solve(H, g, C, lo, hi, lb, ub)
            if dq is None:
                if on_pose is not None:
                    kin.update(on_pose)
                    return on_pose, None
                why = self._describe(q, pos, ang, frozen)
                return q, f"{why} (no step keeps the limits and the held axes)"
            if float(np.abs(dq).max()) < 1e-9:
                break  # stuck
            q = q + np.clip(dq, lb, ub)
        if on_pose is not None:
            kin.update(on_pose)
            return on_pose, None  # the pose was reached; the posture as near as it got
        if elbow is not None:
            kin.update(q)
            errs = [pose_error(target, kin.pose(side))]
            if hold is not None and held is not None:
                errs.append(pose_error(held, kin.pose(hold)))
            if all(
                np.linalg.norm(e[:3]) < POSITION_TOL and np.linalg.norm(e[3:]) < ANGLE_TOL
                for e in errs
            ):
                return q, None  # the pose is reached; the elbow as near as it gets
            # The pose first: this sample again without the elbow.
            return self._solve(start, side, target, frozen, hold, held, None, posture, held_axes)
        return q, self._describe(q, pos, ang, frozen)

    def _describe(self, q: np.ndarray, pos: float, ang: float, frozen: np.ndarray) -> str:
        at_limit = [
            name
            for i, name in enumerate(self.kin.joint_names)
            if not frozen[i] and (q[i] - self.q_min[i] < 1e-4 or self.q_max[i] - q[i] < 1e-4)
        ]
        text = f"closest pose is {pos * 1e3:.1f} mm and {math.degrees(ang):.2f} deg away"
        if at_limit:
            text += f"; joints at their limits: {', '.join(at_limit)}"
        return text


def _too_long(path: LinePath | ArcPath, step: float, angle_step: float) -> str | None:
    """Why ``path`` has too many samples to check (more than :data:`MAX_SAMPLES`), or None."""
    if max(path.length / step, path.angle / angle_step) <= MAX_SAMPLES:
        return None
    return (
        f"the path is too long to check ({1e3 * path.length:.0f} mm, at most "
        f"{1e3 * step * MAX_SAMPLES:.0f} mm per move)"
    )

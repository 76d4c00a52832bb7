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

What is checked is what runs. A redundant arm can follow the path with many joint motions;
every sample is solved from the previous one (:class:`~controller.motion.position_ik.
PositionIK`) for the null-space objective of :mod:`controller.motion.posture`: near a posture
moving from the start to the end configuration (the end found first in coarse steps), out
of the zones next to the joint limits, joints near a limit weighed up. Where a joint moves
more than JUMP_ANGLE between samples the interval is halved; a step that stays that large
down to MAX_SPLITS halvings is a change of IK branch, and the path is checked again with the
posture passing through the far side of it (ANCHORS times), then refused naming the joint.
A pass cannot be run past its first jump: from there on its samples are not split, and
whatever refuses it (a pose out of reach, a singularity) is checked again the same way.
Splitting there cost up to 63 solves per sample where a stretched arm's IK alternates
between two branches: SmartPal V refused a line 0.8 m forward (elbow and waist free) after
1571 IK solves, about 10 s on a loaded 2-core machine; 275 now. A refusal says where, as a
share of the path and in mm (deg for a turn in place).
The recorded joint path (:attr:`ReachabilityChecker.path_q`) goes with the motion and the
loop's null space follows it, so the loop runs the checked motion and ends where the check
did. (Before: minimum-norm steps here, a posture drawn to the start in the loop: SmartPal
V's hand 100 mm up from home was checked with r_arm_j6 short of its limit and an 11 deg
branch change of r_arm_j2, while the loop braked r_arm_j6 on its limit and ended 2 s late.)

Runs on its own :class:`~controller.model.kinematics.Kinematics` (the loop owns the live one).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import (
    RedundantAxis,
    available_axes,
    elbow_axis,
)
from controller.motion.motions import IKSetup
from controller.motion.path_rates import braking_speed_limit, parameter_limits
from controller.motion.paths import ArcPath, LinePath, VectorPath
from controller.motion.position_ik import PositionIK
from controller.motion.posture import off_limits
from controller.qp.constraints import AxisRows
from controller.vocabulary import RightLeft, UnitType

#: Samples at most this far apart along the path.
SAMPLE_STEP = 0.01
SAMPLE_ANGLE = math.radians(2)
#: Most samples one check follows (100 m at 1 cm): bounds the time and memory of a request;
#: a longer path is refused (the gateway's reach check refuses far targets before this).
MAX_SAMPLES = 10_000
#: Smallest singular value [m/rad] of the constrained control-point Jacobian along a path.
MIN_SINGULAR = 0.04
#: A Cartesian path may not take a joint of the moving arm (any free joint, when the
#: constrained arm has no redundancy left) closer than this to a limit [rad] / [m] unless it
#: started there: the live IK brakes the joint before its limit and the rest cannot make up
#: for it at speed, so the hand leaves the line (issue 16.2, SmartPal V: 6.5 mm off the line
#: with r_arm_j6 on its limit; 1.8 mm with it 0.05 deg from its limit, elbow free). Waist
#: and vehicle joints riding their limits are made up for by the arm.
LIMIT_MARGIN = math.radians(0.2)
LIMIT_MARGIN_M = 0.2e-3
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


class ReachabilityChecker:
    """Follows candidate paths with a position-level IK on a planning copy of the robot."""

    def __init__(self, kin: Kinematics):
        self.kin = Kinematics(kin.robot)
        self.axes = available_axes(self.kin)
        self.rows = AxisRows(self.kin, self.axes, 1.0)
        specs = [self.kin.robot.joints[n] for n in self.kin.joint_names]
        self.q_min = np.array([s.lower for s in specs])
        self.q_max = np.array([s.upper for s in specs])
        #: One pose at a time (shares ``q_min``, ``q_max``: :meth:`Planner.set_joint_limits`
        #: narrows them in place).
        self.ik = PositionIK(self.kin, self.rows, self.q_min, self.q_max)
        self._band = (self.q_min, self.q_max)
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
        held_axes = self.ik.moving_axes(held_axes, setup.frozen)
        rigid = self.ik.redundancy(side, hold, setup.frozen, held_axes) <= 0
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
            # A pass that jumped is never run; past its first jump it was followed without
            # splitting (:meth:`_follow`), so whatever it found there is checked again too.
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
        between). Returns why the path is refused (None: it is not) and, when the pass
        jumped between branches, the path parameter and configuration after the first jump
        (whatever refused the pass: past that jump it was followed without splitting)."""
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
            posture = off_limits(poses[k] + t * (poses[k + 1] - poses[k]), s, *self._band)
            start = q_from if goal is not None else self._predict(q_from, s)
            return self.ik.solve(
                start, side, path.at(s), setup.frozen, hold, held, goal, posture, held_axes
            )

        s_prev = float(samples[0])
        for s_next in samples[1:]:
            # Past the first jump the pass cannot be run as it is (it is checked again with
            # an anchor, or refused): its samples are no longer split. Splitting there only
            # sampled a path never run, at up to 2**(MAX_SPLITS+1) - 1 solves per sample
            # where the IK alternates between two branches (SmartPal V reaching 1.5 m
            # forward: r_arm_j4 swinging 13 deg at every split, 1398 solves to refuse).
            splits = MAX_SPLITS if jumped is None else 0
            for s, q_s, err in self._segment(q, s_prev, float(s_next), solve, splits):
                jump = self._jump(q, q_s)
                q = q_s
                self.last_q = q
                self.path_s.append(s)
                self.path_q.append(q.copy())
                where = _where(path, s)
                if err is not None:
                    return f"{where} is not reachable: {err}", _anchor(jumped)
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
            where = _where(path, s_prev)
            if near is None:
                # Without redundancy any free joint counts, else the moving arm's own.
                watched = ~setup.frozen if rigid else self._arm_mask(side)
                close = self._near_limit(q, self.path_q[0], watched)
                if close is not None:
                    near = (where, *close)
            sigma = self.ik.conditioning(side, hold, setup.frozen, held_axes)
            if sigma < MIN_SINGULAR:
                return (
                    f"{where} is too close to a singular configuration (smallest singular "
                    f"value {sigma:.3f} m/rad, need {MIN_SINGULAR}): it could not be followed "
                    "at speed; allow more redundant axes or choose another target"
                ), _anchor(jumped)
        if jumped is not None:
            return jumped[0], _anchor(jumped)
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
        splits: int = MAX_SPLITS,
    ) -> list[tuple[float, np.ndarray, str | None]]:
        """The samples ``(s, q, why not)`` from ``s0`` (solved: ``q``) to ``s1``: one, or
        halves (up to ``splits`` times) while a joint moves more than the jump bound between
        them, so a continuous joint path is sampled densely where it is fast and a jump left
        at the finest split is a change of branch (:meth:`_jump`). Past such a jump the
        rest is not split (see :meth:`_follow`)."""
        q1, err = solve(q, s1)
        if splits <= 0 or (err is None and self._jump(q, q1) is None):
            return [(s1, q1, err)]
        mid = 0.5 * (s0 + s1)
        first = self._segment(q, s0, mid, solve, splits - 1)
        _, q_mid, err_mid = first[-1]
        if err_mid is not None:
            return first
        qs = [q, *(piece[1] for piece in first)]
        jumped = any(self._jump(a, b) is not None for a, b in itertools.pairwise(qs))
        return first + self._segment(q_mid, mid, s1, solve, 0 if jumped else splits - 1)

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
        """:func:`~controller.motion.path_rates.parameter_limits` of the last checked path."""
        return parameter_limits(self.path_s, self.path_q, self.v_max, self.a_max, share)

    def braking_speed_limit(
        self, side: RightLeft, v: float, a: float, share: float = 0.8
    ) -> tuple[float, tuple[str, float, float] | None]:
        """:func:`~controller.motion.path_rates.braking_speed_limit` of the last checked path
        for ``side``'s arm joints farther than LIMIT_MARGIN from their limits (closer is the
        near-limit rule of :meth:`check`; waist and vehicle riding their limits are made up
        for by the arm)."""
        cap, worst = braking_speed_limit(
            self.path_s,
            self.path_q,
            (self.q_min, self.q_max, self.a_max),
            self._arm_mask(side),
            LIMIT_MARGIN,
            (v, a, share),
        )
        if worst is None:
            return cap, None
        j, s, dist = worst
        return cap, (self.kin.joint_names[j], s, dist)

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
        # A PTP move runs a joint-space line to the goal: no null space to agree on.
        end = self._coarse(q, side, path, setup, hold, held, posture_pull=False)
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
        posture_pull: bool = True,
    ) -> np.ndarray | None:
        """The end of ``path`` solved from ``q`` in coarse steps (5 cm, 10 deg: the local IK
        does not fold the arm through a limit), the null space drawn to ``q`` moved off the
        limits along the path (``posture_pull`` False: minimum-norm steps); None when a step
        fails (:attr:`last_q` and :attr:`_coarse_error` say where and why)."""
        q0 = q.copy()
        held_axes = [a for a in self.axes if not setup.allowed.get(a, True)]
        held_axes = self.ik.moving_axes(held_axes, setup.frozen)
        posture = q0 if posture_pull else None
        for s in path.samples(0.05, math.radians(10))[1:]:
            if posture is not None:
                posture = off_limits(q0, s, *self._band)
            q, err = self.ik.solve(
                q, side, path.at(s), setup.frozen, hold, held, None, posture, held_axes
            )
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


def _where(path: LinePath | ArcPath, s: float) -> str:
    """Where ``s`` is on ``path`` for a refusal: the target, or the share of the path and how
    far along it that is [mm] (or [deg] for a turn in place)."""
    if s >= 1.0:
        return "the target"
    if path.length > 0.0:
        along = f"{1e3 * s * path.length:.0f} of {1e3 * path.length:.0f} mm"
    else:
        along = f"{math.degrees(s * path.angle):.0f} of {math.degrees(path.angle):.0f} deg"
    return f"the path at {100 * s:.0f} % ({along})"


def _anchor(
    jumped: tuple[str, float, np.ndarray] | None,
) -> tuple[float, np.ndarray] | None:
    """The path parameter and configuration after a pass's first jump, if it jumped."""
    return None if jumped is None else (jumped[1], jumped[2])


def _too_long(path: LinePath | ArcPath, step: float, angle_step: float) -> str | None:
    """Why ``path`` has too many samples to check (more than :data:`MAX_SAMPLES`), or None."""
    if max(path.length / step, path.angle / angle_step) <= MAX_SAMPLES:
        return None
    return (
        f"the path is too long to check ({1e3 * path.length:.0f} mm, at most "
        f"{1e3 * step * MAX_SAMPLES:.0f} mm per move)"
    )

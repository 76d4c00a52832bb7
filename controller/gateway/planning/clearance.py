"""Clearance along planned paths: a Cartesian move whose target or path would bring two bodies
(or a body and a static obstacle) closer than the security distance d_s is refused before
anything moves.

The same collision model the controller uses (:class:`controller.model.collision.
CollisionDistances` on the checked pairs of ``collision.yaml``, plus the daemon's
``obstacles``) is evaluated at every configuration the planner already computes for the path:
the reachability checker's samples of a linear move (1 cm / 2 deg apart), the joint-space line
of a PTP move (0.01 rad / 1 cm apart), both arms' paths of a dual move combined at the same
path parameter, every step of a CP-hold dry run.

A pair already closer than d_s where the move starts (a held object, a pose reached before
the obstacles were configured) is not held to d_s: it may not get closer than it is (less
:data:`START_SLACK`), so a move that takes it away is accepted.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from controller.model.collision_pairs import robot_distances
from controller.model.kinematics import Kinematics
from controller.model.obstacles import Obstacle, is_obstacle

#: A pair closer than d_s at the start may get this much closer before a move is refused
#: (the IK's rounding along a path) [m].
START_SLACK = 1e-3
#: Largest joint step between two checked configurations of a joint-space line [rad or m].
JOINT_STEP = 0.01


class ClearanceCheck:
    """Distances along a planned path, with a refusal comment naming the two bodies.

    Not thread-safe (one per planner, used under its lock)."""

    def __init__(
        self,
        kin: Kinematics,
        obstacles: Sequence[Obstacle] = (),
        security_distance: float | None = None,
    ):
        """``security_distance``: the closest a path may bring two bodies [m] (None: the
        profile's ``collision_avoidance``: security distance d_s + planning margin)."""
        settings = kin.robot.profile.collision_avoidance
        if security_distance is None:
            security_distance = settings.planning_distance
        self.security_distance = security_distance
        #: How the comment explains the distance.
        self._why = (
            f"closest allowed {1e3 * security_distance:.0f} mm: security distance "
            f"{1e3 * settings.security:.0f} mm + planning margin "
            f"{1e3 * (security_distance - settings.security):.0f} mm"
        )
        self.distances = robot_distances(kin, obstacles)
        self._floor = np.full(len(self.distances), security_distance)

    def start(self, q0: np.ndarray) -> None:
        """Where the move starts: pairs closer than d_s there keep their distance as floor."""
        self.distances.compute(q0)
        self._floor = np.minimum(self.security_distance, self.distances.distances - START_SLACK)

    def problem_at(self, q: np.ndarray, at: str, what: str = "the path") -> str | None:
        """Why ``q`` is too close (after :meth:`start`), or None; ``at`` says where ``q`` is
        ("at 45 % of the path", "at the target") for the comment."""
        dist = self.distances
        dist.compute(q)
        if not len(dist):
            return None
        gap = dist.distances - self._floor
        k = int(np.argmin(gap))
        return self.describe(k, what, at) if gap[k] < 0.0 else None

    def path_problem(
        self, qs: Sequence[np.ndarray], where: Sequence[str], what: str = "the path"
    ) -> str | None:
        """Why the configurations ``qs`` (the first one: where the move starts) come too
        close, or None; ``where[k]`` says where ``qs[k]`` is, for the comment."""
        if len(qs) < 2:
            return None
        self.start(qs[0])
        for q, at in zip(qs[1:], where[1:], strict=True):
            reason = self.problem_at(q, at, what)
            if reason is not None:
                return reason
        return None

    def describe(self, k: int, what: str, at: str) -> str:
        """The refusal comment for pair ``k`` at its current distance."""
        a, b = self.distances.pair_links[k]
        if not is_obstacle(b):
            a, b = b, a  # the link further down the tree (it moves more) first
        d = float(self.distances.distances[k])
        how = f"within {1e3 * d:.1f} mm of" if d >= 0.0 else f"{-1e3 * d:.1f} mm into"
        return f"{what} would bring {a} {how} {b} ({self._why}) {at}"

    def sampled_path_problem(self, s: Sequence[float], qs: Sequence[np.ndarray]) -> str | None:
        """:meth:`path_problem` for samples of a Cartesian path at parameters ``s`` (0..1)."""
        return self.path_problem(qs, [_at(float(x)) for x in s])

    def joint_line_problem(self, q0: np.ndarray, q1: np.ndarray) -> str | None:
        """:meth:`path_problem` along the straight joint-space line ``q0`` → ``q1`` (a PTP
        move; Ruckig's time-synchronised profiles stay close to it)."""
        n = max(2, math.ceil(float(np.abs(q1 - q0).max(initial=0.0)) / JOINT_STEP) + 1)
        s = [k / (n - 1) for k in range(n)]
        return self.sampled_path_problem(s, [q0 + x * (q1 - q0) for x in s])


def _at(s: float) -> str:
    return "at the target" if s >= 1.0 else f"at {100 * s:.0f} % of the path"


def combine(
    q0: np.ndarray, paths: Sequence[tuple[np.ndarray, Sequence[float], Sequence[np.ndarray]]]
) -> tuple[list[float], list[np.ndarray]]:
    """Arms moving together at one path parameter: each path ``(joints, s, qs)`` (its arm's
    joint indices, samples) interpolated at the union of the samples, on top of ``q0``."""
    grid = sorted({float(x) for _, s, _ in paths for x in s} | {0.0})
    out = [q0.copy() for _ in grid]
    for joints, s, qs in paths:
        values = np.array([q[joints] for q in qs])
        for q, x in zip(out, grid, strict=True):
            q[joints] = [np.interp(x, s, values[:, j]) for j in range(len(joints))]
    return grid, out


__all__ = ["ClearanceCheck", "combine"]

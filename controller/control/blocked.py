"""A motion held back by the collision rows: detected, stopped on its path, reported once.

When the QP's collision rows bind (a pair is at the security distance or approaching as fast
as its damper allows) the tasks cannot be followed there: a CP-hold pushing an elbow into the
body would otherwise keep pushing, or slide along the body away from its path. The motion
core watches every cycle: a row binding near the security distance (BLOCKED_GAP) *and* the
tracking error above BLOCKED_ERROR and not shrinking for BLOCKED_TIME means the motion is
blocked. The core then stops it on its path
(as ``stop``: the time law decelerates), raises one MOTION_BLOCKED warning naming the two
links, and ends the motion once its time law has stopped (held still, Ready).
"""

from __future__ import annotations

import numpy as np

from controller.model.kinematics import Kinematics
from controller.motion.arrival import tracking_error
from controller.qp.constraints.collision import CollisionAvoidance
from controller.qp.tasks import Task

#: Tracking error [m] (see :func:`controller.motion.arrival.tracking_error`) above which a
#: motion whose collision rows bind is not following its path.
BLOCKED_ERROR = 0.005
#: For this long [s] without progress: blocked.
BLOCKED_TIME = 0.2
#: Only a pair within this share of (d_i − d_s) above d_s counts: held at the body, not
#: merely slowed by its damper on the way there.
BLOCKED_GAP = 0.2
#: Progress [m]: the tracking error shrinking by this much restarts the watch.
PROGRESS = 1e-4


class BlockWatch:
    """Per cycle: which pair's row binds (-1: none) and the tracking error [m]."""

    def __init__(self, error: float = BLOCKED_ERROR, time: float = BLOCKED_TIME):
        self.error = error
        self.time = time
        self.reset()

    def reset(self) -> None:
        """Forget what was seen (a new motion, or progress)."""
        self._elapsed = 0.0
        self._best = float("inf")

    def observe(self, pair: int, error: float, step: float) -> bool:
        """One cycle of ``step`` [s]: True when the motion is blocked (every cycle from then
        on until :meth:`reset`)."""
        if pair < 0 or error < self.error:
            self.reset()
            return False
        if error < self._best - PROGRESS:  # still getting closer to the path: progress
            self._best = error
            self._elapsed = 0.0
            return False
        self._elapsed += step
        return self._elapsed >= self.time

    def check(
        self,
        rows: CollisionAvoidance,
        v: np.ndarray,
        kin: Kinematics,
        tasks: list[Task],
        step: float,
    ) -> str | None:
        """One cycle of ``step`` [s] with commanded velocity ``v`` [rad/s, m/s]: None, or
        (once blocked) what blocks the motion, for the warning."""
        pair = rows.binding(v, rows.security + BLOCKED_GAP * rows.span)
        error = tracking_error(kin, tasks) if pair >= 0 else 0.0
        if not self.observe(pair, error, step):
            return None
        a, b = rows.distances.pair_links[pair]
        gap = rows.distances.distances[pair]
        return (
            f"motion stopped on its path: {a} and {b} are {gap * 1e3:.1f} mm apart and may "
            f"not come closer than {rows.security * 1e3:g} mm"
        )

"""A motion command between its acceptance and its start, its motion built in the slack.

Building a motion from its spec (path, time law, the set-up of its checks) and starting it
(the IK's tasks and limits), then the motion's first cycle, are the dearest work of the
control loop: one step that carried the build and the start overran a 1 ms period in a
third to a half of the starts (``tools/bench_loop.py``). So the control process spreads a
start over three steps:

1. step N accepts the command: the refusals that depend on the state or on the plan answer
   at once; the accepted spec becomes a :class:`PendingStart`;
2. the slack after step N builds its motion (:meth:`PendingStart.build`: on the live
   kinematics, set to the configuration the spec was planned from and back);
3. step N+1 starts it after its cycle and answers; the motion's first cycle is step N+2's.

Nothing else touches the motion core meanwhile: the commands waiting behind an accepted
start wait for step N+1 (they see the motion started), and an urgent command (stop, pause,
abort, servo off) arriving first starts it before it acts, so commands act in the order
they were accepted. Where no slack ran (a loop without one, or a test stepping by hand) the
start builds the motion itself.
"""

from __future__ import annotations

from typing import Any

from controller.contract.motion_specs import MotionSpec
from controller.model.kinematics import Kinematics
from controller.motion.motions import Motion


class PendingStart:
    """``spec`` accepted, its motion not yet started; ``request``: the command waiting for
    the answer (None for a motion from the queue, which raises an alarm if it cannot
    start)."""

    def __init__(self, spec: MotionSpec, request: Any = None):
        self.spec = spec
        self.request = request
        #: The motion, once built.
        self.motion: Motion | None = None
        #: Why it could not be built (raised again by :meth:`take`).
        self.error: Exception | None = None

    @property
    def built(self) -> bool:
        """Whether :meth:`build` ran (a motion or an error)."""
        return self.motion is not None or self.error is not None

    def build(self, kin: Kinematics, dt: float) -> None:
        """Build the motion the gateway checked, once (period ``dt`` [s]); an exception is
        kept for :meth:`take`. It is built at the configuration it was planned from
        (``spec.planned_from``; the JARA queue's planned end for a queued motion:
        :meth:`MotionSpec.build_as_planned`), so its path and time law are the checked ones,
        not a re-plan from where the robot happens to be; the motion then runs on the live
        kinematics ``kin``. A motion started at once was refused before this if the robot
        moved more than ``PLAN_TOLERANCE`` since planning."""
        if self.built:
            return
        try:
            self.motion = self.spec.build_as_planned(kin, dt)
        except Exception as exc:  # answered (or raised as an alarm) at the start
            self.error = exc

    def take(self, kin: Kinematics, dt: float) -> Motion:
        """The motion (built now if no slack built it); raises what the build raised."""
        self.build(kin, dt)
        if self.error is not None:
            raise self.error
        assert self.motion is not None
        return self.motion

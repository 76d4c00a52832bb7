"""Streamed joint set-points (JARA_ARM ``...CmdCycle`` moves): blended, not rest-to-rest.

A client sends a new set-point every command cycle ``period`` [s]. Each one becomes the
target of one online time law per joint (Ruckig, n DoF) with the stream's velocity at that
point, ``(p_k − p_{k−1}) / period``, as target velocity, so the joints pass through the
set-points without stopping. When no new set-point arrives within 1.5 periods, the target
velocity drops to zero and the joints come to rest on the last set-point; the motion then
ends. Stop and pause brake every joint at its acceleration limit; resume continues toward
the last set-point.
"""

from __future__ import annotations

import numpy as np
from ruckig import ControlInterface, InputParameter, OutputParameter, Result, Ruckig

from controller.model.kinematics import Kinematics
from controller.motion.motions import IKSetup, Motion, _posture
from controller.qp.tasks import PostureTask

#: Time to build up full acceleration [s] (sets the jerk limits).
JERK_TIME = 0.05
#: A stream is over when no set-point came for this many periods.
STALE_PERIODS = 1.5


class JointStreamMotion(Motion):
    """Joints ``joints`` (indices in q) following streamed set-points [rad, m].

    ``v_max``/``a_max`` per joint; ``period``: the client's command cycle [s].
    """

    def __init__(
        self,
        kin: Kinematics,
        dt: float,
        joints: np.ndarray,
        target: np.ndarray,
        v_max: np.ndarray,
        a_max: np.ndarray,
        period: float,
        key: str = "",
    ):
        self.kin = kin
        self.dt = dt
        self.joints = np.asarray(joints, dtype=int)
        self.period = period
        #: Streams with the same key extend each other (e.g. "RIGHT").
        self.key = key
        n = len(self.joints)
        self._otg = Ruckig(n, dt)
        self._in = InputParameter(n)
        self._out = OutputParameter(n)
        start = kin.q[self.joints].copy()
        self._in.current_position = start.tolist()
        self._in.current_velocity = [0.0] * n
        self._in.current_acceleration = [0.0] * n
        self._in.max_velocity = np.asarray(v_max, dtype=float).tolist()
        self._in.max_acceleration = np.asarray(a_max, dtype=float).tolist()
        self._in.max_jerk = (np.asarray(a_max, dtype=float) / JERK_TIME).tolist()
        self.track = PostureTask(kin.q.copy(), self.joints, gain=20.0, weight=1.0, level=1)
        self._last_target = start
        self._age = 0.0
        self._done = False
        self._paused = False
        self._stopping = False
        self._settling = False
        self.extend(target)

    # ------------------------------------------------------------------ stream
    def extend(self, target: np.ndarray) -> None:
        """A new set-point [rad, m] (same joints): aim at it with the stream's velocity."""
        target = np.asarray(target, dtype=float)
        self._velocity = (target - self._last_target) / self.period
        self._last_target = target.copy()
        self._age = 0.0
        self._done = False
        self._settling = False
        if not (self._paused or self._stopping):
            self._aim(self._velocity)

    def _aim(self, velocity: np.ndarray) -> None:
        """Aim at the last set-point, arriving with ``velocity`` where that is reachable:
        only in the direction of the set-point and no faster than the joint can accelerate
        to over the remaining distance (else Ruckig would back up to gain speed)."""
        now = np.asarray(self._in.current_position)
        v_now = np.asarray(self._in.current_velocity)
        a_max = np.asarray(self._in.max_acceleration)
        v_max = np.asarray(self._in.max_velocity)
        dist = self._last_target - now
        reachable = np.sqrt(np.maximum(v_now**2 + a_max * np.abs(dist), 0.0))
        same_way = np.sign(velocity) == np.sign(dist)
        v = np.where(same_way, np.sign(velocity) * np.minimum(np.abs(velocity), reachable), 0.0)
        self._in.control_interface = ControlInterface.Position
        self._in.target_position = self._last_target.tolist()
        self._in.target_velocity = np.clip(v, -v_max, v_max).tolist()
        self._in.target_acceleration = [0.0] * len(self.joints)

    def _brake(self) -> None:
        self._in.control_interface = ControlInterface.Velocity
        self._in.target_velocity = [0.0] * len(self.joints)
        self._in.target_acceleration = [0.0] * len(self.joints)

    # ------------------------------------------------------------------ Motion
    def setup(self) -> IKSetup:
        frozen = np.ones(self.kin.nv, dtype=bool)
        frozen[self.joints] = False
        return IKSetup([self.track, _posture(self.kin)], frozen)

    def apply(self, s0: float, s1: float, dt: float) -> None:
        raise NotImplementedError("a stream has no path parameter: advance() drives it")

    def advance(self, dt: float | None = None) -> None:
        if dt is not None and dt != self.dt:
            self.dt = dt
            self._otg.delta_time = dt
        if self._done:
            return
        self._age += self.dt
        stale = self._age > STALE_PERIODS * self.period
        if stale and not (self._settling or self._paused or self._stopping):
            self._aim(np.zeros(len(self.joints)))  # the stream dried up: settle on the last
            self._settling = True
        now = np.array(self._in.current_position)
        try:
            result = self._otg.update(self._in, self._out)
        except Exception as exc:  # RuckigError is not a RuntimeError
            raise RuntimeError(f"Ruckig failed on the joint stream: {exc}") from exc
        if result not in (Result.Working, Result.Finished):
            raise RuntimeError(f"Ruckig failed on the joint stream: {result}")
        nxt = np.array(self._out.new_position)
        self._out.pass_to_input(self._in)
        self.track.reference[self.joints] = now
        self.track.rate = (nxt - now) / self.dt
        still = float(np.abs(np.asarray(self._in.current_velocity)).max()) < 1e-9
        if result == Result.Finished and still:
            if self._stopping or self._settling:
                self.track.reference[self.joints] = nxt
                self.track.rate = np.zeros(len(self.joints))
                self._done = True

    @property
    def finished(self) -> bool:
        return self._done

    @property
    def paused(self) -> bool:
        return self._paused and float(np.abs(np.asarray(self._in.current_velocity)).max()) < 1e-9

    def stop(self) -> None:
        self._stopping = True
        self._brake()

    def pause(self) -> None:
        if not self._stopping:
            self._paused = True
            self._brake()

    def resume(self) -> None:
        if self._paused:
            self._paused = False
            self._age = 0.0
            self._settling = True  # no stream velocity to resume to: settle on the last
            self._aim(np.zeros(len(self.joints)))

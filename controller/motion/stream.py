"""Streamed joint set-points (JARA_ARM ``...CmdCycle`` moves): blended, not rest-to-rest.

A client sends a new set-point every command cycle ``period`` [s]. Each one becomes the
target of one online time law per joint (Ruckig, n DoF) with the stream's velocity at that
point, ``(p_k − p_{k−1}) / period``, as target velocity, so the joints pass through the
set-points without stopping. When no new set-point arrives within 1.5 periods, the target
velocity drops to zero and the joints come to rest on the last set-point; the motion then
ends. Stop and pause brake every joint at its acceleration limit; resume continues toward
the last set-point.

Round-off: Ruckig (0.19) fails to synchronise the joints, now and then, when some of them
are within round-off of their set-point with round-off-sized speed and acceleration left
(a joint the stream barely moves: a Cartesian stream of 0.04 mm steps, whose IK solutions
change some joints by ~1e-15 rad). Such joints are put exactly on their set-point, at rest,
before each update (:data:`ROUND_OFF`); should Ruckig still fail, the update is redone with
each joint timed on its own (no synchronisation) before it counts as a failure.
"""

from __future__ import annotations

import numpy as np
from ruckig import (
    ControlInterface,
    InputParameter,
    OutputParameter,
    Result,
    Ruckig,
    Synchronization,
)

from controller.model.kinematics import Kinematics
from controller.motion.motions import IKSetup, Motion, _posture
from controller.qp.tasks import PostureTask

#: Time to build up full acceleration [s] (sets the jerk limits).
JERK_TIME = 0.05
#: A stream is over when no set-point came for this many periods.
STALE_PERIODS = 1.5
#: Round-off: distance to the set-point [rad, m], speed [/s] and acceleration [/s²] below
#: which a joint is put exactly on its set-point, at rest (see the module docstring).
ROUND_OFF = (1e-10, 1e-9, 1e-7)


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
    def _make_setup(self) -> IKSetup:
        frozen = np.ones(self.kin.nv, dtype=bool)
        frozen[self.joints] = False
        self._start_posture = _posture(self.kin)
        return IKSetup([self.track, self._start_posture], frozen)

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
        self._snap_round_off()
        now = np.array(self._in.current_position)
        result = self._update()
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

    def _snap_round_off(self) -> None:
        """Joints within round-off of a resting set-point: exactly there, at rest."""
        inp = self._in
        pos = np.asarray(inp.current_position)
        vel = np.asarray(inp.current_velocity)
        acc = np.asarray(inp.current_acceleration)
        target = np.asarray(inp.target_position)
        v_target = np.asarray(inp.target_velocity)
        if inp.control_interface == ControlInterface.Velocity:
            return  # braking: no set-point to snap to
        d_tol, v_tol, a_tol = ROUND_OFF
        snap = (
            (np.abs(target - pos) < d_tol)
            & (np.abs(vel) < v_tol)
            & (np.abs(acc) < a_tol)
            & (np.abs(v_target) < v_tol)
        )
        if snap.any():
            inp.current_position = np.where(snap, target, pos).tolist()
            inp.current_velocity = np.where(snap, 0.0, vel).tolist()
            inp.current_acceleration = np.where(snap, 0.0, acc).tolist()
            inp.target_velocity = np.where(snap, 0.0, v_target).tolist()

    def _update(self) -> Result:
        """One Ruckig update; redone without synchronisation if Ruckig fails (RuntimeError
        when that fails too: the core turns it into a time-law alarm)."""
        error: object = None
        for sync in (None, Synchronization.No):
            if sync is not None:
                self._in.synchronization = sync
            try:
                result = self._otg.update(self._in, self._out)
            except Exception as exc:  # RuckigError is not a RuntimeError
                error = exc
                continue
            finally:
                if sync is not None:
                    self._in.synchronization = Synchronization.Time
            if result in (Result.Working, Result.Finished):
                return result
            error = result
        raise RuntimeError(f"Ruckig failed on the joint stream: {error}")

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

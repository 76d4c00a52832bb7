"""Time law of a path: s ∈ [0, 1] driven by Ruckig, with stop, pause and resume.

Every motion is a fixed geometric path timed by one parameter ``s``, so every axis starts and
stops together and decelerating ``s`` (stop, pause) keeps the robot on the path. Limits on
``s`` come from the path: ṡ_max = min(axis speed / axis extent), and likewise for the
acceleration; jerk is ``s̈_max / JERK_TIME``.

States: RUNNING → DONE; RUNNING → STOPPING → DONE (stop: the rest of the path is dropped);
RUNNING → PAUSING → PAUSED → (resume) RUNNING.
"""

from __future__ import annotations

import enum

from ruckig import ControlInterface, InputParameter, OutputParameter, Result, Ruckig

#: Time [s] to build up full acceleration (sets the jerk limit).
JERK_TIME = 0.05


class ProfileState(enum.Enum):
    RUNNING = "running"
    STOPPING = "stopping"
    PAUSING = "pausing"
    PAUSED = "paused"
    DONE = "done"


class PathProfile:
    """Online 1-DoF time law for ``s`` from 0 to 1.

    ``v_max`` [1/s] and ``a_max`` [1/s²] bound ṡ and s̈; ``duration`` [s], when given, makes
    the motion last exactly that long (Ruckig's minimum duration) if the limits allow it.
    """

    def __init__(self, dt: float, v_max: float, a_max: float, duration: float | None = None):
        if not (v_max > 0 and a_max > 0):
            raise ValueError(f"path limits must be positive (v {v_max}, a {a_max})")
        self.dt = dt
        self._otg = Ruckig(1, dt)
        self._in = InputParameter(1)
        self._out = OutputParameter(1)
        self._in.current_position = [0.0]
        self._in.current_velocity = [0.0]
        self._in.current_acceleration = [0.0]
        self._in.max_velocity = [v_max]
        self._in.max_acceleration = [a_max]
        self._in.max_jerk = [a_max / JERK_TIME]
        self._in.target_position = [1.0]
        self._in.target_velocity = [0.0]
        if duration is not None:
            self._in.minimum_duration = duration
        self.state = ProfileState.RUNNING
        #: True once stop() ended the motion before the end of the path.
        self.stopped = False
        self.s = 0.0
        self.sd = 0.0
        self.sdd = 0.0

    @property
    def a_max(self) -> float:
        return float(self._in.max_acceleration[0])

    @property
    def finished(self) -> bool:
        return self.state == ProfileState.DONE

    def step(self, dt: float | None = None) -> None:
        """Advance one cycle of ``dt`` [s] (default: the nominal period; the motion core
        passes the measured one, so motion time follows the wall clock). No-op when paused
        or done."""
        if dt is not None and dt != self.dt:
            self.dt = dt
            self._otg.delta_time = dt
        if self.state in (ProfileState.PAUSED, ProfileState.DONE):
            self.sd = self.sdd = 0.0
            return
        result = self._update()
        self.s = float(self._out.new_position[0])
        self.sd = float(self._out.new_velocity[0])
        self.sdd = float(self._out.new_acceleration[0])
        self._out.pass_to_input(self._in)
        if result == Result.Finished:
            if self.state == ProfileState.PAUSING:
                self.state = ProfileState.PAUSED
            elif self.state == ProfileState.STOPPING:
                self.state = ProfileState.DONE
            else:  # reached the end of the path: exactly 1, not Ruckig's last rounding
                self.state = ProfileState.DONE
                self.s = 1.0
            self.sd = self.sdd = 0.0

    def _update(self) -> Result:
        """One Ruckig update. Ruckig 0.19 raises on a few exact limit values (e.g. ṡ 49.99…96,
        s̈ 199.99…8 fail where 50 and 200 work): retry once with limits 1e-6 lower. Any other
        failure is a RuntimeError (the core turns it into a time-law alarm)."""
        for attempt in range(2):
            try:
                result = self._otg.update(self._in, self._out)
            except Exception as exc:  # RuckigError is not a RuntimeError
                if attempt:
                    raise RuntimeError(f"Ruckig failed on the path parameter: {exc}") from exc
                self._in.max_velocity = [self._in.max_velocity[0] * (1 - 1e-6)]
                self._in.max_acceleration = [self._in.max_acceleration[0] * (1 - 1e-6)]
                self._in.max_jerk = [self._in.max_jerk[0] * (1 - 1e-6)]
                continue
            if result not in (Result.Working, Result.Finished):
                raise RuntimeError(f"Ruckig failed on the path parameter: {result}")
            return result
        raise AssertionError("unreachable")

    def _decelerate(self) -> None:
        self._in.control_interface = ControlInterface.Velocity
        self._in.target_velocity = [0.0]
        self._in.target_acceleration = [0.0]
        self._in.minimum_duration = None

    def stop(self) -> None:
        """Decelerate on the path at the acceleration limit, then end (rest dropped)."""
        if self.state in (ProfileState.DONE, ProfileState.STOPPING):
            return
        self.stopped = True
        if self.state == ProfileState.PAUSED:
            self.state = ProfileState.DONE
            return
        self._decelerate()
        self.state = ProfileState.STOPPING

    def pause(self) -> None:
        """Decelerate on the path at the acceleration limit and keep the rest for resume."""
        if self.state == ProfileState.RUNNING:
            self._decelerate()
            self.state = ProfileState.PAUSING

    def resume(self) -> None:
        """Continue the same path from where it stopped (also cancels a pause in progress)."""
        if self.state not in (ProfileState.PAUSED, ProfileState.PAUSING):
            return
        self._in.control_interface = ControlInterface.Position
        self._in.target_position = [1.0]
        self._in.target_velocity = [0.0]
        self.state = ProfileState.RUNNING

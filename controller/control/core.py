"""The motion core: one control cycle from measured state to joint commands.

Every cycle (:meth:`MotionCore.cycle`)::

    hardware.read → kinematics.update(measured q) → motion.advance → IK (QP) →
    q_cmd += v·dt → grippers → hardware.write

The controller runs on the *measured* state (Jacobians, task errors) while joint limits
apply to the *commanded* positions it sends, so a command never leaves its limits. Commands
from other threads (start, stop, pause, resume, abort, servo, grippers) take a lock that
:meth:`MotionCore.cycle` also holds, so they land between cycles.

Faults (hardware faults, a failed QP, a failed time law) drop the motion, hold position
(zero velocity next cycle), switch the drives off and raise an alarm; ``clear_alarms`` then
``servo_on`` recover once the cause is gone.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

import numpy as np

from controller.control.blocked import BlockWatch
from controller.errors import StateError
from controller.model.alarms import Alarm, AlarmCode, AlarmType
from controller.model.kinematics import Kinematics
from controller.model.obstacles import Obstacle
from controller.model.robot import Robot
from controller.motion.arrival import hold_posture, off_target
from controller.motion.motions import IKSetup, Motion
from controller.motion.paths import VectorPath
from controller.motion.profile import PathProfile
from controller.qp.constraints.collision import collision_avoidance
from controller.qp.ik import IKResult, WholeBodyIK
from controller.qp.solver import DEFAULT_SOLVER
from controller.vocabulary import CoreState, RightLeft
from hal.interface import HardwareFault, HardwareInterface, HardwareState, JointCommand

#: A finished motion is at rest when every commanded speed is below SETTLED_SPEED [rad/s,
#: m/s] and every measured one below STILL_SPEED; or, SETTLE_TIME [s] after its time law,
#: when both are below STILL_SPEED (0.11 deg/s: quantised drive feedback keeps the commands
#: dithering around 1e-4 on real and emulated drives).
SETTLED_SPEED = 1e-5
STILL_SPEED = 2e-3
SETTLE_TIME = 0.5
#: A motion that has not arrived and come to rest this long [s] after its time law ended is
#: ended anyway, with a warning alarm (MOTION_INCOMPLETE) saying what is off.
ARRIVAL_TIMEOUT = 2.0
#: A cycle advances motions by the measured time since the last one, at most this many
#: nominal periods (longer gaps stretch the motion rather than jump it).
MAX_STEP_PERIODS = 5


class CoreError(StateError):
    """A request that the core's state does not allow (STATUS_ERR)."""


class GripperMotion:
    """Straight joint-space move of one gripper's joints (not part of the QP)."""

    def __init__(
        self, dt: float, start: np.ndarray, goal: np.ndarray, speed: np.ndarray, accel: np.ndarray
    ):
        self.path = VectorPath(start, goal)
        v, a = self.path.limits(speed, accel)
        self.profile = PathProfile(dt, v, a) if not self.path.is_empty else None

    def advance(self, dt: float | None = None) -> np.ndarray:
        if self.profile is None:
            return self.path.end
        self.profile.step(dt)
        return self.path.at(self.profile.s)

    @property
    def finished(self) -> bool:
        return self.profile is None or self.profile.finished


class MotionCore:
    """Owns the kinematics, the IK and the current motion of one robot on one hardware."""

    def __init__(
        self,
        robot: Robot,
        hardware: HardwareInterface,
        dt: float,
        solver: str = DEFAULT_SOLVER,
        obstacles: Sequence[Obstacle] = (),
    ):
        """``obstacles``: static obstacles (the daemon configuration's ``obstacles``) the
        collision rows keep the robot away from, like its own bodies."""
        self.robot = robot
        self.hw = hardware
        self.dt = dt
        self.kin = Kinematics(robot)
        self._planning = Kinematics(robot)
        self.ik = WholeBodyIK(self.kin, dt, solver)
        #: The collision rows (None: disabled in the profile); their distances are updated
        #: once per cycle, after the kinematics, when the IK solves.
        self.collision = collision_avoidance(self.kin, dt, obstacles)
        if self.collision is not None:
            self.ik.add(self.collision)
        self._block_watch = BlockWatch()
        #: The current motion was stopped because the collision rows held it back.
        self._blocked = False
        names = list(hardware.joint_names)
        missing = [n for n in self.kin.joint_names if n not in names]
        if missing:
            raise ValueError(f"hardware lacks joints {missing}")
        #: Hardware index of each kinematic joint, and of each gripper joint.
        index = np.array([names.index(n) for n in self.kin.joint_names], dtype=int)
        #: Where the core's joints are in the hardware's arrays: a slice when they are a
        #: consecutive run (the usual case: views and slice copies, cheaper every cycle).
        consecutive = len(index) and np.array_equal(index, np.arange(index[0], index[-1] + 1))
        self._hw_index: slice | np.ndarray = (
            slice(int(index[0]), int(index[-1]) + 1) if consecutive else index
        )
        self._grippers = {
            RightLeft[side]: np.array([names.index(n) for n in g.joints], dtype=int)
            for side, g in robot.profile.grippers.items()
            if all(n in names for n in g.joints)
        }
        self._lock = threading.RLock()
        self.state = CoreState.SERVO_OFF
        self.motion: Motion | None = None
        self.alarms: list[Alarm] = []
        self.q = np.zeros(self.kin.nv)  # measured
        self.q_cmd = np.zeros(self.kin.nv)
        self.v_cmd = np.zeros(self.kin.nv)
        self._hw_cmd = np.zeros(len(names))
        self._hw_vel = np.zeros(len(names))
        #: Last measured positions in hardware order [rad, m] (zeros before the first read).
        self.measured_hw = np.zeros(len(names))
        self._gripper_motion: dict[RightLeft, GripperMotion] = {}
        self.cycles = 0
        #: Time [s] since the current motion's time law ended.
        self._settling = 0.0
        #: Length [s] of the current cycle (the measured period, see :meth:`cycle`).
        self.step = dt
        #: Last measured joint speeds [rad/s, m/s] (kinematic joints).
        self.v_measured = np.zeros(self.kin.nv)
        self._reported_faults: set[HardwareFault] = set()
        self._hold()

    # ------------------------------------------------------------------- requests
    def _hold(self) -> None:
        """No motion: every joint frozen (decelerates to rest, then stays)."""
        self._apply(IKSetup([], np.ones(self.kin.nv, dtype=bool)))

    def _apply(self, setup: IKSetup) -> None:
        self.ik.tasks = setup.tasks
        self.ik.configure(setup.frozen, setup.allowed, setup.ranges)

    def servo_on(self) -> None:
        """Enable the drives holding the measured position (from servo off, after alarms)."""
        with self._lock:
            if self.state == CoreState.ALARM:
                raise CoreError("alarms are active: clear them first")
            if self.state != CoreState.SERVO_OFF:
                return
            if self.hw.state == HardwareState.UNCONFIGURED:
                self.hw.configure()
            if self.hw.state == HardwareState.FAULT and not self.hw.reset_faults():
                raise CoreError("the hardware is still in fault")
            self.hw.activate()
            self._sync_to_measured()
            self.state = CoreState.READY

    def servo_off(self) -> None:
        with self._lock:
            self.motion = None
            self._gripper_motion.clear()
            self.hw.deactivate()
            if self.state != CoreState.ALARM:
                self.state = CoreState.SERVO_OFF
            self._hold()

    def adopt_measured(self) -> None:
        """Take the hardware's measured positions as the state (measured and commanded,
        holding): after the hardware is configured, before the loop's first cycle, so the
        first snapshot shows the joints where they are (not zeros)."""
        with self._lock:
            self._sync_to_measured()

    def _sync_to_measured(self) -> None:
        measured = self.hw.read().position
        self.measured_hw = measured.copy()
        self._hw_cmd[:] = measured
        self._hw_vel[:] = 0.0
        self.q = measured[self._hw_index].copy()
        self.q_cmd = self.q.copy()
        self.v_cmd = np.zeros(self.kin.nv)
        self.kin.update(self.q)
        self._hold()

    def planning_kinematics(self) -> Kinematics:
        """A copy of the kinematics at the current measured state (offsets and original frame
        included), for building and checking motions outside the control thread. One copy is
        reused: use it from one planning thread at a time."""
        with self._lock:
            self._planning.copy_frames_from(self.kin)
            self._planning.update(self.kin.q.copy())
        return self._planning

    def start(self, motion: Motion) -> None:
        """Run ``motion`` (built against the current measured state). Only from READY."""
        with self._lock:
            if self.state != CoreState.READY:
                raise CoreError(f"cannot start a motion while {self.state.text}")
            box = self.ik.box
            motion.respect_limits(box.q_min, box.q_max, box.a_brake)
            self._apply(motion.setup())
            self.motion = motion
            self._block_watch.reset()
            self._blocked = False
            self.state = CoreState.BUSY

    def stop(self) -> None:
        """Decelerate on the path, drop the rest. From PAUSED the robot already stands
        still: the motion ends at once (Ready in the same cycle)."""
        with self._lock:
            if self.motion is None:
                return
            if self.state == CoreState.PAUSED:
                self.motion = None
                self._hold()
                self.state = CoreState.READY
                return
            self.motion.stop()

    def pause(self) -> None:
        with self._lock:
            if self.motion is not None and self.state == CoreState.BUSY:
                self.motion.pause()
            elif self.state == CoreState.READY:
                self.state = CoreState.PAUSED

    def resume(self) -> None:
        with self._lock:
            if self.state != CoreState.PAUSED and not (
                self.motion is not None and self.state == CoreState.BUSY
            ):
                return
            if self.motion is not None:
                if self.state == CoreState.PAUSED:  # held while paused: the tasks again
                    self._apply(self.motion.setup())
                self.motion.resume()
                self.state = CoreState.BUSY
            else:
                self.state = CoreState.READY

    def abort(self) -> None:
        """Hold now: zero velocity from the next cycle, motion dropped."""
        with self._lock:
            self.motion = None
            self._gripper_motion.clear()
            self.v_cmd[:] = 0.0
            self._hw_vel[:] = 0.0
            self._hold()
            if self.state in (CoreState.BUSY, CoreState.PAUSED):
                self.state = CoreState.READY

    def move_gripper(self, side: RightLeft, ratio: float) -> None:
        """Move a gripper to ``ratio`` (0 closed .. 1 open)."""
        with self._lock:
            if self.state not in (CoreState.READY, CoreState.BUSY, CoreState.PAUSED):
                raise CoreError(f"cannot move a gripper while {self.state.text}")
            idx = self._grippers[side]
            g = self.robot.profile.grippers[side.name]  # type: ignore[index]
            specs = [self.robot.joints[n] for n in g.joints]
            goal = np.array(
                [
                    s.to_si(c + ratio * (o - c))
                    for s, o, c in zip(specs, g.open, g.closed, strict=True)
                ]
            )
            self._gripper_motion[side] = GripperMotion(
                self.dt,
                self._hw_cmd[idx].copy(),
                goal,
                np.array([s.velocity for s in specs]),
                np.array([s.acceleration for s in specs]),
            )

    def gripper_ratio(self, side: RightLeft) -> float:
        """Measured opening of a gripper, 0 (closed) .. 1 (open), from its first joint."""
        idx = self._grippers[side]
        g = self.robot.profile.grippers[side.name]  # type: ignore[index]
        spec = self.robot.joints[g.joints[0]]
        pos = self.hw.read().position[idx[0]]
        lo, hi = spec.to_si(g.closed[0]), spec.to_si(g.open[0])
        return float(np.clip((pos - lo) / (hi - lo), 0.0, 1.0))

    def raise_alarm(self, code: AlarmCode, module: str, description: str) -> None:
        """Record an alarm, stop everything and enter ALARM (callable from any thread)."""
        with self._lock:
            self.alarms.append(Alarm(int(code), AlarmType.FAULT, description, module))
            self._enter_alarm()

    def warn(self, code: AlarmCode, module: str, description: str) -> None:
        """Record a warning alarm (motion goes on) unless one with ``code`` is active."""
        with self._lock:
            if not any(a.code == int(code) for a in self.alarms):
                self.alarms.append(Alarm(int(code), AlarmType.WARNING, description, module))

    def _enter_alarm(self) -> None:
        self.motion = None
        self._gripper_motion.clear()
        self.v_cmd[:] = 0.0
        self._hw_vel[:] = 0.0
        self._hold()
        self.hw.deactivate()
        self.state = CoreState.ALARM

    def clear_alarms(self) -> None:
        """Forget the alarms; the drives stay off until ``servo_on``."""
        with self._lock:
            self.alarms.clear()
            if self.state == CoreState.ALARM:
                self.state = CoreState.SERVO_OFF

    @property
    def hw_command(self) -> np.ndarray:
        """Last commanded positions in hardware order [rad, m]."""
        return self._hw_cmd

    @property
    def is_moving(self) -> bool:
        """A motion runs (or a gripper moves). A motion fully paused does not move."""
        running = self.motion is not None and self.state != CoreState.PAUSED
        return running or bool(self._gripper_motion)

    # --------------------------------------------------------------------- cycle
    def _use_step(self, elapsed: float | None) -> float:
        """The cycle's length [s]: ``elapsed`` (the measured period) within
        [dt, MAX_STEP_PERIODS·dt], or dt. The time law, the IK's limits and the integration
        of the commands all use it, so motion time follows the wall clock when the loop
        runs late."""
        step = self.dt
        if elapsed is not None and elapsed > self.dt:
            step = min(elapsed, MAX_STEP_PERIODS * self.dt)
        if step != self.step:
            self.step = step
            self.ik.set_period(step)
        return step

    def cycle(self, elapsed: float | None = None) -> None:
        """One control cycle; ``elapsed`` [s]: time since the last one (None: the nominal
        period). Never raises for motion problems: they become alarms."""
        with self._lock:
            self.cycles += 1
            step = self._use_step(elapsed)
            if self.hw.state in (HardwareState.UNCONFIGURED, HardwareState.FINALIZED):
                return  # unpowered: nothing to read or command
            measured = self.hw.read()
            self.measured_hw = measured.position
            self.q = measured.position[self._hw_index].copy()
            self.v_measured = measured.velocity[self._hw_index].copy()
            self.kin.update(self.q)
            faults = self.hw.faults()
            if faults:
                self._report(faults)
            elif self._reported_faults:
                self._reported_faults.clear()
            if self.state not in (CoreState.READY, CoreState.BUSY, CoreState.PAUSED):
                self.hw.write(JointCommand(self._hw_cmd, np.zeros_like(self._hw_vel)))
                return
            if self.motion is not None:
                try:
                    self.motion.advance(step)
                except Exception as exc:  # never let a motion take the loop down
                    self.raise_alarm(AlarmCode.TRAJECTORY_FAILURE, "motion", str(exc))
                    self.hw.write(JointCommand(self._hw_cmd, np.zeros_like(self._hw_vel)))
                    return
            if self.collision is not None and self.ik.solves:
                distances = self.collision.distances
                # The compiled kernels place the shapes on the kinematics' joint placements:
                # no Pinocchio pass for them, no second pass over the joints.
                distances.update(
                    self.kin.data if distances.needs_data else None,
                    self.kin.q,
                    self.kin.placed_chain(),
                )
            try:
                result = self.ik.solve(self.q_cmd, self.v_cmd)
            except Exception as exc:  # a solver or numerical error is a failed solve
                result = IKResult(np.zeros(self.kin.nv), False, f"IK raised: {exc!r}")
            if not result.ok:
                self.raise_alarm(AlarmCode.QP_FAILURE, "qp", result.message)
                self.hw.write(JointCommand(self._hw_cmd, np.zeros_like(self._hw_vel)))
                return
            self.v_cmd = result.velocity
            self.q_cmd = self.q_cmd + self.v_cmd * step
            self._hw_cmd[self._hw_index] = self.q_cmd
            self._hw_vel[self._hw_index] = self.v_cmd
            if self._gripper_motion:
                self._advance_grippers(step)
            self.hw.write(JointCommand(self._hw_cmd, self._hw_vel))
            self._watch_blocking(step)
            self._finish_motion()

    def _report(self, faults: list[HardwareFault]) -> None:
        """The hardware's active ``faults``: each raises its alarm once (after clearAlarms a
        fault that persists does not raise it again; servo_on then fails while the hardware
        cannot reset), and a fresh one stops everything."""
        fresh = [f for f in faults if f not in self._reported_faults]
        if fresh:
            self._reported_faults.update(fresh)
            for f in fresh:
                self.alarms.append(Alarm(f.code, AlarmType.FAULT, f.description, f.source))
            if self.state != CoreState.ALARM:
                self._enter_alarm()

    def _advance_grippers(self, step: float) -> None:
        """One ``step`` [s] of every moving gripper; a gripper whose motion ends stops."""
        for side, gm in list(self._gripper_motion.items()):
            idx = self._grippers[side]
            new = gm.advance(step)
            self._hw_vel[idx] = (new - self._hw_cmd[idx]) / step
            self._hw_cmd[idx] = new
            if gm.finished:
                self._hw_vel[idx] = 0.0
                del self._gripper_motion[side]

    def _watch_blocking(self, step: float) -> None:
        """Stop a running motion the collision rows hold back (see
        :mod:`controller.control.blocked`), with one MOTION_BLOCKED warning."""
        motion, collision = self.motion, self.collision
        if motion is None or collision is None or self._blocked or motion.paused:
            return
        if self.state != CoreState.BUSY:
            return
        why = self._block_watch.check(collision, self.v_cmd, self.kin, self.ik.tasks, step)
        if why is not None:
            self._blocked = True
            motion.stop()
            self.warn(AlarmCode.MOTION_BLOCKED, "qp", why)

    def _finish_motion(self) -> None:
        """A motion ends once its time law has ended *and* the robot is on the final targets
        (every task within its arrival tolerance, see :func:`controller.motion.arrival.
        off_target`) *and* at rest (see SETTLED_SPEED and STILL_SPEED): Ready
        means still. One that has not got there ARRIVAL_TIMEOUT after
        its time law is ended anyway (held where it is) with a MOTION_INCOMPLETE warning."""
        motion = self.motion
        if motion is None:
            return
        if motion.paused and self.state == CoreState.BUSY:
            # Paused on the path: hold every joint (the motion's tasks would keep the
            # posture and null-space terms working, and the joints creeping); resume()
            # brings the motion's tasks back.
            self.state = CoreState.PAUSED
            self._hold()
        if not motion.finished:
            self._settling = 0.0
            return
        if self._blocked:  # stopped short of its target (said so): hold where it is
            self._end_motion()
            return
        if self._settling == 0.0:
            hold_posture(self.kin, self.ik.tasks)
        self._settling += self.step
        commanded = float(np.abs(self.v_cmd).max(initial=0.0))
        calm = SETTLED_SPEED if self._settling < SETTLE_TIME else STILL_SPEED
        rest = commanded < calm and (float(np.abs(self.v_measured).max(initial=0.0)) < STILL_SPEED)
        off = None if not rest else off_target(self.kin, self.ik.tasks)
        if rest and off is None:
            self._end_motion()
        elif self._settling >= ARRIVAL_TIMEOUT:
            why = off if rest else self._still_moving()
            if not rest:
                why = off_target(self.kin, self.ik.tasks) or why
            self.alarms.append(
                Alarm(
                    int(AlarmCode.MOTION_INCOMPLETE),
                    AlarmType.WARNING,
                    f"motion ended {ARRIVAL_TIMEOUT:g} s after its time law without arriving: "
                    f"{why}",
                    "motion",
                )
            )
            self._end_motion()

    def _still_moving(self) -> str:
        """What keeps the robot from rest: the fastest joint, commanded and measured."""
        speeds = np.maximum(np.abs(self.v_cmd), np.abs(self.v_measured))
        k = int(np.argmax(speeds))
        return (
            f"still moving: {self.kin.joint_names[k]} commanded {self.v_cmd[k]:.2g}, "
            f"measured {self.v_measured[k]:.2g} (rest below {STILL_SPEED:g}) [rad/s or m/s]"
        )

    def _end_motion(self) -> None:
        self.motion = None
        self._hold()
        if self.state in (CoreState.BUSY, CoreState.PAUSED):
            self.state = CoreState.READY

"""The control process: the fixed-rate loop around the motion core, and its commands.

Everything that touches the motion core runs in the loop thread. Commands arrive from the
gateway over a Unix socket (:mod:`controller.contract.channel`); the channel threads only
hand them to the loop (lock-free queues) and wait for the answer, which the loop gives at
the start of its next cycle. So a command never races a cycle and the loop never waits for
a lock held by a slow request. Urgent commands (stop, pause, abort, servo off) have their
own queue, emptied first: they overtake every other waiting command.

Per cycle::

    urgent commands → other commands → MotionCore.cycle() → queue / soft-limit supervision
    → snapshot (:mod:`controller.control.publisher`) → answers

and in the time left before the next deadline (the loop's slack): the hardware's deferred
work (:meth:`~hal.interface.HardwareInterface.advance`: the MuJoCo stand-in's physics step),
then the garbage collector.

Commands (:mod:`controller.control.commands`) answer with a value or raise an
:class:`~controller.errors.ImotionError` carrying its return code.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from controller.contract.motion_specs import MotionSpec
from controller.control.blackbox import BlackBoxRing
from controller.control.collector import SlackCollector
from controller.control.commands import DIRECT, URGENT, Commands
from controller.control.core import MotionCore
from controller.control.events import LoopEvents
from controller.control.loop import FixedRateLoop
from controller.control.motion_queue import MotionQueue
from controller.control.overruns import OverrunWatch
from controller.control.publisher import SnapshotPublisher
from controller.control.soft_limits import CartesianSoftLimits
from controller.errors import ImotionError, Refused
from controller.model.alarms import AlarmCode
from controller.model.obstacles import Obstacle
from controller.model.robot import Robot
from controller.motion.motions import Motion
from controller.vocabulary import CoreState, ReturnCode
from hal.interface import HardwareInterface

_log = logging.getLogger("imotiond.control")


@dataclass
class Request:
    name: str
    args: dict[str, Any]
    done: threading.Event = field(default_factory=threading.Event)
    ok: bool = False
    value: Any = None
    code: ReturnCode = ReturnCode.NG
    message: str = ""
    #: Set when the caller stopped waiting; the loop then drops the request unexecuted.
    cancelled: bool = False


class Controller(Commands):
    """The loop-side half of the daemon (see the module docstring)."""

    def __init__(
        self,
        robot: Robot,
        hardware: HardwareInterface,
        rate_hz: float,
        snapshot_path: Path,
        queue_depth: int = 8,
        solver: str = "daqp",
        obstacles: Sequence[Obstacle] = (),
        collect_in_slack: bool = True,
    ):
        """``collect_in_slack``: while :meth:`run` runs, the garbage collector runs only in
        the loop's slack (:class:`~controller.control.collector.SlackCollector`)."""
        self.robot = robot
        self.hw = hardware
        self.dt = 1.0 / rate_hz
        self.core = MotionCore(robot, hardware, self.dt, solver, obstacles)
        self.collector = SlackCollector() if collect_in_slack else None
        # Statistics over the last second: cheap enough to summarise from the loop thread.
        self.loop = FixedRateLoop(
            rate_hz,
            self._step,
            realtime=False,
            stats_capacity=max(1, round(rate_hz)),
            slack=self._slack,
        )
        self.overruns = OverrunWatch(self.loop, self.core)
        #: Deadline time [s] of the last cycle (the loop's ``t``), for the measured period.
        self._last_t: float | None = None
        self.queue = MotionQueue(queue_depth)
        self.soft_limits = CartesianSoftLimits(self.core)
        self.urgent: queue.SimpleQueue[Request] = queue.SimpleQueue()
        self.inbox: queue.SimpleQueue[Request] = queue.SimpleQueue()
        self.publisher = SnapshotPublisher(
            snapshot_path, self.core, hardware, self.loop, rate_hz, queue_depth
        )
        self.started = 0
        self.finished = 0
        self._running_motion: object = None
        #: Operator log of state changes, motions and alarms (queued, never written here).
        self.events = LoopEvents()
        #: Set by a signal handler: decelerate, servo off, leave the loop.
        self.shutdown_requested = threading.Event()
        self._shutdown_deadline: float | None = None
        self.stop_timeout = 1.2
        #: Every cycle goes into it when set (imotiond sets it when blackbox.dir is).
        self.blackbox: BlackBoxRing | None = None
        self._handlers: dict[str, Callable[..., Any]] = {
            name.removeprefix("cmd_"): getattr(self, name)
            for name in dir(self)
            if name.startswith("cmd_")
        }
        self.publish()

    # ------------------------------------------------------------------ loop side
    def _step(self, cycle: int, t: float) -> bool:
        executed: list[Request] = []
        try:
            # Urgent commands (stop, pause, servo off, ...) act in this cycle; the others
            # right after it: a motion command builds and starts its motion here and the
            # motion's first cycle (the dearest) runs in the next step, so one step never
            # carries both (a start at 1 kHz overran the period before). Their answer goes
            # out after this step's snapshot either way.
            self._execute_all(self.urgent, executed)
            elapsed = None if self._last_t is None else t - self._last_t
            self._last_t = t
            self.core.cycle(elapsed)
            self._execute_all(self.inbox, executed)
            self.overruns.observe(t)
            self._after_cycle()
            self.publish()
            if self.blackbox is not None:
                self._record_blackbox(self.blackbox)
        finally:
            # Answer only once the snapshot shows the command's effect: a client that reads
            # isMoving/getState right after an OK sees the motion it started.
            for request in executed:
                request.done.set()
        return not self._shutdown_step()

    def _slack(self, left_ns: int) -> None:
        """After each step, before the next deadline: the hardware's deferred work (the
        stand-in's physics step), then the garbage collector in what is left."""
        start = time.monotonic_ns()
        self.hw.advance()
        if self.collector is not None:
            self.collector(left_ns - (time.monotonic_ns() - start))

    def _execute_all(self, inbox: queue.SimpleQueue[Request], executed: list[Request]) -> None:
        if inbox.empty():  # most cycles: no command (and no exception raised to see it)
            return
        while True:
            try:
                request = inbox.get_nowait()
            except queue.Empty:
                return
            self._execute(request)
            executed.append(request)

    def run(self) -> None:
        """Run the loop in the calling thread until shutdown."""
        if self.collector is not None:
            self.collector.start()
        try:
            self.loop.run()
        finally:
            if self.collector is not None:
                self.collector.stop()

    def _execute(self, request: Request) -> None:
        if request.cancelled:  # its caller gave up waiting: never act on it late
            return
        handler = self._handlers.get(request.name)
        try:
            if handler is None:
                raise Refused(ReturnCode.NG, f"unknown command {request.name!r}")
            request.value = handler(**request.args)
            request.ok = True
        except ImotionError as exc:
            request.code, request.message = exc.code, exc.comment
        except Exception as exc:  # a command must never take the loop down
            _log.exception("command %s failed", request.name)
            request.code, request.message = ReturnCode.NG, f"{request.name} failed: {exc}"

    def submit(self, name: str, timeout: float = 5.0, **args: Any) -> Request:
        """Hand a command to the loop and wait for its answer (any thread but the loop's).

        Urgent commands (:data:`~controller.control.commands.URGENT`) go ahead of all others.
        """
        request = Request(name, args)
        if name in DIRECT:  # blocks on another process: never in the loop thread
            self._execute(request)
            return request
        (self.urgent if name in URGENT else self.inbox).put(request)
        if not request.done.wait(timeout):
            request.cancelled = True
            request.code, request.message = ReturnCode.NG, "the control loop did not answer in time"
        return request

    def _after_cycle(self) -> None:
        core = self.core
        if core.motion is not self._running_motion:
            if self._running_motion is not None:
                self.finished += 1
            self._running_motion = core.motion
        self.events.observe(core)
        if core.state in (CoreState.SERVO_OFF, CoreState.ALARM):
            self.queue.clear()
        elif core.state == CoreState.READY and core.motion is None and self.queue:
            spec = self.queue.pop()
            try:
                self._start(spec)
            except Exception as exc:
                self.queue.clear()
                core.raise_alarm(
                    AlarmCode.TRAJECTORY_FAILURE, "queue", f"queued {spec.label}: {exc}"
                )
        if self.soft_limits and core.state == CoreState.BUSY:
            self.soft_limits.check()

    def _start(self, spec: MotionSpec) -> None:
        self.core.start(self._instantiate(spec))
        self._running_motion = self.core.motion
        self.started += 1
        self.events.motion_started(spec.label, self.core.motion)

    def _instantiate(self, spec: MotionSpec) -> Motion:
        """The motion the gateway checked: built at the configuration it was planned from
        (``spec.planned_from``; the JARA queue's planned end for a queued motion), so its
        path and time law are the checked ones, not a re-plan from where the robot happens
        to be. The motion then runs on the live kinematics. A motion started at once was
        refused before this if the robot moved more than PLAN_TOLERANCE since planning."""
        return spec.build_as_planned(self.core.kin, self.dt)

    def _shutdown_step(self) -> bool:
        """True when the loop should end (shutdown requested and the robot is safe)."""
        if not self.shutdown_requested.is_set():
            return False
        now = time.monotonic()
        if self._shutdown_deadline is None:
            self._shutdown_deadline = now + self.stop_timeout
            self.queue.clear()
            self.events.ending("stopped")
            self.core.stop()
            _log.info("shutdown: decelerating to a stop")
        if self.core.is_moving and now < self._shutdown_deadline:
            return False
        self.core.servo_off()
        self.publish()  # the last snapshot says so (the gateway may answer a little longer)
        _log.info("shutdown: servo off")
        return True

    def publish(self) -> None:
        """Write the snapshot (loop thread, once per cycle)."""
        self.publisher.publish(len(self.queue), self.queue.full, self.started, self.finished)

    def _record_blackbox(self, box: BlackBoxRing) -> None:
        """One row of the black box (controller.control.blackbox; written out elsewhere)."""
        core = self.core
        box.record(
            int(core.state),
            self.started,
            len(core.alarms),
            getattr(getattr(core.ik, "solver", None), "iterations", -1),
            self.loop.stats.last(),
            core.measured_hw,
            core.hw_command,
        )

    def close(self) -> None:
        self.publisher.close()
        if self.blackbox is not None:
            self.blackbox.unlink()

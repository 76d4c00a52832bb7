"""The control process: the fixed-rate loop around the motion core, and its commands.

Everything that touches the motion core runs in the loop thread. Commands arrive from the
gateway over a Unix socket (:mod:`controller.contract.channel`); the channel threads only
hand them to the loop (lock-free queues) and wait for the answer, which the loop gives at
the start of its next cycle. So a command never races a cycle and the loop never waits for
a lock held by a slow request. Urgent commands (stop, pause, abort, servo off) have their
own queue, emptied first: they overtake every other waiting command.

Per cycle::

    urgent commands → MotionCore.cycle() → the start accepted last step → other commands
    → queue / soft-limit supervision → snapshot (:mod:`controller.control.publisher`)
    → answers

and in the time left before the next deadline (the loop's slack): the hardware's deferred
work (:meth:`~hal.interface.HardwareInterface.advance`: the MuJoCo stand-in's physics step),
the motion of a start accepted in this step built (:mod:`controller.control.pending_start`:
a start is spread over three steps), then the garbage collector.

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
from controller.control.pending_start import PendingStart
from controller.control.publisher import SnapshotPublisher
from controller.control.soft_limits import CartesianSoftLimits
from controller.errors import ImotionError, Refused
from controller.model import jit
from controller.model.alarms import AlarmCode
from controller.model.obstacles import Obstacle
from controller.model.robot import Robot
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

    def refuse(self, code: ReturnCode, message: str) -> None:
        """Answer with ``code`` and ``message`` and no value (not OK)."""
        self.ok, self.value, self.code, self.message = False, None, code, message


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
        spin_us: float = 0.0,
    ):
        """``collect_in_slack``: while :meth:`run` runs, the garbage collector runs only in
        the loop's slack (:class:`~controller.control.collector.SlackCollector`);
        ``spin_us``: the loop busy-waits this long before each deadline [µs] (see
        :class:`~controller.control.loop.FixedRateLoop`)."""
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
            spin_us=spin_us,
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
        self.pending: PendingStart | None = None
        #: Kernels compiled (or loaded from numba's cache) while :meth:`run` ran.
        self.compiled_while_running: list[str] = []
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
            # right after it. A motion command accepted there has its motion built in this
            # step's slack and started after the next step's cycle; its first cycle (the
            # dearest) runs in the step after: no step carries two of them (one that built
            # and started a motion at 1 kHz overran the period in a third of the starts).
            # Answers go out after the step's snapshot.
            if self.pending is not None and not self.urgent.empty():
                self._start_pending(executed)  # accepted before them: started first
            self._execute_all(self.urgent, executed)
            elapsed = None if self._last_t is None else t - self._last_t
            self._last_t = t
            self.core.cycle(elapsed)
            if self.pending is not None:
                self._start_pending(executed)
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
        stand-in's physics step), the motion of a start accepted in the step, then the
        garbage collector in what is left."""
        start = time.monotonic_ns()
        self.hw.advance()
        if self.pending is not None:
            self.pending.build(self.core.kin, self.dt)
        if self.collector is not None:
            self.collector(left_ns - (time.monotonic_ns() - start))

    def _execute_all(self, inbox: queue.SimpleQueue[Request], executed: list[Request]) -> None:
        if inbox.empty():  # most cycles: no command (and no exception raised to see it)
            return
        while self.pending is None:  # behind an accepted start, the others wait for it
            try:
                request = inbox.get_nowait()
            except queue.Empty:
                return
            self._execute(request)
            if self.pending is not None:  # this request's start: answered once started
                self.pending.request = request
            else:
                executed.append(request)

    def run(self) -> None:
        """Run the loop in the calling thread until shutdown. A compiled kernel that is
        compiled (or loaded from numba's cache) meanwhile is logged as a warning naming it:
        every kernel should be ready before the loop starts, a cycle waited for that one."""
        if self.collector is not None:
            self.collector.start()
        stop_watching = jit.watch_compiles(self._compiled_while_running)
        try:
            self.loop.run()
        finally:
            stop_watching()
            if self.collector is not None:
                self.collector.stop()

    def _compiled_while_running(self, kernel: str, seconds: float, thread: str) -> None:
        self.compiled_while_running.append(kernel)
        _log.warning(
            "kernel %s was compiled (or loaded from numba's cache) in thread %s while the "
            "control loop ran: %.0f ms in which no cycle could run (the drives may have "
            "lost the heartbeat); every kernel should be ready before the loop starts: "
            "report this",
            kernel, thread, seconds * 1e3,
        )  # fmt: skip

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
            request.refuse(exc.code, exc.comment)
        except Exception as exc:  # a command must never take the loop down
            _log.exception("command %s failed", request.name)
            request.refuse(ReturnCode.NG, f"{request.name} failed: {exc}")

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
        elif (
            core.state == CoreState.READY
            and core.motion is None
            and self.pending is None
            and self.queue
        ):
            self._start(self.queue.pop())  # built in the slack, started next step
        if self.soft_limits and core.state == CoreState.BUSY:
            self.soft_limits.check()

    def _start(self, spec: MotionSpec) -> None:
        self.pending = PendingStart(spec)

    def _start_pending(self, executed: list[Request]) -> None:
        """Start the motion of the accepted start (built in the last slack, or now) and
        answer its command; a motion from the queue that cannot start raises an alarm."""
        pending, self.pending = self.pending, None
        if pending is None:
            return
        core, spec, request = self.core, pending.spec, pending.request
        try:
            motion = pending.take(core.kin, self.dt)
            if core.state != CoreState.READY or core.motion is not None:
                raise Refused(
                    ReturnCode.STATUS_ERR,
                    f"{spec.label}: not started: the robot became {core.state.text} first",
                )
            core.start(motion)
        except Refused as exc:
            code, message = exc.code, exc.comment
        except ValueError as exc:  # e.g. a finite but absurd target no time law can cover
            code, message = ReturnCode.VALUE_ERR, f"{spec.label}: cannot be planned: {exc}"
        except Exception as exc:
            _log.exception("starting %s failed", spec.label)
            code, message = ReturnCode.NG, f"{spec.label}: cannot start: {exc}"
        else:
            self._running_motion = motion
            self.started += 1
            self.events.motion_started(spec.label, motion)
            if request is not None:
                executed.append(request)
            return
        if request is not None:
            request.refuse(code, message)
            executed.append(request)
        elif core.state not in (CoreState.SERVO_OFF, CoreState.ALARM):
            self.queue.clear()
            core.raise_alarm(AlarmCode.TRAJECTORY_FAILURE, "queue", f"queued {message}")

    def _shutdown_step(self) -> bool:
        """True when the loop should end (shutdown requested and the robot is safe)."""
        if not self.shutdown_requested.is_set():
            return False
        now = time.monotonic()
        if self._shutdown_deadline is None:
            self._shutdown_deadline = now + self.stop_timeout
            pending, self.pending = self.pending, None
            if pending is not None and pending.request is not None:
                message = f"{pending.spec.label}: not started: the daemon is stopping"
                pending.request.refuse(ReturnCode.STATUS_ERR, message)
                pending.request.done.set()
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
        self.publisher.publish(
            len(self.queue), self.queue.full, self.started, self.finished, self.pending is not None
        )

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

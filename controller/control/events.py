"""Operator events of the control loop: state changes, motion start and end, alarms.

:class:`LoopEvents` is called by the loop thread once per cycle; it compares a few
references (state, running motion, alarm list) and logs only when something changed, so a
quiet cycle costs well under a microsecond. The log call itself only queues the record
(:mod:`controller.logs`): nothing is written or formatted on the loop thread.

Lines (logger ``imotiond.events``)::

    msg="state changed" from=ready to=busy
    msg="motion started" motion="linear RIGHT ..." id=3
    msg="motion ended" motion="linear RIGHT ..." id=3 result=done duration_s=2.01
    msg="alarm raised" code=0x0411 source=loop type=FAULT description="..."
    msg="alarm cleared" code=0x0411 source=loop description="..."

``result`` is ``done``, ``stopped`` (stop / shutdown), ``aborted``, ``servo off``,
``alarm`` or ``replaced`` (another motion took over).

The loop thread does not even run the logger: it puts ``(level, event, fields)`` into a
queue (a fraction of a microsecond) and the ``loop-events`` thread makes the log call
(structlog's processors, ~20 us), which in turn only queues the record for the writer
thread (:mod:`controller.logs`). ``tools/bench_logs.py`` measures both.
"""

from __future__ import annotations

import queue
import threading
import time
from typing import Any

from controller.control.core import MotionCore
from controller.logs import get_logger
from controller.model.alarms import Alarm
from controller.vocabulary import CoreState

_log = get_logger("imotiond.events")


class LoopEvents:
    """What the loop last saw, to log what changed (loop thread only)."""

    def __init__(self) -> None:
        self.state: CoreState | None = None
        self.motion: object = None
        self.label = ""
        self.number = 0
        self.started = 0.0
        #: Why the running motion will end, set by the command that ends it.
        self.end_reason: str | None = None
        self.alarms: list[Alarm] = []
        self._out: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start the ``loop-events`` thread now (idempotent; else at the first event). The
        daemon starts it before the loop thread turns real-time, so it is one of the helper
        threads (controller.control.realtime), not an ordinary thread the loop started."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._drain, name="loop-events", daemon=True)
            self._thread.start()

    def _emit(self, level: str, event: str, **fields: Any) -> None:
        """Hand one log event to the ``loop-events`` thread (never blocks)."""
        self._out.put((level, event, fields))
        if self._thread is None:
            self.start()

    def _drain(self) -> None:
        while True:
            item = self._out.get()
            if isinstance(item, threading.Event):
                item.set()
                continue
            level, event, fields = item
            try:
                getattr(_log, level)(event, **fields)
            except Exception:  # a bad field must not end the thread
                continue

    def flush(self, timeout: float = 5.0) -> bool:
        """Wait until every event so far went to the logger (tests, shutdown)."""
        if self._thread is None:
            return True
        done = threading.Event()
        self._out.put(done)
        return done.wait(timeout)

    def motion_started(self, label: str, motion: object) -> None:
        if self.motion is not None:
            self._motion_ended("replaced")
        self.number += 1
        self.motion, self.label, self.started = motion, label, time.monotonic()
        self.end_reason = None
        self._emit("info", "motion started", motion=label, id=self.number)

    def ending(self, reason: str) -> None:
        """The running motion (if any) will end because of ``reason`` (stop, abort, ...)."""
        if self.motion is not None and self.end_reason is None:
            self.end_reason = reason

    def observe(self, core: MotionCore) -> None:
        """Once per cycle, after the core's cycle."""
        if core.motion is not self.motion and self.motion is not None:
            if core.state == CoreState.ALARM:
                result = "alarm"
            else:
                result = self.end_reason or "done"
            self._motion_ended(result)
        if core.state is not self.state:
            if self.state is not None:
                level = "warning" if core.state == CoreState.ALARM else "info"
                self._emit(
                    level, "state changed", **{"from": self.state.text, "to": core.state.text}
                )
            self.state = core.state
        alarms = core.alarms
        if len(alarms) != len(self.alarms) or (alarms and alarms[-1] is not self.alarms[-1]):
            self._alarms_changed(list(alarms))

    def _motion_ended(self, result: str) -> None:
        duration = time.monotonic() - self.started
        self._emit(
            "warning" if result == "alarm" else "info",
            "motion ended",
            motion=self.label,
            id=self.number,
            result=result,
            duration_s=round(duration, 3),
        )
        self.motion, self.end_reason = None, None

    def _alarms_changed(self, alarms: list[Alarm]) -> None:
        before = {id(a) for a in self.alarms}
        now = {id(a) for a in alarms}
        for alarm in alarms:
            if id(alarm) not in before:
                self._emit("warning", "alarm raised", **_fields(alarm), type=alarm.type.name)
        for alarm in self.alarms:
            if id(alarm) not in now:
                self._emit("info", "alarm cleared", **_fields(alarm))
        self.alarms = alarms


def _fields(alarm: Alarm) -> dict[str, Any]:
    return {"code": f"0x{alarm.code:04X}", "source": alarm.module, "description": alarm.description}

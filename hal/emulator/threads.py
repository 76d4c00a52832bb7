"""The threads that serve a drive emulator's buses (``DriveEmulator.start``).

* Buses with a file descriptor (``unix``, ``socketcan``): one thread, ``emu``, waits on all
  of them (one ``epoll`` over their descriptors), then handles every frame waiting on the
  buses found ready, in the order sent, and again while the wait finds more (up to
  :data:`CATCH_UP` batches, so heartbeats keep their ticks under a flood); it ticks the
  heartbeats every :data:`TICK` [s]. A batch that took over :data:`SLOW_BATCH` is logged:
  the host held the emulator back.
* Others (``virtual``): one receive thread per bus (``emu-<bus>``) and a ticker
  (``emu-tick``).

Every thread runs under SCHED_FIFO at ``priority`` when given (below the control loop's),
and takes the emulator's lock around its work; what a batch does (frames in, SYNC rounds,
TPDOs out) is the emulator's (:class:`hal.emulator.emulator.DriveEmulator`), given here as
callables.
"""

from __future__ import annotations

import logging
import os
import select
import threading
import time
from collections.abc import Callable

import can

from hal.emulator.port import Port

log = logging.getLogger(__name__)

#: Heartbeat tick period of the threads [s].
TICK = 0.005
#: A batch of frames that took longer than this [s] is logged (the emulator fell behind).
SLOW_BATCH = 0.02
#: Batches handled at most before the heartbeats are ticked (frames keep coming).
CATCH_UP = 20


class BusThreads:
    """The threads serving ``ports`` (module doc). ``handle(ports, more)`` handles the
    frames waiting on those ports and says how many; ``more()``, which it may call, names
    the ports that still hold something (one ``epoll`` for all of them);
    ``process(port, msg)`` one frame of a bus without a descriptor; ``tick(now)`` the
    heartbeats; ``lock`` is held around each; ``clock`` [s] is the heartbeats'.
    ``priority``: SCHED_FIFO priority of every thread (0: normal scheduling)."""

    def __init__(
        self,
        ports: list[Port],
        lock: threading.RLock,
        handle: Callable[[list[Port], Callable[[], list[Port]]], int],
        process: Callable[[Port, can.Message], None],
        tick: Callable[[float], None],
        clock: Callable[[], float],
        priority: int = 0,
    ):
        self._ports = ports
        self._lock = lock
        self._handle = handle
        self._process = process
        self._tick = tick
        self._clock = clock
        self.priority = priority
        self.threads: list[threading.Thread] = []
        self._running = threading.Event()

    @property
    def running(self) -> bool:
        return self._running.is_set()

    def start(self) -> None:
        """Start the threads (once; the buses must be open)."""
        if self._running.is_set():
            return
        self._running.set()
        ports = self._ports
        if all(port.selectable() for port in ports):
            self.threads.append(
                threading.Thread(target=self._select_loop, args=(ports,), name="emu", daemon=True)
            )
        else:
            for port in ports:
                thread = threading.Thread(
                    target=self._receive_loop, args=(port,), name=f"emu-{port.name}", daemon=True
                )
                self.threads.append(thread)
            self.threads.append(
                threading.Thread(target=self._tick_loop, name="emu-tick", daemon=True)
            )
        for thread in self.threads:
            thread.start()

    def stop(self) -> None:
        """Stop the threads and wait for them (2 s each at most)."""
        self._running.clear()
        for thread in self.threads:
            thread.join(timeout=2.0)
        self.threads.clear()

    # -------------------------------------------------------------------------- the loops

    def _receive_loop(self, port: Port) -> None:
        self._realtime()
        while self._running.is_set():
            bus = port.bus
            if bus is None:
                return
            try:
                msg = bus.recv(0.05)
            except Exception as exc:
                log.error("bus %s: receive failed, the emulator leaves it: %s", port.name, exc)
                return
            if msg is None:
                continue
            with self._lock:
                try:
                    self._process(port, msg)
                except Exception:  # one bad frame must not end the bus
                    log.exception("bus %s: frame 0x%03X failed", port.name, msg.arbitration_id)

    def _select_loop(self, ports: list[Port]) -> None:
        """All buses in one thread: wait on their descriptors, then handle every frame waiting
        on any bus in the order they were sent; tick the heartbeats every :data:`TICK` [s].
        The descriptors are watched by one ``epoll`` of this thread's, set up once (a
        ``select`` over the same descriptors builds its sets again at every call: ~2 µs more
        each, several calls per round)."""
        fds = {port.bus.fileno(): port for port in ports if port.bus is not None}
        waiter = select.epoll()
        for fd in fds:
            waiter.register(fd, select.EPOLLIN)

        def more() -> list[Port]:
            """The ports that still hold something (an error: none; the next wait says why)."""
            try:
                return [fds[fd] for fd, _ in waiter.poll(0)]
            except (OSError, ValueError):
                return []

        self._realtime()
        next_tick = 0.0
        try:
            while self._running.is_set():
                try:
                    ready = [fds[fd] for fd, _ in waiter.poll(TICK)]
                except (OSError, ValueError) as exc:
                    if self._running.is_set():
                        log.error("emulator: wait failed, the emulator stops: %s", exc)
                    return
                with self._lock:
                    start = time.monotonic()
                    handled = 0
                    for _ in range(CATCH_UP if ready else 0):  # what came meanwhile too, so
                        handled += self._handle(ready, more)  # the ticks below see every
                        if self._clock() >= next_tick + TICK:  # heartbeat; ticks due
                            break
                        if not (ready := more()):  # the buses that got more meanwhile
                            break
                    took = time.monotonic() - start
                    if took > SLOW_BATCH:
                        log.warning("emulator: %.0f ms to handle %d frames (host busy?)",
                                    took * 1e3, handled)  # fmt: skip
                    now = self._clock()
                    if now >= next_tick:
                        self._tick(now)
                        next_tick = now + TICK
        finally:
            waiter.close()

    def _tick_loop(self) -> None:
        self._realtime()
        while self._running.is_set():
            with self._lock:
                self._tick(self._clock())
            time.sleep(TICK)

    def _realtime(self) -> None:
        """The calling thread under SCHED_FIFO at :attr:`priority` (if set)."""
        if not self.priority:
            return
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(self.priority))
        except (AttributeError, OSError) as exc:
            log.warning("emulator: SCHED_FIFO priority %d not in effect: %s", self.priority, exc)

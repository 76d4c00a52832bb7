"""A fixed-rate loop on absolute deadlines, with cycle statistics in ring buffers.

Cycle ``k`` is due at ``t0 + k·period``. The loop sleeps until each deadline (``time.sleep``
on the remaining time, then an optional busy-wait for the last ``spin_us`` microseconds, never
so long that the thread sleeps less than :data:`MIN_SLEEP_SHARE` of the period), runs the
step, and measures the wake latency (actual wake − deadline) and the compute time (step
duration). A step that ends after the next deadline is an *overrun*: it is counted and the
loop resumes at the first deadline still in the future, never catching up with a burst of
late cycles. With ``paced=False`` cycles run back to back without sleeping (lockstep
simulation, tests); the step then sees ``t = cycle × period``.

An optional ``slack(ns)`` callable runs after each step with the time left before the next
deadline [ns] (the whole period when unpaced), outside the compute time: the place for work
that may wait, such as :class:`controller.control.collector.SlackCollector`.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Collection

import numpy as np

from controller.control import realtime as rt

#: The step: ``step(cycle, t)`` with ``t`` the cycle's deadline since the start [s];
#: returning False stops the loop.
Step = Callable[[int, float], bool | None]
#: Work for the time left before the next deadline: ``slack(ns)``.
Slack = Callable[[int], None]

MIN_RATE_HZ = 1.0
MAX_RATE_HZ = 2000.0
#: Seconds of cycles the statistics keep by default.
DEFAULT_HISTORY_S = 10.0
#: With ``spin_us``, the loop still sleeps at least this share of each period (or up to the
#: deadline when less is left): a SCHED_FIFO thread busy for more than
#: ``sched_rt_runtime_us / sched_rt_period_us`` of a second (Linux: 95 %) is stopped for the
#: rest of that second, 50 ms without a cycle (seen in tools/bench_hil.py with a spin that
#: left no sleep: an overrun of 35-50 ms every second).
MIN_SLEEP_SHARE = 0.1


def spin_start(deadline: int, now: int, spin_ns: int, period_ns: int) -> int:
    """When to stop sleeping before ``deadline`` [ns], at ``now`` [ns]: ``spin_ns`` before
    it, or later so that the sleep lasts at least :data:`MIN_SLEEP_SHARE` of ``period_ns``
    (up to the deadline when less is left); without a spin, the deadline itself."""
    if not spin_ns:
        return deadline
    return max(deadline - spin_ns, min(now + round(MIN_SLEEP_SHARE * period_ns), deadline))


def percentiles(values: np.ndarray, q: tuple[float, ...]) -> list[float]:
    """The ``q`` percentiles [%] of ``values`` as ``np.percentile`` gives them (linear
    interpolation between the closest ranks), then the maximum, from one partial sort of
    ``values`` in place (pass a copy to keep the order)."""
    n = values.size
    ranks: list[tuple[int, int, float]] = []
    for p in q:
        at = p / 100.0 * (n - 1)
        below = min(int(at), n - 1)
        ranks.append((below, min(below + 1, n - 1), at - below))
    kth = sorted({k for below, above, _ in ranks for k in (below, above)} | {n - 1})
    values.partition(kth)
    out = []
    for below, above, t in ranks:
        a, b = float(values[below]), float(values[above])
        out.append(b - (b - a) * (1.0 - t) if t >= 0.5 else a + (b - a) * t)
    out.append(float(values[n - 1]))
    return out


class LoopStats:
    """Per-cycle compute time and wake latency [µs] in preallocated ring buffers."""

    def __init__(self, period_s: float, capacity: int):
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.period_us = period_s * 1e6
        self.capacity = capacity
        self._compute_us = np.zeros(capacity)
        self._latency_us = np.zeros(capacity)
        self.cycles = 0
        self.overruns = 0
        #: Cycles that woke more than half a period after their deadline.
        self.late = 0

    def record(self, compute_us: float, latency_us: float) -> None:
        """Store one cycle's compute time and wake latency [µs] (no allocation)."""
        i = self.cycles % self.capacity
        self._compute_us[i] = compute_us
        self._latency_us[i] = latency_us
        self.cycles += 1
        if latency_us > 0.5 * self.period_us:
            self.late += 1

    def last(self) -> tuple[float, float]:
        """The latest cycle's wake latency and compute time [µs] (zeros before any)."""
        if not self.cycles:
            return 0.0, 0.0
        i = (self.cycles - 1) % self.capacity
        return float(self._latency_us[i]), float(self._compute_us[i])

    def record_overrun(self) -> None:
        self.overruns += 1

    def compute_us(self) -> np.ndarray:
        """Compute times [µs] held in the buffer (the last ``capacity`` cycles, unordered)."""
        return self._compute_us[: min(self.cycles, self.capacity)].copy()

    def latency_us(self) -> np.ndarray:
        """Wake latencies [µs] held in the buffer (the last ``capacity`` cycles, unordered)."""
        return self._latency_us[: min(self.cycles, self.capacity)].copy()

    def summary(self) -> dict[str, float | int]:
        """Counts over all cycles; p50/p99/max over the buffer [µs] (NaN before any cycle).

        Cheap enough for the loop thread (the snapshot publishes it every 0.2 s): ~20 µs
        for 1000 cycles, where ``np.percentile`` took 175."""
        out: dict[str, float | int] = {
            "cycles": self.cycles,
            "overruns": self.overruns,
            "late_by_more_than_half_period": self.late,
        }
        samples = (("compute_us", self.compute_us()), ("wake_latency_us", self.latency_us()))
        for name, values in samples:
            if values.size:
                p50, p99, top = percentiles(values, (50.0, 99.0))
                out[f"{name}_p50"] = p50
                out[f"{name}_p99"] = p99
                out[f"{name}_max"] = top
            else:
                out[f"{name}_p50"] = out[f"{name}_p99"] = out[f"{name}_max"] = math.nan
        return out

    def reset(self) -> None:
        """Forget every cycle and count."""
        self._compute_us.fill(0.0)
        self._latency_us.fill(0.0)
        self.cycles = self.overruns = self.late = 0


class FixedRateLoop:
    """Runs ``step(cycle, t)`` at ``rate_hz`` [Hz] on absolute deadlines; see the module doc.

    ``realtime``: :func:`controller.control.realtime.apply_realtime` in the thread calling
    :meth:`run`, at its start (best effort, warnings when refused), restored when it returns.
    ``spin_us``: busy-wait for the last microseconds before each deadline (costs a CPU), in
    what is left after the least sleep (:data:`MIN_SLEEP_SHARE` of the period).
    ``stats_capacity``: cycles kept by :attr:`stats` (default 10 s worth).
    ``slack``: called after each step with the time left before the next deadline [ns].
    ``cpus``: with ``realtime``, pin the thread calling :meth:`run` to these CPUs.
    ``clock_ns`` and ``sleep`` replace :func:`time.monotonic_ns` and :func:`time.sleep` (tests).
    """

    def __init__(
        self,
        rate_hz: float,
        step: Step,
        realtime: bool = True,
        paced: bool = True,
        *,
        spin_us: float = 0.0,
        stats_capacity: int | None = None,
        slack: Slack | None = None,
        cpus: Collection[int] | None = None,
        clock_ns: Callable[[], int] = time.monotonic_ns,
        sleep: Callable[[float], None] = time.sleep,
    ):
        if not (math.isfinite(rate_hz) and MIN_RATE_HZ <= rate_hz <= MAX_RATE_HZ):
            raise ValueError(
                f"rate_hz must be within {MIN_RATE_HZ:g}..{MAX_RATE_HZ:g} Hz, got {rate_hz!r}"
            )
        self.rate_hz = float(rate_hz)
        #: Period [ns].
        self.period_ns = round(1e9 / rate_hz)
        if not (math.isfinite(spin_us) and 0.0 <= spin_us * 1e3 < self.period_ns):
            raise ValueError(f"spin_us must be within 0..period, got {spin_us!r}")
        self.spin_ns = round(spin_us * 1e3)
        self.step = step
        self.slack = slack
        self.realtime = realtime
        self.cpus = cpus
        self.paced = paced
        capacity = stats_capacity or max(1, math.ceil(DEFAULT_HISTORY_S * rate_hz))
        self.stats = LoopStats(self.period_ns / 1e9, capacity)
        #: What the last run's real-time setup achieved (None when ``realtime`` is False).
        self.realtime_report: rt.RealtimeReport | None = None
        self._clock_ns = clock_ns
        self._sleep = sleep
        self._stop = threading.Event()
        self._running = threading.Lock()

    @property
    def period(self) -> float:
        """Period [s]."""
        return self.period_ns / 1e9

    def stop(self) -> None:
        """Ask :meth:`run` to return before its next step (thread-safe).

        Takes effect within one period. A stop requested before :meth:`run` makes it return
        at once; the request is cleared when run() returns.
        """
        self._stop.set()

    def run(self, max_cycles: int | None = None) -> int:
        """Run until the step returns False, ``max_cycles`` steps ran or :meth:`stop`.

        Returns the number of steps run. Not re-entrant: one run at a time.
        """
        if max_cycles is not None and max_cycles < 0:
            raise ValueError(f"max_cycles must be >= 0, got {max_cycles}")
        if not self._running.acquire(blocking=False):
            raise RuntimeError("FixedRateLoop.run() is already running")
        report = None
        try:
            if self.realtime:
                report = rt.apply_realtime(cpus=self.cpus)
                self.realtime_report = report
            if self.paced:
                return self._run_paced(max_cycles)
            return self._run_unpaced(max_cycles)
        finally:
            if report is not None:
                rt.restore(report)
            self._stop.clear()
            self._running.release()

    def _run_paced(self, max_cycles: int | None) -> int:
        clock, period, stats, step, stop = self._hot_path()
        slack = self.slack
        cycle = 0
        k = 0  # deadline index
        t0 = clock()
        while not stop.is_set() and (max_cycles is None or cycle < max_cycles):
            deadline = t0 + k * period
            woke = self._wait_until(deadline)
            if stop.is_set():
                break
            result = step(cycle, (deadline - t0) / 1e9)
            end = clock()
            stats.record((end - woke) / 1e3, (woke - deadline) / 1e3)
            cycle += 1
            if result is False:
                break
            k += 1
            if end > t0 + k * period:
                stats.record_overrun()
                k = (end - t0) // period + 1
            if slack is not None:
                slack(t0 + k * period - end)
        return cycle

    def _run_unpaced(self, max_cycles: int | None) -> int:
        clock, period, stats, step, stop = self._hot_path()
        slack = self.slack
        cycle = 0
        while not stop.is_set() and (max_cycles is None or cycle < max_cycles):
            start = clock()
            result = step(cycle, cycle * period / 1e9)
            end = clock()
            stats.record((end - start) / 1e3, 0.0)
            cycle += 1
            if result is False:
                break
            if slack is not None:
                slack(max(0, period - (end - start)))
        return cycle

    def _hot_path(
        self,
    ) -> tuple[Callable[[], int], int, LoopStats, Step, threading.Event]:
        """Locals for the cycle loop (attribute look-ups hoisted out of it)."""
        return self._clock_ns, self.period_ns, self.stats, self.step, self._stop

    def _wait_until(self, deadline: int) -> int:
        """Sleep, then spin (from :func:`spin_start`), until ``deadline`` [ns]; returns the
        wake time [ns]."""
        clock = self._clock_ns
        now = clock()
        spin_from = spin_start(deadline, now, self.spin_ns, self.period_ns)
        while spin_from - now > 0:
            self._sleep((spin_from - now) / 1e9)
            now = clock()
        while now < deadline:
            now = clock()
        return now

"""controller.control.loop: cycle counts, stop, pacing, overruns, statistics. Counts, never times.

Exact deadline behaviour is checked on a fake clock; the real clock only runs with margins a
noisy machine cannot break (a no-op step never takes a 20 ms period).
"""

from __future__ import annotations

import math
import os
import threading
import time

import numpy as np
import pytest

from controller.control import realtime
from controller.control.loop import MIN_SLEEP_SHARE, FixedRateLoop, LoopStats

SUMMARY_KEYS = {
    "cycles",
    "overruns",
    "late_by_more_than_half_period",
    "compute_us_p50",
    "compute_us_p99",
    "compute_us_max",
    "wake_latency_us_p50",
    "wake_latency_us_p99",
    "wake_latency_us_max",
}


@pytest.fixture(autouse=True)
def _process_stays_normal():
    policy = os.sched_getscheduler(0)
    yield
    assert os.sched_getscheduler(0) == policy != os.SCHED_FIFO


class FakeClock:
    """Simulated monotonic time [ns]: sleep() and work() advance it; ``oversleep`` adds lateness
    to chosen sleep calls (by call index)."""

    def __init__(self, oversleep: dict[int, int] | None = None):
        self.now = 1_000_000_000
        self.sleeps: list[int] = []
        self.oversleep = oversleep or {}

    def clock_ns(self) -> int:
        return self.now

    def sleep(self, seconds: float) -> None:
        assert seconds > 0
        self.now += round(seconds * 1e9) + self.oversleep.get(len(self.sleeps), 0)
        self.sleeps.append(round(seconds * 1e9))

    def work(self, ns: int) -> None:
        self.now += ns


def fake_loop(clock: FakeClock, rate_hz: float, step, **kwargs) -> FixedRateLoop:
    return FixedRateLoop(
        rate_hz, step, realtime=False, clock_ns=clock.clock_ns, sleep=clock.sleep, **kwargs
    )


def test_runs_exactly_max_cycles():
    seen: list[tuple[int, float]] = []
    loop = FixedRateLoop(1000, lambda c, t: seen.append((c, t)), realtime=False)
    assert loop.run(max_cycles=25) == 25
    assert [c for c, _ in seen] == list(range(25))
    assert loop.stats.cycles == 25
    assert loop.run(max_cycles=0) == 0
    assert loop.stats.cycles == 25


def test_step_returning_false_stops_and_none_continues():
    loop = FixedRateLoop(2000, lambda c, t: c != 6, realtime=False)
    assert loop.run() == 7
    loop = FixedRateLoop(2000, lambda c, t: None, realtime=False)
    assert loop.run(max_cycles=5) == 5


def test_stop_from_another_thread():
    reached = threading.Event()

    def step(cycle: int, t: float) -> None:
        if cycle == 10:
            reached.set()

    loop = FixedRateLoop(500, step, realtime=False)
    result: list[int] = []
    runner = threading.Thread(target=lambda: result.append(loop.run()))
    runner.start()
    assert reached.wait(timeout=30)
    loop.stop()
    runner.join(timeout=30)
    assert not runner.is_alive()
    assert result[0] >= 11
    # The stop request is consumed: the loop can run again.
    assert loop.run(max_cycles=3) == 3


def test_stop_before_run_returns_at_once():
    loop = FixedRateLoop(100, lambda c, t: pytest.fail("no step expected"), realtime=False)
    loop.stop()
    assert loop.run() == 0


def test_run_is_not_reentrant():
    holder: list[FixedRateLoop] = []

    def step(cycle: int, t: float) -> bool:
        with pytest.raises(RuntimeError, match="already running"):
            holder[0].run(max_cycles=1)
        return False

    holder.append(FixedRateLoop(100, step, realtime=False))
    assert holder[0].run() == 1


def test_unpaced_runs_back_to_back_without_sleeping():
    def no_sleep(seconds: float) -> None:
        pytest.fail("an unpaced loop must not sleep")

    times: list[float] = []
    loop = FixedRateLoop(
        1, lambda c, t: times.append(t), realtime=False, paced=False, sleep=no_sleep
    )
    assert loop.run(max_cycles=1000) == 1000  # 1000 s of cycles at 1 Hz, if it slept
    np.testing.assert_allclose(times, np.arange(1000.0))
    summary = loop.stats.summary()
    assert summary["overruns"] == 0 and summary["wake_latency_us_max"] == 0.0


def test_paced_deadlines_are_absolute_on_a_fake_clock():
    clock = FakeClock()
    times: list[float] = []

    def step(cycle: int, t: float) -> None:
        times.append(t)
        clock.work(300_000)  # 0.3 ms of work in a 1 ms period

    loop = fake_loop(clock, 1000, step)
    assert loop.run(max_cycles=5) == 5
    np.testing.assert_allclose(times, [0.0, 0.001, 0.002, 0.003, 0.004])
    # It sleeps only the remainder of each period, so there is no drift.
    assert clock.sleeps == [700_000] * 4
    summary = loop.stats.summary()
    assert summary["overruns"] == 0
    assert summary["compute_us_max"] == pytest.approx(300.0)
    assert summary["wake_latency_us_max"] == 0.0


def test_overruns_are_counted_once_per_slow_cycle_and_skip_to_the_next_deadline():
    clock = FakeClock()
    slow = {2: 2_500_000, 5: 1_200_000, 6: 4_000_000}  # cycle -> work [ns], period 1 ms
    times: list[float] = []

    def step(cycle: int, t: float) -> None:
        times.append(t)
        clock.work(slow.get(cycle, 100_000))

    loop = fake_loop(clock, 1000, step)
    assert loop.run(max_cycles=10) == 10
    assert loop.stats.overruns == len(slow)
    # Cycle 2 (due 2 ms) ends at 4.5 ms: next due 5 ms, no burst for 3 and 4 ms.
    # Cycle 5 (due 7 ms) ends at 8.2 ms -> 9 ms; cycle 6 ends at 13 ms exactly -> 14 ms.
    expected_ms = [0, 1, 2, 5, 6, 7, 9, 14, 15, 16]
    np.testing.assert_allclose(times, np.array(expected_ms) / 1e3)


def test_slack_gets_the_time_left_before_the_next_deadline_outside_the_compute_time():
    clock = FakeClock()
    work = {0: 300_000, 1: 1_500_000, 2: 100_000}  # cycle 1 overruns: next due at 3 ms
    slack: list[int] = []

    def step(cycle: int, t: float) -> None:
        clock.work(work[cycle])

    def use_slack(ns: int) -> None:
        slack.append(ns)
        clock.work(ns // 2)  # half the slack: never part of a cycle's compute time

    loop = fake_loop(clock, 1000, step, slack=use_slack)
    assert loop.run(max_cycles=3) == 3
    # Cycle 0 ends at 0.3 ms (next due 1 ms); cycle 1 wakes at 1 ms, ends at 2.5 ms (next
    # due 3 ms); cycle 2 wakes at 3 ms, ends at 3.1 ms (next due 4 ms).
    assert slack == [700_000, 500_000, 900_000]
    np.testing.assert_allclose(np.sort(loop.stats.compute_us()), [100.0, 300.0, 1500.0])


def test_unpaced_slack_is_the_rest_of_the_period():
    clock = FakeClock()
    slack: list[int] = []
    loop = fake_loop(clock, 1000, lambda c, t: clock.work(400_000), paced=False, slack=slack.append)
    assert loop.run(max_cycles=2) == 2
    assert slack == [600_000, 600_000]


def test_late_wakes_are_counted():
    # Sleep calls 1 and 3 wake 0.6 and 0.2 periods late: only the first is "late".
    clock = FakeClock(oversleep={1: 600_000, 3: 200_000})
    loop = fake_loop(clock, 1000, lambda c, t: clock.work(10_000))
    loop.run(max_cycles=6)
    summary = loop.stats.summary()
    assert summary["late_by_more_than_half_period"] == 1
    assert summary["wake_latency_us_max"] == pytest.approx(600.0)
    assert summary["overruns"] == 0


def test_spin_busy_waits_the_last_microseconds():
    clock = FakeClock()
    reads = 0

    def counting_clock() -> int:
        nonlocal reads
        reads += 1
        clock.now += 1_000  # each clock read costs 1 µs
        return clock.now

    loop = FixedRateLoop(
        1000,
        lambda c, t: None,
        realtime=False,
        spin_us=50,
        clock_ns=counting_clock,
        sleep=clock.sleep,
    )
    loop.run(max_cycles=3)
    # Sleeps stop 50 µs short of the deadline; the rest is spun on the clock.
    assert all(ns <= 1_000_000 - 50_000 for ns in clock.sleeps)
    assert reads > 2 * 40  # cycle 0 is due at once; cycles 1 and 2 spin ~49 µs each
    assert loop.stats.summary()["wake_latency_us_max"] <= 1.0


@pytest.mark.parametrize("work_us", [500, 950])
def test_a_spin_leaves_the_thread_a_tenth_of_the_period_asleep(work_us: int):
    """A spin as long as the period allows still sleeps MIN_SLEEP_SHARE of it (a FIFO
    thread that never sleeps is stopped by the kernel's real-time throttling); with less
    left than that, the loop sleeps up to the deadline and does not spin."""
    assert MIN_SLEEP_SHARE == 0.1
    clock = FakeClock()

    def reading_clock() -> int:
        clock.now += 1_000  # each clock read costs 1 µs
        return clock.now

    loop = FixedRateLoop(
        1000,
        lambda c, t: clock.work(work_us * 1_000),
        realtime=False,
        spin_us=900,
        clock_ns=reading_clock,
        sleep=clock.sleep,
    )
    loop.run(max_cycles=5)
    least = min(100_000, (1000 - work_us) * 1_000)  # the share, or what is left [ns]
    assert len(clock.sleeps) == 4  # cycle 0 is due at once
    assert all(least - 5_000 <= ns <= least for ns in clock.sleeps), clock.sleeps


def test_overruns_on_the_real_clock():
    period = 0.02
    slow = {2, 5, 6}

    def step(cycle: int, t: float) -> None:
        if cycle in slow:
            time.sleep(2.5 * period)

    loop = FixedRateLoop(1 / period, step, realtime=False)
    assert loop.run(max_cycles=10) == 10
    assert loop.stats.overruns == len(slow)


def test_realtime_is_applied_in_the_calling_thread_and_restored(monkeypatch):
    events: list[tuple[str, int]] = []
    report = realtime.RealtimeReport()

    def fake_apply(cpus=None) -> realtime.RealtimeReport:
        events.append(("apply", threading.get_ident()))
        events.append(("cpus", cpus))
        return report

    monkeypatch.setattr(realtime, "apply_realtime", fake_apply)
    monkeypatch.setattr(realtime, "restore", lambda r: events.append(("restore", id(r))))
    loop = FixedRateLoop(1000, lambda c, t: events.append(("step", c)), realtime=True, cpus=[0])
    loop.run(max_cycles=2)
    assert events == [
        ("apply", threading.get_ident()),
        ("cpus", [0]),
        ("step", 0),
        ("step", 1),
        ("restore", id(report)),
    ]
    assert loop.realtime_report is report


def test_realtime_is_restored_when_the_step_raises(monkeypatch):
    restored: list[object] = []
    report = realtime.RealtimeReport()
    monkeypatch.setattr(realtime, "apply_realtime", lambda cpus=None: report)
    monkeypatch.setattr(realtime, "restore", restored.append)

    def boom(cycle: int, t: float) -> None:
        raise KeyError("step failed")

    loop = FixedRateLoop(1000, boom)
    with pytest.raises(KeyError):
        loop.run()
    assert restored == [report]
    assert loop.run(max_cycles=0) == 0  # not stuck "running"


def test_stats_summary_ring_buffer_and_reset():
    stats = LoopStats(period_s=0.001, capacity=4)
    summary = stats.summary()
    assert set(summary) == SUMMARY_KEYS
    assert summary["cycles"] == 0 and math.isnan(summary["compute_us_p50"])
    for i in range(10):
        stats.record(compute_us=float(i), latency_us=100.0 * i)
    stats.record_overrun()
    summary = stats.summary()
    assert set(summary) == SUMMARY_KEYS
    assert summary["cycles"] == 10 and summary["overruns"] == 1
    assert sorted(stats.compute_us()) == [6.0, 7.0, 8.0, 9.0]  # the last 4 cycles
    assert summary["compute_us_max"] == 9.0
    assert summary["compute_us_p50"] == pytest.approx(7.5)
    assert summary["wake_latency_us_max"] == 900.0
    assert summary["late_by_more_than_half_period"] == 4  # 600..900 µs > 500 µs
    stats.reset()
    assert stats.summary()["cycles"] == 0 and stats.overruns == 0 and stats.late == 0
    with pytest.raises(ValueError):
        LoopStats(0.001, 0)


def test_default_stats_capacity_is_ten_seconds():
    assert FixedRateLoop(500, lambda c, t: None).stats.capacity == 5000
    assert FixedRateLoop(500, lambda c, t: None, stats_capacity=16).stats.capacity == 16


@pytest.mark.parametrize("rate", [0.0, 0.5, 2000.5, 1e6, -100.0, math.nan, math.inf])
def test_invalid_rate_raises(rate: float):
    with pytest.raises(ValueError, match="rate_hz"):
        FixedRateLoop(rate, lambda c, t: None)


def test_valid_rate_bounds_and_bad_arguments():
    assert FixedRateLoop(1, lambda c, t: None).period == 1.0
    assert FixedRateLoop(2000, lambda c, t: None).period_ns == 500_000
    with pytest.raises(ValueError, match="spin_us"):
        FixedRateLoop(1000, lambda c, t: None, spin_us=1000)
    with pytest.raises(ValueError, match="max_cycles"):
        FixedRateLoop(1000, lambda c, t: None, realtime=False).run(max_cycles=-1)


@pytest.mark.parametrize("n", [1, 2, 3, 7, 100, 999, 1000, 10000])
def test_percentiles_are_numpys_from_one_partial_sort(n: int):
    from controller.control.loop import percentiles

    rng = np.random.default_rng(n)
    for values in (rng.exponential(300.0, n), np.round(rng.uniform(0, 50, n)), np.full(n, 7.0)):
        expected = [*np.percentile(values, [50.0, 99.0, 0.0, 100.0]), values.max()]
        got = percentiles(values.copy(), (50.0, 99.0, 0.0, 100.0))
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)

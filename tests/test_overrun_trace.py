"""tools/overrun_trace.py: per-cycle figures and the cause named for each overrun (synthetic
cycles: no clock is asserted)."""

from __future__ import annotations

import gc
import mmap
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from overrun_trace import CAUSES, HOST_CAUSES, CycleTrace, print_overruns, read_steal

PERIOD = 0.002  # [s]


def trace_of(cycles: int) -> CycleTrace:
    trace = CycleTrace(cycles)
    trace.close()  # figures set by hand below
    return trace


def test_only_cycles_past_the_period_are_rows_and_each_names_its_largest_part():
    trace = trace_of(5)
    # cycle 1: a collection of 1.5 ms; 2: read waited 0.4 ms for TPDOs (feedback_wait) and
    # 1.2 ms more off the CPU; 3: woke 1.9 ms late; 4: 2.1 ms of its own work.
    trace.gc_in[1] = 1.5e-3
    trace.step_cpu[1] = 2.0e-3
    trace.read_wait[2] = 1.6e-3
    trace.missing[2] = 21
    trace.switches[2] = 2  # it slept in select, then for the GIL
    trace.step_cpu[2] = 0.6e-3
    trace.step_cpu[3] = 0.5e-3
    trace.step_cpu[4] = 2.1e-3
    latency = [20.0, 20.0, 20.0, 1900.0, 20.0]
    compute = [600.0, 2000.0, 2200.0, 500.0, 2100.0]
    rows = trace.overruns(PERIOD, 0.4e-3, latency, compute)
    assert [r["cycle"] for r in rows] == [1, 2, 3, 4]
    assert [r["cause"] for r in rows] == ["gc", "off cpu", "late wake", "cpu"]
    assert rows[1]["tpdo_wait_us"] == 400.0 and rows[1]["missing_tpdo1"] == 21
    assert not any(r["motion_start"] for r in rows)
    trace._cycle = 3
    trace.motion_started()  # step 3 starts a motion: 3 and 4 (its first cycle) are marked
    rows = trace.overruns(PERIOD, 0.4e-3, latency, compute)
    assert [r["motion_start"] for r in rows] == [False, False, True, True]
    counts = print_overruns(rows)
    assert set(counts) == set(CAUSES) and sum(counts.values()) == 4
    # The slack after step 2 built a motion: cycle 3's late wake is that build, not the host.
    trace._cycle = 2
    trace.motion_built()
    rows = trace.overruns(PERIOD, 0.4e-3, latency, compute)
    assert [r["cause"] for r in rows] == ["gc", "off cpu", "build", "cpu"]
    assert rows[2]["motion_start"] and "build" not in HOST_CAUSES


def test_collections_are_counted_while_installed_and_reset_forgets():
    trace = CycleTrace(3)
    try:
        trace.begin(0)
        gc.collect(0)
        trace.end()
        assert trace.gc_counts[0] >= 1 and trace.gc_in[0] > 0.0
        trace.reset()
        assert trace.gc_counts == [0, 0, 0] and trace.gc_in[0] == 0.0
    finally:
        trace.close()
    assert trace._on_gc not in gc.callbacks


def test_a_negative_cycle_is_not_recorded_and_forgetting_collections_keeps_the_cycles():
    trace = CycleTrace(3)
    try:
        trace.begin(-1)  # a warm-up step: nothing of it is kept
        trace.read_done(1e-3, 1e-4, 2)
        trace.motion_started()
        gc.collect(0)
        trace.end()
        assert not trace.read_wall.any() and not trace.started.any() and not trace.gc_in.any()
        assert trace.gc_counts[0] >= 1
        trace.begin(0)
        trace.read_done(1e-3, 1e-4, 2)
        trace.end()
        trace.forget_collections()  # the measured run starts: its cycles stay
        assert trace.gc_counts == [0, 0, 0] and trace.gc_total == 0.0
        assert trace.read_wall[0] == 1e-3 and trace.missing[0] == 2
    finally:
        trace.close()


def steady_trace(cycles: int) -> tuple[CycleTrace, list[float], list[float]]:
    """``cycles`` alike cycles: read 0.2 ms of CPU (0.25 ms wall), write 0.15 ms, the rest
    0.35 ms; wake 20 µs. Their trace, latencies and compute times [µs]."""
    trace = trace_of(cycles)
    trace.read_cpu[:] = 0.2e-3
    trace.read_wall[:] = 0.25e-3
    trace.write_wall[:] = 0.15e-3
    trace.step_cpu[:] = 0.7e-3
    return trace, [20.0] * cycles, [750.0] * cycles


def test_a_step_slow_in_every_part_is_the_hosts_slow_cpu_one_part_grown_is_its_own():
    trace, latency, compute = steady_trace(20)
    # 5: every part three times as long (the CPU ran slow); 9: only the rest of the step
    # (e.g. a motion's first cycle); 13: slow everywhere, but the thread faulted pages in.
    for k in (5, 13):
        trace.read_cpu[k], trace.read_wall[k] = 0.6e-3, 0.75e-3
        trace.write_wall[k] = 0.45e-3
        trace.step_cpu[k] = 2.1e-3
        compute[k] = 2250.0
    trace.step_cpu[9] = 2.4e-3
    compute[9] = 2450.0
    trace.faults[13] = 33
    rows = trace.overruns(PERIOD, 0.4e-3, latency, compute)
    assert [(r["cycle"], r["cause"]) for r in rows] == [(5, "slow cpu"), (9, "cpu"), (13, "cpu")]
    assert rows[0]["slowdown"] == 3.0 and rows[1]["slowdown"] == 1.0
    assert rows[2]["faults"] == 33
    counts = print_overruns(rows)
    assert counts["slow cpu"] == 1 and counts["cpu"] == 2
    assert "slow cpu" in HOST_CAUSES and "cpu" not in HOST_CAUSES


def test_the_cause_is_the_part_most_above_its_usual_value_not_the_largest():
    trace, latency, compute = steady_trace(10)
    # 4: a step of its usual 0.7 ms CPU (the largest part) in a cycle that woke 0.6 ms late
    # and waited its whole feedback_wait (0.4 ms) for TPDOs, 0.3 ms more off the CPU.
    latency[4] = 620.0
    trace.read_wait[4] = 0.7e-3
    trace.read_wall[4] = 0.95e-3
    trace.switches[4] = 1
    compute[4] = 1450.0
    (row,) = trace.overruns(PERIOD, 0.4e-3, latency, compute)
    assert row["cpu_us"] == 700.0 and row["cause"] == "late wake"


def test_off_the_cpu_without_leaving_it_is_the_hosts_steal():
    trace, latency, compute = steady_trace(10)
    # 2 and 6: 1.5 ms more wall time than CPU time in write(); 6 waited (a switch) for the
    # GIL, 2 never left the CPU: its task clock stopped (the hypervisor took the CPU).
    for k in (2, 6):
        trace.write_wall[k] = 1.65e-3
        compute[k] = 2250.0
    trace.switches[6] = 3
    rows = trace.overruns(PERIOD, 0.4e-3, latency, compute)
    assert [(r["cycle"], r["cause"]) for r in rows] == [(2, "steal"), (6, "off cpu")]
    assert rows[0]["off_cpu_us"] == 1550.0 and rows[1]["switches"] == 3


def test_the_sends_of_a_write_add_up_per_cycle_and_none_after_the_last_step():
    trace = CycleTrace(2)
    trace.begin(1)
    for _ in range(5):
        trace.sent(10e-6, 12e-6)
    trace.write_done(0.2e-3, 0.2e-3)
    trace.end()
    trace.close()
    trace.sent(1e-3, 1e-3)  # e.g. the shutdown's, after the loop: not the last step's
    assert abs(trace.send_wall[1] - 50e-6) < 1e-12 and abs(trace.send_cpu[1] - 60e-6) < 1e-12
    assert trace.send_wall[0] == 0.0 and trace.write_wall[1] == 0.2e-3


def test_steal_is_read_from_proc_stat_per_cpu(tmp_path):
    stat = tmp_path / "stat"
    stat.write_text(
        "cpu  100 0 50 9000 5 0 1 30 0 0\n"
        "cpu0 60 0 30 4500 2 0 1 10 0 0\n"
        "cpu1 40 0 20 4500 3 0 0 20 0 0\n"
        "intr 12345\n"
    )
    out = np.zeros(2)
    fd = os.open(stat, os.O_RDONLY)
    try:
        read_steal(fd, out)
    finally:
        os.close(fd)
    tick = os.sysconf("SC_CLK_TCK")
    assert list(out) == [10 / tick, 20 / tick]


def test_an_overrun_row_has_the_steal_of_its_cpu_between_the_reads_around_it():
    trace, latency, compute = steady_trace(20)
    trace._stat = None  # reads set by hand: before cycle 0, after cycles 4, 9, 14
    trace.steal[:4] = [[0.0, 0.0], [0.0, 0.01], [0.02, 0.015], [0.02, 0.015]]
    trace.steal_cycle[:4] = [-1, 4, 9, 14]
    trace._steals = 4
    trace.cpu_begin[:] = trace.cpu_end[:] = 0
    trace.cpu_begin[3] = trace.cpu_end[3] = 1
    latency[3] = latency[7] = latency[17] = 1500.0
    rows = {r["cycle"]: r for r in trace.overruns(PERIOD, 0.4e-3, latency, compute)}
    assert rows[3]["steal_us"] == 10000.0 and rows[3]["steal_window_cycles"] == 5
    assert rows[3]["cpus"] == [1] and rows[3]["cause"] == "late wake"
    assert rows[3]["steal_other_cpus_us"] == 0.0
    assert rows[7]["steal_us"] == 20000.0  # cpu 0 between the reads after cycles 4 and 9
    assert rows[7]["steal_other_cpus_us"] == 5000.0  # cpu 1, the other one
    assert rows[3]["steal_us"] + rows[3]["steal_other_cpus_us"] == 10000.0
    assert rows[17]["steal_us"] == 0.0 and rows[17]["steal_window_cycles"] == 0  # no read after
    assert trace.steal_total() == [0.02, 0.015]


def test_a_recorded_step_counts_its_page_faults_switches_and_cpu():
    trace = CycleTrace(2)
    try:
        trace.sample_steal(first=True)
        trace.begin(0)
        # A fresh mapping inside the step: its pages fault in as they are touched, or all at
        # the mmap where memory is locked (a heap block could come back already faulted in,
        # and did in a full suite run).
        with mmap.mmap(-1, 1 << 20) as block:
            for offset in range(0, len(block), mmap.PAGESIZE):
                block[offset] = 1
        trace.end()
        trace.sample_steal()
        assert trace.faults[0] >= 1
        assert trace.cpu_begin[0] >= 0 and trace.cpu_end[0] >= 0
        assert trace.t_begin[0] > 0.0 and trace.tid > 0
        if os.path.exists("/proc/stat"):
            assert list(trace.steal_cycle[:2]) == [-1, 0]
    finally:
        trace.close()

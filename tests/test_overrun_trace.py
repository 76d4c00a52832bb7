"""tools/overrun_trace.py: per-cycle figures and the cause named for each overrun (synthetic
cycles: no clock is asserted)."""

from __future__ import annotations

import gc
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from overrun_trace import CAUSES, CycleTrace, print_overruns

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

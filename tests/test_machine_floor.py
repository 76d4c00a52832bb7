"""tools/machine_floor.py: the bare real-time sleep loop the benchmarks compare against."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

import machine_floor


def test_the_floor_runs_in_its_own_process_and_reports_its_wakes():
    floor = machine_floor.measure(rate=500.0, seconds=0.2)
    assert set(floor) == {"late", "wake_p99_us", "wake_max_us", "fifo"}
    assert 0 <= floor["late"] <= 100  # 0.2 s at 500 Hz: 100 deadlines
    assert 0.0 <= floor["wake_p99_us"] <= floor["wake_max_us"]


def test_a_failing_floor_says_why_instead_of_raising():
    floor = machine_floor.measure(rate=0.0, seconds=0.1)  # no period
    assert floor.get("error")


def test_a_threshold_counts_the_wakes_later_than_it_at_the_priority_asked():
    floor = machine_floor.measure(rate=500.0, seconds=0.2, priority=70, threshold_us=-1.0)
    assert floor["priority"] == 70 and floor["threshold_us"] == -1.0
    assert floor["late_past_threshold"] == 100  # every wake is later than -1 us
    assert 0 <= floor["late"] <= 100


def test_loops_measured_together_answer_in_the_order_of_their_priorities():
    loop, second = machine_floor.measure_together(500.0, 0.2, (80, 70), threshold_us=1e6)
    assert (loop["priority"], second["priority"]) == (80, 70)
    assert loop["threshold_us"] == second["threshold_us"] == 1e6
    assert loop["late_past_threshold"] >= 0 and second["late_past_threshold"] >= 0


def test_a_spinning_floor_says_so_and_only_the_first_of_loops_together_spins():
    floor = machine_floor.measure(rate=500.0, seconds=0.2, spin_us=500.0)
    assert floor["spin_us"] == 500.0 and 0 <= floor["late"] <= 100
    loop, second = machine_floor.measure_together(500.0, 0.2, (80, 70), 1e6, spin_us=300.0)
    assert loop["spin_us"] == 300.0 and "spin_us" not in second

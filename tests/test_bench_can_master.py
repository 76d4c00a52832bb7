"""tools/bench_can_master.py: the measurement runs and reports every figure (no timing asserts)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from bench_can_master import PHASES, measure_master, measure_master_hil


def test_measure_master_reports_cycle_and_phases():
    result = measure_master("smartpal5", 500.0, cycles=50, warmup=5)
    assert (result["drives"], result["buses"]) == (21, 5)
    cycle = result["cycle"]
    assert isinstance(cycle, dict) and set(cycle) == {"p50_us", "p99_us", "max_us", "mean_us"}
    phases = result["phases_p50_us"]
    assert isinstance(phases, dict) and set(phases) == set(PHASES)
    # 21 RPDO1 + 5 SYNC + 21 TPDO1 + 8 TPDO2 per cycle, plus heartbeats.
    assert isinstance(result["frames_per_cycle"], float) and result["frames_per_cycle"] >= 55


def test_measure_master_paced_runs_one_cycle_per_period():
    result = measure_master("pa10", 1000.0, cycles=10, warmup=2, paced=True)
    assert result["paced"] is True and result["cycles"] == 10
    phases = result["phases_p50_us"]
    assert isinstance(phases, dict) and set(phases) == set(PHASES)


def test_measure_master_hil_reports_the_master_on_unix_buses():
    """The master against the emulator process (unix buses, hold_pdos): read/write CPU."""
    result = measure_master_hil("pa10", 200.0, seconds=0.2, warmup=0.2)
    assert (result["drives"], result["buses"], result["transport"]) == (9, 2, "unix")
    assert isinstance(result["cycles"], int) and result["cycles"] > 0
    for name in ("cpu_cycle", "cpu_read", "cpu_write"):
        figures = result[name]
        assert isinstance(figures, dict) and figures["p50_us"] > 0
    phases = result["cpu_phases_p50_us"]  # every other cycle, phase by phase
    assert isinstance(phases, dict) and set(phases) == set(PHASES)

"""tools/bench_hil.py: one loop for the warm-up and the measured run, and the machine's
floor read beside the run's overruns, the host's share of them (issue 13)."""

from __future__ import annotations

import os

import numpy as np

from tests.support import run_tool

SHORT = ("--robot", "pa10", "--seconds", "0.5", "--no-realtime", "--planner", "thread")


def test_the_measured_run_continues_the_warm_up_loop_and_the_floor_follows_it():
    lines, result = run_tool("bench_hil.py", *SHORT, "--rate", "250", "--floor-seconds", "0.3")
    out = "\n".join(lines)
    assert result["cycles"] == 125 and result["warmup_overruns"] >= 0
    # Servo on and the first motions: no kernel compiled while the loop ran (one did, on a
    # fresh install: a 1 s step and the drives' heartbeat lost).
    assert result["compiled_in_loop"] == []
    # No pause between the warm-up and the measured run (a second loop started after the
    # warm-up made its first step pay for the pause): the first measured deadline is a
    # whole number of periods after the warm-up's last one, on the same loop's grid.
    seam = result["warmup_seam_periods"]
    assert seam >= 1 and seam == round(seam)
    assert "the measured run continues its loop" in out
    floor = result["machine_floor"]
    assert floor["seconds"] == 0.3 and floor["emulator"] is None  # the emulator not FIFO
    assert floor["threshold_us"] == round(1e6 / 250 - result["compute_us_p50"], 1)
    assert floor["loop"]["priority"] == 80
    assert floor["loop"]["threshold_us"] == floor["threshold_us"]
    assert result["floor_late"] == floor["loop"]["late_past_threshold"] >= 0
    assert result["floor_late_emulator"] is None
    assert "the machine's floor for 0.3 s after it" in out


def test_each_rate_gets_its_floor_with_a_second_thread_at_the_emulator_priority():
    lines, result = run_tool(
        "bench_hil.py", *SHORT, "--rates", "250,200", "--emulator-priority", "70",
        "--floor-seconds", "0.2", "--spin-us", "500",
    )  # fmt: skip
    out = "\n".join(lines)
    assert [r["rate_hz"] for r in result["runs"]] == [250.0, 200.0]
    for run in result["runs"]:
        floor = run["machine_floor"]
        assert floor["threshold_us"] == round(1e6 / run["rate_hz"] - run["compute_us_p50"], 1)
        assert floor["emulator"]["priority"] == 70 and floor["loop"]["priority"] == 80
        # The loop busy-waits its last 500 us, and so does the floor's loop thread only.
        assert run["spin_us"] == floor["loop"]["spin_us"] == 500.0
        assert "spin_us" not in floor["emulator"]
        assert run["floor_late_emulator"] == floor["emulator"]["late_past_threshold"] >= 0
        assert run["floor_late"] == floor["loop"]["late_past_threshold"] >= 0
    assert "machine floor's late wakes (FIFO 80 / 70)" in out


def test_no_floor_when_told_and_the_hosts_share_and_every_cycle_saved(tmp_path):
    saved = tmp_path / "cycles.npz"
    _, result = run_tool("bench_hil.py", *SHORT, "--rate", "250", "--floor-seconds", "0",
                         "--trace-out", str(saved))  # fmt: skip
    assert "machine_floor" not in result and "floor_late" not in result
    # What tells the host's overruns from the loop's own: steal time, the host's causes.
    assert len(result["steal_s_per_cpu"]) == os.cpu_count()
    assert 0 <= result["host_overruns"] <= result["overruns"]
    assert result["send_us_p50"] > 0.0  # write()'s socket sends, timed apart
    assert result["send_us_max"] >= result["send_us_p99"] and result["sends_over_400us"] >= 0
    with np.load(saved) as cycles:
        assert len(cycles["compute_us"]) == result["cycles"] == 125
        assert (cycles["send_wall"][:125] > 0).all() and int(cycles["tid"]) > 0


def test_the_emulator_in_this_process_in_lockstep_runs_too():
    _, result = run_tool("bench_hil.py", *SHORT, "--rate", "250", "--floor-seconds", "0",
                         "--emulator", "thread")  # fmt: skip
    assert result["emulator"] == "thread" and result["cycles"] == 125
    assert result["emulator_cpu_us_per_cycle"] is None  # no process of its own

"""tools/bench_loop.py runs and reports the per-piece breakdown (issue 14)."""

from __future__ import annotations

import os

from tests.support import run_tool

SHORT = ("--seconds", "0.5", "--rate", "200", "--no-realtime", "--spread-seconds", "0.2")


def test_bench_loop_prints_the_breakdown_of_the_cycle_and_the_median_of_its_runs():
    # The planner in a thread: a worker process per run took ~5 s of the test's 10-15 s to
    # start; the next test runs the default (a worker process).
    lines, result = run_tool("bench_loop.py", *SHORT, "--runs", "2", "--planner", "thread")
    out = "\n".join(lines)
    assert result["runs"] == 2 and len(result["per_run"]) == 2
    assert set(result["median"]) == {
        "compute_us_p50",
        "compute_us_p99",
        "cpu_us_p50",
        "cpu_us_p99",
        "late_by_more_than_half_period",
        "overruns",
        "start_cpu_us_p50",
        "start_cpu_us_max",
        "start_build_us_p50",
        "starts_over_period",
        "plant_us_p99",
        "compute_plus_plant_us_p99",
    }
    for run in result["per_run"]:
        assert run["cycles"] == 100
        # The physics step runs in the slack, after the step the compute time measured.
        assert 0 < run["plant_us"]["p50"] <= run["plant_us"]["p99"]
        assert run["compute_plus_plant_us"]["p50"] > run["compute_us_p50"]
        assert 0 < run["cpu_us_p50"] <= run["cpu_us_p99"]
        assert all("cpu_p50" in seg for seg in run["segments"].values())
        assert len(run["load"]) == 3
        assert "late_by_more_than_half_period" in run and "overruns" in run
        # The host's share, read beside the late cycles: steal time per CPU over the run.
        steal = run["steal_ms_per_cpu"]
        assert len(steal) == os.cpu_count() and all(x >= 0 for x in steal)
        pieces = run["pieces_us"]
        assert set(pieces) == {
            "read",
            "kinematics",
            "motion",
            "collision",
            "qp_build",
            "qp_solve",
            "write",
            "publish",
            "other",
        }
        assert all(
            p["p50"] >= 0 and p["p99"] >= p["p50"] for k, p in pieces.items() if k != "other"
        )
        assert pieces["qp_build"]["p50"] > 0 and pieces["publish"]["p50"] > 0
        assert pieces["collision"]["p50"] > 0
        assert 0.0 <= run["collision"]["rows_active_pct"] <= 100.0
        assert {"idle", "hand line", "arms close"} <= set(run["segments"])
        assert sum(seg["cycles"] for seg in run["segments"].values()) == 100
        moving = [seg for name, seg in run["segments"].items() if seg["cycles"] and name != "idle"]
        assert moving and all(set(seg["pieces_p50"]) == set(pieces) for seg in moving)
        spread = run["identical_work_cpu_us"]
        assert 0 < spread["p50"] <= spread["p99"] and spread["p99_over_p50"] >= 1.0
        starts = run["starts"]["all"]  # 0.5 s at 200 Hz: the mix starts a motion or more
        assert starts["starts"] >= 1 and run["start_cpu_us_p50"] == starts["start_first_p50"]
        assert 0 < starts["start_p50"] and 0 < starts["first_p50"]
        # Built in the slack of the step that accepted it, as the control process does.
        assert 0 < starts["build_p50"] == run["start_build_us_p50"]
        assert 0 <= run["starts_over_period"] <= starts["starts"]
        assert run["compiled_in_loop"] == []  # every kernel ready before the loop
        assert starts["start_first_p50"] <= starts["start_first_max"]
    assert "piece medians by segment" in out and "identical work" in out
    assert "per cycle [us]" in out and "median of 2 runs" in out and "plant_us" in out
    assert "motion start: build in the slack" in out
    assert "collision rows active in" in out and "by segment" in out
    floor = result["machine_floor"]  # as long as a run by default
    assert set(floor) == {"late", "wake_p99_us", "wake_max_us", "fifo", "steal_ms_per_cpu"}
    assert len(floor["steal_ms_per_cpu"]) == os.cpu_count()
    assert floor["late"] >= 0 and 0 <= floor["wake_p99_us"] <= floor["wake_max_us"]
    assert "machine floor: a bare SCHED_FIFO sleep loop" in out


def test_bench_loop_without_the_breakdown_still_reports_the_cycle_and_spins_when_asked():
    lines, result = run_tool(
        "bench_loop.py", *SHORT, "--no-breakdown", "--floor-seconds", "0.1", "--spin-us", "200"
    )
    out = "\n".join(lines)
    # The loop and the floor's bare thread both busy-wait the last 200 us of each period.
    assert result["spin_us"] == 200.0 and result["machine_floor"]["spin_us"] == 200.0
    assert "machine floor: a bare SCHED_FIFO sleep + spin loop" in out
    (run,) = result["per_run"]
    assert run["cycles"] == 100 and run["pieces_us"] == {}
    assert all("pieces_p50" not in seg for seg in run["segments"].values())
    assert "per cycle [us]" not in out and "collision rows active in" in out

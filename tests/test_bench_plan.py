"""tools/bench_plan.py plans its moves and reports the CPU time per move."""

from __future__ import annotations

from tests.support import run_tool


def test_bench_plan_prints_the_planning_time_of_every_move():
    lines, figures = run_tool("bench_plan.py", "--rounds", "1")
    assert figures["robot"] == "smartpal5" and figures["moves"] == 12
    assert figures["refused"] == []
    assert 0.0 < figures["median_ms"] <= figures["max_ms"]
    assert sum(": median " in line for line in lines) == 12

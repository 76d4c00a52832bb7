"""tools/bench_cycle_cpu.py runs and reports the CPU time of each piece (issue 14)."""

from __future__ import annotations

from tests.support import run_tool


def test_bench_cycle_cpu_prints_every_piece():
    _, result = run_tool("bench_cycle_cpu.py", "--number", "20")
    pieces = result["pieces_us"]
    assert set(pieces) == {"read", "write", "mj_step", "publish", "kinematics", "cycle_glue"}
    assert all(0 <= p["min"] <= p["median"] for p in pieces.values())

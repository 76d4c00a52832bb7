"""tools/bench_hil.py: one loop for the warm-up and the measured run (issue 13)."""

from __future__ import annotations

from tests.support import run_tool

SHORT = ("--robot", "pa10", "--seconds", "0.5", "--no-realtime", "--planner", "thread")


def test_the_measured_run_continues_the_warm_up_loop():
    lines, result = run_tool("bench_hil.py", *SHORT, "--rate", "250")
    out = "\n".join(lines)
    assert result["cycles"] == 125 and result["warmup_overruns"] >= 0
    # No pause between the warm-up and the measured run (a second loop started after the
    # warm-up made its first step pay for the pause): the first measured deadline is a
    # whole number of periods after the warm-up's last one, on the same loop's grid.
    seam = result["warmup_seam_periods"]
    assert seam >= 1 and seam == round(seam)
    assert "the measured run continues its loop" in out

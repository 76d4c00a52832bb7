"""tools/bench_plan.py plans its moves and reports the CPU time per move."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_plan_prints_the_planning_time_of_every_move():
    out = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "bench_plan.py"), "--rounds", "1"],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
        cwd=ROOT,
    ).stdout
    lines = out.strip().splitlines()
    figures = json.loads(lines[-1])
    assert figures["robot"] == "smartpal5" and figures["moves"] == 12
    assert figures["refused"] == []
    assert 0.0 < figures["median_ms"] <= figures["max_ms"]
    assert sum(": median " in line for line in lines) == 12

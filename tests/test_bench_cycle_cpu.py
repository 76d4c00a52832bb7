"""tools/bench_cycle_cpu.py runs and reports the CPU time of each piece (issue 14)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_cycle_cpu_prints_every_piece():
    out = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "bench_cycle_cpu.py"), "--number", "20"],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    ).stdout
    result = json.loads(out.strip().splitlines()[-1])
    pieces = result["pieces_us"]
    assert set(pieces) == {"read", "write", "mj_step", "publish", "kinematics", "cycle_glue"}
    assert all(0 <= p["min"] <= p["median"] for p in pieces.values())

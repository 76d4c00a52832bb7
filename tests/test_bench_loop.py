"""tools/bench_loop.py runs and reports the per-piece breakdown (issue 14)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_loop_prints_the_breakdown_of_the_cycle():
    out = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tools" / "bench_loop.py"),
            "--seconds",
            "0.5",
            "--rate",
            "200",
            "--no-realtime",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    ).stdout
    result = json.loads(out.strip().splitlines()[-1])
    assert result["cycles"] == 100
    pieces = result["pieces_us"]
    assert set(pieces) == {
        "read",
        "kinematics",
        "motion",
        "qp_build",
        "qp_solve",
        "write",
        "publish",
        "other",
    }
    assert all(p["p50"] >= 0 and p["p99"] >= p["p50"] for k, p in pieces.items() if k != "other")
    assert pieces["qp_build"]["p50"] > 0 and pieces["publish"]["p50"] > 0
    assert "per cycle [us]" in out

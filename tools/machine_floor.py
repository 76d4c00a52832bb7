#!/usr/bin/env python3
"""The machine's floor for a periodic real-time loop: a SCHED_FIFO thread (priority 80, as
the control loop's) that only sleeps to absolute deadlines, no Python work, no other thread.

Usage: python tools/machine_floor.py [--rate 1000] [--seconds 60]

Prints one JSON line: ``late`` (cycles woken later than half a period), ``wake_p99_us``,
``wake_max_us`` and ``fifo`` (whether SCHED_FIFO was granted). On shared virtual cores even
this thread is late now and then (the host runs something else on the core): a loop's late
cycles are judged against the floor measured in the same minutes. :func:`measure` runs it in
a process of its own (the benchmarks call it before or after their runs).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np


def bare_loop(rate: float, seconds: float) -> dict[str, Any]:
    """Sleep to ``rate`` [Hz] deadlines for ``seconds`` [s] in this thread (SCHED_FIFO 80
    when permitted); the late count and wake latencies [µs]."""
    fifo = True
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(80))
    except (OSError, AttributeError):
        fifo = False
    period = round(1e9 / rate)
    n = max(1, int(rate * seconds))
    wake = np.zeros(n)
    t0 = time.monotonic_ns()
    for k in range(n):
        deadline = t0 + (k + 1) * period
        now = time.monotonic_ns()
        if deadline > now:
            time.sleep((deadline - now) / 1e9)
        wake[k] = (time.monotonic_ns() - deadline) / 1e3
    return {
        "late": int(np.count_nonzero(wake > 0.5 * period / 1e3)),
        "wake_p99_us": round(float(np.percentile(wake, 99.0)), 1),
        "wake_max_us": round(float(wake.max()), 1),
        "fifo": fifo,
    }


def measure(rate: float, seconds: float) -> dict[str, Any]:
    """:func:`bare_loop` in a process of its own (nothing else of the caller's in it); on a
    failure ``{"error": ...}``."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--rate", f"{rate:g}"]
    cmd += ["--seconds", f"{seconds:g}"]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=seconds + 60)
    lines = out.stdout.strip().splitlines()
    return dict(json.loads(lines[-1])) if lines else {"error": out.stderr.strip()[-300:]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=1000.0, help="[Hz]")
    parser.add_argument("--seconds", type=float, default=60.0)
    args = parser.parse_args()
    print(json.dumps(bare_loop(args.rate, args.seconds)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

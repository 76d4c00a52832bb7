#!/usr/bin/env python3
"""The machine's floor for a periodic real-time loop: a SCHED_FIFO thread (priority 80, as
the control loop's) that only sleeps to absolute deadlines, no Python work, no other thread.

Usage: python tools/machine_floor.py [--rate 1000] [--seconds 60] [--priority 80]
                                     [--threshold-us US] [--spin-us US]

Prints one JSON line: ``late`` (cycles woken later than half a period), ``wake_p99_us``,
``wake_max_us`` and ``fifo`` (whether SCHED_FIFO was granted); with ``--threshold-us`` also
``late_past_threshold`` (cycles woken later than that [µs]: for a loop whose step takes
``c`` [µs], a wake later than ``period - c`` is an overrun), ``threshold_us`` and
``priority``. On shared virtual cores even this thread is late now and then (the host runs
something else on the core): a loop's late cycles are judged against the floor measured in
the same minutes. :func:`measure` runs it in a process of its own (the benchmarks call it
before or after their runs); :func:`measure_together` runs several such processes at once,
each at its own priority, as a setup of several real-time threads (``tools/bench_hil.py``:
the loop at 80 and the drive emulator's process at 70 on a 2-core machine).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from controller.control.loop import spin_start

#: The control loop's SCHED_FIFO priority (controller.control.realtime's default).
LOOP_PRIORITY = 80


def bare_loop(
    rate: float,
    seconds: float,
    priority: int = LOOP_PRIORITY,
    threshold_us: float | None = None,
    spin_us: float = 0.0,
) -> dict[str, Any]:
    """Sleep to ``rate`` [Hz] deadlines for ``seconds`` [s] in this thread (SCHED_FIFO
    ``priority`` when permitted), the last ``spin_us`` [µs] before each busy-waiting (as
    the loop with ``realtime.spin_us``, by its rule: ``controller.control.loop.spin_start``);
    the late count and wake latencies [µs], and with
    ``threshold_us`` the wakes later than it (module doc)."""
    fifo = True
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (OSError, AttributeError):
        fifo = False
    period = round(1e9 / rate)
    spin = round(spin_us * 1e3)
    n = max(1, int(rate * seconds))
    wake = np.zeros(n)
    clock = time.monotonic_ns
    t0 = clock()
    for k in range(n):
        deadline = t0 + (k + 1) * period
        now = clock()
        spin_from = spin_start(deadline, now, spin, period)  # the loop's rule
        if spin_from > now:
            time.sleep((spin_from - now) / 1e9)
            now = clock()
        while now < deadline:
            now = clock()
        wake[k] = (now - deadline) / 1e3
    out: dict[str, Any] = {
        "late": int(np.count_nonzero(wake > 0.5 * period / 1e3)),
        "wake_p99_us": round(float(np.percentile(wake, 99.0)), 1),
        "wake_max_us": round(float(wake.max()), 1),
        "fifo": fifo,
    }
    if spin:
        out["spin_us"] = spin_us
    if threshold_us is not None:
        out["late_past_threshold"] = int(np.count_nonzero(wake > threshold_us))
        out["threshold_us"] = round(float(threshold_us), 1)
        out["priority"] = priority
    return out


def measure(
    rate: float,
    seconds: float,
    priority: int = LOOP_PRIORITY,
    threshold_us: float | None = None,
    spin_us: float = 0.0,
) -> dict[str, Any]:
    """:func:`bare_loop` in a process of its own (nothing else of the caller's in it); on a
    failure ``{"error": ...}``."""
    return measure_together(rate, seconds, (priority,), threshold_us, spin_us)[0]


def measure_together(
    rate: float,
    seconds: float,
    priorities: Sequence[int],
    threshold_us: float | None = None,
    spin_us: float = 0.0,
) -> list[dict[str, Any]]:
    """One :func:`bare_loop` process per priority of ``priorities``, all at the same time
    (same rate and deadlines' period; each its own start); their results in that order,
    ``{"error": ...}`` for one that failed. ``spin_us`` applies to the first (the loop's
    stand-in; the others are the loop's helper processes, which sleep)."""
    procs: list[subprocess.Popen[str]] = []
    for priority in priorities:
        cmd = [sys.executable, str(Path(__file__).resolve()), "--rate", f"{rate:g}"]
        cmd += ["--seconds", f"{seconds:g}"]
        if priority != LOOP_PRIORITY or threshold_us is not None:
            cmd += ["--priority", str(priority)]
        if threshold_us is not None:
            cmd += ["--threshold-us", repr(float(threshold_us))]
        if spin_us and not procs:
            cmd += ["--spin-us", repr(float(spin_us))]
        procs.append(subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                      text=True))  # fmt: skip
    results = []
    for proc in procs:
        try:
            stdout, stderr = proc.communicate(timeout=seconds + 60)
        except subprocess.TimeoutExpired:
            proc.kill()
            stdout, stderr = proc.communicate()
        lines = stdout.strip().splitlines()
        results.append(dict(json.loads(lines[-1])) if lines else {"error": stderr.strip()[-300:]})
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=1000.0, help="[Hz]")
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--priority", type=int, default=LOOP_PRIORITY,
                        help="SCHED_FIFO priority (1..99)")  # fmt: skip
    parser.add_argument("--threshold-us", type=float, default=None,
                        help="also count the wakes later than this [us]")  # fmt: skip
    parser.add_argument("--spin-us", type=float, default=0.0,
                        help="busy-wait the last microseconds before each deadline")  # fmt: skip
    args = parser.parse_args()
    result = bare_loop(args.rate, args.seconds, args.priority, args.threshold_us, args.spin_us)
    print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

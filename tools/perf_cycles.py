#!/usr/bin/env python3
"""The ``perf`` samples of a benchmark's loop thread, cycle by cycle (tools/bench_hil.py).

Usage: python tools/perf_cycles.py CYCLES.npz PERF.data CYCLE [CYCLE ...]

``CYCLES.npz`` is ``bench_hil.py --trace-out`` (each step's start on CLOCK_MONOTONIC, its
thread), ``PERF.data`` a ``perf record -k CLOCK_MONOTONIC -e cpu-clock -F 4000 -g -p PID``
of the same run. Prints, per cycle asked, the samples of the loop thread from 0.5 ms
before its step to its end: time into the step [µs] and the innermost frames. What it
tells: samples every ~250 µs spread over ordinary code in a long step is a slow CPU; a
gap without samples in the middle of ordinary code is time the virtual CPU did not run
(steal); many samples in one kernel path is the kernel's work (docs/emulator.md, "Those
``write()`` bursts are the host's").
"""

from __future__ import annotations

import bisect
import subprocess
import sys
from dataclasses import dataclass, field

import numpy as np

#: How far before a step its samples are listed [s] (the wake-up).
BEFORE = 0.5e-3


@dataclass
class Sample:
    """One ``perf script`` sample: time [s], thread, event, frames innermost first."""

    time: float
    tid: int
    event: str
    frames: list[str] = field(default_factory=list)


def parse(text: str) -> list[Sample]:
    """The samples of ``perf script -F tid,time,event,ip,sym`` output, in its order."""
    samples: list[Sample] = []
    current: Sample | None = None
    for line in text.splitlines():
        if not line.strip():
            current = None
            continue
        if not line.startswith("\t"):  # a sample's header; its frames are indented by tabs
            tid, stamp, event = line.split()[:3]
            current = Sample(float(stamp.rstrip(":")), int(tid), event.rstrip(":"))
            samples.append(current)
        elif current is not None:
            words = line.split(None, 1)
            current.frames.append((words[1] if len(words) > 1 else words[0]).split(" (")[0])
    return samples


def in_cycle(samples: list[Sample], start: float, end: float) -> list[Sample]:
    """The samples (sorted by time) from ``BEFORE`` before ``start`` to ``end`` [s]."""
    times = [s.time for s in samples]
    return samples[bisect.bisect_left(times, start - BEFORE) : bisect.bisect_right(times, end)]


def main() -> int:
    if len(sys.argv) < 4:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    cycles = np.load(sys.argv[1])
    text = subprocess.run(
        ["perf", "script", "-i", sys.argv[2], "-F", "tid,time,event,ip,sym"],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    tid = int(cycles["tid"])
    samples = sorted((s for s in parse(text) if s.tid == tid), key=lambda s: s.time)
    for k in map(int, sys.argv[3:]):
        start = float(cycles["t_begin"][k])
        compute = float(cycles["compute_us"][k])
        print(f"cycle {k}: step of {compute:.0f} us, its thread's CPU "
              f"{cycles['step_cpu'][k] * 1e6:.0f} us")  # fmt: skip
        for s in in_cycle(samples, start, start + compute * 1e-6):
            print(f"  {(s.time - start) * 1e6:8.0f} us  {s.event:10s} " + " <- ".join(s.frames[:5]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

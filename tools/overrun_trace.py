"""What each overrun of a benchmark's control loop was made of (tools/bench_hil.py).

:class:`CycleTrace` records, per cycle, in preallocated arrays: the step's thread CPU time,
the master's ``read()`` (wall time, the part of it spent waiting for TPDOs, drives whose
TPDO1 had not come) and ``write()`` (wall time), the garbage collections of this process
(any thread: while the step ran, and between the previous step's end and this one's start,
where they delay the wake-up), whether the planning thread was planning and whether the
step started a motion (:meth:`CycleTrace.motion_started`). Nothing is
allocated per cycle (a growing list would add page faults of its own to the figures). After the run,
:meth:`CycleTrace.overruns` joins these with the loop's wake latency and compute time and
names, per overrun, the largest part of it:

* ``gc``: garbage collections of this process in or just before the cycle;
* ``tpdo wait``: ``read()`` waiting (up to ``feedback_wait``) for TPDOs the emulator had not
  sent yet (the emulator process late: on time, every TPDO is there when the loop wakes);
* ``off cpu``: the step's thread not running although it was not waiting for a frame
  (another thread held the GIL, e.g. the planner, or the host ran something else);
* ``late wake``: the loop woke late;
* ``cpu``: the step's own work.
"""

from __future__ import annotations

import gc
import threading
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

CAUSES = ("gc", "tpdo wait", "off cpu", "late wake", "cpu")


class CycleTrace:
    """Per-cycle figures of up to ``capacity`` cycles (module doc). Times [s]."""

    def __init__(self, capacity: int):
        self.capacity = capacity
        self.step_cpu = np.zeros(capacity)
        self.read_wall = np.zeros(capacity)
        self.read_wait = np.zeros(capacity)
        self.write_wall = np.zeros(capacity)
        self.missing = np.zeros(capacity, dtype=np.int32)
        self.gc_in = np.zeros(capacity)
        self.gc_before = np.zeros(capacity)
        self.planning_during = np.zeros(capacity, dtype=bool)
        #: The step started a motion (its first cycle of motion is the next one).
        self.started = np.zeros(capacity, dtype=bool)
        #: The master's ``read()`` + ``write()`` per cycle: thread CPU and wall time [s].
        self.master_cpu = np.zeros(capacity)
        self.master_wall = np.zeros(capacity)
        self._read_cpu = 0.0
        #: Odd while the planner plans (it adds 1 before and after a plan).
        self.planning = 0
        self._cycle = -1
        self._cpu0 = 0.0
        self._gc0 = 0.0
        self._gc_end = 0.0
        self._plan0 = 0
        #: Garbage collections of this process: total time [s], count per generation, longest
        #: [s] and the thread that ran the longest.
        self.gc_total = 0.0
        self.gc_counts = [0, 0, 0]
        self.gc_longest = 0.0
        self.gc_longest_generation = -1
        self._gc_start = 0.0
        self._lock = threading.Lock()
        gc.callbacks.append(self._on_gc)

    def reset(self) -> None:
        """Forget every cycle and collection (the start of the measured run)."""
        for array in (
            self.step_cpu,
            self.read_wall,
            self.read_wait,
            self.write_wall,
            self.missing,
            self.gc_in,
            self.gc_before,
            self.planning_during,
            self.started,
            self.master_cpu,
            self.master_wall,
        ):
            array.fill(0)
        self.forget_collections()

    def forget_collections(self) -> None:
        """Forget the collections counted so far (not the cycles: cheap enough for a step,
        e.g. the first measured one of a loop whose earlier cycles were not recorded)."""
        self.gc_total = self.gc_longest = self._gc_end = 0.0
        self.gc_counts = [0, 0, 0]
        self.gc_longest_generation = -1

    def close(self) -> None:
        """Stop counting collections."""
        if self._on_gc in gc.callbacks:
            gc.callbacks.remove(self._on_gc)

    def _on_gc(self, phase: str, info: dict[str, Any]) -> None:
        if phase == "start":
            self._gc_start = time.perf_counter()
            return
        took = time.perf_counter() - self._gc_start
        self.gc_total += took
        generation = int(info.get("generation", 0))
        self.gc_counts[generation] += 1
        if took > self.gc_longest:
            self.gc_longest, self.gc_longest_generation = took, generation

    # ----------------------------------------------------------------------- the cycle
    def begin(self, cycle: int) -> None:
        """The step of ``cycle`` starts (a negative ``cycle``: not recorded)."""
        self._cycle = cycle if cycle < self.capacity else -1
        if self._cycle >= 0:
            self.gc_before[cycle] = self.gc_total - self._gc_end
        self._gc0 = self.gc_total
        self._plan0 = self.planning
        self._cpu0 = time.thread_time()

    def read_done(self, wall: float, cpu: float, missing: int) -> None:
        """``read()`` took ``wall`` [s], ``cpu`` [s] of them on the CPU; ``missing`` drives
        had not sent their TPDO1."""
        k = self._cycle
        if k >= 0:
            self.read_wall[k] = wall
            self.read_wait[k] = max(0.0, wall - cpu)
            self.missing[k] = missing
            self._read_cpu = cpu

    def write_done(self, wall: float, cpu: float) -> None:
        """``write()`` took ``wall`` [s], ``cpu`` [s] of them on the CPU."""
        k = self._cycle
        if k >= 0:
            self.write_wall[k] = wall
            self.master_cpu[k] = self._read_cpu + cpu
            self.master_wall[k] = self.read_wall[k] + wall

    def motion_started(self) -> None:
        """The step started a motion (``MotionCore.start``)."""
        if self._cycle >= 0:
            self.started[self._cycle] = True

    def end(self) -> None:
        """The step ends."""
        k = self._cycle
        self._gc_end = self.gc_total
        if k < 0:
            return
        self.step_cpu[k] = time.thread_time() - self._cpu0
        self.gc_in[k] = self.gc_total - self._gc0
        self.planning_during[k] = bool(self._plan0 % 2 or self.planning != self._plan0)

    # ----------------------------------------------------------------------- the report
    def overruns(
        self,
        period: float,
        feedback_wait: float,
        latency_us: Sequence[float] | np.ndarray,
        compute_us: Sequence[float] | np.ndarray,
    ) -> list[dict[str, Any]]:
        """One row per cycle whose wake latency + compute time passed ``period`` [s] (the
        loop's arrays [µs], in cycle order): its figures [µs] and the largest ``cause``.
        ``read()`` off the CPU up to ``feedback_wait`` [s] is waiting for TPDOs, beyond it
        (select returned, the GIL or the CPU was not free) is off the CPU."""
        rows = []
        n = min(len(latency_us), len(compute_us), self.capacity)
        for k in range(n):
            latency, compute = float(latency_us[k]), float(compute_us[k])
            if latency + compute <= period * 1e6:
                continue
            gc_us = (self.gc_in[k] + self.gc_before[k]) * 1e6
            wait = min(self.read_wait[k], feedback_wait) * 1e6  # the rest: not on the CPU
            cpu = self.step_cpu[k] * 1e6
            off = max(0.0, compute - cpu - wait)
            parts = {"gc": gc_us, "tpdo wait": wait, "off cpu": off, "late wake": latency,
                     "cpu": cpu - self.gc_in[k] * 1e6}  # fmt: skip
            rows.append({
                "cycle": k,
                "wake_us": round(latency, 1),
                "compute_us": round(compute, 1),
                "cpu_us": round(cpu, 1),
                "read_us": round(self.read_wall[k] * 1e6, 1),
                "tpdo_wait_us": round(wait, 1),
                "missing_tpdo1": int(self.missing[k]),
                "write_us": round(self.write_wall[k] * 1e6, 1),
                "gc_us": round(gc_us, 1),
                "off_cpu_us": round(off, 1),
                "planning": bool(self.planning_during[k]),
                # started a motion, or ran its first cycle
                "motion_start": bool(self.started[k] or (k > 0 and self.started[k - 1])),
                "cause": max(parts, key=lambda name: parts[name]),
            })  # fmt: skip
        return rows


def print_overruns(rows: list[dict[str, Any]], limit: int = 40) -> dict[str, int]:
    """Print the rows of :meth:`CycleTrace.overruns` (the first ``limit``); causes counted."""
    counts = dict.fromkeys(CAUSES, 0)
    for row in rows:
        counts[row["cause"]] += 1
    if not rows:
        return counts
    print("overruns [us]:  cycle    wake  compute      cpu     read  tpdo-wait miss   write"
          "       gc  off-cpu plan start cause")  # fmt: skip
    for r in rows[:limit]:
        print(f"  {r['cycle']:12d} {r['wake_us']:7.0f} {r['compute_us']:8.0f} {r['cpu_us']:8.0f} "
              f"{r['read_us']:8.0f} {r['tpdo_wait_us']:10.0f} {r['missing_tpdo1']:4d} "
              f"{r['write_us']:7.0f} {r['gc_us']:8.0f} {r['off_cpu_us']:8.0f} "
              f"{'yes' if r['planning'] else 'no':>4s} "
              f"{'yes' if r['motion_start'] else 'no':>5s} {r['cause']}")  # fmt: skip
    if len(rows) > limit:
        print(f"  ... {len(rows) - limit} more")
    print("overrun causes: " + ", ".join(f"{k} {v}" for k, v in counts.items() if v))
    return counts

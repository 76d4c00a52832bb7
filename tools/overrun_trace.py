"""What each overrun of a benchmark's control loop was made of (tools/bench_hil.py).

:class:`CycleTrace` records, per cycle, in preallocated arrays: the step's thread CPU time,
the master's ``read()`` (wall and thread CPU time, the part of it spent waiting for TPDOs,
drives whose TPDO1 had not come) and ``write()`` (wall and thread CPU time, and its socket
sends' wall and CPU time), the step's page faults and context switches (``getrusage`` of
its thread), the CPU it began and ended on, the garbage collections of this process (any
thread: while the step ran, and between the previous step's end and this one's start,
where they delay the wake-up), whether the planning thread was planning and whether the
step started a motion (:meth:`CycleTrace.motion_started`) or its slack built one
(:meth:`CycleTrace.motion_built`); and, read in the loop's slack
every :data:`STEAL_EVERY` cycles, the steal time of each CPU (``/proc/stat``: time the
hypervisor ran something else while the guest's CPU wanted to run). Nothing is allocated
per cycle (a growing list would add page faults of its own to the figures). After the
run, :meth:`CycleTrace.overruns` joins these with the loop's wake latency and compute time
and names, per overrun, the part of it most above that part's median over the run (what
made the cycle longer than the others, not the largest part: a step of usual cost in a
cycle that woke 0.5 ms late and waited 0.4 ms for TPDOs is a late wake, not its CPU):

* ``gc``: garbage collections of this process in or just before the cycle;
* ``tpdo wait``: ``read()`` waiting (up to ``feedback_wait``) for TPDOs the emulator had not
  sent yet (the emulator process late: on time, every TPDO is there when the loop wakes);
* ``off cpu``: the step's thread not running although it was not waiting for a frame
  (another thread held the GIL, e.g. the planner, or the host ran something else);
* ``steal``: off the CPU, but the thread never left it (no context switch, voluntary or
  not, in the step): its task clock stopped while the guest kernel kept running it, which
  is the hypervisor running something else on the virtual CPU (the guest counts it as
  steal time and leaves it out of the thread's CPU time). ``perf record`` of such cycles
  shows a gap of that length without a sample in the middle of ordinary code;
* ``late wake``: the loop woke late (the host's: :mod:`machine_floor`'s bare thread wakes
  as late as often);
* ``build``: the loop woke late after a slack that built a motion (a command's motion is
  built in the slack of the step that accepted it, :mod:`controller.control.pending_start`):
  the loop's own, not the host's;
* ``slow cpu``: the step's own work, but not one part of it grown: ``write()`` and one of
  the other two parts (``read()``'s own CPU, the rest of the step) each took :data:`SLOW`
  times their run's median or more, with no page fault, context switch or collection in
  the cycle. ``write()`` does the same work every cycle (the same frames, the same sends),
  so it is a probe of the CPU's speed: the virtual CPU ran slow, the host's doing
  (``perf record`` of such cycles shows its samples spread evenly over ordinary code, no
  kernel path, no fault);
* ``cpu``: the step's own work (one part of it grown: e.g. a motion's first cycle).

``steal``, ``late wake`` and ``slow cpu`` are the host's; ``cpu``, ``build`` and ``gc`` the
loop's own;
``tpdo wait`` the emulator process's (usually the host's too: it runs under SCHED_FIFO on
the other core). The thread CPU times are the kernel's task clock: on this virtual machine
they differ from the wall clock (``time.perf_counter``) by up to ~0.5 ms at times, even
above it, so the rows compare wall times where they can.
"""

from __future__ import annotations

import ctypes
import gc
import os
import resource
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

CAUSES = ("gc", "tpdo wait", "off cpu", "steal", "late wake", "slow cpu", "build", "cpu")
#: The causes that are the host's (module doc).
HOST_CAUSES = ("steal", "late wake", "slow cpu")

#: Cycles between two reads of the steal time (``/proc/stat``: ~10 µs a read, in the loop's
#: slack; its figures move in 10 ms steps anyway).
STEAL_EVERY = 5

#: ``slow cpu``: how many times their run's medians ``write()`` and another part of the step
#: must take (module doc). Each part alone passes twice its median in ~0.1 % of cycles.
SLOW = 2.0


def _sched_getcpu() -> Callable[[], int] | None:
    """libc's ``sched_getcpu`` (the CPU the calling thread runs on), None without it."""
    try:
        function = ctypes.CDLL(None).sched_getcpu
    except (OSError, AttributeError):
        return None
    function.restype = ctypes.c_int
    function.argtypes = []
    return function


def read_steal(fd: int, out: np.ndarray) -> None:
    """The steal time [s] of each CPU (``/proc/stat`` open as ``fd``) into ``out`` (CPUs
    beyond its length are left out)."""
    tick = os.sysconf("SC_CLK_TCK")
    for line in os.pread(fd, 1 << 16, 0).split(b"\n")[1:]:
        if not line.startswith(b"cpu"):
            break
        fields = line.split()
        cpu = int(fields[0][3:])
        if cpu < len(out) and len(fields) > 8:
            out[cpu] = int(fields[8]) / tick


class CycleTrace:
    """Per-cycle figures of up to ``capacity`` cycles (module doc). Times [s]."""

    def __init__(self, capacity: int):
        self.capacity = capacity
        self.step_cpu = np.zeros(capacity)
        self.read_wall = np.zeros(capacity)
        self.read_cpu = np.zeros(capacity)
        self.read_wait = np.zeros(capacity)
        self.write_wall = np.zeros(capacity)
        self.write_cpu = np.zeros(capacity)
        #: ``write()``'s socket sends (one record per bus and peer), summed per cycle.
        self.send_wall = np.zeros(capacity)
        self.send_cpu = np.zeros(capacity)
        self.missing = np.zeros(capacity, dtype=np.int32)
        self.gc_in = np.zeros(capacity)
        self.gc_before = np.zeros(capacity)
        self.planning_during = np.zeros(capacity, dtype=bool)
        #: The step started a motion (its first cycle of motion is the next one).
        self.started = np.zeros(capacity, dtype=bool)
        #: The slack after the step built a motion (the next cycle may wake late for it).
        self.built = np.zeros(capacity, dtype=bool)
        #: The master's ``read()`` + ``write()`` per cycle: thread CPU and wall time [s].
        self.master_cpu = np.zeros(capacity)
        self.master_wall = np.zeros(capacity)
        #: The step's thread: minor page faults, voluntary and involuntary context switches.
        self.faults = np.zeros(capacity, dtype=np.int32)
        self.switches = np.zeros(capacity, dtype=np.int32)
        self.preempted = np.zeros(capacity, dtype=np.int32)
        #: When each step began (``time.perf_counter``, CLOCK_MONOTONIC [s]; for lining
        #: them up with ``perf record -k CLOCK_MONOTONIC``), the CPUs it began and ended on
        #: (−1: unknown) and the thread that ran the steps.
        self.t_begin = np.zeros(capacity)
        self.cpu_begin = np.full(capacity, -1, dtype=np.int16)
        self.cpu_end = np.full(capacity, -1, dtype=np.int16)
        self.tid = 0
        #: Steal time per CPU [s] (``/proc/stat``), read after cycle ``steal_cycle[j]``
        #: (−1: before the first).
        self.steal = np.zeros((capacity // STEAL_EVERY + 2, os.cpu_count() or 1))
        self.steal_cycle = np.full(len(self.steal), -1, dtype=np.int64)
        self._steals = 0
        try:
            self._stat: int | None = os.open("/proc/stat", os.O_RDONLY)
        except OSError:
            self._stat = None
        self._getcpu = _sched_getcpu()
        self._usage0: Any = None
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
        """Forget every cycle, collection and steal read (the start of the measured run)."""
        for array in vars(self).values():
            if isinstance(array, np.ndarray):
                array.fill(0)
        for array in (self.cpu_begin, self.cpu_end, self.steal_cycle):
            array.fill(-1)
        self._steals = 0
        self.forget_collections()

    def forget_collections(self) -> None:
        """Forget the collections counted so far (not the cycles: cheap enough for a step,
        e.g. the first measured one of a loop whose earlier cycles were not recorded)."""
        self.gc_total = self.gc_longest = self._gc_end = 0.0
        self.gc_counts = [0, 0, 0]
        self.gc_longest_generation = -1

    def close(self) -> None:
        """Stop recording (what comes after the last step, e.g. the shutdown's sends, is
        not its) and counting collections and reading steal time."""
        self._cycle = -1
        if self._on_gc in gc.callbacks:
            gc.callbacks.remove(self._on_gc)
        if self._stat is not None:
            os.close(self._stat)
            self._stat = None

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
            self.t_begin[cycle] = time.perf_counter()
            self.tid = threading.get_native_id()
            if self._getcpu is not None:
                self.cpu_begin[cycle] = self._getcpu()
            self._usage0 = resource.getrusage(resource.RUSAGE_THREAD)
        self._gc0 = self.gc_total
        self._plan0 = self.planning
        self._cpu0 = time.thread_time()

    def read_done(self, wall: float, cpu: float, missing: int) -> None:
        """``read()`` took ``wall`` [s], ``cpu`` [s] of them on the CPU; ``missing`` drives
        had not sent their TPDO1."""
        k = self._cycle
        if k >= 0:
            self.read_wall[k] = wall
            self.read_cpu[k] = cpu
            self.read_wait[k] = max(0.0, wall - cpu)
            self.missing[k] = missing
            self._read_cpu = cpu

    def sent(self, wall: float, cpu: float) -> None:
        """One socket send of the cycle's ``write()`` took ``wall`` [s], ``cpu`` [s] of them
        on the CPU."""
        k = self._cycle
        if k >= 0:
            self.send_wall[k] += wall
            self.send_cpu[k] += cpu

    def write_done(self, wall: float, cpu: float) -> None:
        """``write()`` took ``wall`` [s], ``cpu`` [s] of them on the CPU."""
        k = self._cycle
        if k >= 0:
            self.write_wall[k] = wall
            self.write_cpu[k] = cpu
            self.master_cpu[k] = self._read_cpu + cpu
            self.master_wall[k] = self.read_wall[k] + wall

    def motion_started(self) -> None:
        """The step started a motion (``MotionCore.start``)."""
        if self._cycle >= 0:
            self.started[self._cycle] = True

    def motion_built(self) -> None:
        """The slack after the last step built a motion (``PendingStart.build``)."""
        if self._cycle >= 0:
            self.built[self._cycle] = True

    def end(self) -> None:
        """The step ends."""
        k = self._cycle
        self._gc_end = self.gc_total
        if k < 0:
            return
        self.step_cpu[k] = time.thread_time() - self._cpu0
        if self._getcpu is not None:
            self.cpu_end[k] = self._getcpu()
        u0, u1 = self._usage0, resource.getrusage(resource.RUSAGE_THREAD)
        self.faults[k] = u1.ru_minflt - u0.ru_minflt + u1.ru_majflt - u0.ru_majflt
        self.switches[k] = u1.ru_nvcsw - u0.ru_nvcsw
        self.preempted[k] = u1.ru_nivcsw - u0.ru_nivcsw
        self.gc_in[k] = self.gc_total - self._gc0
        self.planning_during[k] = bool(self._plan0 % 2 or self.planning != self._plan0)

    def sample_steal(self, first: bool = False) -> None:
        """In the loop's slack after a step: each CPU's steal time, after every
        :data:`STEAL_EVERY`-th recorded cycle (``first``: now, before the first one)."""
        k = -1 if first else self._cycle
        if self._stat is None or self._steals >= len(self.steal):
            return
        if not first and (k < 0 or k % STEAL_EVERY):
            return
        read_steal(self._stat, self.steal[self._steals])
        self.steal_cycle[self._steals] = k
        self._steals += 1

    def steal_total(self) -> list[float]:
        """Each CPU's steal time [s] between the first read and the last."""
        n = self._steals
        if n < 2:
            return [0.0] * self.steal.shape[1]
        return [round(float(x), 3) for x in self.steal[n - 1] - self.steal[0]]

    def steal_around(self, k: int) -> tuple[float, float, int]:
        """Between the reads before and after cycle ``k``: the steal time [s] of the CPUs
        it ran on (every CPU if unknown), of the other CPUs (where the emulator process
        ran, on two), and how many cycles apart the reads were (0: no read after it)."""
        cycles = self.steal_cycle[: self._steals]
        j = int(np.searchsorted(cycles, k))  # the first read after the step of cycle k
        if j == 0 or j >= len(cycles):
            return 0.0, 0.0, 0
        cpus = {int(c) for c in (self.cpu_begin[k], self.cpu_end[k]) if c >= 0}
        delta = self.steal[j] - self.steal[j - 1]
        own = sum(delta[c] for c in cpus) if cpus else delta.sum()
        return float(own), float(delta.sum() - own), int(cycles[j] - cycles[j - 1])

    # ----------------------------------------------------------------------- the report
    def save(self, path: str, latency_us: np.ndarray, compute_us: np.ndarray) -> None:
        """Every per-cycle array and the loop's wake latency and compute time [µs] to
        ``path`` (NumPy ``.npz``; with ``tid``, ``pid`` for ``perf``)."""
        arrays: dict[str, Any] = {k: v for k, v in vars(self).items() if isinstance(v, np.ndarray)}
        arrays.update(latency_us=latency_us, compute_us=compute_us, tid=self.tid,
                      pid=os.getpid())  # fmt: skip
        np.savez(path, **arrays)

    def slowdown(self, compute_us: np.ndarray) -> np.ndarray:
        """Per cycle (of ``compute_us``, the loop's [µs]): how many times their run's median
        ``write()`` and another part of the step (``read()``'s CPU or the rest) both took at
        least (module doc: ``slow cpu`` when it is :data:`SLOW` or more)."""
        n = min(len(compute_us), self.capacity)
        compute = np.asarray(compute_us[:n], dtype=float) * 1e-6
        parts = np.stack([
            self.read_cpu[:n],
            self.write_wall[:n],
            np.maximum(0.0, compute - self.read_wall[:n] - self.write_wall[:n]),
        ])  # fmt: skip
        medians = np.median(parts, axis=1) if n else np.zeros(3)
        ratios = parts / np.maximum(medians, 1e-9)[:, None]
        return np.minimum(ratios[1], np.maximum(ratios[0], ratios[2]))

    def overruns(
        self,
        period: float,
        feedback_wait: float,
        latency_us: Sequence[float] | np.ndarray,
        compute_us: Sequence[float] | np.ndarray,
    ) -> list[dict[str, Any]]:
        """One row per cycle whose wake latency + compute time passed ``period`` [s] (the
        loop's arrays [µs], in cycle order): its figures [µs] and its ``cause``, the part of
        it most above that part's median over the run (what made this cycle longer than the
        others; the module doc lists them). ``read()`` off the CPU up to ``feedback_wait``
        [s] is waiting for TPDOs, beyond it (select returned, the GIL or the CPU was not
        free) is off the CPU."""
        rows = []
        n = min(len(latency_us), len(compute_us), self.capacity)
        latencies = np.asarray(latency_us[:n], dtype=float)
        computes = np.asarray(compute_us[:n], dtype=float)
        slowdown = self.slowdown(computes)
        # Per cycle [µs]: TPDO wait, own CPU (collections left out), off the CPU.
        waits = np.minimum(self.read_wait[:n], feedback_wait) * 1e6
        cpus = (self.step_cpu[:n] - self.gc_in[:n]) * 1e6
        offs = np.maximum(0.0, computes - self.step_cpu[:n] * 1e6 - waits)
        usual = {
            name: float(np.median(values)) if n else 0.0
            for name, values in (("tpdo wait", waits), ("off cpu", offs),
                                 ("late wake", latencies), ("cpu", cpus))
        }  # fmt: skip
        usual["gc"] = 0.0
        for k in range(n):
            latency, compute = float(latencies[k]), float(computes[k])
            if latency + compute <= period * 1e6:
                continue
            gc_us = (self.gc_in[k] + self.gc_before[k]) * 1e6
            wait, cpu, off = float(waits[k]), self.step_cpu[k] * 1e6, float(offs[k])
            parts = {"gc": gc_us, "tpdo wait": wait, "off cpu": off, "late wake": latency,
                     "cpu": float(cpus[k])}  # fmt: skip
            cause = max(parts, key=lambda name: parts[name] - usual[name])
            quiet = not (self.faults[k] or self.switches[k] or self.preempted[k] or gc_us)
            built_before = k > 0 and bool(self.built[k - 1])
            if cause == "late wake" and built_before:
                cause = "build"
            elif cause == "cpu" and quiet and slowdown[k] >= SLOW:
                cause = "slow cpu"
            elif cause == "off cpu" and not (self.switches[k] or self.preempted[k]):
                cause = "steal"
            steal, steal_others, window = self.steal_around(k)
            rows.append({
                "cycle": k,
                "wake_us": round(latency, 1),
                "compute_us": round(compute, 1),
                "cpu_us": round(cpu, 1),
                "read_us": round(self.read_wall[k] * 1e6, 1),
                "tpdo_wait_us": round(wait, 1),
                "missing_tpdo1": int(self.missing[k]),
                "write_us": round(self.write_wall[k] * 1e6, 1),
                "write_cpu_us": round(self.write_cpu[k] * 1e6, 1),
                "send_us": round(self.send_wall[k] * 1e6, 1),
                "send_cpu_us": round(self.send_cpu[k] * 1e6, 1),
                "gc_us": round(gc_us, 1),
                "off_cpu_us": round(off, 1),
                "faults": int(self.faults[k]),
                "switches": int(self.switches[k]),
                "preempted": int(self.preempted[k]),
                "slowdown": round(float(slowdown[k]), 2),
                "cpus": sorted({int(self.cpu_begin[k]), int(self.cpu_end[k])}),
                "steal_us": round(steal * 1e6, 1),
                "steal_other_cpus_us": round(steal_others * 1e6, 1),
                "steal_window_cycles": window,
                "planning": bool(self.planning_during[k]),
                # built a motion in the slack before it, started one, or ran its first cycle
                "motion_start": bool(
                    self.started[k] or (k > 0 and self.started[k - 1]) or built_before
                ),
                "cause": cause,
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
          "    send       gc  off-cpu flt/sw slow  steal plan start cause")  # fmt: skip
    for r in rows[:limit]:
        print(f"  {r['cycle']:12d} {r['wake_us']:7.0f} {r['compute_us']:8.0f} {r['cpu_us']:8.0f} "
              f"{r['read_us']:8.0f} {r['tpdo_wait_us']:10.0f} {r['missing_tpdo1']:4d} "
              f"{r['write_us']:7.0f} {r['send_us']:7.0f} {r['gc_us']:8.0f} "
              f"{r['off_cpu_us']:8.0f} {r['faults']:3d}/{r['switches'] + r['preempted']:<2d} "
              f"{r['slowdown']:4.1f} {r['steal_us'] / 1e3:5.0f}ms "
              f"{'yes' if r['planning'] else 'no':>4s} "
              f"{'yes' if r['motion_start'] else 'no':>5s} {r['cause']}")  # fmt: skip
    if len(rows) > limit:
        print(f"  ... {len(rows) - limit} more")
    host = sum(counts[c] for c in HOST_CAUSES)
    print("overrun causes: " + ", ".join(f"{k} {v}" for k, v in counts.items() if v)
          + f" ({host} the host's: {' / '.join(HOST_CAUSES)})")  # fmt: skip
    return counts

"""Per-cycle loop statistics kept for the whole run and written to a file at exit.

The control loop's own :class:`~controller.control.loop.LoopStats` keeps one second of cycles (the
snapshot publishes its percentiles). Benchmarks need every cycle: with ``loop.stats_file``
set, the daemon swaps in a :class:`CycleLog`, which also stores each cycle's wake latency
and compute time [µs] in preallocated arrays (no allocation in the loop), and
:meth:`CycleLog.save` writes them as an ``.npz`` file when the daemon stops::

    wake_us[i], compute_us[i]   cycle i (the snapshot's cycle counter), in order
    period_us                   the loop period
    overruns                    overruns over the run

When the run outlasts the arrays, the oldest cycles are overwritten (the file then holds the
last ``capacity`` cycles and ``first_cycle`` says which one comes first).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from controller.control.loop import LoopStats

#: Longest run kept in full [s].
HISTORY_S = 900.0


class CycleLog(LoopStats):
    """:class:`LoopStats` (window of ``capacity`` cycles) + every cycle since the start."""

    def __init__(self, period_s: float, capacity: int, history_s: float = HISTORY_S):
        super().__init__(period_s, capacity)
        size = max(1, round(history_s / period_s))
        self._all_wake = np.zeros(size)
        self._all_compute = np.zeros(size)
        self._n = 0

    def record(self, compute_us: float, latency_us: float) -> None:
        super().record(compute_us, latency_us)
        i = self._n % self._all_wake.size
        self._all_wake[i] = latency_us
        self._all_compute[i] = compute_us
        self._n += 1

    def save(self, path: Path) -> None:
        """Write the cycles recorded so far (chronological) to ``path`` (.npz)."""
        size = self._all_wake.size
        if self._n <= size:
            first, wake, compute = 0, self._all_wake[: self._n], self._all_compute[: self._n]
        else:
            first = self._n - size
            shift = -(self._n % size)
            wake, compute = np.roll(self._all_wake, shift), np.roll(self._all_compute, shift)
        with open(path, "wb") as f:
            np.savez(
                f,
                wake_us=wake,
                compute_us=compute,
                first_cycle=first,
                period_us=self.period_us,
                overruns=self.overruns,
            )

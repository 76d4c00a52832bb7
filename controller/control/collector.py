"""Python's cyclic garbage collector run in the control loop's slack, never mid-cycle.

By default CPython collects when a thread allocates its 700th net container object: in the
middle of whatever that thread is doing, holding the GIL. In the control process that can be
the loop's IK, or another thread (a command channel, an in-process planner) the loop then
waits for. Timed in ``tools/bench_loop.py``'s process (SmartPal V, start-up included):
young collections 77 µs median, middle ones ~1 ms, full ones 43 ms; any of them in the
middle of a cycle makes it overrun. While the loop runs, the process allocates little: in
20 s of the benchmark's mix CPython ran 3 young collections and no older one.

:class:`SlackCollector` turns the automatic collector off and runs it itself, after a step,
when the time left before the next deadline covers what that generation cost the last time:

* **generation 0** when at least :data:`YOUNG_THRESHOLD` objects are pending (CPython's
  default threshold), or at once past :data:`YOUNG_LIMIT` (a cycle late by a young
  collection is better than memory that only grows);
* **generation 1** after every :data:`MIDDLE_EVERY` young collections, when it fits;
  when it does not, its objects (those that survived a young collection) go into the
  permanent generation with :func:`gc.freeze` instead, and the cost is taken as a little
  lower the next time (:data:`DECAY`), so the collection is tried again;
* **generation 2** (the full collection) never while the loop runs. Objects in the permanent
  generation are still freed by reference counting; only a reference cycle that becomes
  garbage after it was frozen stays in memory until the process ends. :attr:`frozen` counts
  the objects frozen this way (``gc.get_freeze_count``), so growth can be watched.

:meth:`stop` restores the collector as it found it. Process-wide: one per process.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable

#: Pending objects that make a young collection due (CPython's default threshold 0).
YOUNG_THRESHOLD = 700
#: Pending objects past which a young collection runs even without slack.
YOUNG_LIMIT = 20 * YOUNG_THRESHOLD
#: Young collections between two attempts at generation 1 (CPython's default threshold 1).
MIDDLE_EVERY = 10
#: Margin on a collection's last measured cost before it is run in the slack.
MARGIN = 1.5
#: Factor on generation 1's cost each time it was frozen instead (so it is tried again).
DECAY = 0.8


class SlackCollector:
    """Runs the garbage collector between cycles; see the module docstring.

    ``clock_ns`` replaces :func:`time.perf_counter_ns` (tests).
    """

    def __init__(self, clock_ns: Callable[[], int] = time.perf_counter_ns):
        self._clock_ns = clock_ns
        #: Last measured cost of a collection of generation 0 and 1 [ns]. The first guesses
        #: are small so the first collection runs and measures.
        self.cost_ns = [50_000, 200_000]
        #: Collections run, by generation (0, 1).
        self.collections = [0, 0]
        #: Generation-1 collections replaced by a freeze because they did not fit.
        self.freezes = 0
        #: Young collections run without slack (past YOUNG_LIMIT).
        self.forced = 0
        self._was_enabled: bool | None = None
        self._was_frozen = False

    @property
    def active(self) -> bool:
        """True between :meth:`start` and :meth:`stop`."""
        return self._was_enabled is not None

    @property
    def frozen(self) -> int:
        """Objects in the permanent generation (all of them, not only this collector's)."""
        return gc.get_freeze_count()

    def start(self) -> None:
        """Turn the automatic collector off (idempotent)."""
        if self._was_enabled is None:
            self._was_enabled = gc.isenabled()
            self._was_frozen = gc.get_freeze_count() > 0
            gc.disable()

    def stop(self) -> None:
        """Give the automatic collector back as :meth:`start` found it (idempotent): enabled
        if it was, and nothing frozen if nothing was (what it froze goes back to the oldest
        generation; what someone else froze before stays frozen)."""
        if self._was_enabled is None:
            return
        if self.freezes and not self._was_frozen:
            gc.unfreeze()
        if self._was_enabled:
            gc.enable()
        self._was_enabled = None

    def __call__(self, slack_ns: int) -> None:
        """Collect what is due and fits in ``slack_ns`` [ns], the time to the next deadline."""
        pending, young_runs, _ = gc.get_count()
        if young_runs >= MIDDLE_EVERY:
            if slack_ns >= MARGIN * self.cost_ns[1]:
                self._collect(1)
            else:
                gc.freeze()  # its survivors are long-lived: stop scanning them
                self.freezes += 1
                # gc.freeze() resets only generation 0's count; collecting the (now empty)
                # generation 1 resets both. Try a real one again once the cost has decayed.
                gc.collect(1)
                self.cost_ns[1] = int(self.cost_ns[1] * DECAY)
            return
        if pending < YOUNG_THRESHOLD:
            return
        if slack_ns >= MARGIN * self.cost_ns[0]:
            self._collect(0)
        elif pending >= YOUNG_LIMIT:
            self.forced += 1
            self._collect(0)

    def _collect(self, generation: int) -> None:
        start = self._clock_ns()
        gc.collect(generation)
        self.cost_ns[generation] = self._clock_ns() - start
        self.collections[generation] += 1

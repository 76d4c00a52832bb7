"""The periodic loop-health log line of imotiond (supervisor thread).

It reads only what the loop already published (the overrun counter, the snapshot's latency
percentiles): it costs the loop nothing.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from controller.contract import snapshot as snap
from controller.logs import get_logger

if TYPE_CHECKING:
    from controller.control.process import Controller

_events = get_logger("imotiond.events")


class LoopHealth:
    """The periodic loop-health line (supervisor thread; reads what the loop published).

    ``msg="loop health" cycles=... overruns=... new_overruns=... compute_p99_us=...
    wake_p99_us=...`` every ``period`` [s], a warning when cycles overran in it; and at
    once a warning for the first overruns after a clean line (so at most two lines per
    period)."""

    def __init__(self, controller: Controller, period: float):
        self.controller = controller
        self.period = period
        self.overruns = 0
        self.cycles = 0
        self.last = time.monotonic()
        #: An early warning was logged since the last periodic line.
        self.warned = False

    def tick(self, now: float) -> None:
        overruns = self.controller.loop.stats.overruns
        new = overruns - self.overruns
        due = now - self.last >= self.period
        if not due and (new <= 0 or self.warned):
            return
        values = self.controller.publisher.writer.values
        cycles = self.controller.core.cycles
        log = _events.warning if new > 0 else _events.info
        log(
            "loop health",
            cycles=cycles,
            cycles_since=cycles - self.cycles,
            overruns=overruns,
            new_overruns=max(new, 0),
            compute_p99_us=round(float(values[snap.V_COMPUTE + 1]), 1),
            wake_p99_us=round(float(values[snap.V_WAKE + 1]), 1),
            wake_max_us=round(float(values[snap.V_WAKE + 2]), 1),
        )
        self.overruns, self.cycles = overruns, cycles
        if due:
            self.last, self.warned = now, False
        else:
            self.warned = True

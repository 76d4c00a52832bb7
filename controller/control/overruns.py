"""Sustained loop overruns become a warning alarm (LOOP_OVERRUN, type WARNING).

A loop that cannot keep its rate skips deadlines (see :mod:`controller.control.loop`); the
motion core then advances motions by the measured period, so motion time keeps to the wall
clock, but tracks with a coarser step. Every OVERRUN_WINDOW seconds of loop time the watch
counts the window's cycles: OVERRUN_WINDOWS windows in a row below OVERRUN_RATE_SHARE of
the nominal rate raise the warning (once, until clearAlarms); nothing stops.
"""

from __future__ import annotations

import logging

from controller.control.core import MotionCore
from controller.control.loop import FixedRateLoop
from controller.model.alarms import AlarmCode

_log = logging.getLogger("imotiond.control")

#: Length [s] of a window ...
OVERRUN_WINDOW = 1.0
#: ... how many slow windows in a row raise the warning ...
OVERRUN_WINDOWS = 3
#: ... and the share of the nominal rate below which a window is slow.
OVERRUN_RATE_SHARE = 0.75


class OverrunWatch:
    """Call :meth:`observe` every cycle with the cycle's deadline time ``t`` [s]."""

    def __init__(self, loop: FixedRateLoop, core: MotionCore):
        self.loop = loop
        self.core = core
        self._start = 0.0
        self._cycles = 0
        self._overruns = 0
        #: Consecutive slow windows.
        self.slow_windows = 0

    def observe(self, t: float) -> None:
        span = t - self._start
        if span < OVERRUN_WINDOW:
            return
        stats = self.loop.stats
        cycles, overruns = stats.cycles - self._cycles, stats.overruns - self._overruns
        rate = cycles / span
        slow = overruns > 0 and rate < OVERRUN_RATE_SHARE * self.loop.rate_hz
        self.slow_windows = self.slow_windows + 1 if slow else 0
        if self.slow_windows == OVERRUN_WINDOWS:
            self.core.warn(
                AlarmCode.LOOP_OVERRUN,
                "loop",
                f"the control loop runs late: ~{rate:.0f} Hz instead of "
                f"{self.loop.rate_hz:g} Hz for {OVERRUN_WINDOWS * OVERRUN_WINDOW:g} s "
                f"({overruns} of the last {cycles} cycles overran); motions keep to the "
                "wall clock",
            )
            _log.warning("loop overruns: ~%.0f Hz instead of %g Hz", rate, self.loop.rate_hz)
        self._start, self._cycles, self._overruns = t, stats.cycles, stats.overruns

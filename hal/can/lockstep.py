"""Lockstep of the CAN master with a simulated bus partner (``--hal hil``).

With a partner (the drive emulator, in the process or behind a local transport) the master
counts the SYNCs it sends per bus and, before it decodes a cycle's feedback or sends the next
round, waits until the partner has answered all of them (:meth:`Lockstep.wait_answered`):
the feedback is exactly that of the cycle just commanded however late the partner runs on a
busy host (a late cycle is an overrun, never a missing TPDO). The wait is bounded by
``timeout`` [s]; after a timeout (a stopped partner) :class:`LockstepGate` waits at most two
periods until the partner answers again, and the TPDO timeout counts the cycles as usual.
Real buses (``--hal can``) have no partner: supervision stays on the wire's timing.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping
from typing import Protocol

log = logging.getLogger(__name__)


class Lockstep(Protocol):
    """A simulated bus partner that answers SYNCs (the drive emulator)."""

    def wait_answered(self, sent: Mapping[str, int], timeout: float) -> bool:
        """Wait up to ``timeout`` [s] until each bus of ``sent`` has answered that many SYNC
        frames (their TPDOs are on the bus, no cycle left open); False on timeout."""
        ...


class LockstepGate:
    """Bounded waits on ``partner`` (None: no lockstep) at loop period ``dt`` [s]."""

    def __init__(self, partner: Lockstep | None, dt: float, timeout: float = 1.0):
        self.partner = partner
        self.dt = dt
        #: Longest wait [s] for the partner to answer a round of SYNCs.
        self.timeout = timeout
        #: The last wait timed out: wait at most two periods until it answers again.
        self.stalled = False
        #: Waits that timed out.
        self.timeouts = 0
        #: Time spent waiting for the partner [s] (the master's own share of a cycle is the
        #: cycle's time minus this).
        self.waited = 0.0

    def wait(self, sent: Mapping[str, int]) -> bool:
        """Until the partner answered ``sent`` SYNCs per bus (True), or the bound passed."""
        if self.partner is None:
            return True
        timeout = 2 * self.dt if self.stalled else self.timeout
        start = time.perf_counter()
        answered = self.partner.wait_answered(sent, timeout)
        self.waited += time.perf_counter() - start
        if answered:
            self.stalled = False
            return True
        if not self.stalled:
            log.warning("lockstep: SYNCs unanswered after %.3f s", timeout)
        self.stalled = True
        self.timeouts += 1
        return False

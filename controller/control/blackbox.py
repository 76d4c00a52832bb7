"""The black box's ring, loop side: one row per control cycle into shared memory.

Layout, reader and why the writing happens in the gateway: :mod:`controller.contract.blackbox`.
The hook in the control process is one call per cycle (``Controller._record_blackbox``).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from controller.contract.blackbox import (
    C_ALARMS,
    C_COMPUTE,
    C_MOTION,
    C_QP_ITER,
    C_SEQ,
    C_STAMP,
    C_STATE,
    C_WAKE,
    H_ALARM_COUNT,
    H_ALARM_EVENTS,
    H_CAPACITY,
    H_COUNT,
    H_JOINTS,
    H_RATE_MHZ,
    ROW_FIXED,
    Mapped,
)


class BlackBoxRing(Mapped):
    """The loop side: creates the file; :meth:`record` once per cycle."""

    def __init__(self, path: Path, n_joints: int, rate_hz: float, seconds: float):
        capacity = max(2, round(seconds * rate_hz))
        super().__init__(path, capacity, n_joints, create=True)
        self.header[:] = 0
        self.rows[:] = np.nan
        self.header[H_CAPACITY] = capacity
        self.header[H_JOINTS] = n_joints
        self.header[H_RATE_MHZ] = round(rate_hz * 1e3)
        self._count = 0
        self._alarms = 0
        self._q = slice(ROW_FIXED, ROW_FIXED + n_joints)
        self._q_cmd = slice(ROW_FIXED + n_joints, ROW_FIXED + 2 * n_joints)

    def record(
        self,
        state: int,
        motion: int,
        alarms: int,
        qp_iterations: int,
        timing_us: tuple[float, float],
        q: np.ndarray,
        q_cmd: np.ndarray,
    ) -> None:
        """Append this cycle (loop thread). ``timing_us``: the previous cycle's wake latency
        and compute time [us]; ``q``, ``q_cmd``: measured and commanded [rad, m]."""
        seq = self._count
        row = self.rows[seq % self.capacity]
        row[C_SEQ] = -1.0  # incomplete until the end
        row[C_STAMP] = time.time()
        row[C_STATE] = state
        row[C_MOTION] = motion
        row[C_ALARMS] = alarms
        row[C_QP_ITER] = qp_iterations
        row[C_WAKE], row[C_COMPUTE] = timing_us
        row[self._q] = q
        row[self._q_cmd] = q_cmd
        row[C_SEQ] = seq
        self._count = seq + 1
        self.header[H_COUNT] = self._count
        if alarms > self._alarms:
            self.header[H_ALARM_COUNT] = self._count
            self.header[H_ALARM_EVENTS] += 1
        self._alarms = alarms

    def unlink(self) -> None:
        self.close()
        self.path.unlink(missing_ok=True)

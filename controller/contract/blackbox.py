"""The black box: the last seconds of every control cycle, in a preallocated shared ring.

The control loop appends one row per cycle (:meth:`BlackBoxRing.record`, a few numpy slice
assignments, no allocation, no lock, no system call) to a memory-mapped file in the runtime
directory, and counts the alarms it sees appear. Everything else happens in another process:
the gateway's writer thread (:mod:`controller.gateway.observe.blackbox_writer`) notices the alarm
counter move, copies the ring with :class:`RingReader` and writes the MCAP file. So an
alarm costs the loop nothing, not even the GIL (a writer thread in the control process would
hold it while encoding thousands of messages, just when the robot is stopping).

Layout (native endian), ``capacity`` rows of ``ROW_FIXED + 2n`` float64 for ``n`` joints::

    uint64 header[HEADER]     see the H_* indices
    float64 rows[capacity][ROW_FIXED + 2n]
        C_SEQ      row sequence number (written last: a row is whole once it matches)
        C_STAMP    wall clock [s] (time.time)
        C_STATE    index into snapshot.CORE_STATES
        C_MOTION   motions started so far (the running motion's id)
        C_ALARMS   active alarms
        C_QP_ITER  iterations of the last QP solve (-1: none yet)
        C_WAKE     wake latency of the *previous* cycle [us] (the current one is not over)
        C_COMPUTE  compute time of the previous cycle [us]
        then q (measured) and q_cmd (commanded), hardware order [rad, m]

A reader copies the rows without a lock: rows the writer overwrote during the copy are
recognised from the counters read before and after and dropped (:meth:`RingReader.copy`).
"""

from __future__ import annotations

import mmap
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: The ring's file in the runtime directory.
BLACKBOX_NAME = "blackbox"

H_COUNT = 0  #: rows written so far (the next row's sequence number)
H_ALARM_EVENTS = 1  #: times the active alarm list grew
H_ALARM_COUNT = 2  #: H_COUNT when it last grew
H_CAPACITY = 3
H_JOINTS = 4
H_RATE_MHZ = 5  #: loop rate [mHz]
HEADER = 8

C_SEQ = 0
C_STAMP = 1
C_STATE = 2
C_MOTION = 3
C_ALARMS = 4
C_QP_ITER = 5
C_WAKE = 6
C_COMPUTE = 7
ROW_FIXED = 8


def ring_size(capacity: int, n_joints: int) -> int:
    return 8 * HEADER + 8 * capacity * (ROW_FIXED + 2 * n_joints)


class Mapped:
    def __init__(self, path: Path, capacity: int, n_joints: int, create: bool):
        self.path = Path(path)
        size = ring_size(capacity, n_joints)
        fd = os.open(self.path, os.O_RDWR | (os.O_CREAT if create else 0), 0o600)
        try:
            if create:
                os.ftruncate(fd, size)
            elif os.fstat(fd).st_size != size:
                raise ValueError(f"{self.path}: black-box size {os.fstat(fd).st_size} != {size}")
            self._mm = mmap.mmap(fd, size)
        finally:
            os.close(fd)
        self.capacity = capacity
        self.n = n_joints
        self.header = np.frombuffer(self._mm, dtype=np.uint64, count=HEADER)
        width = ROW_FIXED + 2 * n_joints
        self.rows = np.frombuffer(
            self._mm, dtype=np.float64, count=capacity * width, offset=8 * HEADER
        ).reshape(capacity, width)

    def close(self) -> None:
        del self.header, self.rows  # numpy views keep the map exported
        self._mm.close()


@dataclass
class Cycles:
    """Whole rows of a copy, oldest first (see the module docstring for the columns)."""

    seq: np.ndarray
    stamp: np.ndarray  #: [s] wall clock
    state: np.ndarray
    motion: np.ndarray
    alarms: np.ndarray
    qp_iterations: np.ndarray
    wake_us: np.ndarray  #: of the cycle itself (shifted back from the next row; NaN: unknown)
    compute_us: np.ndarray
    q: np.ndarray  #: (cycles, n) measured [rad, m]
    q_cmd: np.ndarray  #: (cycles, n) commanded [rad, m]

    def __len__(self) -> int:
        return int(self.seq.size)


class RingReader(Mapped):
    """The gateway side: maps an existing ring (size from its header)."""

    def __init__(self, path: Path):
        with open(path, "rb") as f:
            head = np.frombuffer(f.read(8 * HEADER), dtype=np.uint64)
        super().__init__(path, int(head[H_CAPACITY]), int(head[H_JOINTS]), create=False)
        self.rate_hz = int(head[H_RATE_MHZ]) / 1e3

    @property
    def count(self) -> int:
        return int(self.header[H_COUNT])

    @property
    def alarm_events(self) -> int:
        return int(self.header[H_ALARM_EVENTS])

    @property
    def alarm_count(self) -> int:
        """Rows written when the alarm list last grew (its row is ``alarm_count - 1``)."""
        return int(self.header[H_ALARM_COUNT])

    def copy(self) -> Cycles:
        """The rows the writer did not touch during the copy, oldest first."""
        before = self.count
        rows = self.rows.copy()
        after = self.count
        first = max(0, after - self.capacity + 1)
        seqs = np.arange(first, before)
        picked = rows[seqs % self.capacity]
        whole = picked[:, C_SEQ] == seqs
        picked = picked[whole]
        n = self.n
        wake = np.append(picked[1:, C_WAKE], np.nan)
        compute = np.append(picked[1:, C_COMPUTE], np.nan)
        gap = np.diff(picked[:, C_SEQ]) != 1  # the next row is not the next cycle
        wake[:-1][gap] = np.nan
        compute[:-1][gap] = np.nan
        return Cycles(
            seq=picked[:, C_SEQ].astype(np.int64),
            stamp=picked[:, C_STAMP],
            state=picked[:, C_STATE].astype(np.int64),
            motion=picked[:, C_MOTION].astype(np.int64),
            alarms=picked[:, C_ALARMS].astype(np.int64),
            qp_iterations=picked[:, C_QP_ITER].astype(np.int64),
            wake_us=wake,
            compute_us=compute,
            q=picked[:, ROW_FIXED : ROW_FIXED + n],
            q_cmd=picked[:, ROW_FIXED + n : ROW_FIXED + 2 * n],
        )

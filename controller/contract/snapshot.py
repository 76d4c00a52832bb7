"""The state snapshot the control loop publishes for the service gateway, in shared memory.

The loop writes one snapshot per cycle into a memory-mapped file; any number of readers in
other processes copy it out without ever talking to (or taking a lock of) the loop. A
sequence counter guards consistency (a seqlock): the writer makes it odd, writes, makes it
even; a reader copies and retries while the counter was odd or changed. Reads therefore cost
the loop nothing, whatever the client load.

Layout (native endian), for a robot with ``n`` hardware joints::

    uint64 header[HEADER]                  see the H_* indices
    float64 values[VALUES_FIXED + 2n]      stamp, loop statistics, q, q_cmd, frames
    uint8 alarms[ALARM_BYTES]              JSON list of the active alarms

Angles and lengths are SI, poses in the original frame; frames are 3x4 ``[R | p]``.
"""

from __future__ import annotations

import json
import mmap
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from controller.vocabulary import CoreState
from hal.interface import HardwareState

#: Files of the runtime directory the control process writes for the gateway: the snapshot
#: (this module) and the joint names in its order (JSON list).
SNAPSHOT_NAME = "snapshot"
JOINTS_NAME = "joints.json"

# header indices
H_SEQ = 0
# H_CYCLE .. H_QUEUE and H_STARTED, H_FINISHED are consecutive: the publisher writes each
# run in one slice assignment.
H_CYCLE = 1
H_CORE_STATE = 2  #: a CoreState value
H_HW_STATE = 3  #: index into HW_STATES
H_FLAGS = 4
H_QUEUE = 5  #: motions waiting in the queue
H_QUEUE_DEPTH = 6
H_ALARM_LEN = 7  #: bytes of alarm JSON
H_STARTED = 8  #: motions started so far
H_FINISHED = 9  #: motions ended so far (finished, stopped, aborted or failed)
H_OVERRUNS = 10
H_PID = 11
HEADER = 16

# flags
F_MOVING = 1 << 0  #: a motion or a gripper is executing
F_MOTION = 1 << 1  #: a whole-body motion is executing (grippers excluded)
F_PAUSED = 1 << 2
F_QUEUE_FULL = 1 << 3
F_SERVO_ON = 1 << 4  #: every drive enabled

# value indices
V_STAMP = 0  #: [s] monotonic clock of the control process
V_COMPUTE = 1  #: compute p50, p99, max [us]
V_WAKE = 4  #: wake latency p50, p99, max [us]
V_ORIGINAL = 7  #: original frame in the world (3x4)
V_OFFSETS = 19  #: control-point offsets RIGHT, LEFT (2 x 3x4)
V_ORIGINAL_THETA = 43  #: vehicle θ joint when the original frame was set [rad]
VALUES_FIXED = 44

ALARM_BYTES = 16384

#: How long a reader retries at once when another process is writing the snapshot [s].
SPIN_S = 50e-6

#: Hardware states in the order of their header value.
HW_STATES: tuple[HardwareState, ...] = tuple(HardwareState)


@dataclass
class Snapshot:
    """One consistent copy of the published state."""

    cycle: int
    core_state: CoreState
    hw_state: HardwareState
    flags: int
    queue: int
    queue_depth: int
    started: int
    finished: int
    overruns: int
    pid: int
    stamp: float  #: [s]
    compute_us: np.ndarray  #: p50, p99, max
    wake_us: np.ndarray  #: p50, p99, max
    q: np.ndarray  #: measured, hardware order [rad, m]
    q_cmd: np.ndarray  #: commanded, hardware order [rad, m]
    original: np.ndarray  #: original frame (3x4, p in m)
    original_theta: float  #: [rad]
    offsets: np.ndarray  #: control-point offsets (2 x 3x4), RIGHT then LEFT
    alarms: list[dict]  #: code, type, description, module

    @property
    def moving(self) -> bool:
        return bool(self.flags & F_MOVING)

    @property
    def servo_on(self) -> bool:
        return bool(self.flags & F_SERVO_ON)


class StateHeader(NamedTuple):
    """The states and counters of one snapshot, without joints, frames or alarms
    (:meth:`SnapshotReader.read_state`)."""

    cycle: int
    core_state: CoreState
    hw_state: HardwareState
    flags: int
    queue: int

    @property
    def moving(self) -> bool:
        return bool(self.flags & F_MOVING)

    @property
    def servo_on(self) -> bool:
        return bool(self.flags & F_SERVO_ON)


def snapshot_size(n_joints: int) -> int:
    return 8 * HEADER + 8 * (VALUES_FIXED + 2 * n_joints) + ALARM_BYTES


class _Mapped:
    def __init__(self, path: Path, n_joints: int, create: bool):
        self.path = Path(path)
        self.n = n_joints
        size = snapshot_size(n_joints)
        flags = os.O_RDWR | (os.O_CREAT if create else 0)
        fd = os.open(self.path, flags, 0o600)
        try:
            if create:
                os.ftruncate(fd, size)
            elif os.fstat(fd).st_size != size:
                raise ValueError(
                    f"{self.path}: snapshot size {os.fstat(fd).st_size} != {size} expected for "
                    f"{n_joints} joints (daemon and gateway disagree on the robot)"
                )
            self._mm = mmap.mmap(fd, size)
        finally:
            os.close(fd)
        n_values = VALUES_FIXED + 2 * n_joints
        self.header = np.frombuffer(self._mm, dtype=np.uint64, count=HEADER)
        self.values = np.frombuffer(self._mm, dtype=np.float64, count=n_values, offset=8 * HEADER)
        self.alarm_buf = np.frombuffer(
            self._mm, dtype=np.uint8, count=ALARM_BYTES, offset=8 * (HEADER + n_values)
        )
        self.q = self.values[VALUES_FIXED : VALUES_FIXED + n_joints]
        self.q_cmd = self.values[VALUES_FIXED + n_joints :]

    def close(self) -> None:
        # numpy views keep the buffer exported; drop them before closing the map.
        del self.header, self.values, self.alarm_buf, self.q, self.q_cmd
        self._mm.close()


class SnapshotWriter(_Mapped):
    """The loop side: creates the file; :meth:`publish` once per cycle (a few µs)."""

    def __init__(self, path: Path, n_joints: int, queue_depth: int = 0):
        super().__init__(path, n_joints, create=True)
        self.header[:] = 0
        self.values[:] = 0.0
        self.header[H_PID] = os.getpid()
        self.header[H_QUEUE_DEPTH] = queue_depth
        self._alarm_key: object = None

    def begin(self) -> None:
        self.header[H_SEQ] += 1  # odd: write in progress

    def end(self) -> None:
        self.header[H_SEQ] += 1  # even: consistent

    def set_alarms(self, alarms: list[dict]) -> None:
        """Rewrite the alarm region (between begin() and end()) when the list changed."""
        key = tuple((a["code"], a["description"]) for a in alarms)
        if key == self._alarm_key:
            return
        self._alarm_key = key
        data = json.dumps(alarms).encode()
        while len(data) > ALARM_BYTES and alarms:  # keep the newest alarms
            alarms = alarms[1:]
            data = json.dumps(alarms).encode()
        self.alarm_buf[: len(data)] = np.frombuffer(data, dtype=np.uint8)
        self.header[H_ALARM_LEN] = len(data)

    def unlink(self) -> None:
        self.close()
        self.path.unlink(missing_ok=True)


class SnapshotReader(_Mapped):
    """The gateway side: maps an existing snapshot file read-write (for the seqlock only)."""

    def __init__(self, path: Path, n_joints: int):
        super().__init__(path, n_joints, create=False)
        #: Retry at once for a moment when the writer is mid-write (see :meth:`read`): only
        #: when it is another process, which writes on while this one spins.
        self.spin = int(self.header[H_PID]) != os.getpid()

    def read(self, timeout: float = 1.0) -> Snapshot:
        """A consistent copy; raises RuntimeError if the writer never stands still.

        A write takes ~10 us (p99 ~15 us) and is in progress for ~0.3 % of the time; a
        reader that finds one retries at once for up to :data:`SPIN_S` when the writer is
        another process (it finishes meanwhile), then between attempts yields the CPU (and,
        in one process, the GIL): a writer preempted mid-write must be able to finish, which
        a tight spin would prevent. Yielding the GIL at once cost a reader up to a GIL
        switch interval (5 ms) whenever it met a write.
        """
        header, values, alarm_bytes = self._consistent(True, timeout)
        return _decode(header, values, alarm_bytes, self.n)

    def read_state(self, timeout: float = 1.0) -> StateHeader:
        """The states and counters alone (the header: 128 bytes, no joints, no alarms), a
        consistent copy like :meth:`read` at a tenth of its cost: what getState, isMoving
        and isServoOn answer from."""
        h = self._consistent(False, timeout)[0].tolist()
        return StateHeader(
            cycle=h[H_CYCLE],
            core_state=CoreState(h[H_CORE_STATE]),
            hw_state=HW_STATES[h[H_HW_STATE]],
            flags=h[H_FLAGS],
            queue=h[H_QUEUE],
        )

    def _consistent(self, full: bool, timeout: float) -> tuple[np.ndarray, np.ndarray, bytes]:
        """(header, values, alarm bytes) from one write (values and alarms only if
        ``full``): the seqlock's retry loop."""
        now = time.monotonic()
        deadline = now + timeout
        spin_end = now + SPIN_S if self.spin else now
        tries = sleeps = 0
        while tries < 3 or time.monotonic() < deadline:
            if tries and time.monotonic() >= spin_end:
                time.sleep(0 if sleeps < 7 else 1e-4)
                sleeps += 1
            tries += 1
            seq = int(self.header[H_SEQ])
            if seq & 1:
                continue
            header = self.header.copy()
            values, alarm_bytes = _NO_VALUES, b""
            if full:
                values = self.values.copy()
                alarm_bytes = self.alarm_buf[: int(header[H_ALARM_LEN])].tobytes()
            if int(self.header[H_SEQ]) != seq:
                continue
            return header, values, alarm_bytes
        raise RuntimeError("the control loop kept rewriting the snapshot: no consistent copy")


_NO_VALUES = np.zeros(0)


def _decode(header: np.ndarray, values: np.ndarray, alarm_bytes: bytes, n: int) -> Snapshot:
    # ``values`` is this read's own copy: views of it are as independent of later writes as
    # copies would be, at a fraction of the cost.
    h = header.tolist()
    return Snapshot(
        cycle=h[H_CYCLE],
        core_state=CoreState(h[H_CORE_STATE]),
        hw_state=HW_STATES[h[H_HW_STATE]],
        flags=h[H_FLAGS],
        queue=h[H_QUEUE],
        queue_depth=h[H_QUEUE_DEPTH],
        started=h[H_STARTED],
        finished=h[H_FINISHED],
        overruns=h[H_OVERRUNS],
        pid=h[H_PID],
        stamp=float(values[V_STAMP]),
        compute_us=values[V_COMPUTE : V_COMPUTE + 3],
        wake_us=values[V_WAKE : V_WAKE + 3],
        q=values[VALUES_FIXED : VALUES_FIXED + n],
        q_cmd=values[VALUES_FIXED + n :],
        original=values[V_ORIGINAL : V_ORIGINAL + 12].reshape(3, 4),
        original_theta=float(values[V_ORIGINAL_THETA]),
        offsets=values[V_OFFSETS : V_OFFSETS + 24].reshape(2, 3, 4),
        alarms=json.loads(alarm_bytes) if alarm_bytes and alarm_bytes != b"[]" else [],
    )

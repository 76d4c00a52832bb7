"""controller.contract.snapshot: the seqlock shared-memory snapshot (writer and readers)."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest

from controller.contract import snapshot as snap
from controller.contract.snapshot import SnapshotReader, SnapshotWriter
from controller.vocabulary import CoreState
from hal.interface import HardwareState

N = 5


def _alarm(code: int, text: str = "x") -> dict:
    return {"code": code, "type": 0, "description": text, "module": "m"}


def test_published_values_come_back(tmp_path: Path):
    w = SnapshotWriter(tmp_path / "s", N, queue_depth=4)
    r = SnapshotReader(tmp_path / "s", N)
    try:
        w.begin()
        w.header[snap.H_CYCLE] = 42
        w.header[snap.H_CORE_STATE] = int(CoreState.BUSY)
        w.header[snap.H_HW_STATE] = snap.HW_STATES.index(HardwareState.ACTIVE)
        w.header[snap.H_FLAGS] = snap.F_MOVING | snap.F_SERVO_ON
        w.header[snap.H_QUEUE] = 2
        w.values[snap.V_STAMP] = 12.5
        w.q[:] = np.arange(N) * 0.1
        w.q_cmd[:] = np.arange(N) * 0.2
        original = np.hstack([np.eye(3), [[1.0], [2.0], [3.0]]])
        w.values[snap.V_ORIGINAL : snap.V_ORIGINAL + 12] = original.ravel()
        w.values[snap.V_OFFSETS + 12 : snap.V_OFFSETS + 24] = np.full(12, 7.0)
        w.values[snap.V_ORIGINAL_THETA] = 0.25
        w.set_alarms([_alarm(0x400, "drive fault")])
        w.end()
        s = r.read()
    finally:
        r.close()
        w.unlink()
    assert s.cycle == 42 and s.core_state == CoreState.BUSY
    assert s.hw_state == HardwareState.ACTIVE
    assert s.moving and s.servo_on and s.queue == 2 and s.queue_depth == 4
    assert s.stamp == 12.5 and s.original_theta == 0.25
    np.testing.assert_array_equal(s.q, np.arange(N) * 0.1)
    np.testing.assert_array_equal(s.q_cmd, np.arange(N) * 0.2)
    np.testing.assert_array_equal(s.original, original)
    np.testing.assert_array_equal(s.offsets[1], np.full((3, 4), 7.0))
    assert s.alarms == [_alarm(0x400, "drive fault")]
    assert s.pid > 0
    assert not (tmp_path / "s").exists()  # unlink removed the file


def test_the_state_alone_comes_back(tmp_path: Path):
    """read_state: the states and counters of the header, without joints or alarms."""
    w = SnapshotWriter(tmp_path / "s", N)
    r = SnapshotReader(tmp_path / "s", N)
    try:
        w.begin()
        w.header[snap.H_CYCLE] = 7
        w.header[snap.H_CORE_STATE] = int(CoreState.PAUSED)
        w.header[snap.H_HW_STATE] = snap.HW_STATES.index(HardwareState.ACTIVE)
        w.header[snap.H_FLAGS] = snap.F_SERVO_ON
        w.header[snap.H_QUEUE] = 3
        w.end()
        h = r.read_state()
    finally:
        r.close()
        w.unlink()
    assert (h.cycle, h.core_state, h.hw_state, h.queue) == (
        7,
        CoreState.PAUSED,
        HardwareState.ACTIVE,
        3,
    )
    assert h.servo_on and not h.moving


def test_a_copy_is_independent_of_later_writes(tmp_path: Path):
    w = SnapshotWriter(tmp_path / "s", N)
    r = SnapshotReader(tmp_path / "s", N)
    try:
        first = r.read()
        w.begin()
        w.q[:] = 1.0
        w.end()
        assert np.all(first.q == 0.0)
        assert np.all(r.read().q == 1.0)
    finally:
        r.close()
        w.unlink()


def test_reader_rejects_a_snapshot_of_another_size(tmp_path: Path):
    w = SnapshotWriter(tmp_path / "s", N)
    try:
        with pytest.raises(ValueError, match=r"joints.*disagree on the robot"):
            SnapshotReader(tmp_path / "s", N + 1)
    finally:
        w.unlink()


def test_reader_waits_for_a_write_in_progress(tmp_path: Path):
    w = SnapshotWriter(tmp_path / "s", N)
    r = SnapshotReader(tmp_path / "s", N)
    try:
        w.begin()
        w.q[:] = 3.0
        got: list[snap.Snapshot] = []
        reader = threading.Thread(target=lambda: got.append(r.read(timeout=10.0)))
        reader.start()
        time.sleep(0.05)
        assert not got  # still odd: the reader waits
        w.q_cmd[:] = 3.0
        w.end()
        reader.join(10.0)
        assert got and np.all(got[0].q == 3.0) and np.all(got[0].q_cmd == 3.0)
    finally:
        r.close()
        w.unlink()


def test_reader_gives_up_when_the_writer_never_finishes(tmp_path: Path):
    w = SnapshotWriter(tmp_path / "s", N)
    r = SnapshotReader(tmp_path / "s", N)
    try:
        w.begin()  # a writer that died mid-write
        with pytest.raises(RuntimeError, match="no consistent copy"):
            r.read(timeout=0.05)
    finally:
        r.close()
        w.unlink()


@pytest.mark.parametrize("spin", [False, True], ids=["yield", "spin"])
def test_reads_are_never_torn_under_a_busy_writer(tmp_path: Path, spin: bool):
    """Element by element writes (a thread switch can land between them): every copy a reader
    gets has all joints (and header fields) from the same write, whether the reader yields
    at once or first retries for a moment (as it does when the writer is another
    process)."""
    w = SnapshotWriter(tmp_path / "s", N)
    r = SnapshotReader(tmp_path / "s", N)
    assert not r.spin  # the writer is this process
    r.spin = spin
    stop = threading.Event()

    def write() -> None:
        k = 0.0
        while not stop.is_set():
            k += 1.0
            w.begin()
            w.header[snap.H_CYCLE] = int(k)
            for i in range(N):
                w.q[i] = k
                w.q_cmd[i] = k
            w.header[snap.H_QUEUE] = int(k)
            w.end()

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    try:
        seen = set()
        end = time.monotonic() + 5.0
        while len(seen) < 10 and time.monotonic() < end:
            s = r.read()
            assert np.all(s.q == s.q[0]) and np.all(s.q_cmd == s.q[0]), s.q
            assert s.cycle == s.queue == int(s.q[0])
            h = r.read_state()
            assert h.cycle == h.queue
            seen.add(float(s.q[0]))
            time.sleep(0)  # let the writer run between reads too
        assert len(seen) > 1  # the writer did run concurrently
    finally:
        stop.set()
        writer.join(5.0)
        r.close()
        w.unlink()


def test_alarms_keep_the_newest_when_too_long(tmp_path: Path):
    w = SnapshotWriter(tmp_path / "s", N)
    r = SnapshotReader(tmp_path / "s", N)
    try:
        many = [_alarm(0x400 + i, "d" * 1000) for i in range(40)]  # ~40 kB > ALARM_BYTES
        w.begin()
        w.set_alarms(many)
        w.end()
        alarms = r.read().alarms
        assert 0 < len(alarms) < len(many)
        assert alarms == many[-len(alarms) :]
        w.begin()
        w.set_alarms([])
        w.end()
        assert r.read().alarms == []
    finally:
        r.close()
        w.unlink()


def test_core_and_hardware_states_decode_by_name(tmp_path: Path):
    w = SnapshotWriter(tmp_path / "s", N)
    r = SnapshotReader(tmp_path / "s", N)
    try:
        for i, name in enumerate(CoreState):
            w.begin()
            w.header[snap.H_CORE_STATE] = i
            w.header[snap.H_HW_STATE] = i % len(snap.HW_STATES)
            w.end()
            s = r.read()
            assert s.core_state == name
            assert s.hw_state == snap.HW_STATES[i % len(snap.HW_STATES)]
    finally:
        r.close()
        w.unlink()

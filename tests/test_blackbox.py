"""Black box (controller/control/blackbox.py ring + controller/gateway/observe/blackbox_writer.py).

The ring is checked alone (order, wrap-around, rows torn by a concurrent writer); then a
daemon on ``--hal ideal`` with ``blackbox.dir`` set gets an injected alarm, and the MCAP file
that appears holds the cycles before it (read back with the ``mcap`` library).
"""

from __future__ import annotations

import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from controller.client.recording import metadata_limits, read_mcap
from controller.contract.blackbox import C_SEQ, RingReader
from controller.control import overruns
from controller.control.blackbox import BlackBoxRing
from controller.gateway.observe import blackbox_writer
from controller.gateway.process import start_observers
from controller.model.alarms import AlarmCode
from controller.vocabulary import CoreState
from tests.daemon_support import TestDaemon


def _fill(ring: BlackBoxRing, n: int, alarm_at: int | None = None) -> None:
    for k in range(n):
        q = np.full(ring.n, float(k))
        alarms = 1 if alarm_at is not None and k >= alarm_at else 0
        ring.record(1, 0, alarms, 3, (10.0 + k, 20.0 + k), q, -q)


def test_ring_keeps_the_last_capacity_cycles_in_order(tmp_path: Path) -> None:
    ring = BlackBoxRing(tmp_path / "bb", 3, rate_hz=100.0, seconds=0.1)  # 10 rows
    _fill(ring, 25, alarm_at=21)
    reader = RingReader(tmp_path / "bb")
    cycles = reader.copy()
    assert reader.capacity == 10 and reader.rate_hz == 100.0
    assert cycles.seq.tolist() == list(range(16, 25))  # the oldest row may be mid-rewrite
    assert cycles.q[:, 0].tolist() == [float(k) for k in range(16, 25)]
    assert np.array_equal(cycles.q_cmd, -cycles.q)
    # timing of cycle k is recorded with cycle k + 1 and shifted back by the reader
    assert cycles.wake_us[:-1].tolist() == [10.0 + k for k in range(17, 25)]
    assert np.isnan(cycles.wake_us[-1])
    assert reader.alarm_events == 1 and reader.alarm_count == 22  # row 21 raised it
    reader.close()
    ring.unlink()


def test_rows_overwritten_during_a_copy_are_dropped(tmp_path: Path) -> None:
    ring = BlackBoxRing(tmp_path / "bb", 2, rate_hz=100.0, seconds=0.1)
    _fill(ring, 10)
    reader = RingReader(tmp_path / "bb")
    real_copy = reader.rows.copy

    class Rows:  # the writer appends 4 rows while the reader copies
        def copy(self) -> np.ndarray:
            out = real_copy()
            _fill_from(ring, 10, 4)
            return out

    def _fill_from(r: BlackBoxRing, start: int, n: int) -> None:
        for k in range(start, start + n):
            q = np.full(r.n, float(k))
            r.record(1, 0, 0, 3, (0.0, 0.0), q, q)

    reader.rows = Rows()  # type: ignore[assignment]
    cycles = reader.copy()
    # rows 0..9 were copied, but rows of cycles < 14 - 10 + 1 = 5 may be torn: dropped
    assert cycles.seq.tolist() == list(range(5, 10))
    del reader
    ring.rows[13 % 10, C_SEQ] = -1.0  # a row caught mid-write is never returned either
    fresh = RingReader(tmp_path / "bb")
    seqs = fresh.copy().seq.tolist()
    assert 13 not in seqs and 12 in seqs
    fresh.close()
    ring.unlink()


def test_an_alarm_raised_while_a_file_is_written_gets_a_file_too(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Only the alarms already in the ring's copy share its file: one raised during the
    (slow) write of the file used to be counted as seen, and got no file at all."""
    ring = BlackBoxRing(tmp_path / "bb", 2, rate_hz=100.0, seconds=0.1)
    _fill(ring, 5)
    calls: list[int] = []

    def slow_write(path: Path, cycles, *args) -> None:  # type: ignore[no-untyped-def]
        calls.append(len(cycles))
        if len(calls) == 1:  # a second alarm while the first file is written
            q = np.zeros(ring.n)
            ring.record(1, 0, 2, 3, (0.0, 0.0), q, q)

    monkeypatch.setattr(blackbox_writer, "write_blackbox", slow_write)
    view = SimpleNamespace(snapshot=lambda: SimpleNamespace(alarms=[]), robot=None, hw_joints=[])
    writer = blackbox_writer.BlackBoxWriter(tmp_path / "bb", tmp_path / "out", 0.0, view)  # type: ignore[arg-type]
    try:
        q = np.zeros(ring.n)
        ring.record(1, 0, 1, 3, (0.0, 0.0), q, q)  # the first alarm
        deadline = time.monotonic() + 30.0
        while len(writer.written) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        writer.close()
        ring.unlink()
    assert len(writer.written) == 2, calls


def test_an_alarm_writes_a_file_with_the_cycles_before_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The file must be the injected alarm's: a loaded machine makes this 250 Hz loop overrun
    # for seconds, and the LOOP_OVERRUN (0x411) warning it then raises got a file first.
    monkeypatch.setattr(overruns, "OVERRUN_WINDOWS", 1 << 30)
    td = TestDaemon(**{"blackbox.dir": str(tmp_path / "bb"), "blackbox.seconds": 2.0,
                       "blackbox.after_s": 0.2})  # fmt: skip
    observers = start_observers(td.cfg, td.daemon.runtime, td.ctx)
    try:
        td.reset()
        assert observers.blackbox is not None
        ring = observers.blackbox.ring
        assert td.wait_for(lambda: td.controller.core.state == CoreState.READY)
        ready_at = ring.count
        # the ring went round in Ready (counting from the start would let a slow servo-on
        # leave Servo-off rows in it)
        assert td.wait_for(lambda: ring.count > ready_at + ring.capacity + 10)
        td.controller.core.raise_alarm(AlarmCode.OVERSPEED, "test", "injected by the test")
        assert td.wait_for(lambda: bool(observers.blackbox and observers.blackbox.written))
        path = observers.blackbox.written[0]
    finally:
        observers.close()
        td.close()
    assert path.parent == tmp_path / "bb" and path.name.endswith("-0003.mcap")
    rec = read_mcap(path)
    cycles = rec.messages("/blackbox/cycle")
    states = [c[1]["state"] for c in cycles]
    first_alarm = states.index("alarm")
    rate = td.cfg.loop.rate_hz
    assert first_alarm >= 1.5 * rate  # ~2 s of cycles before the alarm
    assert len(cycles) - first_alarm >= 0.1 * rate  # and some after
    seqs = [c[1]["cycle"] for c in cycles]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # every cycle, in order
    assert all(c[1]["state"] == "ready" for c in cycles[:first_alarm])
    assert rec.schemas["/joint_states/measured"] == "foxglove.JointStates"
    assert len(rec.messages("/joint_states/measured")) == len(cycles)
    names = [j["name"] for j in rec.messages("/joint_states/commanded")[0][1]["joints"]]
    assert names == list(td.daemon.hw.joint_names)
    logs = [m[1]["message"] for m in rec.messages("/alarms")]
    assert any("0x0003" in m and "injected" in m for m in logs)
    assert rec.messages("/tf") and rec.messages("/robot_description")
    assert rec.metadata["imotion"]["robot"] == "smartpal5"
    assert metadata_limits(rec)["r_arm_j1"]["lower"] < 0.0
    assert "alarm" in rec.metadata


def test_without_blackbox_dir_the_loop_keeps_no_ring() -> None:
    td = TestDaemon()
    try:
        assert td.controller.blackbox is None
        assert not (td.daemon.runtime / "blackbox").exists()
    finally:
        td.close()


def test_the_ring_is_cheap_for_the_loop(tmp_path: Path) -> None:
    """Not a timing assert: records 10 000 rows without allocating new arrays."""
    ring = BlackBoxRing(tmp_path / "bb", 30, rate_hz=1000.0, seconds=1.0)
    rows_id = id(ring.rows)
    q = np.zeros(30)
    start = time.perf_counter()
    for _ in range(10_000):
        ring.record(1, 0, 0, 3, (1.0, 2.0), q, q)
    assert time.perf_counter() > start and id(ring.rows) == rows_id
    ring.unlink()

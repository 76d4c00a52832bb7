"""controller.control.cycle_log: every cycle kept, chronological, written as .npz."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from controller.control.cycle_log import CycleLog


def test_keeps_every_cycle_and_the_window(tmp_path: Path) -> None:
    log = CycleLog(0.001, capacity=10, history_s=1.0)
    for i in range(25):
        log.record(float(i), float(100 + i))
    assert log.latency_us().size == 10  # the one-window summary is unchanged
    log.save(tmp_path / "s.npz")
    data = np.load(tmp_path / "s.npz")
    assert np.array_equal(data["wake_us"], 100.0 + np.arange(25))
    assert np.array_equal(data["compute_us"], np.arange(25.0))
    assert int(data["first_cycle"]) == 0
    assert float(data["period_us"]) == 1000.0


def test_wraps_around_keeping_the_newest(tmp_path: Path) -> None:
    log = CycleLog(0.1, capacity=3, history_s=0.5)  # 5 cycles kept
    for i in range(12):
        log.record(0.0, float(i))
    log.save(tmp_path / "s.npz")
    data = np.load(tmp_path / "s.npz")
    assert np.array_equal(data["wake_us"], np.arange(7.0, 12.0))
    assert int(data["first_cycle"]) == 7
    assert log.late == 0

"""hal.can.supervision: codes, sources and texts of every per-cycle check."""

from __future__ import annotations

import numpy as np
import pytest

from controller.model.alarms import AlarmCode
from hal.can.cia402 import State
from hal.can.supervision import DriveError, Supervisor


def make() -> Supervisor:
    return Supervisor(
        ["a", "b"], [3, 4], ["bus0", "bus1"], 0.002, np.array([0.1, 0.1]), 0.006, 0.3, 3
    )


def test_emcy_codes_map_to_alarms():
    s = make()
    assert s.emcy(0, 0x0000, 0) is None
    f = s.emcy(1, 0x8611, 0x20)
    assert f is not None and f.code == AlarmCode.FOLLOWING_ERROR and f.source == "b"
    assert "node 4 on bus bus1" in f.description and "0x8611" in f.description
    assert s.emcy(0, 0x8130, 0x10).code == AlarmCode.HEARTBEAT_LOST  # type: ignore[union-attr]
    assert s.emcy(0, 0x2310, 0x02).code == AlarmCode.EMCY  # type: ignore[union-attr]


def test_fault_state_and_nmt():
    s = make()
    assert s.state(0, State.OPERATION_ENABLED, 0x27) is None
    f = s.state(0, State.FAULT, 0x0208)
    assert f is not None and f.code == AlarmCode.DRIVE_FAULT and "0x0208" in f.description
    assert s.nmt(0, 0x05) is None
    assert "booted" in s.nmt(1, 0x00).description  # type: ignore[union-attr]


def test_tpdo_timeout_after_n_cycles_once():
    s = make()
    fresh = np.array([True, False])
    assert s.tpdo(fresh) == [] and s.tpdo(fresh) == []
    faults = s.tpdo(fresh)
    assert [(f.code, f.source) for f in faults] == [(AlarmCode.TPDO_TIMEOUT, "b")]
    assert s.tpdo(fresh) == []  # reported once


def test_heartbeat_timeout_and_alive():
    s = make()
    s.reset(10.0)
    assert s.heartbeats(10.29) == [] and s.alive(10.29)
    s.last_heartbeat[0] = 10.2
    faults = s.heartbeats(10.31)
    assert [f.source for f in faults] == ["b"] and "no heartbeat for 310 ms" in faults[
        0
    ].description
    assert s.heartbeats(10.4) == []
    assert not s.alive(10.4)


def test_following_error_needs_the_time():
    s = make()  # 6 ms at 2 ms = 3 cycles
    err, on = np.array([0.2, 0.05]), np.array([True, True])
    assert s.following(err, on) == [] and s.following(err, on) == []
    assert [f.source for f in s.following(err, on)] == ["a"]
    assert s.following(err, np.array([False, True])) == []  # disabled drives are not checked


def test_drive_error_lists_faults():
    s = make()
    err = DriveError([s.enable_refused(1, State.SWITCHED_ON, 0.5)])
    assert "0x407 b" in str(err) and "switched on" in str(err)
    assert Supervisor.bus_off("bus0", "x").code == AlarmCode.BUS_OFF
    assert Supervisor.bus_error("bus0", "x").code == AlarmCode.BUS_ERROR


def test_tpdo_timeout_in_time_waits_for_both_cycles_and_time():
    """A bus bridged over a network: 3 cycles and 20 ms both have to pass."""
    s = Supervisor(["a", "b"], [3, 4], ["bus0", "bus1"], 0.002, np.ones(2), 0.006, 0.3,
                   [3, 3], [0.0, 0.020])  # fmt: skip
    s.reset(0.0)
    missing = np.array([False, False])
    t, faults = 0.0, []
    while not any(f.source == "b" for f in faults):
        t += 0.002
        faults += s.tpdo(missing, t)
    assert [f.source for f in faults] == ["a", "b"]
    assert t == pytest.approx(0.020)
    assert "(20 ms)" in faults[1].description and "3 cycles" in faults[0].description
    assert s.tpdo(missing, t + 0.002) == []  # once per episode
    assert s.tpdo(np.array([True, True]), t + 0.004) == []
    assert not s.tpdo_reported.any() and (s.last_tpdo == t + 0.004).all()


def test_tpdo_timeout_cycles_per_drive_and_bad_values():
    s = Supervisor(["a", "b"], [3, 4], ["bus0", "bus1"], 0.002, np.ones(2), 0.006, 0.3, [1, 2])
    assert [f.source for f in s.tpdo(np.array([False, False]))] == ["a"]
    assert [f.source for f in s.tpdo(np.array([False, False]))] == ["b"]
    with pytest.raises(ValueError):
        Supervisor(["a"], [3], ["b"], 0.002, np.ones(1), 0.006, 0.3, 0)


def test_check_runs_every_check_of_a_cycle():
    s = make()
    s.reset(0.0)
    fresh = np.array([True, True])
    enabled = [State.OPERATION_ENABLED, State.OPERATION_ENABLED]
    assert (
        s.check(0.002, fresh, enabled, [0x27, 0x27], True, True, False, np.zeros(2), np.zeros(2))
        == []
    )
    states = [State.OPERATION_ENABLED, State.SWITCHED_ON]
    faults = s.check(
        0.004, fresh, states, [0x27, 0x23], True, False, False, np.zeros(2), np.zeros(2)
    )
    assert [(f.code, f.source) for f in faults] == [(AlarmCode.DRIVE_FAULT, "b")]
    assert "left operation enabled (state: switched on)" in faults[0].description
    states = [State.FAULT, State.SWITCH_ON_DISABLED]
    faults = s.check(
        0.006, fresh, states, [0x08, 0x40], False, False, True, np.zeros(2), np.zeros(2)
    )
    assert [(f.code, f.source) for f in faults] == [(AlarmCode.DRIVE_FAULT, "a")]
    # Following error: enabled drives with fresh feedback, for the following time.
    err, on = np.array([0.5, 0.5]), [0x27, 0x27]
    faults = []
    for t in (0.008, 0.010, 0.012):
        faults += s.check(
            t, np.array([True, False]), enabled, on, True, True, False, err, np.zeros(2)
        )
    assert [(f.code, f.source) for f in faults] == [
        (AlarmCode.TPDO_TIMEOUT, "b"),
        (AlarmCode.FOLLOWING_ERROR, "a"),
    ]  # fmt: skip  (b: stale, so not checked for following; a over the window 3 cycles)

"""hal.can.supervision: codes, sources and texts of every per-cycle check."""

from __future__ import annotations

import numpy as np

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

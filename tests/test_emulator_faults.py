"""Every fault-injection hook, observed at frame level on the master's side of the bus."""

from __future__ import annotations

import can
import pytest

from controller.model.robot import load_robot
from hal.emulator.drive_state import PowerState
from hal.emulator.emulator import DriveEmulator
from hal.emulator.faults import FaultKind
from tests.emulator_support import FakeClock, FrameMaster, emcy, ids, state_of, tpdo1

NODE = 1  # J1 on arm_a
OTHER = 5  # J5 on arm_b


@pytest.fixture(scope="module")
def pa10():
    return load_robot("pa10")


@pytest.fixture
def rig(pa10):
    clock = FakeClock()
    emulator = DriveEmulator(pa10, clock=clock)
    emulator.open()
    master = FrameMaster(emulator, "arm_a", clock)
    master.sdo_write(NODE, 0x1017, 0, 10, 2)  # heartbeat every 10 ms
    master.nmt(0x01)
    yield emulator, master
    master.close()
    emulator.close()


def _enable(master: FrameMaster) -> int:
    frames = master.cycle()
    position = tpdo1(frames, NODE)[1]
    for controlword in (0x06, 0x07, 0x0F):
        frames = master.cycle({NODE: (controlword, position)})
    assert state_of(frames, NODE) is PowerState.OPERATION_ENABLED
    return position


def test_emcy_faults_the_drive(rig):
    emulator, master = rig
    position = _enable(master)
    emulator.inject("emcy", "J1")
    frames = master.cycle({NODE: (0x0F, position)})
    assert emcy(frames, NODE) == [(0xFF00, 0x81)]
    assert state_of(frames, NODE) is PowerState.FAULT_REACTION_ACTIVE
    assert state_of(master.cycle({NODE: (0x0F, position)}), NODE) is PowerState.FAULT


def test_emcy_without_fault_only_sends_the_frame(rig):
    emulator, master = rig
    position = _enable(master)
    emulator.inject("emcy", "J1", code=0x4210, fault=False)
    frames = master.cycle({NODE: (0x0F, position)})
    assert emcy(frames, NODE) == [(0x4210, 0x00)]
    assert state_of(frames, NODE) is PowerState.OPERATION_ENABLED
    assert emulator.active_faults == []  # one-shot


def test_silent_node_answers_nothing_then_comes_back_in_fault(rig):
    emulator, master = rig
    master.sdo_write(NODE, 0x1016, 1, (127 << 16) | 100, 4)
    position = _enable(master)
    master.send(0x77F, [0x05])
    master.cycle({NODE: (0x0F, position)})
    emulator.inject("silent", "J1")
    for _ in range(10):
        master.send(0x77F, [0x05])  # the master is alive, but the node cannot hear it
        frames = master.cycle({NODE: (0x0F, position)}, dt=0.02)
        assert not {0x181, 0x081, 0x701} & set(ids(frames))
        assert tpdo1(frames, 2) is not None  # its neighbours keep talking
    assert master.sdo_read(NODE, 0x1000) == b""
    assert emulator.clear("silent", "J1") == 1
    frames = master.cycle({NODE: (0x0F, position)}, dt=0.02)
    assert state_of(frames, NODE) is PowerState.FAULT  # it lost the master's heartbeat
    assert master.sdo_read(NODE, 0x603F)[4:6] == (0x8130).to_bytes(2, "little")


def test_heartbeat_loss_stops_only_the_heartbeat(rig):
    emulator, master = rig
    emulator.inject("heartbeat_loss", "J1")
    frames = []
    for _ in range(10):
        frames += master.cycle(dt=0.01)
    assert 0x701 not in ids(frames)
    assert 0x181 in ids(frames)
    emulator.clear("heartbeat_loss")
    frames = master.cycle(dt=0.02)
    assert 0x701 in ids(frames)


def test_following_error_trips_at_once(rig):
    emulator, master = rig
    position = _enable(master)
    emulator.inject("following_error", "J1")
    frames = master.cycle({NODE: (0x0F, position)})
    assert emcy(frames, NODE) == [(0x8611, 0x21)]
    statusword = tpdo1(frames, NODE)[0]
    assert statusword & 0x2000
    master.cycle({NODE: (0x00, position)})
    frames = master.cycle({NODE: (0x80, position)})  # fault reset clears bit 13
    assert state_of(frames, NODE) is PowerState.SWITCH_ON_DISABLED
    assert not tpdo1(frames, NODE)[0] & 0x2000


def test_refuse_enable_keeps_switched_on_until_cleared(rig):
    emulator, master = rig
    emulator.inject("refuse_enable", "J1")
    frames = master.cycle()
    position = tpdo1(frames, NODE)[1]
    for controlword in (0x06, 0x07, 0x0F, 0x0F, 0x0F):
        frames = master.cycle({NODE: (controlword, position)})
    assert state_of(frames, NODE) is PowerState.SWITCHED_ON
    emulator.clear("refuse_enable", "J1")
    frames = master.cycle({NODE: (0x0F, position)})
    assert state_of(frames, NODE) is PowerState.OPERATION_ENABLED


def test_bus_off_fails_master_sends_and_silences_the_bus(rig):
    emulator, master = rig
    other = FrameMaster(emulator, "arm_b", master.clock)
    try:
        other.send(0x000, [0x01, 0])
        emulator.inject("bus_off", "J1")
        assert master.bus.state is can.BusState.ERROR
        with pytest.raises(can.CanOperationError, match="bus-off"):
            master.send(0x080)
        other.send(0x080)  # the other bus goes on alone
        frames = other.exchange()
        assert tpdo1(frames, OTHER) is not None
        assert master.frames() == []
        assert emulator.clear("bus_off", "J1") == 1
        assert master.bus.state is can.BusState.ACTIVE
        assert tpdo1(master.cycle(), NODE) is not None  # answered at once, on its own
    finally:
        other.close()


def test_delayed_tpdo_arrives_n_cycles_late(rig):
    emulator, master = rig
    frames = master.cycle()
    position = tpdo1(frames, NODE)[1]
    emulator.inject("delayed_tpdo", "J1", cycles=2)
    shown = []
    for controlword in (0x06, 0x07, 0x0F, 0x0F, 0x0F):
        frames = master.cycle({NODE: (controlword, position)})
        shown.append(state_of(frames, NODE))
    assert shown == [
        None,
        None,
        PowerState.READY_TO_SWITCH_ON,
        PowerState.SWITCHED_ON,
        PowerState.OPERATION_ENABLED,
    ]
    assert tpdo1(frames, 2) is not None  # the others are on time
    emulator.clear("delayed_tpdo")
    frames = master.cycle({NODE: (0x0F, position)})
    assert len([m for m in frames if m.arbitration_id == 0x181]) == 3  # queue flushed


def test_clear_everything_and_active_list(rig):
    emulator, _ = rig
    emulator.inject("silent", "J2")
    emulator.inject("refuse_enable", "J3")
    emulator.inject("bus_off", bus="arm_b")
    assert {(f.kind, f.target) for f in emulator.active_faults} == {
        (FaultKind.SILENT, "J2"),
        (FaultKind.REFUSE_ENABLE, "J3"),
        (FaultKind.BUS_OFF, "arm_b"),
    }
    assert emulator.clear() == 3
    assert emulator.active_faults == []
    assert not emulator.drives["J2"].silent


@pytest.mark.parametrize(
    ("kind", "joint", "params", "message"),
    [
        ("melt", "J1", {}, "unknown fault kind 'melt'"),
        ("emcy", "J42", {}, "unknown drive 'J42'"),
        ("emcy", "J1", {"colour": 1}, "unknown parameters"),
        ("emcy", "J1", {"code": 0x10000}, "code must be an integer"),
        ("delayed_tpdo", "J1", {"cycles": 0}, "cycles must be an integer"),
        ("bus_off", None, {"bus": "can9"}, "give a drive"),
    ],
)
def test_bad_injections_say_what_is_wrong(rig, kind, joint, params, message):
    emulator, _ = rig
    with pytest.raises(ValueError, match=message):
        emulator.inject(kind, joint, **params)


def test_clear_unknown_target_is_refused(rig):
    emulator, _ = rig
    with pytest.raises(ValueError, match="neither a drive nor a bus"):
        emulator.clear(joint="J42")

"""CiA 402 power state machine of the emulated drive, at frame level, against the standard.

Every case drives node 1 (PA-10 J1, bus ``arm_a``) with RPDO1 controlwords and SYNCs and reads
the statusword from TPDO1, as a master would; the transition numbers are CiA 402's.
"""

from __future__ import annotations

import pytest

from controller.model.robot import load_robot
from hal.emulator.drive_state import (
    Command,
    DriveStateMachine,
    PowerState,
    decode_command,
    decode_statusword,
)
from hal.emulator.emulator import DriveEmulator
from tests.emulator_support import FakeClock, FrameMaster, emcy, state_of, tpdo1

NODE = 1
SOD = PowerState.SWITCH_ON_DISABLED
RTSO = PowerState.READY_TO_SWITCH_ON
SO = PowerState.SWITCHED_ON
OE = PowerState.OPERATION_ENABLED
QSA = PowerState.QUICK_STOP_ACTIVE
FRA = PowerState.FAULT_REACTION_ACTIVE
FAULT = PowerState.FAULT

#: Controlwords that lead from Switch on disabled to each state.
PATHS = {SOD: [], RTSO: [0x06], SO: [0x06, 0x07], OE: [0x06, 0x07, 0x0F]}

#: The full statusword each state reports (bit 9 remote; bit 4 voltage; bit 12 CSP follows).
STATUSWORD = {
    SOD: 0x0240,
    RTSO: 0x0231,
    SO: 0x0233,
    OE: 0x1237,
    QSA: 0x0217,
    FRA: 0x020F,
    FAULT: 0x0208,
}


@pytest.fixture(scope="module")
def pa10():
    return load_robot("pa10")


@pytest.fixture
def rig(pa10):
    clock = FakeClock()
    emulator = DriveEmulator(pa10, clock=clock)
    emulator.open()
    master = FrameMaster(emulator, "arm_a", clock)
    master.nmt(0x01)
    yield emulator, master
    master.close()
    emulator.close()


def _go(master: FrameMaster, controlwords: list[int]) -> list:
    """Send each controlword in its own cycle (target = the last reported position)."""
    frames = master.cycle()
    for controlword in controlwords:
        position = tpdo1(frames, NODE)[1]
        frames = master.cycle({NODE: (controlword, position)})
    return frames


def _reach(master: FrameMaster, state: PowerState) -> list:
    frames = _go(master, PATHS[state])
    assert state_of(frames, NODE) is state
    return frames


# ------------------------------------------------------------------------ transition table

TABLE = [
    # (transitions, from, controlword, to)
    ((2,), SOD, 0x06, RTSO),  # shutdown
    ((2,), SOD, 0x0E, RTSO),  # shutdown, bit 3 is "don't care"
    ((3,), RTSO, 0x07, SO),  # switch on
    ((3, 4), RTSO, 0x0F, OE),  # switch on + enable operation
    ((4,), SO, 0x0F, OE),  # enable operation
    ((5,), OE, 0x07, SO),  # disable operation
    ((6,), SO, 0x06, RTSO),  # shutdown
    ((7,), RTSO, 0x00, SOD),  # disable voltage
    ((7,), RTSO, 0x02, SOD),  # quick stop
    ((8,), OE, 0x06, RTSO),  # shutdown
    ((9,), OE, 0x00, SOD),  # disable voltage
    ((9,), OE, 0x0D, SOD),  # disable voltage (bit 1 clear, others set)
    ((10,), SO, 0x00, SOD),  # disable voltage
    ((10,), SO, 0x02, SOD),  # quick stop
    ((11,), OE, 0x02, QSA),  # quick stop
]


@pytest.mark.parametrize(("transitions", "start", "controlword", "end"), TABLE)
def test_transition_table(rig, transitions, start, controlword, end):
    emulator, master = rig
    frames = _reach(master, start)
    sm = emulator.drive_on("arm_a", NODE).sm
    sm.transitions.clear()
    position = tpdo1(frames, NODE)[1]
    frames = master.cycle({NODE: (controlword, position)})
    statusword = tpdo1(frames, NODE)[0]
    assert decode_statusword(statusword) is end
    assert statusword == STATUSWORD[end]
    assert tuple(sm.transitions) == transitions


IGNORED = [
    (SOD, 0x07),  # switch on needs Ready to switch on
    (SOD, 0x0F),
    (SOD, 0x02),
    (SOD, 0x00),
    (RTSO, 0x06),
    (SO, 0x07),
    (OE, 0x0F),
]


@pytest.mark.parametrize(("state", "controlword"), IGNORED)
def test_commands_without_a_transition_keep_the_state(rig, state, controlword):
    _, master = rig
    frames = _reach(master, state)
    frames = master.cycle({NODE: (controlword, tpdo1(frames, NODE)[1])})
    assert state_of(frames, NODE) is state


def test_boot_takes_transitions_0_and_1_and_shows_switch_on_disabled(rig):
    emulator, master = rig
    master.nmt(0x81, NODE)  # reset node: the application boots again
    sm = emulator.drive_on("arm_a", NODE).sm
    assert list(sm.transitions) == [0, 1]
    master.nmt(0x01, NODE)
    frames = master.cycle()
    assert tpdo1(frames, NODE)[0] == STATUSWORD[SOD]


# ---------------------------------------------------------------------------- quick stop


def test_quick_stop_option_2_ends_in_switch_on_disabled_after_one_tpdo(rig):
    emulator, master = rig
    frames = _reach(master, OE)
    position = tpdo1(frames, NODE)[1]
    frames = master.cycle({NODE: (0x02, position)})
    assert tpdo1(frames, NODE)[0] == STATUSWORD[QSA]  # transition 11
    frames = master.cycle({NODE: (0x02, position)})
    assert state_of(frames, NODE) is SOD  # transition 12 once the ramp is done
    assert list(emulator.drive_on("arm_a", NODE).sm.transitions)[-2:] == [11, 12]


def test_quick_stop_option_0_disables_at_once(rig):
    _, master = rig
    assert master.sdo_write(NODE, 0x605A, 0, 0, 2)[0] == 0x60
    frames = _reach(master, OE)
    frames = master.cycle({NODE: (0x02, tpdo1(frames, NODE)[1])})
    assert state_of(frames, NODE) is SOD


@pytest.mark.parametrize("option", [5, 6, 7, 8])
def test_quick_stop_option_5_to_8_stays_until_enable_operation(rig, option):
    emulator, master = rig
    assert master.sdo_write(NODE, 0x605A, 0, option, 2)[0] == 0x60
    frames = _reach(master, OE)
    position = tpdo1(frames, NODE)[1]
    for _ in range(3):
        frames = master.cycle({NODE: (0x02, position)})
        assert state_of(frames, NODE) is QSA
    frames = master.cycle({NODE: (0x0F, position)})  # transition 16
    assert state_of(frames, NODE) is OE
    assert emulator.drive_on("arm_a", NODE).sm.transitions[-1] == 16


def test_quick_stop_active_disable_voltage_is_transition_12(rig):
    emulator, master = rig
    master.sdo_write(NODE, 0x605A, 0, 6, 2)
    frames = _reach(master, OE)
    position = tpdo1(frames, NODE)[1]
    master.cycle({NODE: (0x02, position)})
    frames = master.cycle({NODE: (0x00, position)})
    assert state_of(frames, NODE) is SOD
    assert emulator.drive_on("arm_a", NODE).sm.transitions[-1] == 12


def test_quick_stop_active_ignores_enable_with_option_2(rig):
    _, master = rig
    frames = _reach(master, OE)
    position = tpdo1(frames, NODE)[1]
    master.cycle({NODE: (0x02, position)})
    frames = master.cycle({NODE: (0x0F, position)})
    assert state_of(frames, NODE) is SOD  # the ramp ended; 16 only for options 5..8


# ------------------------------------------------------------------- fault and fault reset


@pytest.mark.parametrize("start", [SOD, RTSO, SO, OE])
def test_fault_reaction_then_fault_from_any_state(rig, start):
    emulator, master = rig
    frames = _reach(master, start)
    position = tpdo1(frames, NODE)[1]
    controlword = ([0x00, *PATHS[start]])[-1]
    emulator.inject("emcy", "J1", code=0x2310)
    frames = master.cycle({NODE: (controlword, position)})
    assert tpdo1(frames, NODE)[0] == STATUSWORD[FRA]  # transition 13
    frames = master.cycle({NODE: (controlword, position)})
    assert tpdo1(frames, NODE)[0] == STATUSWORD[FAULT]  # transition 14
    assert list(emulator.drive_on("arm_a", NODE).sm.transitions)[-2:] == [13, 14]


def test_fault_reset_on_bit_7_rising_edge_only(rig):
    emulator, master = rig
    frames = _reach(master, OE)
    position = tpdo1(frames, NODE)[1]
    emulator.inject("emcy", "J1")
    frames = master.cycle({NODE: (0x0F, position)})
    assert state_of(frames, NODE) is FRA
    frames = master.cycle({NODE: (0x80, position)})  # 14 then 15 at this SYNC
    assert state_of(frames, NODE) is SOD
    assert tpdo1(frames, NODE)[0] == STATUSWORD[SOD]
    assert emcy(frames, NODE) == [(0x0000, 0x00)]  # EMCY "error reset"
    emulator.inject("emcy", "J1")
    for _ in range(3):  # bit 7 held high: no edge, no reset
        frames = master.cycle({NODE: (0x80, position)})
    assert state_of(frames, NODE) is FAULT
    master.cycle({NODE: (0x00, position)})
    frames = master.cycle({NODE: (0x80, position)})  # transition 15
    assert state_of(frames, NODE) is SOD
    assert emulator.drive_on("arm_a", NODE).sm.transitions[-1] == 15
    frames = _go(master, [0x06, 0x07, 0x0F])
    assert state_of(frames, NODE) is OE


def test_fault_holds_until_reset_whatever_the_controlword(rig):
    emulator, master = rig
    frames = _reach(master, OE)
    position = tpdo1(frames, NODE)[1]
    emulator.inject("emcy", "J1")
    for controlword in (0x0F, 0x06, 0x07, 0x0F, 0x02, 0x00):
        frames = master.cycle({NODE: (controlword, position)})
    assert state_of(frames, NODE) is FAULT


# ------------------------------------------------------------------------- pure helpers


def test_decode_statusword_of_every_state_pattern():
    for state in PowerState:
        assert decode_statusword(state.pattern) is state
        assert decode_statusword(state.pattern | 0x3290) is state  # bits 4, 7, 9, 12, 13
    assert decode_statusword(0x0003) is None  # not a CiA 402 pattern


@pytest.mark.parametrize(
    ("controlword", "command"),
    [
        (0x06, Command.SHUTDOWN),
        (0x0E, Command.SHUTDOWN),
        (0x07, Command.SWITCH_ON),
        (0x0F, Command.ENABLE_OPERATION),
        (0x00, Command.DISABLE_VOLTAGE),
        (0x05, Command.DISABLE_VOLTAGE),
        (0x02, Command.QUICK_STOP),
        (0x0A, Command.QUICK_STOP),
    ],
)
def test_decode_command(controlword, command):
    assert decode_command(controlword) is command


def test_refused_enable_stays_switched_on():
    sm = DriveStateMachine()
    sm.boot()
    sm.refuse_enable = True
    for controlword in (0x06, 0x07, 0x0F):
        sm.controlword(controlword)
    assert sm.state is SO
    sm.refuse_enable = False
    sm.controlword(0x0F)
    assert sm.state is OE

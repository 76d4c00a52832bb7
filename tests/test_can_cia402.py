"""hal.can.cia402: statusword decoding, the master state machine, and frame-level checks of
the standard's transition table against an emulated drive (RPDO1/SYNC/TPDO1 on a virtual bus).
"""

from __future__ import annotations

import can
import pytest

from hal.can import cia402, pdo
from hal.can.cia402 import STATUSWORD, DriveMaster, Goal, State, decode
from hal.can.drive_profile import DEFAULT_EDS
from hal.can.setup import SetupNetwork, interpolation_period, set_up_drive
from hal.emulator.emulator import DriveEmulator
from tests.can_support import SDO_TIMEOUT, FakeClock
from tests.support import robot


# ------------------------------------------------------------------------------ decoding
@pytest.mark.parametrize("state", list(STATUSWORD))
def test_decode_ignores_unrelated_bits(state: State):
    word = STATUSWORD[state]
    for extra in (0x0010, 0x0080, 0x0200, 0x0400, 0x2000, 0x0010 | 0x0200 | 0x8000):
        assert decode(word | extra) is state
    # bit 5 (quick stop) is "don't care" for these four states
    if state in (State.NOT_READY_TO_SWITCH_ON, State.SWITCH_ON_DISABLED, State.FAULT,
                 State.FAULT_REACTION_ACTIVE):  # fmt: skip
        assert decode(word | 0x20) is state


# --------------------------------------------------------------------- master decisions
ENABLE_PATH = [
    (State.UNKNOWN, cia402.CW_DISABLE_VOLTAGE),
    (State.SWITCH_ON_DISABLED, cia402.CW_SHUTDOWN),  # transition 2
    (State.READY_TO_SWITCH_ON, cia402.CW_SWITCH_ON),  # 3
    (State.SWITCHED_ON, cia402.CW_ENABLE_OPERATION),  # 4
    (State.OPERATION_ENABLED, cia402.CW_ENABLE_OPERATION),
    (State.QUICK_STOP_ACTIVE, cia402.CW_DISABLE_VOLTAGE),  # 12
    (State.FAULT, cia402.CW_DISABLE_VOLTAGE),  # never resets on its own
]
OFF_PATH = [
    (State.OPERATION_ENABLED, cia402.CW_QUICK_STOP),  # 11
    (State.QUICK_STOP_ACTIVE, cia402.CW_QUICK_STOP),
    (State.SWITCHED_ON, cia402.CW_QUICK_STOP),  # 10
    (State.READY_TO_SWITCH_ON, cia402.CW_QUICK_STOP),  # 7
    (State.SWITCH_ON_DISABLED, cia402.CW_DISABLE_VOLTAGE),
]


@pytest.mark.parametrize(("goal", "path"), [(Goal.ENABLED, ENABLE_PATH), (Goal.OFF, OFF_PATH)])
def test_one_transition_per_cycle(goal: Goal, path: list[tuple[State, int]]):
    m = DriveMaster()
    m.goal = goal
    for state, cw in path:
        word = None if state is State.UNKNOWN else STATUSWORD[state]
        assert m.controlword(word) == cw, state


def test_fault_reset_is_a_bit7_edge_then_off():
    m = DriveMaster()
    assert m.controlword(STATUSWORD[State.FAULT]) == 0x00
    m.goal = Goal.RESET
    words = [m.controlword(STATUSWORD[State.FAULT]) for _ in range(4)]
    assert words == [0x80, 0x00, 0x80, 0x00]
    assert m.controlword(STATUSWORD[State.SWITCH_ON_DISABLED]) == 0x00
    assert m.goal is Goal.OFF and not m.faulted


def test_repeated_inputs_give_the_same_controlword_and_a_reset_starts_high():
    """The per-cycle shortcut (same statusword and goal -> the last controlword) changes no
    answer: state follows the statusword, a new goal is seen, a reset edge starts at 0x80."""
    m = DriveMaster()
    m.goal = Goal.ENABLED
    enabled = STATUSWORD[State.OPERATION_ENABLED]
    assert [m.controlword(enabled) for _ in range(3)] == [0x0F, 0x0F, 0x0F]
    assert m.enabled
    m.goal = Goal.OFF
    assert m.controlword(enabled) == 0x02
    fault = STATUSWORD[State.FAULT]
    assert [m.controlword(fault) for _ in range(2)] == [0x00, 0x00] and m.faulted
    m.goal = Goal.RESET
    assert m.controlword(fault) == 0x80
    m.goal = Goal.OFF  # the backend gives up the reset after one edge
    assert m.controlword(fault) == 0x00
    m.goal = Goal.RESET
    assert [m.controlword(fault) for _ in range(2)] == [0x80, 0x00]


# ------------------------------------------------------------------ frame level, emulated
class Frames:
    """pa10's emulated drives; frames to drive J3 (node 3 on bus arm_a) by hand."""

    DT = 0.002

    def __init__(self) -> None:
        self.clock = FakeClock()
        r = robot("pa10")
        self.emu = DriveEmulator(r, period=self.DT, clock=self.clock)
        self.profile = self.emu.profile
        self.buses = {n: self.emu.open_master_bus(n) for n in self.profile.buses}
        self.emu.start()
        try:
            for bus_name, bus in self.buses.items():
                net = SetupNetwork(bus, SDO_TIMEOUT)
                for drive in self.profile.drives_on(bus_name).values():
                    node = net.node(drive.node_id, DEFAULT_EDS)
                    set_up_drive(node, drive, self.profile, interpolation_period(self.DT))
                net.close()
        finally:
            self.emu.stop()
        self.node = 3
        self.actual = 0
        self.statusword = 0
        self.step(0x00)

    def send(self, bus: str, cob: int, data: bytes) -> None:
        self.buses[bus].send(can.Message(arbitration_id=cob, data=data, is_extended_id=False))

    def step(self, controlword: int) -> State:
        """RPDO1 to J3, SYNC and master heartbeat on every bus, one emulated period."""
        self.send("arm_a", pdo.RPDO1 + self.node, pdo.RPDO1_STRUCT.pack(controlword, self.actual))
        for bus in self.buses:
            self.send(bus, pdo.SYNC, b"")
            self.send(bus, pdo.HEARTBEAT + 127, b"\x05")
        self.clock.t += self.DT
        self.emu.poll()
        for msg in iter(lambda: self.buses["arm_a"].recv(0.0), None):
            if msg.arbitration_id == pdo.TPDO1 + self.node:
                self.statusword, self.actual = pdo.TPDO1_STRUCT.unpack(msg.data)
        return decode(self.statusword)

    def sdo(self, index: int, value: int) -> None:
        self.emu.drives["J3"].node.sdo[index].raw = value

    def close(self) -> None:
        self.emu.close()


@pytest.fixture
def frames():
    f = Frames()
    yield f
    f.close()


S = State
#: (transition, controlwords that lead to the start state, command, expected state)
TABLE = [
    (2, [], 0x06, S.READY_TO_SWITCH_ON),
    (3, [0x06], 0x07, S.SWITCHED_ON),
    (4, [0x06, 0x07], 0x0F, S.OPERATION_ENABLED),
    (5, [0x06, 0x07, 0x0F], 0x07, S.SWITCHED_ON),
    (6, [0x06, 0x07], 0x06, S.READY_TO_SWITCH_ON),
    (7, [0x06], 0x00, S.SWITCH_ON_DISABLED),
    (7, [0x06], 0x02, S.SWITCH_ON_DISABLED),
    (8, [0x06, 0x07, 0x0F], 0x06, S.READY_TO_SWITCH_ON),
    (9, [0x06, 0x07, 0x0F], 0x00, S.SWITCH_ON_DISABLED),
    (10, [0x06, 0x07], 0x00, S.SWITCH_ON_DISABLED),
    (10, [0x06, 0x07], 0x02, S.SWITCH_ON_DISABLED),
    (11, [0x06, 0x07, 0x0F], 0x02, S.QUICK_STOP_ACTIVE),
    (16, [0x06, 0x07, 0x0F, 0x02], 0x0F, S.OPERATION_ENABLED),
    (12, [0x06, 0x07, 0x0F, 0x02], 0x00, S.SWITCH_ON_DISABLED),
]


@pytest.mark.parametrize(("transition", "path", "command", "expected"), TABLE)
def test_transition_table_on_the_wire(
    frames: Frames, transition: int, path: list[int], command: int, expected: State
):
    frames.sdo(0x605A, 6)  # quick stop option 6: stay in Quick stop active (11, 12, 16)
    assert frames.step(0x00) is S.SWITCH_ON_DISABLED
    for cw in path:
        frames.step(cw)
    assert frames.step(command) is expected, f"transition {transition}"
    assert transition in frames.emu.drives["J3"].sm.transitions


def test_fault_reset_edge_on_the_wire(frames: Frames):
    frames.emu.inject("emcy", "J3", code=0x5530)
    assert frames.step(0x00) is S.FAULT_REACTION_ACTIVE  # 13
    assert frames.step(0x00) is S.FAULT  # 14
    assert frames.step(0x80) is S.SWITCH_ON_DISABLED  # transition 15 on the rising edge


def test_master_enables_and_quick_stops_over_frames(frames: Frames):
    m = DriveMaster()
    m.goal = Goal.ENABLED
    for _ in range(6):
        frames.step(m.controlword(frames.statusword))
    assert decode(frames.statusword) is S.OPERATION_ENABLED
    m.goal = Goal.OFF
    for _ in range(3):
        frames.step(m.controlword(frames.statusword))
    assert decode(frames.statusword) is S.SWITCH_ON_DISABLED  # 0x605A = 2: 11 then 12
    frames.emu.inject("emcy", "J3", code=0x5530)
    frames.step(m.controlword(frames.statusword))
    frames.step(m.controlword(frames.statusword))
    assert m.controlword(frames.statusword) == 0x00 and decode(frames.statusword) is S.FAULT
    m.goal = Goal.RESET
    for _ in range(3):
        frames.step(m.controlword(frames.statusword))
    assert decode(frames.statusword) is S.SWITCH_ON_DISABLED

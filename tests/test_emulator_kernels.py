"""hal.emulator.kernels (and the compiled round as a whole): the same frames as the Python path.

Two emulators of one robot, one with the compiled round (``compiled=True``: bank, kernels,
inbox), one with every drive's Python (``compiled=False``, what ``IMOTION_JIT=0`` runs),
get the same frames at the same fake times; every frame they send back must be the same,
in the same order, and their banks the same, through the enable sequence, motion, a quick
stop that stays, a following error and its reset, master heartbeat loss, every injected
fault, a short RPDO, remapped PDOs and a bus that goes off.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterable
from pathlib import Path

import can
import numpy as np
import pytest

from controller.model import jit
from controller.model.robot import load_robot
from hal.emulator import kernels
from hal.emulator.bank import FLOAT, INT, TPDO_STATUS_POSITION, TPDO_VELOCITY, DriveBank
from hal.emulator.drive_state import PowerState
from hal.emulator.emulator import DriveEmulator
from hal.emulator.plant import Plant
from tests.emulator_support import SDO_DOWNLOAD, FakeClock

# Run with IMOTION_JIT=0 too: the tests ask for the compiled round explicitly.
pytestmark = pytest.mark.skipif(jit.numba is None, reason="numba not installed")

MASTER = 127
Frame = tuple[int, bytes]


class Twin:
    """The same robot emulated twice, compiled and Python, fed the same frames."""

    def __init__(self, robot: str, tmp_path: Path | None = None):
        self.clock = FakeClock()
        self.emulators: list[DriveEmulator] = []
        self.masters: list[dict[str, can.BusABC]] = []
        for n, compiled in enumerate((True, False)):
            channels = None
            if tmp_path is not None:
                buses = DriveEmulator(robot, clock=self.clock).channels
                channels = {b: ("unix", str(tmp_path / f"{n}{b}")) for b in buses}
            emulator = DriveEmulator(robot, clock=self.clock, channels=channels,
                                     compiled=compiled)  # fmt: skip
            emulator.open()
            self.emulators.append(emulator)
            masters = {}
            for bus, (interface, channel) in emulator.channels.items():
                masters[bus] = (
                    emulator.open_master_bus(bus)
                    if interface == "virtual"
                    else can.Bus(interface=interface, channel=channel)
                )
            self.masters.append(masters)
            emulator.poll(0.0)  # unix: accept the masters
        fast, slow = self.emulators
        assert fast.compiled and not slow.compiled
        self.buses = list(fast.channels)
        self.nodes = {
            bus: [fast.profile.drives[name].node_id for name in fast.profile.drives_on(bus)]
            for bus in self.buses
        }
        self.position = {d.node_id: d.actual for d in fast.drives.values()}

    def exchange(self, frames: Iterable[tuple[str, int, bytes]], dt: float = 0.0) -> dict:
        """Send ``frames`` (bus, identifier, data) to both, advance the clock, poll both;
        the frames each sent back, per bus, asserted equal."""
        frames = list(frames)
        self.clock.now += dt
        answers = []
        for emulator, masters in zip(self.emulators, self.masters, strict=True):
            for bus, can_id, data in frames:
                try:
                    masters[bus].send(can.Message(arbitration_id=can_id, data=data,
                                                  is_extended_id=False))  # fmt: skip
                except can.CanOperationError:  # an injected bus-off: as the master sees it
                    pass
            emulator.poll(self.clock.now)
            got: dict[str, list[Frame]] = {}
            for bus, master in masters.items():
                got[bus] = []
                while (msg := master.recv(0.0)) is not None:
                    got[bus].append((msg.arbitration_id, bytes(msg.data)))
            answers.append(got)
        assert answers[0] == answers[1]
        for frames_of_bus in answers[0].values():
            for can_id, data in frames_of_bus:
                if 0x181 <= can_id <= 0x1FF and len(data) == 6:
                    self.position[can_id - 0x180] = struct.unpack("<Hi", data)[1]
        return answers[0]

    def cycle(self, rpdos: dict[int, tuple[int, int]], heartbeat: bool = True,
              extra: Iterable[tuple[str, int, bytes]] = ()) -> dict:  # fmt: skip
        """One master cycle: RPDO1 (controlword, target) per node, SYNC per bus, 2 ms."""
        frames = list(extra)
        for bus in self.buses:
            for node in self.nodes[bus]:
                if node in rpdos:
                    frames.append((bus, 0x200 + node, struct.pack("<Hi", *rpdos[node])))
            frames.append((bus, 0x080, b""))
            if heartbeat:
                frames.append((bus, 0x700 + MASTER, bytes([0x05])))
        return self.exchange(frames, dt=0.002)

    def sdo(self, node: int, index: int, subindex: int, value: int, size: int) -> None:
        data = struct.pack("<BHB", SDO_DOWNLOAD[size], index, subindex)
        data += value.to_bytes(size, "little").ljust(4, b"\0")
        self.exchange([(self.bus_of(node), 0x600 + node, data)])

    def bus_of(self, node: int) -> str:
        return next(bus for bus in self.buses if node in self.nodes[bus])

    def inject(self, kind: str, joint: str | None, **params: object) -> None:
        for emulator in self.emulators:
            emulator.inject(kind, joint, **params)

    def clear(self, kind: str | None = None, joint: str | None = None) -> None:
        for emulator in self.emulators:
            emulator.clear(kind, joint)

    def assert_same_banks(self) -> None:
        fast, slow = (e.bank for e in self.emulators)
        np.testing.assert_array_equal(fast.ints, slow.ints)
        np.testing.assert_array_equal(fast.floats, slow.floats)  # NaN == NaN here

    def close(self) -> None:
        for emulator, masters in zip(self.emulators, self.masters, strict=True):
            for master in masters.values():
                master.shutdown()
            emulator.close()


def _scenario(twin: Twin) -> None:
    """Everything the compiled round must do as the Python one (module doc)."""
    nodes = [n for bus in twin.buses for n in twin.nodes[bus]]
    first, second, third, fourth = nodes[0], nodes[1], nodes[-1], nodes[-2]
    names = {d.node_id: d.name for d in twin.emulators[0].drives.values()}
    for bus in twin.buses:
        twin.exchange([(bus, 0x000, bytes([0x01, 0]))])  # NMT start
    for node in nodes:
        twin.sdo(node, 0x1016, 1, (MASTER << 16) | 100, 4)  # master heartbeat: 100 ms
        twin.sdo(node, 0x6065, 0, 5000, 4)  # following error window [counts]
        twin.sdo(node, 0x6066, 0, 10, 2)  # ... for 10 ms
    twin.sdo(first, 0x1801, 1, 0x280 + first, 4)  # TPDO2 (velocity) on, every 2nd SYNC
    twin.sdo(first, 0x1801, 2, 2, 1)
    twin.sdo(second, 0x605A, 0, 6, 2)  # quick stop stays until enable operation
    twin.sdo(second, 0x6007, 0, 0, 2)  # master heartbeat lost: warning only
    twin.sdo(third, 0x6007, 0, 3, 2)  # ... quick stop
    twin.sdo(third, 0x1A01, 0, 0, 1)  # TPDO2 remapped (statusword alone): Python's codec
    twin.sdo(third, 0x1A01, 1, 0x60410010, 4)
    twin.sdo(third, 0x1A01, 0, 1, 1)
    twin.sdo(third, 0x1801, 1, 0x280 + third, 4)
    twin.sdo(fourth, 0x1600, 0, 0, 1)  # RPDO1 as target + controlword: Python's codec
    twin.sdo(fourth, 0x1600, 1, 0x607A0020, 4)
    twin.sdo(fourth, 0x1600, 2, 0x60400010, 4)
    twin.sdo(fourth, 0x1600, 0, 2, 1)

    def rpdos(controlword: int, offset: float = 0.0, **special: tuple[int, int]) -> dict:
        out = {n: (controlword, twin.position[n] + int(offset)) for n in nodes if n != fourth}
        out.update({int(k[1:]): v for k, v in special.items()})
        return out

    def fourth_rpdo(controlword: int, target: int) -> tuple[str, int, bytes]:
        return (twin.bus_of(fourth), 0x200 + fourth, struct.pack("<iH", target, controlword))

    for controlword in (0x06, 0x07, 0x0F):
        twin.cycle(rpdos(controlword), extra=[fourth_rpdo(controlword, twin.position[fourth])])
    for k in range(20):  # motion
        twin.cycle(rpdos(0x0F, 300 * math.sin(k / 5)),
                   extra=[fourth_rpdo(0x0F, twin.position[fourth])])  # fmt: skip
    twin.cycle(rpdos(0x0F, **{f"n{second}": (0x02, twin.position[second])}))  # quick stop
    twin.cycle(rpdos(0x0F))  # option 6: stays; enable operation takes it back (16)
    twin.cycle(rpdos(0x0F))
    far = twin.position[first] + 200_000  # following error: out of the window for 10 ms
    for _ in range(8):
        twin.cycle(rpdos(0x0F, **{f"n{first}": (0x0F, far)}))
    for controlword in (0x80, 0x06, 0x07, 0x0F):  # fault reset, enable again
        twin.cycle(rpdos(controlword))
    twin.exchange([(twin.bus_of(first), 0x200 + first, b"\x0f\x00")])  # short RPDO
    twin.cycle(rpdos(0x0F))
    twin.inject("emcy", names[second], code=0x2310)
    twin.cycle(rpdos(0x0F))
    twin.inject("silent", names[first])
    twin.inject("delayed_tpdo", names[third], cycles=2)
    twin.inject("refuse_enable", names[second])
    for controlword in (0x80, 0x06, 0x07, 0x0F, 0x0F):
        twin.cycle(rpdos(controlword))
    twin.clear()
    for _ in range(3):
        twin.cycle(rpdos(0x0F))
    twin.inject("following_error", names[third])
    twin.inject("bus_off", None, bus=twin.buses[-1])
    for _ in range(3):
        twin.cycle(rpdos(0x0F))
    twin.clear("bus_off")
    twin.cycle(rpdos(0x0F))
    for _ in range(60):  # master heartbeats stop: loss after 100 ms (0x6007 reaction)
        twin.cycle(rpdos(0x0F), heartbeat=False)
    for controlword in (0x80, 0x06, 0x07, 0x0F, 0x0F):
        twin.cycle(rpdos(controlword))
    twin.assert_same_banks()
    ports = twin.emulators[0]._ports.values()
    assert all(not port.slow[: len(port.drives)].all() for port in ports)  # compiled, mostly


@pytest.mark.parametrize("robot", ["pa10", "smartpal5"])
def test_compiled_and_python_rounds_send_the_same_frames_on_virtual_buses(robot):
    twin = Twin(robot)
    try:
        _scenario(twin)
        drives = twin.emulators[0].drives.values()
        assert any(d.sm.state is PowerState.OPERATION_ENABLED for d in drives)
    finally:
        twin.close()


def test_compiled_and_python_rounds_send_the_same_frames_on_unix_buses(tmp_path):
    twin = Twin("pa10", tmp_path)
    try:
        _scenario(twin)
    finally:
        twin.close()


# ------------------------------------------------------------------------- kernels alone


def _plain_bank() -> DriveBank:
    bank = DriveBank(2)
    for row in bank.ints:
        row[INT["state"]] = row[INT["last_state"]] = PowerState.OPERATION_ENABLED.pattern
        row[INT["nmt_state"]] = 5  # OPERATIONAL
        row[INT["fast"]] = 1
        row[INT["fe_window"]] = 0xFFFFFFFF
        row[INT["tpdos"]] = 2
        row[INT["tpdo_kind0"]], row[INT["tpdo_cob0"]] = TPDO_STATUS_POSITION, 0x181
        row[INT["tpdo_kind1"]], row[INT["tpdo_cob1"]] = TPDO_VELOCITY, 0x281
        row[INT["tpdo_type1"]] = 3  # every third SYNC
        row[INT["actual"]] = -5
        row[INT["velocity"]] = 77
    return bank


def _frames(out: np.ndarray, end: int) -> list[tuple[int, bytes, float]]:
    buf = out[:end].tobytes()
    frames, at = [], 0
    while at < end:
        can_id, flags, dlc, length, stamp = struct.unpack_from("<IBBBxd", buf, at)
        assert flags == 0 and dlc == length
        frames.append((can_id, buf[at + 16 : at + 16 + length], stamp))
        at += 16 + length
    return frames


def test_sync_drives_encodes_the_tpdos_due_as_wire_frames():
    bank = _plain_bank()
    now = np.array([1234.5])
    out = np.zeros(2 * kernels.DRIVE_BYTES, dtype=np.uint8)
    ends, slow = np.zeros(2, dtype=np.int64), np.zeros(2, dtype=bool)
    slots = np.array([1, 0], dtype=np.int64)
    sent = []
    for _ in range(3):
        left = kernels.sync_drives(bank.ints, bank.floats, slots, 0.0, now.view(np.uint8),
                                   out, ends, slow)  # fmt: skip
        assert left == 0 and not slow.any()
        sent.append(_frames(out, int(ends[1])))
    statusword = struct.pack("<Hi", 0x1237, -5)  # enabled, remote, voltage, follows target
    assert sent[0] == [(0x181, statusword, 1234.5)] * 2
    assert sent[2] == [(0x181, statusword, 1234.5), (0x281, struct.pack("<i", 77), 1234.5)] * 2
    assert list(bank.ints[:, INT["syncs"]]) == [3, 3]


@pytest.mark.parametrize(
    ("column", "value"),
    [
        ("state", PowerState.FAULT_REACTION_ACTIVE.pattern),  # also != last_state
        ("reaction_cycles", 1),
        ("silent", 1),
        ("tpdo_delay", 1),
        ("delayed", 1),
        ("waiting", 1),
        ("fast", 0),
        ("nmt_state", 127),  # pre-operational
    ],
)
def test_sync_drives_leaves_a_drive_that_is_not_plain_to_python(column, value):
    bank = _plain_bank()
    bank.ints[1, INT[column]] = value
    before = bank.ints.copy()
    out = np.zeros(2 * kernels.DRIVE_BYTES, dtype=np.uint8)
    ends, slow = np.zeros(2, dtype=np.int64), np.zeros(2, dtype=bool)
    left = kernels.sync_drives(bank.ints, bank.floats, np.array([0, 1]), 0.0,
                               np.zeros(8, dtype=np.uint8), out, ends, slow)  # fmt: skip
    assert left == 1 and list(slow) == [False, True]
    np.testing.assert_array_equal(bank.ints[1], before[1])  # untouched
    assert ends[1] == ends[0] > 0  # no frame for it


@pytest.mark.parametrize(
    ("state", "controlword", "previous", "plain"),
    [
        (PowerState.OPERATION_ENABLED, 0x0F, 0x0F, True),
        (PowerState.OPERATION_ENABLED, 0x07, 0x0F, False),  # disable operation: 5
        (PowerState.SWITCHED_ON, 0x07, 0x07, True),
        (PowerState.SWITCHED_ON, 0x0F, 0x07, False),  # enable operation: 4
        (PowerState.READY_TO_SWITCH_ON, 0x06, 0x06, True),
        (PowerState.SWITCH_ON_DISABLED, 0x00, 0x00, True),
        (PowerState.SWITCH_ON_DISABLED, 0x06, 0x00, False),  # shutdown: 2
        (PowerState.FAULT, 0x80, 0x80, True),  # no rising edge
        (PowerState.FAULT, 0x80, 0x00, False),  # fault reset: 15
    ],
)
def test_a_controlword_that_makes_a_transition_goes_to_python(state, controlword, previous,
                                                               plain):  # fmt: skip
    bank = _plain_bank()
    row = bank.ints[0]
    row[INT["state"]] = row[INT["last_state"]] = state.pattern
    row[INT["sm_controlword"]] = previous
    row[INT["rx_fresh"]], row[INT["rx_controlword"]], row[INT["rx_target"]] = 1, controlword, 9
    out = np.zeros(2 * kernels.DRIVE_BYTES, dtype=np.uint8)
    ends, slow = np.zeros(1, dtype=np.int64), np.zeros(1, dtype=bool)
    kernels.sync_drives(bank.ints, bank.floats, np.array([0]), 0.0,
                        np.zeros(8, dtype=np.uint8), out, ends, slow)  # fmt: skip
    assert slow[0] == (not plain)
    if plain:
        assert (row[INT["target"]], row[INT["controlword"]], row[INT["rx_fresh"]]) == (
            9,
            controlword,
            0,
        )


def test_following_error_is_timed_and_its_trip_left_to_python():
    bank = _plain_bank()
    row = bank.ints[0]
    row[INT["fe_window"]] = 100
    bank.floats[0, FLOAT["fe_time"]] = 0.004
    row[INT["target"]] = 500  # 505 counts off
    out = np.zeros(2 * kernels.DRIVE_BYTES, dtype=np.uint8)
    ends, slow = np.zeros(1, dtype=np.int64), np.zeros(1, dtype=bool)
    args = (np.zeros(8, dtype=np.uint8), out, ends, slow)
    for t in (0.010, 0.012):
        kernels.sync_drives(bank.ints, bank.floats, np.array([0]), t, *args)
        assert not slow[0] and bank.floats[0, FLOAT["outside_since"]] == 0.010
    kernels.sync_drives(bank.ints, bank.floats, np.array([0]), 0.014, *args)
    assert slow[0]  # 4 ms out of the window: the fault is Python's


def test_setpoints_and_move_as_the_drives_do():
    bank = DriveBank(3)
    states = (PowerState.OPERATION_ENABLED, PowerState.QUICK_STOP_ACTIVE, PowerState.FAULT)
    for row, state in zip(bank.ints, states, strict=True):
        row[INT["state"]] = state.pattern
        row[INT["target"]], row[INT["hold"]], row[INT["actual"]] = 1, 2, 3
    setpoint, torque = np.zeros(3, dtype=np.int64), np.zeros(3, dtype=bool)
    kernels.setpoints(bank.ints, setpoint, torque)
    assert list(setpoint) == [1, 2, 3] and list(torque) == [True, True, False]
    # SI in (2 counts per unit, offset 1): rounded half to even as ScalingArray.to_counts
    factor, offset = np.full(3, 2.0), np.ones(3)
    position = (np.array([2.0**31, -(2.0**31) - 1, 7.0]) - 1.0) / 2.0
    position[2] = 3.25  # 7.5 counts: 8
    kernels.move(bank.ints, position, np.array([2.0**40, -(2.0**40), 1.25]), factor, offset)
    assert list(bank.ints[:, INT["actual"]]) == [-(2**31), 2**31 - 1, 8]
    assert list(bank.ints[:, INT["velocity"]]) == [2**31 - 1, -(2**31), 2]


@pytest.mark.parametrize("robot", ["pa10", "smartpal5"])
def test_plant_step_compiled_is_the_numpy_step(robot):
    loaded = load_robot(robot)
    emulator = DriveEmulator(loaded, compiled=False)
    plants = [Plant(loaded, emulator.profile, emulator.period, compiled=c) for c in (True, False)]
    for plant in plants:
        plant.start()
    start = plants[0].position_counts()
    rng = np.random.default_rng(3)
    torque = np.ones(start.size, dtype=bool)
    for k in range(60):
        if k % 20 == 10:
            torque = rng.random(start.size) > 0.2
        setpoints = start + (rng.normal(size=start.size) * 3000 * math.sin(k / 7)).astype(np.int64)
        for plant in plants:
            plant.step(setpoints, torque)
        np.testing.assert_array_equal(plants[0].position_counts(), plants[1].position_counts())
        np.testing.assert_array_equal(plants[0].velocity_counts(), plants[1].velocity_counts())
        _assert_same_plants(*plants)
    emulator.close()


def _assert_same_plants(compiled: Plant, plain: Plant) -> None:
    """The SI state of both plants to 1e-12: measured values, servo mask, the commands
    MuJoCo got (so its state too) and both vehicle mappings' state."""
    for name in ("position", "velocity"):
        np.testing.assert_allclose(getattr(compiled, name), getattr(plain, name), rtol=1e-12,
                                   atol=1e-12, err_msg=name)  # fmt: skip
    np.testing.assert_array_equal(compiled.backend.servo_mask, plain.backend.servo_mask)
    np.testing.assert_allclose(compiled.backend.read().position, plain.backend.read().position,
                               rtol=1e-12, atol=1e-12)  # fmt: skip
    assert compiled.sim_time == plain.sim_time
    for attr in ("_mapping_cmd", "_mapping_act"):
        a, b = getattr(compiled, attr), getattr(plain, attr)
        if a is None:
            assert b is None
            continue
        for field in ("pose", "velocity", "measured_wheels", "command_pose", "wheel_targets"):
            np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=1e-12,
                                       atol=1e-12, err_msg=f"{attr}.{field}")  # fmt: skip


def test_the_compiled_vehicle_step_is_the_numpy_one_when_the_base_turns_on_and_off():
    """SmartPal V's wheels: the base off (one wheel drive without torque: the measured pose
    held), on (the odometry starts at the measured pose), moving along a curve and turning,
    off and on again; every step the same state as the NumPy step's, to 1e-12."""
    loaded = load_robot("smartpal5")
    emulator = DriveEmulator(loaded, compiled=False)
    plants = [Plant(loaded, emulator.profile, emulator.period, compiled=c) for c in (True, False)]
    for plant in plants:
        plant.start()
    wheels = [plants[0].names.index(name) for name in emulator.profile.wheels]
    assert len(wheels) == 3
    start = plants[0].position_counts()
    torque = np.ones(start.size, dtype=bool)
    for k in range(90):
        torque[wheels[1]] = not 20 <= k < 30 and k >= 5  # off, on at 5, off 20-29, on
        setpoints = start.copy()
        swing = np.array([1.0, -0.5, 0.7]) * 4000 * math.sin(k / 15)  # a curve, turning
        setpoints[wheels] += swing.astype(np.int64)
        for plant in plants:
            plant.step(setpoints, torque)
        np.testing.assert_array_equal(plants[0].position_counts(), plants[1].position_counts())
        np.testing.assert_array_equal(plants[0].velocity_counts(), plants[1].velocity_counts())
        _assert_same_plants(*plants)
    assert plants[0]._vehicle_on[0] and abs(plants[0]._mapping_cmd.pose).max() > 1e-4
    emulator.close()


def test_a_faulted_or_silenced_drive_goes_the_python_way_and_the_others_stay_compiled():
    twin = Twin("pa10")
    try:
        nodes = twin.nodes[twin.buses[0]]
        for bus in twin.buses:
            twin.exchange([(bus, 0x000, bytes([0x01, 0]))])
        targets = {n: (0x0F, twin.position[n]) for n in nodes}
        for controlword in (0x06, 0x07, 0x0F):
            twin.cycle({n: (controlword, twin.position[n]) for n in nodes}, heartbeat=False)
        port = twin.emulators[0]._ports[twin.buses[0]]
        assert port.slow[: len(nodes)].all()  # each a transition (4): the state machine's
        twin.cycle(targets, heartbeat=False)
        assert not port.slow[: len(nodes)].any()  # all plain: the kernel took them
        names = {d.node_id: d.name for d in twin.emulators[0].drives.values()}
        twin.inject("emcy", names[nodes[0]])
        twin.inject("silent", names[nodes[1]])
        twin.cycle(targets, heartbeat=False)
        assert list(port.slow[: len(nodes)]) == [True, True] + [False] * (len(nodes) - 2)
        twin.cycle(targets, heartbeat=False)  # the fault reaction ends (14): Python's too
        assert list(port.slow[: len(nodes)]) == [True, True] + [False] * (len(nodes) - 2)
        twin.cycle(targets, heartbeat=False)  # in Fault, plain again; still silent
        assert list(port.slow[: len(nodes)]) == [False, True] + [False] * (len(nodes) - 2)
    finally:
        twin.close()

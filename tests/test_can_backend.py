"""hal.can.backend: lifecycle, cycle, injected faults and recovery, full stack in HIL.

Every test runs the CAN backend against the drive emulator in one process over python-can
``virtual`` buses, lock-step on a fake clock (tests/can_support.py): no wall-clock asserts.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping

import can
import numpy as np
import pytest

from controller.control.core import CoreState, MotionCore
from controller.model.alarms import AlarmCode
from controller.motion.motions import JointMotion
from controller.vocabulary import UnitType
from hal.can import pdo
from hal.can.backend import CanBackend, Port
from hal.can.cia402 import CW_ENABLE_OPERATION
from hal.can.drive_profile import drives_path, load_drive_profile
from hal.can.stub_bus import StubDrivesBus
from hal.can.supervision import DriveError
from hal.interface import HardwareState, JointCommand, JointState
from tests.can_support import FakeClock, Hil
from tests.support import robot

#: Controlword bits that command torque with motion (enable operation = bits 0-3 set).
ENABLE_BITS = CW_ENABLE_OPERATION


@pytest.fixture
def hil():
    h = Hil("smartpal5", 0.002)
    yield h
    h.close()


def test_configure_sets_every_drive_up(hil: Hil):
    hil.configure()
    assert hil.backend.state is HardwareState.INACTIVE
    for name, cfg in hil.profile.drives.items():
        drive = hil.emulator.drives[name]
        od = drive.node.sdo
        assert od[0x6060].raw == 8
        assert (od[0x60C2][1].raw, od[0x60C2][2].raw) == (2, -3)
        assert od[0x1017].raw == hil.profile.heartbeat.drive_producer_ms
        assert od[0x1016][1].raw == (127 << 16) | hil.profile.heartbeat.drive_consumer_ms
        assert od[0x6007].raw == 3
        assert od[0x1801][1].raw & 0x80000000 == (0 if cfg.velocity_feedback else 0x80000000)
        assert drive.nmt_state == 0x05
    for _ in range(3):
        hil.cycle()
    assert not hil.backend.faults()
    assert set(hil.backend.drive_states().values()) == {hil.backend.drive_states()["r_arm_j1"]}


def test_activate_holds_position_and_tracks(hil: Hil):
    hil.configure()
    hil.cycle()
    start = hil.cycle().position.copy()
    hil.backend.activate()
    assert hil.backend.state is HardwareState.ACTIVE
    assert all(hil.drive_state(n) == "operation enabled" for n in hil.profile.drives)
    # Nothing jumps at enable (target := actual).
    np.testing.assert_allclose(hil.cycle().position, start, atol=1e-4)
    names = hil.backend.joint_names
    j1, x = names.index("r_arm_j1"), names.index("vehicle_x")
    target = start.copy()
    for k in range(250):
        target[j1] = start[j1] + 0.2 * k / 250
        target[x] = 0.1 * k / 250
        hil.cycle(target)
    for _ in range(100):
        state = hil.cycle(target)
    assert abs(state.position[j1] - target[j1]) < 2e-3
    assert abs(state.position[x] - target[x]) < 2e-3  # odometry of the three omni wheels
    assert not hil.backend.faults()


def test_deactivate_quick_stops_then_disables(hil: Hil):
    hil.configure()
    hil.cycle()
    hil.backend.activate()
    hil.sniffer.frames()
    hil.backend.deactivate()
    assert hil.backend.state is HardwareState.INACTIVE
    hil.cycle()
    rpdo = [m for _, m in hil.sniffer.frames() if m.arbitration_id & 0x780 == pdo.RPDO1]
    assert rpdo and all(m.data[0] == 0x02 for m in rpdo)  # quick stop
    for _ in range(5):
        hil.cycle()
    assert all(hil.drive_state(n) == "switch on disabled" for n in hil.profile.drives)
    assert not hil.backend.faults()
    hil.backend.activate()  # and again
    assert hil.backend.state is HardwareState.ACTIVE


def test_the_heartbeat_thread_sleeps_while_active_and_wakes_outside(hil: Hil):
    """Outside ACTIVE the heartbeat thread keeps the drives' consumers fed; in ACTIVE it
    blocks on the idle event (no wake-up taking the loop's GIL), until the backend leaves
    ACTIVE by deactivate() or a fault."""
    backend = hil.backend
    hil.configure()
    thread = backend._keepalive
    assert thread is not None and thread.is_alive() and backend._idle.is_set()
    hil.cycle()
    backend.activate()
    assert not backend._idle.is_set()
    backend.deactivate()
    assert backend._idle.is_set()
    backend.activate()
    assert not backend._idle.is_set()
    hil.emulator.inject("emcy", "r_arm_j1")
    for _ in range(3):
        hil.cycle()
    assert backend.state is HardwareState.FAULT and backend._idle.is_set()
    backend.shutdown()
    assert not thread.is_alive()


def test_refused_enable_is_0x407_naming_the_drive(hil: Hil):
    hil.configure()
    hil.cycle()
    hil.emulator.inject("refuse_enable", "l_arm_j3")
    with pytest.raises(DriveError) as err:
        hil.backend.activate()
    assert [(f.code, f.source) for f in err.value.faults] == [(0x407, "l_arm_j3")]
    assert "node 13 on bus arm_l_shoulder" in err.value.faults[0].description
    assert hil.backend.state is HardwareState.FAULT
    hil.emulator.clear()
    assert hil.backend.reset_faults()
    hil.backend.activate()
    assert hil.backend.state is HardwareState.ACTIVE


def test_reset_fails_while_the_cause_persists(hil: Hil):
    hil.configure()
    hil.cycle()
    hil.emulator.inject("silent", "wheel_2")
    for _ in range(4):
        hil.cycle()
    assert hil.backend.state is HardwareState.FAULT
    assert not hil.backend.reset_faults()
    assert hil.backend.state is HardwareState.FAULT
    hil.emulator.clear()
    assert hil.backend.reset_faults()


def test_second_read_without_write_is_the_same_state(hil: Hil):
    hil.configure()
    hil.cycle()
    a = hil.backend.read()
    b = hil.backend.read()
    np.testing.assert_array_equal(a.position, b.position)
    assert a.stamp == b.stamp


def test_a_pre_operational_heartbeat_is_stale_before_the_first_tpdo(hil: Hil):
    """A drive's heartbeat sent during its set-up may arrive after it (a thread race with
    the NMT start): not a fault. Once the drive answered a SYNC it is one (0x401)."""
    heartbeat = can.Message(arbitration_id=pdo.HEARTBEAT + 33, data=[0x7F], is_extended_id=False)
    send_cycle = hil.backend._send_cycle

    def late_heartbeat_then_send_cycle(position: np.ndarray | None) -> None:
        hil.sniffer.buses["body"].send(heartbeat)  # wheel_3, the last drive set up
        hil.backend._send_cycle = send_cycle  # type: ignore[method-assign]
        send_cycle(position)

    hil.backend._send_cycle = late_heartbeat_then_send_cycle  # type: ignore[method-assign]
    hil.configure()  # its first SYNC comes after the stale heartbeat
    hil.cycle()
    assert not hil.backend.faults()
    hil.cycle()
    assert not hil.backend.faults()
    hil.sniffer.buses["body"].send(heartbeat)
    hil.cycle()
    assert [(f.code, f.source) for f in hil.backend.faults()] == [
        (AlarmCode.HEARTBEAT_LOST, "wheel_3")
    ]


def test_non_finite_set_point_faults(hil: Hil):
    hil.configure()
    hil.cycle()
    hil.backend.activate()
    command = hil.backend.read().position.copy()
    command[3] = np.nan
    hil.cycle(command)
    assert hil.backend.state is HardwareState.FAULT
    assert hil.backend.faults()[0].code == AlarmCode.HARDWARE_INVALID_COMMAND


# ------------------------------------------------------------------------------- lockstep
class Partner:
    """A lockstep partner on the harness: the emulator handles frames only when asked."""

    def __init__(self, hil: Hil):
        self.hil = hil
        self.answer = True
        self.timeouts: list[float] = []

    def wait_answered(self, sent: Mapping[str, int], timeout: float) -> bool:
        self.timeouts.append(timeout)
        if not self.answer:
            return False
        self.hil.emulator.poll()
        return self.hil.emulator.wait_answered(sent, 0.0)


def bare_cycle(hil: Hil, command: np.ndarray | None = None) -> JointState:
    """read + write, time passes, but the emulator runs only inside the lockstep wait."""
    state = hil.backend.read()
    hil.backend.write(JointCommand(state.position if command is None else command))
    hil.clock.t += hil.dt
    return state


def test_lockstep_read_gets_the_feedback_of_the_cycle_it_sent(hil: Hil):
    hil.configure()
    hil.cycle()
    hil.backend.activate()
    partner = Partner(hil)
    hil.backend.lockstep = partner
    target = hil.backend.read().position.copy()
    j = hil.backend.joint_names.index("r_arm_j2")
    for _ in range(100):
        target[j] += 0.002
        bare_cycle(hil, target)
        hil.backend.read()  # the next cycle's read: every SYNC sent is answered
        assert hil.emulator.sync_counts() == hil.backend.syncs_sent
    state = bare_cycle(hil, target)
    assert hil.backend.state is HardwareState.ACTIVE and not hil.backend.faults()
    assert state.position[j] == pytest.approx(target[j], abs=0.01)
    assert set(partner.timeouts) == {hil.backend.lockstep_timeout}
    hil.backend.lockstep = None  # without the partner nothing answers: TPDO timeout
    for _ in range(4):
        bare_cycle(hil, target)
    assert {f.code for f in hil.backend.faults()} == {AlarmCode.TPDO_TIMEOUT}


def test_lockstep_sends_no_round_before_the_last_is_answered(hil: Hil):
    """activate() and shutdown() right after a write() (servoOn between two cycles): each
    SYNC goes out only once the emulator has handled every earlier one on its bus."""
    hil.configure()
    hil.cycle()
    hil.backend.lockstep = Partner(hil)
    backend, emulator = hil.backend, hil.emulator
    checked: list[bool] = []

    def checked_send(port: Port, send: Callable[..., None]) -> Callable[..., None]:
        def check_then_send(msg: can.Message, timeout: float | None = None) -> None:
            if msg.arbitration_id == pdo.SYNC:
                answered = emulator.sync_counts()[port.name]
                checked.append(answered == backend.syncs_sent[port.name])
            send(msg, timeout)

        return check_then_send

    for port in backend.io.ports:
        port.bus.send = checked_send(port, port.bus.send)  # type: ignore[method-assign]
    bare_cycle(hil)
    backend.activate()
    bare_cycle(hil)
    backend.shutdown()
    assert len(checked) > 3 * len(hil.profile.buses) and all(checked)


def test_a_stalled_lockstep_partner_costs_cycles_not_seconds(hil: Hil):
    hil.configure()
    hil.cycle()
    partner = Partner(hil)
    partner.answer = False
    hil.backend.lockstep = partner
    for _ in range(4):
        bare_cycle(hil)
    dt, full = hil.dt, hil.backend.lockstep_timeout
    assert partner.timeouts == [full, 2 * dt, 2 * dt, 2 * dt]
    assert hil.backend.lockstep_timeouts == 4
    assert {f.code for f in hil.backend.faults()} == {AlarmCode.TPDO_TIMEOUT}
    partner.answer = True  # the emulator runs again: full waits from then on
    bare_cycle(hil)
    bare_cycle(hil)
    assert partner.timeouts[-2:] == [2 * dt, full] and not hil.backend.lockstep_stalled


# ----------------------------------------------------------------- injected faults, full core
def servo_on_core(hil: Hil) -> MotionCore:
    core = MotionCore(hil.robot, hil.backend, hil.dt)
    hil.configure()
    hil.cycle()
    core.servo_on()
    for _ in range(5):
        hil.core_cycle(core)
    assert core.state is CoreState.READY
    return core


def arm_motion(core: MotionCore, delta: float) -> JointMotion:
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    box = core.ik.box
    return JointMotion(
        core.kin, core.dt, joints, core.q_cmd[joints] + delta, box.v_max[joints], box.a_max[joints]
    )


#: (injection, drive, params, expected alarm code, cycles allowed after the fault is visible)
FAULTS = [
    ("emcy", "r_arm_j4", {"code": 0x2310}, AlarmCode.EMCY, 2),
    ("emcy_no_fault", "lumbar_upper", {"code": 0x4310, "fault": False}, AlarmCode.EMCY, 2),
    ("following_error", "l_arm_j2", {}, AlarmCode.FOLLOWING_ERROR, 2),
    ("silent", "wheel_1", {}, AlarmCode.TPDO_TIMEOUT, 2 + 3),
    ("delayed_tpdo", "r_gripper", {"cycles": 5}, AlarmCode.TPDO_TIMEOUT, 2 + 3),
    ("bus_off", "r_arm_j6", {}, AlarmCode.BUS_OFF, 2),
]


@pytest.mark.parametrize(("kind", "drive", "params", "code", "within"), FAULTS)
def test_injected_fault_alarms_quick_stops_and_recovers(
    hil: Hil, kind: str, drive: str, params: dict, code: int, within: int
):
    core = servo_on_core(hil)
    core.start(arm_motion(core, 0.2))
    for _ in range(20):
        hil.core_cycle(core)
    assert core.state is CoreState.BUSY
    hil.emulator.inject(kind.removesuffix("_no_fault"), drive, **params)
    cycles = 0
    while core.state is not CoreState.ALARM and cycles < 20:
        hil.core_cycle(core)
        cycles += 1
    assert core.state is CoreState.ALARM
    assert cycles <= within, f"alarm after {cycles} cycles"
    alarm = core.alarms[0]
    assert alarm.code == code, core.alarms
    bus = hil.profile.drives[drive].bus
    node = hil.profile.drives[drive].node_id
    assert alarm.module == (bus if kind == "bus_off" else drive)
    assert f"bus {bus}" in alarm.description
    if kind != "bus_off":
        assert f"node {node}" in alarm.description
    # Every drive quick-stopped; nothing further commanded.
    hil.sniffer.frames()
    for _ in range(5):
        hil.core_cycle(core)
    frames = hil.sniffer.frames()
    rpdo = [m for _, m in frames if m.arbitration_id & 0x780 == pdo.RPDO1]
    assert rpdo and all(m.data[0] & ENABLE_BITS != ENABLE_BITS for m in rpdo)
    if kind in ("silent", "bus_off"):
        # Unreachable drives stop on their own once the master's heartbeat is missing.
        for _ in range(int(0.35 / hil.dt)):
            hil.core_cycle(core)
    assert all(hil.drive_state(n) != "operation enabled" for n in hil.profile.drives)
    assert core.motion is None
    # Recovery once the cause is gone.
    hil.emulator.clear()
    core.clear_alarms()
    core.servo_on()
    assert core.state is CoreState.READY, core.alarms
    assert all(hil.drive_state(n) == "operation enabled" for n in hil.profile.drives)
    core.start(arm_motion(core, -0.1))
    for _ in range(2000):
        hil.core_cycle(core)
        if core.motion is None:
            break
    assert core.state is CoreState.READY and not core.alarms


def test_heartbeat_loss_alarms_after_the_consumer_time(hil: Hil):
    core = servo_on_core(hil)
    hil.emulator.inject("heartbeat_loss", "lumbar_lower")
    timeout = hil.profile.heartbeat.master_consumer_ms / 1000
    cycles = 0
    while core.state is not CoreState.ALARM and cycles < 1000:
        hil.core_cycle(core)
        cycles += 1
    assert core.alarms[0].code == AlarmCode.HEARTBEAT_LOST
    assert core.alarms[0].module == "lumbar_lower"
    # The last heartbeat came at most one producer period before the injection.
    assert cycles * hil.dt <= timeout + 2 * hil.dt
    hil.emulator.clear()
    for _ in range(60):  # a heartbeat (100 ms) comes in again
        hil.core_cycle(core)
    core.clear_alarms()
    core.servo_on()
    assert core.state is CoreState.READY


# ------------------------------------------------------------------------- full stack in HIL
@pytest.mark.parametrize("rate", [250, 500])
def test_smartpal_full_stack_on_five_buses(rate: int):
    hil = Hil("smartpal5", 1.0 / rate)
    try:
        core = servo_on_core(hil)
        assert len(hil.profile.buses) == 5
        start = core.q.copy()
        motion = arm_motion(core, 0.15)
        goal = motion.target.copy() if hasattr(motion, "target") else None
        core.start(motion)
        for _ in range(5 * rate):
            hil.core_cycle(core)
            if core.motion is None:
                break
        assert core.state is CoreState.READY, core.alarms
        joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
        np.testing.assert_allclose(core.q[joints], start[joints] + 0.15, atol=5e-3)
        del goal
        vehicle = core.kin.unit_indices(UnitType.VEHICLE)
        vmotion = JointMotion(
            core.kin,
            core.dt,
            vehicle,
            core.q_cmd[vehicle] + np.array([0.1, -0.05, 0.2]),
            core.ik.box.v_max[vehicle],
            core.ik.box.a_max[vehicle],
        )
        core.start(vmotion)
        for _ in range(5 * rate):
            hil.core_cycle(core)
            if core.motion is None:
                break
        assert core.state is CoreState.READY, core.alarms
        np.testing.assert_allclose(
            core.q[vehicle], start[vehicle] + np.array([0.1, -0.05, 0.2]), atol=5e-3
        )
        sent = hil.backend.frames_sent
        assert all(sent[b] > 0 for b in hil.profile.buses)
    finally:
        hil.close()


# ------------------------------------------------------------- stub drives (no emulator)
class StubRig:
    """The backend on stub buses (precomputed answers), a fake clock, no emulator."""

    def __init__(self, bus_options: dict | None = None):
        r = robot("smartpal5")
        self.profile = load_drive_profile(drives_path(r), r)
        self.clock = FakeClock()
        self.opened: dict[str, dict] = {}
        self.buses = {}
        for name in self.profile.buses:
            drives = list(self.profile.drives_on(name).values())
            self.buses[name] = StubDrivesBus(
                name,
                [d.node_id for d in drives],
                [d.velocity_feedback for d in drives],
                heartbeat_every=10,
            )

        def factory(name: str, kwargs: dict) -> can.BusABC:
            self.opened[name] = kwargs
            return self.buses[name]

        try:
            self.backend = CanBackend(
                r, 0.002, self.profile, bus_options=bus_options, bus_factory=factory,
                clock=self.clock, sleep=self.sleep,
            )  # fmt: skip
        except BaseException:
            for bus in self.buses.values():
                bus.shutdown()
            raise

    def sleep(self, seconds: float) -> None:
        self.clock.t += seconds

    def cycle(self) -> None:
        state = self.backend.read()
        self.backend.write(JointCommand(state.position))
        self.sleep(0.002)


def cycles_to_fault(rig: StubRig) -> int:
    for k in range(1, 50):
        rig.cycle()
        if rig.backend.state is HardwareState.FAULT:
            return k
    raise AssertionError("no fault")


def test_per_bus_tpdo_timeout_in_time_from_bus_options():
    """A bus bridged over a network (remote interface): its TPDO timeout in cycles and ms
    comes with its python-can settings, which python-can never sees."""
    options = {"body": {"interface": "remote", "channel": "ws://127.0.0.1:1/",
                        "tpdo_timeout_cycles": 4, "tpdo_timeout_ms": 20}}  # fmt: skip
    rig = StubRig(options)
    assert rig.backend.bus_kwargs("body") == {"interface": "remote", "channel": "ws://127.0.0.1:1/"}
    rig.backend.configure()
    assert "tpdo_timeout_ms" not in rig.opened["body"]
    rig.cycle()
    rig.backend.activate()
    rig.buses["body"].muted.add(rig.profile.drives["wheel_2"].node_id)
    # The first cycle still reads the TPDOs of the SYNC before the mute; then 20 ms at 2 ms.
    assert cycles_to_fault(rig) == 1 + 10
    assert [(f.code, f.source) for f in rig.backend.faults()] == [
        (AlarmCode.TPDO_TIMEOUT, "wheel_2")
    ]
    assert "ms)" in rig.backend.faults()[0].description
    rig.backend.shutdown()


def test_other_buses_keep_the_profile_timeout_in_cycles():
    rig = StubRig({"body": {"tpdo_timeout_ms": 20}})
    rig.backend.configure()
    rig.cycle()
    rig.backend.activate()
    rig.buses["arm_r_wrist"].muted.add(rig.profile.drives["r_arm_j5"].node_id)
    assert cycles_to_fault(rig) == 1 + rig.profile.tpdo_timeout_cycles
    rig.backend.shutdown()


def test_bad_supervision_options_are_refused():
    with pytest.raises(ValueError, match="tpdo_timeout_cycles"):
        StubRig({"body": {"tpdo_timeout_cycles": 0}})
    with pytest.raises(ValueError, match="tpdo_timeout_ms"):
        StubRig({"body": {"tpdo_timeout_ms": "soon"}})


def test_master_alone_counts_its_frames_and_heartbeat_is_public():
    rig = StubRig()
    rig.backend.configure()
    rig.cycle()
    rig.backend.activate()
    sent = rig.backend.frames_sent
    for _ in range(10):
        rig.cycle()
    assert rig.backend.state is HardwareState.ACTIVE and not rig.backend.faults()
    after = rig.backend.frames_sent
    for name in rig.profile.buses:
        # Per cycle: one RPDO1 per drive and one SYNC (plus heartbeats when due).
        assert after[name] - sent[name] >= 10 * (len(rig.profile.drives_on(name)) + 1)
    before = sum(rig.backend.frames_sent.values())
    rig.sleep(1.0)
    rig.backend.send_heartbeat()
    assert sum(rig.backend.frames_sent.values()) == before + len(rig.profile.buses)
    counted = rig.backend.frames_sent
    rig.backend.shutdown()
    # Counters survive the shutdown (which sends one more quick-stop round).
    assert all(rig.backend.frames_sent[n] > counted[n] for n in counted)


def test_configure_logs_one_line_per_drive_and_no_canopen_chatter(
    hil: Hil, caplog: pytest.LogCaptureFixture
):
    """canopen logged ~1100 INFO lines at SmartPal V's set-up (hil); now one line per drive."""
    canopen_log = logging.getLogger("canopen")
    saved = canopen_log.level
    canopen_log.setLevel(logging.NOTSET)
    try:
        with caplog.at_level(logging.INFO):
            hil.configure()
    finally:
        canopen_log.setLevel(saved)
    assert not [r for r in caplog.records if r.name.startswith("canopen")]
    setup_lines = [r for r in caplog.records if r.getMessage().startswith("set up ")]
    assert len(setup_lines) == len(hil.profile.drives)

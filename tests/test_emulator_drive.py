"""The emulated drive as a CANopen slave: SDO, PDO mapping, NMT, heartbeat, EMCY, following
error, CSP set-points. SDO and PDO set-up go through canopen's RemoteNode (threaded emulator);
the rest is raw frames in lockstep (synchronous emulator, fake clock)."""

from __future__ import annotations

import struct
import time

import canopen
import pytest
from canopen.sdo import SdoAbortedError

from controller.model.robot import load_robot
from hal.can.drive_profile import DEFAULT_EDS
from hal.emulator.drive import EmulatedDrive
from hal.emulator.drive_state import PowerState
from hal.emulator.emulator import DriveEmulator
from tests.emulator_support import FakeClock, FrameMaster, emcy, ids, state_of, tpdo1

NODE = 1  # PA-10 J1 on bus arm_a


@pytest.fixture(scope="module")
def pa10():
    return load_robot("pa10")


@pytest.fixture
def rig(pa10):
    clock = FakeClock()
    emulator = DriveEmulator(pa10, clock=clock)
    emulator.open()
    master = FrameMaster(emulator, "arm_a", clock)
    yield emulator, master
    master.close()
    emulator.close()


@pytest.fixture
def remote(pa10):
    """A canopen RemoteNode for node 1 against the threaded emulator."""
    emulator = DriveEmulator(pa10)
    emulator.start()
    network = canopen.Network(emulator.open_master_bus("arm_a"))
    network.NOTIFIER_CYCLE = 0.05  # a quick teardown
    network.connect()
    node = canopen.RemoteNode(NODE, str(DEFAULT_EDS))
    node.sdo.RESPONSE_TIMEOUT = 2.0
    network.add_node(node)
    yield emulator, network, node
    network.disconnect()
    emulator.close()


def _enable(master: FrameMaster, node: int = NODE) -> int:
    """NMT start, then shutdown / switch on / enable; the position [counts]."""
    master.nmt(0x01, node)
    frames = master.cycle()
    position = tpdo1(frames, node)[1]
    for controlword in (0x06, 0x07, 0x0F):
        frames = master.cycle({node: (controlword, position)})
    assert state_of(frames, node) is PowerState.OPERATION_ENABLED
    return position


# ----------------------------------------------------------------------------------- SDO


def test_sdo_reads_identity_and_live_objects(remote):
    _, _, node = remote
    assert node.sdo[0x1000].raw == 0x0002_0192  # CiA 402 servo drive
    assert node.sdo[0x1018][2].raw == 0x402
    assert node.sdo[0x1008].raw == "imotion CiA 402 drive"  # segmented upload
    assert node.sdo[0x6041].raw == 0x0240  # Switch on disabled
    assert node.sdo[0x6061].raw == 8  # CSP
    assert node.sdo[0x1001].raw == 0


@pytest.mark.parametrize(
    ("index", "subindex", "value", "code"),
    [
        (0x6060, 0, 1, 0x0609_0030),  # only CSP
        (0x6041, 0, 0, 0x0601_0002),  # statusword is read-only
        (0x1003, 0, 3, 0x0609_0030),  # only 0 clears the error history
        (0x1A00, 1, 0x6065_0020, 0x0604_0041),  # following error window is not mappable
        (0x1A00, 1, 0x6041_0020, 0x0604_0041),  # wrong length for the statusword
    ],
)
def test_sdo_refuses_bad_writes_with_the_standard_abort_code(remote, index, subindex, value, code):
    _, _, node = remote
    variable = node.sdo[index] if subindex == 0 and index != 0x1003 else node.sdo[index][subindex]
    with pytest.raises(SdoAbortedError) as info:
        variable.raw = value
    assert info.value.code == code


def test_sdo_unknown_object_is_refused(remote):
    _, _, node = remote
    with pytest.raises(SdoAbortedError) as info:
        node.sdo.upload(0x2345, 0)
    assert info.value.code == 0x0602_0000


def test_pdo_mapping_with_canopens_pdo_api(remote):
    """The master's set-up path: read, remap TPDO1, enable TPDO2, save; then operate."""
    _, network, node = remote
    node.tpdo.read()
    node.rpdo.read()
    assert [v.index for v in node.rpdo[1].map] == [0x6040, 0x607A]
    assert [v.index for v in node.tpdo[1].map] == [0x6041, 0x6064]
    tpdo1_map = node.tpdo[1]
    tpdo1_map.clear()
    tpdo1_map.add_variable(0x6041)
    tpdo1_map.add_variable(0x6064)
    tpdo1_map.add_variable(0x6061)  # 7 bytes now
    tpdo1_map.trans_type = 1
    tpdo1_map.enabled = True
    tpdo1_map.save()
    node.tpdo[2].trans_type = 1
    node.tpdo[2].enabled = True
    node.tpdo[2].save()
    node.nmt.state = "OPERATIONAL"
    for _ in range(250):  # SYNC until both TPDOs came (bounded; no timing asserted)
        if node.tpdo[1].timestamp is not None and node.tpdo[2].timestamp is not None:
            break
        network.sync.transmit()
        time.sleep(0.02)
    assert node.tpdo[1].timestamp is not None
    assert node.tpdo[2].timestamp is not None
    assert len(node.tpdo[1].data) == 7
    assert node.tpdo[1]["Modes of operation display"].raw == 8
    assert node.tpdo[2]["Velocity actual value"].raw == 0


def test_sdo_write_of_controlword_acts_at_once(remote):
    emulator, _, node = remote
    for controlword in (0x06, 0x07, 0x0F):
        node.sdo[0x6040].raw = controlword
    assert node.sdo[0x6041].raw & 0x6F == 0x27  # Operation enabled
    drive = emulator.drive_on("arm_a", NODE)
    assert drive.target == drive.actual  # no fresh target: it holds where it is


# ----------------------------------------------------------------------------------- NMT


def test_pdos_only_in_operational_heartbeat_state_byte_follows_nmt(rig):
    _, master = rig
    assert master.sdo_write(NODE, 0x1017, 0, 10, 2)[0] == 0x60
    frames = master.cycle(dt=0.02)
    assert tpdo1(frames, NODE) is None  # PRE-OPERATIONAL: no PDO
    assert (0x701, b"\x7f") in [(m.arbitration_id, bytes(m.data)) for m in frames]
    master.nmt(0x01, NODE)
    frames = master.cycle(dt=0.02)
    assert tpdo1(frames, NODE) is not None
    assert (0x701, b"\x05") in [(m.arbitration_id, bytes(m.data)) for m in frames]
    master.nmt(0x02, NODE)  # STOPPED: heartbeat only, no SDO, no PDO
    frames = master.cycle(dt=0.02)
    assert tpdo1(frames, NODE) is None
    assert (0x701, b"\x04") in [(m.arbitration_id, bytes(m.data)) for m in frames]
    assert master.sdo_read(NODE, 0x1000) == b""
    master.nmt(0x80, NODE)  # PRE-OPERATIONAL serves SDO again
    assert master.sdo_read(NODE, 0x1000)[4:] == (0x0002_0192).to_bytes(4, "little")


def test_nmt_for_another_node_is_ignored(rig):
    _, master = rig
    master.nmt(0x01, 2)
    frames = master.cycle()
    assert tpdo1(frames, NODE) is None
    assert tpdo1(frames, 2) is not None


def test_reset_communication_restores_communication_objects_only(rig):
    _, master = rig
    master.sdo_write(NODE, 0x1017, 0, 50, 2)
    master.sdo_write(NODE, 0x6065, 0, 1234, 4)
    frames = master.nmt(0x82, NODE)
    assert [(m.arbitration_id, bytes(m.data)) for m in frames] == [(0x701, b"\x00")]  # boot-up
    assert master.sdo_read(NODE, 0x1017)[4:6] == b"\x00\x00"
    assert int.from_bytes(master.sdo_read(NODE, 0x6065)[4:], "little") == 1234


def test_reset_node_restores_the_whole_dictionary(rig):
    _, master = rig
    master.sdo_write(NODE, 0x6065, 0, 1234, 4)
    frames = master.nmt(0x81, NODE)
    assert ids(frames) == [0x701]
    assert int.from_bytes(master.sdo_read(NODE, 0x6065)[4:], "little") == 0xFFFF_FFFF


def test_sync_cob_id_can_be_moved(rig):
    _, master = rig
    master.nmt(0x01, NODE)
    master.sdo_write(NODE, 0x1005, 0, 0x081, 4)
    frames = master.cycle()  # SYNC on 0x080: the other drives answer, node 1 does not
    assert tpdo1(frames, NODE) is None
    master.send(0x081)
    assert tpdo1(master.exchange(), NODE) is not None


def test_transmission_type_n_sends_on_every_nth_sync(rig):
    _, master = rig
    master.sdo_write(NODE, 0x1800, 2, 3, 1)
    master.nmt(0x01, NODE)
    sent = [tpdo1(master.cycle(), NODE) is not None for _ in range(9)]
    assert sent.count(True) == 3


# ----------------------------------------------------------------------------- heartbeat


def test_heartbeat_producer_period_in_emulator_time(rig):
    _, master = rig
    master.sdo_write(NODE, 0x1017, 0, 100, 2)
    beats = 0
    for _ in range(100):  # 1 s in 10 ms steps
        master.now += 0.01
        beats += ids(master.exchange()).count(0x701)
    assert beats in (10, 11)


def _monitor_master(master: FrameMaster, option: int) -> None:
    master.sdo_write(NODE, 0x1016, 1, (127 << 16) | 300, 4)
    master.sdo_write(NODE, 0x6007, 0, option, 2)


def test_heartbeat_loss_with_option_1_faults_with_emcy_8130(rig):
    _, master = rig
    _monitor_master(master, 1)
    position = _enable(master)
    master.send(0x77F, [0x05])  # the master's heartbeat starts the monitoring
    frames = master.cycle({NODE: (0x0F, position)})
    for _ in range(14):  # 280 ms without heartbeat: still fine
        frames = master.cycle({NODE: (0x0F, position)}, dt=0.02)
        assert emcy(frames, NODE) == []
    frames = master.cycle({NODE: (0x0F, position)}, dt=0.03)
    assert emcy(frames, NODE) == [(0x8130, 0x11)]  # generic + communication
    assert state_of(frames, NODE) is PowerState.FAULT_REACTION_ACTIVE
    frames = master.cycle({NODE: (0x0F, position)})
    assert state_of(frames, NODE) is PowerState.FAULT
    answer = master.sdo_read(NODE, 0x603F)
    assert int.from_bytes(answer[4:6], "little") == 0x8130


def test_heartbeat_loss_with_option_3_quick_stops_and_warns(rig):
    _, master = rig
    _monitor_master(master, 3)
    position = _enable(master)
    master.send(0x77F, [0x05])
    master.cycle({NODE: (0x0F, position)})
    frames = master.cycle({NODE: (0x0F, position)}, dt=0.4)
    assert emcy(frames, NODE) == [(0x8130, 0x11)]
    assert state_of(frames, NODE) is PowerState.QUICK_STOP_ACTIVE
    assert tpdo1(frames, NODE)[0] & 0x0080  # warning
    frames = master.cycle({NODE: (0x0F, position)})
    assert state_of(frames, NODE) is PowerState.SWITCH_ON_DISABLED
    master.send(0x77F, [0x05])  # the master is back: warning and error cleared
    frames = master.cycle({NODE: (0x0F, position)})
    assert not tpdo1(frames, NODE)[0] & 0x0080
    assert master.sdo_read(NODE, 0x1001)[4] == 0


def test_no_monitoring_before_the_first_master_heartbeat(rig):
    _, master = rig
    _monitor_master(master, 1)
    position = _enable(master)
    frames = master.cycle({NODE: (0x0F, position)}, dt=2.0)
    assert emcy(frames, NODE) == []
    assert state_of(frames, NODE) is PowerState.OPERATION_ENABLED


# ------------------------------------------------------------------- EMCY and error objects


def test_fault_records_error_code_register_and_history(rig):
    emulator, master = rig
    position = _enable(master)
    emulator.inject("emcy", "J1", code=0x2310, info=b"\x01\x02")
    frames = master.cycle({NODE: (0x0F, position)})
    [msg] = [m for m in frames if m.arbitration_id == 0x081]
    assert bytes(msg.data) == bytes.fromhex("1023810102000000")
    assert int.from_bytes(master.sdo_read(NODE, 0x603F)[4:6], "little") == 0x2310
    assert master.sdo_read(NODE, 0x1001)[4] == 0x81
    assert master.sdo_read(NODE, 0x1003, 0)[4] == 1
    assert int.from_bytes(master.sdo_read(NODE, 0x1003, 1)[4:], "little") == 0x2310
    assert master.sdo_write(NODE, 0x1003, 0, 0, 1)[0] == 0x60  # clears the history
    assert master.sdo_read(NODE, 0x1003, 0)[4] == 0


# -------------------------------------------------------------------- CSP and supervision


def test_csp_target_is_followed_and_following_error_trips_after_its_time(rig):
    _, master = rig
    master.sdo_write(NODE, 0x6065, 0, 20000, 4)  # window [counts]
    master.sdo_write(NODE, 0x6066, 0, 10, 2)  # 10 ms
    position = _enable(master)
    target = position
    for _ in range(50):  # a slow ramp is tracked well inside the window
        target += 500
        frames = master.cycle({NODE: (0x0F, target)})
        assert abs(tpdo1(frames, NODE)[1] - target) < 20000
    assert state_of(frames, NODE) is PowerState.OPERATION_ENABLED
    target += 10_000_000  # a jump no servo follows in one cycle
    states = []
    for _ in range(8):
        frames = master.cycle({NODE: (0x0F, target)})
        states.append(state_of(frames, NODE))
        if emcy(frames, NODE):
            break
    assert emcy(frames, NODE) == [(0x8611, 0x21)]
    assert states[-1] is PowerState.FAULT_REACTION_ACTIVE
    assert tpdo1(frames, NODE)[0] & 0x2000  # statusword bit 13
    assert len(states) >= 5  # outside the window for 10 ms = 5 cycles of 2 ms first


def test_following_error_window_off_never_trips(rig):
    _, master = rig
    position = _enable(master)
    for _ in range(20):
        frames = master.cycle({NODE: (0x0F, position + 10_000_000)})
    assert state_of(frames, NODE) is PowerState.OPERATION_ENABLED


def test_quick_stop_holds_the_position_whatever_the_target(rig):
    _, master = rig
    master.sdo_write(NODE, 0x605A, 0, 6, 2)  # stay in quick stop
    position = _enable(master)
    frames = master.cycle({NODE: (0x02, position)})
    held = tpdo1(frames, NODE)[1]
    for _ in range(20):
        frames = master.cycle({NODE: (0x02, position + 500_000)})
    assert state_of(frames, NODE) is PowerState.QUICK_STOP_ACTIVE
    assert abs(tpdo1(frames, NODE)[1] - held) < 2000


def test_short_rpdo_is_ignored(rig):
    _, master = rig
    position = _enable(master)
    master.send(0x201, struct.pack("<H", 0x00))  # 2 bytes, the mapping needs 6
    frames = master.cycle()
    assert state_of(frames, NODE) is PowerState.OPERATION_ENABLED
    assert abs(tpdo1(frames, NODE)[1] - position) < 2000


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # canopen's own logger.warn
def test_drive_rejects_bad_node_id_and_eds(tmp_path):
    with pytest.raises(ValueError, match="node id 0"):
        EmulatedDrive("x", 0, DEFAULT_EDS, lambda i, d: None)
    broken = tmp_path / "broken.eds"
    broken.write_text("[1000]\nParameterName=x\n")
    with pytest.raises(ValueError, match=r"broken\.eds"):
        EmulatedDrive("x", 1, broken, lambda i, d: None)


def test_each_drive_gets_its_own_object_dictionary_parsed_once(tmp_path):
    """``object_dictionary``: what canopen parses from the EDS for that node id, a separate
    object per call (a drive writes to its own); a changed file is parsed anew."""
    from hal.emulator.drive import _parsed, object_dictionary

    eds = tmp_path / "drive.eds"
    eds.write_bytes(DEFAULT_EDS.read_bytes())
    parses = _parsed.cache_info().misses
    a, b = object_dictionary(eds, 3), object_dictionary(eds, 3)
    assert _parsed.cache_info().misses == parses + 1  # one parse for both
    reference = canopen.import_od(str(eds), 3)
    assert a is not b and a[0x6040] is not b[0x6040]
    assert sorted(a.keys()) == sorted(reference.keys())
    assert a[0x1018][1].default == reference[0x1018][1].default
    a[0x6064].default = 12345
    assert b[0x6064].default != 12345
    object_dictionary(eds, 4)  # another node id: its own parse
    assert _parsed.cache_info().misses == parses + 2
    text = eds.read_text().replace("ProductName=", "ProductName=Changed ", 1)
    eds.write_text(text)
    object_dictionary(eds, 3)
    assert _parsed.cache_info().misses == parses + 3

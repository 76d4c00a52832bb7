"""hal.can.kernels: the compiled per-cycle work of the CAN master against its NumPy form."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from controller.model import jit
from hal.can import kernels
from hal.can.drive_profile import drives_path, load_drive_profile
from hal.can.joints import JointMap
from hal.can.scaling import I32_MAX, I32_MIN
from hal.can.supervision import Supervisor
from hal.can.unix_wire import encode
from tests.support import kernel_signatures, kernels_gained, robot

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba not installed or IMOTION_JIT=0")


def joint_maps(robot_id: str) -> tuple[JointMap, JointMap]:
    r = robot(robot_id)
    profile = load_drive_profile(drives_path(r), r)
    compiled, plain = JointMap(r, profile, 0.002), JointMap(r, profile, 0.002)
    plain.compiled = False
    assert compiled.compiled
    return compiled, plain


@pytest.mark.parametrize("robot_id", ["smartpal5", "pa10", "rh", "seednoid"])
def test_feedback_and_command_are_the_numpy_ones(robot_id: str):
    """Drives seen one by one, stale ones, wheels turning over the 32-bit wrap, odometry
    started once every wheel is seen: the same state and counts as NumPy."""
    compiled, plain = joint_maps(robot_id)
    n, joints = len(compiled.drive_names), len(compiled.joint_names)
    rng = np.random.default_rng(7)
    raw = rng.integers(-(2**31), 2**31, n, dtype=np.int64)
    raw[compiled.wheel_idx] = I32_MAX - 1000  # wheels about to wrap
    seen = np.zeros(n, dtype=bool)
    for k in range(60):
        seen[: k * n // 10 + 1] = True
        fresh = seen & (rng.random(n) > 0.2)
        raw = np.where(fresh, raw + rng.integers(-3000, 3000, n), raw)
        raw = (raw - I32_MIN) % 2**32 + I32_MIN
        raw_velocity = rng.integers(-(10**6), 10**6, n, dtype=np.int64)
        for m in (compiled, plain):
            m.update(raw, raw_velocity, fresh.copy(), seen.copy())
        for name in ("pos", "vel", "position", "velocity"):
            np.testing.assert_allclose(getattr(compiled, name), getattr(plain, name),
                                       rtol=1e-12, atol=1e-12, err_msg=name)  # fmt: skip
        q = compiled.position + rng.normal(0.0, 0.01, joints)
        counts = [np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)]
        for m, out in zip((compiled, plain), counts, strict=True):
            if k % 7 == 3:
                m.hold()
            m.command(q, out)
        np.testing.assert_allclose(compiled.target, plain.target, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(counts[0], counts[1])
    if compiled.vehicle is not None and plain.vehicle is not None:
        assert compiled._vehicle_started and plain._vehicle_started
        np.testing.assert_allclose(compiled.vehicle.pose, plain.vehicle.pose, atol=1e-12)


def test_supervise_gives_the_numpy_faults():
    """TPDO timeouts (cycles and time), heartbeats, following error, drives not enabled:
    the same faults, texts and counters."""
    names, nodes, buses = ["a", "b", "c", "d"], [1, 2, 3, 4], ["x", "x", "y", "y"]

    def make(compiled: bool) -> Supervisor:
        s = Supervisor(names, nodes, buses, 0.002, np.full(4, 0.01), 0.006, 0.3,
                       [3, 3, 2, 5], [0.0, 0.01, 0.0, 0.0])  # fmt: skip
        s.compiled = compiled
        s.reset(0.0)
        return s

    fast, numpy = make(True), make(False)
    assert not numpy.compiled
    rng = np.random.default_rng(1)
    from hal.can.cia402 import State

    for k in range(300):
        now = 0.002 * (k + 1)
        fresh = rng.random(4) > (0.6 if k % 50 < 10 else 0.05)
        for s in (fast, numpy):
            s.last_heartbeat[fresh & (rng.random(4) > 0.5)] = now
        if k % 100 == 0:
            for s in (fast, numpy):
                s.reset(now)
        states = [State.OPERATION_ENABLED] * 4
        if k % 40 == 20:
            states[1] = State.SWITCHED_ON
        position, setpoint = rng.normal(0.0, 0.01, 4), np.zeros(4)
        active = k % 60 > 5
        args = (now, fresh, states, [0x27] * 4, active, states[1] is State.OPERATION_ENABLED,
                False, position, setpoint)  # fmt: skip
        got, want = fast.check(*args), numpy.check(*args)
        assert [(f.code, f.source, f.description) for f in got] == [
            (f.code, f.source, f.description) for f in want
        ], k
        for name in ("missed", "last_tpdo", "tpdo_reported", "outside", "reported"):
            np.testing.assert_array_equal(getattr(fast, name), getattr(numpy, name), name)


def test_decode_record_stops_at_what_python_decodes():
    kinds, drives = np.zeros(2048, dtype=np.int64), np.zeros(2048, dtype=np.int64)
    for cob, kind, i in ((0x183, kernels.K_TPDO1, 0), (0x283, kernels.K_TPDO2, 0),
                         (0x703, kernels.K_HEARTBEAT, 0), (0x083, kernels.K_EMCY, 0)):  # fmt: skip
        kinds[cob], drives[cob] = kind, i
    import can

    def frame(cob: int, data: bytes, **flags: bool) -> bytes:
        return encode(can.Message(arbitration_id=cob, data=data, is_extended_id=False, **flags))

    record = (
        frame(0x183, (0x27).to_bytes(2, "little") + (-5).to_bytes(4, "little", signed=True))
        + frame(0x283, (-(2**31)).to_bytes(4, "little", signed=True))
        + frame(0x703, b"\x05")
        + frame(0x555, b"\x01\x02")  # nobody's: counted, skipped
        + frame(0x083, b"\x10\x23\x02")  # EMCY: the caller's
    )
    data = record
    sw, pos, vel = (np.zeros(1, dtype=np.int64) for _ in range(3))
    fresh, seen, last = np.zeros(1, dtype=bool), np.zeros(1, dtype=bool), np.zeros(1)
    counts = np.zeros(2, dtype=np.int64)
    bits = np.arange(100, 109, dtype=np.int64)
    stop = kernels.decode_record(data, 0, kinds, drives, bits, sw, pos, vel, fresh, seen, 4.0,
                                 last, counts)  # fmt: skip
    assert stop == len(record) - 19
    assert (sw[0], pos[0], vel[0], fresh[0], seen[0], last[0]) == (0x27, -5, -(2**31), 1, 1, 4.0)
    assert counts.tolist() == [4, 106 + 104 + 101 + 102]
    assert kernels.decode_record(data, stop + 19, kinds, drives, bits, sw, pos, vel, fresh,
                                 seen, 4.0, last, counts) == len(record)  # fmt: skip
    # A frame with flags, a cut record: left to the caller where they start.
    flagged = frame(0x183, b"\0" * 6, is_remote_frame=False, is_error_frame=True)
    assert kernels.decode_record(flagged, 0, kinds, drives, bits,
                                 sw, pos, vel, fresh, seen, 4.0, last, counts) == 0  # fmt: skip
    cut = record[:30]
    assert kernels.decode_record(cut, 0, kinds, drives, bits, sw, pos, vel, fresh, seen, 4.0,
                                 last, counts) == 22  # fmt: skip


def test_encode_records_is_the_wire_format():
    """Two buses' records in one call: RPDO1s of the drives seen, then each bus's SYNC."""
    import can

    def frame(cob: int, data: bytes, stamp: float = 0.0) -> bytes:
        msg = can.Message(timestamp=stamp, arbitration_id=cob, data=data, is_extended_id=False)
        return encode(msg)

    frames = ((0x203, 6), (0x204, 6), (0x080, 0), (0x201, 6), (0x080, 0))
    header = np.array([np.frombuffer(frame(cob, bytes(n), 1.0)[:8], np.uint8)
                       for cob, n in frames])  # fmt: skip
    stamp = np.array([12.5])
    out = np.zeros(5 * 22, dtype=np.uint8)
    seen = np.array([True, False, True])
    cw, target = np.array([0x0F, 0, 0x80]), np.array([7, 0, -(2**31)])
    bounds = np.zeros((2, 2), dtype=np.int64)
    kernels.encode_records(out, header, stamp.view(np.uint8), np.array([0, 3, 5]),
                           np.array([0, 1, -1, 2, -1]), seen, cw, target, bounds)  # fmt: skip
    first = frame(0x203, b"\x0f\x00\x07\x00\x00\x00", 12.5) + frame(0x080, b"", 12.5)
    second = frame(0x201, b"\x80\x00\x00\x00\x00\x80", 12.5) + frame(0x080, b"", 12.5)
    assert bounds.tolist() == [[0, len(first)], [len(first), len(first) + len(second)]]
    assert out[: bounds[1, 1]].tobytes() == first + second


def test_a_master_cycle_adds_no_signature():
    """Compiled at import for the arrays the master passes: its cycles (records on stub
    buses, every drive enabled and moving) never wait for the compiler."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    import bench_can_master

    before = kernel_signatures()
    for kernel in (kernels.feedback, kernels.command, kernels.supervise, kernels.decode_record,
                   kernels.encode_records):  # fmt: skip
        assert before[f"{kernel.__module__}.{kernel.__name__}"] > 0
    result = bench_can_master.measure_master("smartpal5", cycles=50, warmup=10)
    assert result["path"] == "records" and result["compiled"]
    assert kernels_gained(before) == {}

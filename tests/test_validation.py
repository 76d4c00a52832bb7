"""controller.gateway.grpc.validation: every numeric field of every request is bounded.

The fuzz test walks the proto descriptors of every service (so a new field is fuzzed without
a change here) and sends each floating-point field NaN, ±inf and ±1e308, and each repeated
field a wrong length, to one daemon (SmartPal V, --hal ideal, servo on, so an accepted move
would really move). Each call must answer VALUE_ERR with a short comment, nothing may move,
and the gateway must log no traceback. The request walk runs before any state check, so the
code is VALUE_ERR in every state (never STATUS_ERR or NOT_SV_ON_ERR for a bad number).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator

import numpy as np
import pytest
from google.protobuf.descriptor import FieldDescriptor

from controller.bounds import LENGTH, MAX_REPEATED, ROTATION_ENTRY
from controller.errors import ArgumentError
from controller.gateway.grpc.validation import check_request, quantity_of
from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import ReturnCode
from tests.daemon_support import TestDaemon

SERVICES = (
    ("IntegratedMotion", "spec_a"),
    ("ManipulatorCommon", "common"),
    ("ManipulatorMiddle", "middle"),
    ("DualManipulatorCommon", "dual_common"),
    ("DualManipulatorMiddle", "dual_middle"),
)
BAD = (math.nan, math.inf, -math.inf, 1e308, -1e308)
#: A wrong length for every repeated number field on SmartPal V (7-axis arms, 2-joint waist).
WRONG_LENGTHS = (9, 100_000)
IDENTITY = [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0]
_DOUBLE = (FieldDescriptor.TYPE_DOUBLE, FieldDescriptor.TYPE_FLOAT)

Path = tuple[FieldDescriptor, ...]


def methods() -> Iterator[tuple[str, str, str]]:
    """(stub attribute, method name, request message name) of every unary RPC."""
    for service, stub in SERVICES:
        for method in pb.DESCRIPTOR.services_by_name[service].methods:
            yield stub, method.name, method.input_type.name


def number_paths(desc, prefix: Path = ()) -> Iterator[Path]:  # type: ignore[no-untyped-def]
    """Every floating-point field under ``desc`` (paths of field descriptors)."""
    for fd in desc.fields:
        if fd.type == FieldDescriptor.TYPE_MESSAGE:
            yield from number_paths(fd.message_type, (*prefix, fd))
        elif fd.type in _DOUBLE:
            yield (*prefix, fd)


def repeated_paths(desc, prefix: Path = ()) -> Iterator[Path]:  # type: ignore[no-untyped-def]
    for fd in desc.fields:
        if fd.is_repeated:
            yield (*prefix, fd)
        if fd.type == FieldDescriptor.TYPE_MESSAGE:
            yield from repeated_paths(fd.message_type, (*prefix, fd))


def build(request_name: str, path: Path, values: list) -> object:  # type: ignore[type-arg]
    """A request with ``values`` at ``path`` (HgMatrices on the way get a valid identity)."""
    request = getattr(pb, request_name)()
    msg = request
    for fd in path[:-1]:
        if fd.is_repeated:
            msg = getattr(msg, fd.name).add()
        else:
            msg = getattr(msg, fd.name)
        if msg.DESCRIPTOR.name == "HgMatrix":
            msg.m.extend(IDENTITY)
    last = path[-1]
    if last.is_repeated:
        field = getattr(msg, last.name)
        del field[:]
        if last.type == FieldDescriptor.TYPE_MESSAGE:
            for _ in values:
                field.add()
        else:
            field.extend(values)
    else:
        setattr(msg, last.name, values[0])
    return request


def cases() -> Iterator[tuple[str, str, object, str]]:
    """(stub, method, request, what) for every bad number and every wrong length."""
    for stub, method, request_name in methods():
        desc = getattr(pb, request_name).DESCRIPTOR
        for path in number_paths(desc):
            where = ".".join(fd.name for fd in path)
            for bad in BAD:
                if path[-1].containing_type.name == "HgMatrix":
                    for i in range(12):
                        values = list(IDENTITY)
                        values[i] = bad
                        yield stub, method, build(request_name, path, values), f"{where}[{i}]={bad}"
                elif path[-1].is_repeated:
                    values = [0.0, bad]
                    yield stub, method, build(request_name, path, values), f"{where}[1]={bad}"
                else:
                    yield stub, method, build(request_name, path, [bad]), f"{where}={bad}"
        for path in repeated_paths(desc):
            where = ".".join(fd.name for fd in path)
            if path[-1].containing_type.name == "HgMatrix":
                lengths: tuple[int, ...] = (11, 13, 100_000)
            elif path[-1].type == FieldDescriptor.TYPE_MESSAGE:
                lengths = (MAX_REPEATED + 1,)
            elif path[-1].type in _DOUBLE:
                lengths = WRONG_LENGTHS
            else:
                continue
            for n in lengths:
                yield stub, method, build(request_name, path, [0.0] * n), f"{where} x{n}"


# ------------------------------------------------------------------ unit
def test_the_tables_name_every_number_of_every_request() -> None:
    missing = []
    for _, method, request_name in methods():
        for path in number_paths(getattr(pb, request_name).DESCRIPTOR):
            fd = path[-1]
            message = fd.containing_type.name
            limit_of = path[-2].name if len(path) > 1 else None
            if message == "HgMatrix":
                continue
            if quantity_of(message, fd.name, limit_of) is None:
                missing.append(f"{method}: {'.'.join(f.name for f in path)}")
    assert not missing, "add these fields to validation.FIELDS / LIMIT_FIELDS: " + str(missing)


def test_a_huge_number_gets_a_short_comment() -> None:
    request = pb.MoveLinearCartesianRelRequest()
    request.rel_hg_mat.m.extend([*IDENTITY[:3], 1e300, *IDENTITY[4:]])
    with pytest.raises(ArgumentError) as err:
        check_request(request)
    assert "rel_hg_mat.m[3]" in err.value.comment
    assert "out of range" in err.value.comment
    assert len(err.value.comment) < 120


def test_hg_matrix_entries_have_their_own_quantities() -> None:
    request = pb.MovePTPCartesianAbsRequest(time=1.0)
    m = list(IDENTITY)
    m[11] = LENGTH.limit  # at the bound: accepted
    request.abs_hg_mat.m.extend(m)
    check_request(request)
    request.abs_hg_mat.m[0] = 1.0 + 2 * (ROTATION_ENTRY.limit - 1.0)
    with pytest.raises(ArgumentError, match="rotation entry"):
        check_request(request)


def test_vehicle_unit_moves_take_mm_then_deg() -> None:
    request = pb.MoveUnitRelRequest(unit=pb.VEHICLE, rel_pos=[50_000.0, 0.0, 3_000.0])
    check_request(request)  # 50 m and 3000 deg are within the edge bounds
    request = pb.MoveUnitRelRequest(unit=pb.RIGHT_ARM, rel_pos=[50_000.0])
    with pytest.raises(ArgumentError, match="deg is out of range"):
        check_request(request)


# ------------------------------------------------------------------ through the daemon
@pytest.fixture(scope="module")
def daemon() -> Iterator[TestDaemon]:
    d = TestDaemon("smartpal5")
    d.reset()
    assert d.wait_for(lambda: d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on)
    yield d
    d.close()


def test_fuzz_every_number_of_every_request(
    daemon: TestDaemon, caplog: pytest.LogCaptureFixture
) -> None:
    q0 = np.array(daemon.ctx.snapshot().q)
    failures = []
    count = 0
    with caplog.at_level(logging.INFO, logger="imotiond"):
        for stub, method, request, what in cases():
            count += 1
            reply = getattr(getattr(daemon, stub), method)(request)
            rid = reply.return_id
            if rid.id != ReturnCode.VALUE_ERR or not rid.comment or len(rid.comment) > 200:
                failures.append(f"{method} {what}: {ReturnCode(rid.id).name} {rid.comment!r}")
            snap = daemon.ctx.snapshot()
            moved = float(np.abs(np.array(snap.q) - q0).max())
            if snap.moving or snap.queue or moved > 1e-9:
                failures.append(f"{method} {what}: the robot moved ({moved:.3g})")
                daemon.reset()
                daemon.wait_idle()
                q0 = np.array(daemon.ctx.snapshot().q)
    tracebacks = [r.getMessage() for r in caplog.records if r.exc_info]
    assert count > 1000
    assert not failures, f"{len(failures)} of {count}:\n" + "\n".join(failures[:60])
    assert not tracebacks, tracebacks[:5]


# ------------------------------------------------------------------ issue items, one by one
RIGHT = pb.RIGHT
CART_SPEED = pb.CartesianSpeed(translation=100.0, rotation=30.0)
CART_ACCEL = pb.CartesianAccel(translation=500.0, rotation=100.0)


def hg(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> pb.HgMatrix:
    return pb.HgMatrix(m=[1.0, 0, 0, x, 0, 1.0, 0, y, 0, 0, 1.0, z])


def refused(d: TestDaemon, reply: object, code: ReturnCode = ReturnCode.VALUE_ERR) -> str:
    """The reply's comment, after checking its code and that nothing moves."""
    rid = reply.return_id  # type: ignore[attr-defined]
    assert rid.id == code, rid
    assert rid.comment and len(rid.comment) < 200, rid.comment
    snap = d.ctx.snapshot()
    assert not snap.moving and not snap.queue
    return str(rid.comment)


@pytest.fixture
def d(daemon: TestDaemon) -> Iterator[TestDaemon]:
    q0 = np.array(daemon.ctx.snapshot().q)
    yield daemon
    moved = float(np.abs(np.array(daemon.ctx.snapshot().q) - q0).max())
    assert moved < 1e-9, f"the robot moved {moved:.3g}"


@pytest.mark.parametrize(
    "name, build",
    [  # issue 16.1: 1e12 and 1e9 mm targets used to exhaust memory (MemoryError after 12-30 s)
        (
            "MoveLinearCartesianRel",
            lambda x: dict(rel_hg_mat=hg(x), speed=CART_SPEED, accel=CART_ACCEL),
        ),
        (
            "MoveLinearCartesianAbs",
            lambda x: dict(abs_hg_mat=hg(x), speed=CART_SPEED, accel=CART_ACCEL),
        ),
        ("MovePTPCartesianAbs", lambda x: dict(abs_hg_mat=hg(x), time=2.0)),
        ("MovePTPCartesianRel", lambda x: dict(rel_hg_mat=hg(z=x), time=2.0)),
    ],
)
def test_huge_targets_are_refused_before_planning(d: TestDaemon, name: str, build) -> None:  # type: ignore[no-untyped-def]
    request_type = getattr(pb, f"{name}Request")
    for x in (1e12, 1e9, 1e8):  # beyond the edge bound: VALUE_ERR
        comment = refused(d, getattr(d.spec_a, name)(request_type(type=RIGHT, **build(x))))
        assert "out of range" in comment
    # within the edge bound but beyond the arm: refused by the reach bound, no path sampled
    comment = refused(
        d,
        getattr(d.spec_a, name)(request_type(type=RIGHT, **build(20_000.0))),
        ReturnCode.CANNOT_REACH_TARGET_ERR,
    )
    assert "beyond its reach" in comment


def test_cp_hold_comments_speak_the_interface_units(d: TestDaemon) -> None:
    # issue 16.7: -10 deg/s was reported as "got -0.174533", -100 mm/s as "got -0.1"
    speed = pb.RedundantSpeed(elbow=-10.0)
    accel = pb.RedundantAccel(elbow=100.0)
    request = pb.MoveCPHoldRelRequest(
        type=RIGHT, rel_pos=pb.RedundantPos(elbow=5.0), speed=speed, accel=accel
    )
    comment = refused(d, d.spec_a.MoveCPHoldRel(request))
    assert "speed.elbow" in comment and "got -10" in comment and "deg/s" in comment
    speed = pb.RedundantSpeed(vehicle_translation=-100.0, vehicle_rotation=10.0)
    accel = pb.RedundantAccel(vehicle_translation=100.0, vehicle_rotation=10.0)
    request = pb.MoveCPHoldRelRequest(
        type=RIGHT, rel_pos=pb.RedundantPos(vehicle_x=50.0), speed=speed, accel=accel
    )
    comment = refused(d, d.spec_a.MoveCPHoldRel(request))
    assert "got -100" in comment and "mm/s" in comment


def test_a_1e300_argument_gets_a_short_comment(d: TestDaemon) -> None:
    # issue 16.8: a 375-character comment with a 300-digit number
    request = pb.MoveLinearCartesianRelRequest(
        type=RIGHT, rel_hg_mat=hg(1e300), speed=CART_SPEED, accel=CART_ACCEL
    )
    comment = refused(d, d.spec_a.MoveLinearCartesianRel(request))
    assert "1e+300 mm is out of range" in comment and len(comment) < 120


def test_too_slow_motions_are_refused_at_once(d: TestDaemon) -> None:
    # issue 16.12: moveCPHoldRel at 1e-9 deg/s answered after 8-18 s of planning
    request = pb.MoveCPHoldRelRequest(
        type=RIGHT,
        rel_pos=pb.RedundantPos(elbow=5.0),
        speed=pb.RedundantSpeed(elbow=1e-9),
        accel=pb.RedundantAccel(elbow=100.0),
    )
    comment = refused(d, d.spec_a.MoveCPHoldRel(request))
    assert "speed.elbow" in comment and "longest motion" in comment
    slow = pb.CartesianSpeed(translation=1e-6, rotation=30.0)
    request = pb.MoveLinearCartesianRelRequest(
        type=RIGHT, rel_hg_mat=hg(z=10.0), speed=slow, accel=CART_ACCEL
    )
    assert "longest motion" in refused(d, d.spec_a.MoveLinearCartesianRel(request))
    request = pb.MoveUnitRelRequest(
        unit=pb.RIGHT_ARM, rel_pos=[5.0] + [0.0] * 6, speed=[1e-6], accel=[100.0]
    )
    assert "longest motion" in refused(d, d.spec_a.MoveUnitRel(request))


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 1e308, -1e308])
def test_cp_hold_checks_axes_the_robot_does_not_have(d: TestDaemon, bad: float) -> None:
    # issue 17.1: NaN in lumbar_rx (SmartPal V has no lumbarRx) answered OK and moved 2.2 deg
    request = pb.MoveCPHoldRelRequest(
        type=RIGHT,
        rel_pos=pb.RedundantPos(lumbar_rx=bad, elbow=2.0),
        speed=pb.RedundantSpeed(elbow=10.0),
        accel=pb.RedundantAccel(elbow=100.0),
    )
    assert "rel_pos.lumbar_rx" in refused(d, d.spec_a.MoveCPHoldRel(request))


def test_jara_refuses_what_spec_a_refuses(d: TestDaemon) -> None:
    # issue 17.2: one bound per quantity, the same on every interface
    car = pb.CarPosWithElbow(car_pos=hg(), elbow=1e308)
    r = d.middle.MoveLinearCartesianRel(
        pb.ManipulatorMiddleMoveLinearCartesianRelRequest(car_point=car)
    )
    assert "car_point.elbow" in refused(d, r)
    offset = hg(z=1e308)
    r = d.middle.SetControlPointOffset(
        pb.ManipulatorMiddleSetControlPointOffsetRequest(offset=offset)
    )
    assert "out of range" in refused(d, r)
    r = d.middle.SetControlPointOffset(
        pb.ManipulatorMiddleSetControlPointOffsetRequest(offset=hg(z=3000.0))
    )
    assert "limit 2000 mm" in refused(d, r)
    r = d.spec_a.SetControlPointOffset(pb.SetControlPointOffsetRequest(offset=hg(z=3000.0)))
    assert "limit 2000 mm" in refused(d, r)
    r = d.middle.SetMinAccelTimeCartesian(
        pb.ManipulatorMiddleSetMinAccelTimeCartesianRequest(acl_time=1e308)
    )
    assert "acl_time" in refused(d, r)
    limit = pb.RedundantLimit(right_elbow=pb.LimitValue(upper=1e308, lower=-1e308))
    r = d.spec_a.SelectRedundantAxes(
        pb.SelectRedundantAxesRequest(redundancy=pb.RedundantAxesMask(elbow=True), limit=limit)
    )
    assert "limit.right_elbow.upper" in refused(d, r)
    r = d.spec_a.MoveUnitAbs(
        pb.MoveUnitAbsRequest(
            unit=pb.VEHICLE, abs_pos=[0.0, 0.0, 1e308], speed=[100, 10], accel=[100, 10]
        )
    )
    assert "abs_pos[2]" in refused(d, r)


@pytest.mark.parametrize(
    "name, request_",
    [  # issue 17.5: these answered NG "internal error" with a traceback
        (
            "MoveCPHoldRel",
            pb.MoveCPHoldRelRequest(
                type=RIGHT,
                rel_pos=pb.RedundantPos(vehicle_x=1e308),
                speed=pb.RedundantSpeed(vehicle_translation=100, vehicle_rotation=10),
                accel=pb.RedundantAccel(vehicle_translation=100, vehicle_rotation=10),
            ),
        ),
        (
            "MovePTPCartesianRel",
            pb.MovePTPCartesianRelRequest(type=RIGHT, rel_hg_mat=hg(z=1e308), time=2.0),
        ),
        (
            "MoveCPHoldRel",
            pb.MoveCPHoldRelRequest(
                type=RIGHT,
                rel_pos=pb.RedundantPos(elbow=5.0),
                speed=pb.RedundantSpeed(elbow=10),
                accel=pb.RedundantAccel(elbow=1e308),
            ),
        ),
        (
            "MovePTPCartesianAbs",
            pb.MovePTPCartesianAbsRequest(type=RIGHT, abs_hg_mat=hg(z=1e308), time=2.0),
        ),
    ],
)
def test_absurd_numbers_are_value_errors_not_internal_errors(
    d: TestDaemon, caplog: pytest.LogCaptureFixture, name: str, request_: object
) -> None:
    with caplog.at_level(logging.INFO, logger="imotiond"):
        comment = refused(d, getattr(d.spec_a, name)(request_))
    assert "internal error" not in comment
    assert not [r for r in caplog.records if r.exc_info]


def test_set_max_speed_cartesian_refuses_more_than_the_arm_can_do(d: TestDaemon) -> None:
    # issue 15.8: setMaxSpeedCartesian(1e9, 1e9) returned OK
    for t, r in ((1e9, 1e9), (9_000.0, 90.0), (250.0, 3_000.0)):
        request = pb.ManipulatorMiddleSetMaxSpeedCartesianRequest(
            speed=pb.CartesianSpeed(translation=t, rotation=r)
        )
        refused(d, d.middle.SetMaxSpeedCartesian(request))
    request = pb.ManipulatorMiddleSetMaxSpeedCartesianRequest(
        speed=pb.CartesianSpeed(translation=250.0, rotation=90.0)
    )
    assert d.middle.SetMaxSpeedCartesian(request).return_id.id == ReturnCode.OK


def test_joint_count_comment_says_which_counts_are_accepted(d: TestDaemon) -> None:
    # issue 15.8: "expected 7 joint values (7 joints + 1 gripper), got 6"
    r = d.middle.MovePTPJointRel(pb.ManipulatorMiddleMovePTPJointRelRequest(joint_points=[0.0] * 6))
    assert "expected 7 or 8 joint values" in refused(d, r)

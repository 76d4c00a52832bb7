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

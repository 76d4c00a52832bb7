"""controller.client against an in-process fake daemon (tests/client_fake.py).

Every RPC of every service is called through its original lowerCamel name with arguments in
Python form, and the request the fake receives is compared with one built by hand here.
"""

from __future__ import annotations

import math
import shutil
import socket
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import grpc
import numpy as np
import pytest
from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message

from controller import vocabulary as core_enums
from controller.client import (
    LEFT,
    RIGHT,
    Alarm,
    AlarmType,
    ArgumentError,
    AuthenticationError,
    CarPosWithElbow,
    CartesianAccel,
    CartesianSpeed,
    Client,
    DaemonUnavailable,
    LimitValue,
    ReturnID,
    RpcFailed,
    StateSample,
    codes,
    is_local,
    pose,
    rpy_of,
    xyz_of,
)
from controller.client.service import Operation, Result, ServiceProxy
from controller.client.types import ENUM_TYPES, MESSAGE_TYPES, RightLeft, UnitType
from controller.rpc import imotion_pb2, imotion_pb2_grpc
from tests import client_fake

PROXIES = {
    "integrated": ["IntegratedMotion"],
    "right_arm": ["ManipulatorCommon", "ManipulatorMiddle"],
    "left_arm": ["ManipulatorCommon", "ManipulatorMiddle"],
    "dual": ["DualManipulatorCommon", "DualManipulatorMiddle"],
}
BOUND_ARM = {"right_arm": imotion_pb2.RIGHT, "left_arm": imotion_pb2.LEFT}


@pytest.fixture(scope="module")
def daemon() -> Iterator[tuple[client_fake.FakeDaemon, str]]:
    server, fake, address = client_fake.start()
    yield fake, address
    server.stop(None)


@pytest.fixture
def fake(daemon: tuple[client_fake.FakeDaemon, str]) -> client_fake.FakeDaemon:
    daemon[0].reset()
    return daemon[0]


@pytest.fixture
def client(daemon: tuple[client_fake.FakeDaemon, str]) -> Iterator[Client]:
    with Client.connect(daemon[1], token="s3cret", timeout=5.0) as c:
        yield c


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# ---------------------------------------------------------------- samples (Python, proto)


def sample(f: FieldDescriptor) -> tuple[Any, Any]:
    """A (Python argument, expected proto value) pair for a request field."""
    if f.is_repeated and f.type == FieldDescriptor.TYPE_DOUBLE:
        return [0.0, 10.0, -45.5], [0.0, 10.0, -45.5]
    if f.is_repeated:
        one, proto = _single(f)
        return [one, one], [proto, proto]
    return _single(f)


def _single(f: FieldDescriptor) -> tuple[Any, Any]:
    if f.type == FieldDescriptor.TYPE_MESSAGE:
        return sample_message(f.message_type)
    if f.type == FieldDescriptor.TYPE_ENUM:
        return ENUM_TYPES[f.enum_type.name](1), 1
    value = {
        FieldDescriptor.TYPE_DOUBLE: 12.5,
        FieldDescriptor.TYPE_BOOL: True,
        FieldDescriptor.TYPE_UINT32: 42,
    }[f.type]
    return value, value


def sample_message(d: Descriptor) -> tuple[Any, Message]:
    cls = getattr(imotion_pb2, d.name)
    if d.name == "HgMatrix":
        hg = pose([100.0, -200.0, 300.0], [10.0, 20.0, 30.0])
        return hg, cls(m=[float(x) for x in hg.ravel()])
    pairs = {f.name: sample(f) for f in d.fields}
    py = MESSAGE_TYPES[d.name](*[p for p, _ in pairs.values()])
    return py, cls(**{name: proto for name, (_, proto) in pairs.items()})


def all_operations() -> list[tuple[str, str, str]]:
    ops = []
    for proxy, services in PROXIES.items():
        for service in services:
            for m in imotion_pb2.DESCRIPTOR.services_by_name[service].methods:
                ops.append((proxy, service, m.name))
    return ops


# ---------------------------------------------------------------- coverage of the contract


def test_every_rpc_is_reachable_by_its_original_name(client: Client) -> None:
    reached = set()
    for proxy_name, service, rpc in all_operations():
        proxy: ServiceProxy = getattr(client, proxy_name)
        op = getattr(proxy, rpc[0].lower() + rpc[1:])
        assert isinstance(op, Operation)
        assert op.service == service and op.method.name == rpc
        reached.add((service, rpc))
    contract = {
        (s.name, m.name)
        for s in imotion_pb2.DESCRIPTOR.services_by_name.values()
        if s.name not in ("Monitor", "Testing")  # a stream; test-only (Client.inject_fault)
        for m in s.methods
    }
    assert reached == contract
    assert len(contract) == 97
    assert len(client.integrated.operations) == 29
    assert len(client.right_arm.operations) == 54
    assert len(client.dual.operations) == 14


def test_original_spellings(client: Client) -> None:
    for proxy, name in [
        (client.integrated, "getState"),
        (client.integrated, "servoOn"),
        (client.integrated, "moveCPHoldAbs"),
        (client.right_arm, "servoON"),
        (client.left_arm, "movePTPJointRelCmdCycle"),
        (client.dual, "servoONArm"),
        (client.dual, "getRelativePosition"),
    ]:
        assert callable(getattr(proxy, name))
    with pytest.raises(AttributeError, match="did you mean servoON"):
        _ = client.right_arm.servoOn


@pytest.mark.parametrize(("proxy_name", "service", "rpc"), all_operations())
def test_every_rpc_round_trips(
    client: Client, fake: client_fake.FakeDaemon, proxy_name: str, service: str, rpc: str
) -> None:
    op: Operation = getattr(getattr(client, proxy_name), rpc[0].lower() + rpc[1:])
    pairs = [sample(f) for f in op.fields]
    result = op(*[py for py, _ in pairs])

    call = fake.last()
    assert (call.service, call.rpc) == (service, rpc)
    expected = {f.name: proto for f, (_, proto) in zip(op.fields, pairs, strict=True)}
    if proxy_name in BOUND_ARM:
        expected["arm"] = BOUND_ARM[proxy_name]
    assert call.request == type(call.request)(**expected)
    assert call.metadata["authorization"] == "Bearer s3cret"

    assert isinstance(result, Result) and isinstance(result, tuple)
    assert result[0] == ReturnID(0, f"{rpc} done") and result.ok
    assert len(result) == 1 + len(op.outputs)
    for f, value in zip(op.outputs, result[1:], strict=True):
        check_python_form(f, value)


def check_python_form(f: FieldDescriptor, value: Any) -> None:
    """Outputs come back as Python values in the documented forms."""
    if f.is_repeated and f.type == FieldDescriptor.TYPE_DOUBLE:
        assert value == [1.0, 2.0, 3.0]
        return
    if f.is_repeated:
        assert isinstance(value, list) and value
        value = value[0]
    if f.type == FieldDescriptor.TYPE_MESSAGE and f.message_type.name == "HgMatrix":
        assert isinstance(value, np.ndarray) and value.shape == (3, 4)
        np.testing.assert_array_equal(value.ravel(), client_fake.CANNED_HG)
    elif f.type == FieldDescriptor.TYPE_MESSAGE:
        assert isinstance(value, MESSAGE_TYPES[f.message_type.name])
        for sub, v in zip(f.message_type.fields, value, strict=True):
            check_python_form(sub, [v] if sub.is_repeated and not isinstance(v, list) else v)
    elif f.type == FieldDescriptor.TYPE_ENUM:
        assert isinstance(value, ENUM_TYPES[f.enum_type.name]) and value == 1
    elif f.type == FieldDescriptor.TYPE_DOUBLE:
        assert value == 1.5
    elif f.type == FieldDescriptor.TYPE_BOOL:
        assert value is True
    elif f.type == FieldDescriptor.TYPE_STRING:
        assert isinstance(value, str)
    else:
        assert value == 7


def test_python_types_follow_the_contract() -> None:
    for name, cls in MESSAGE_TYPES.items():
        d = imotion_pb2.DESCRIPTOR.message_types_by_name[name]
        assert list(cls._fields) == [f.json_name for f in d.fields], name
    for name, enum_cls in ENUM_TYPES.items():
        d = imotion_pb2.DESCRIPTOR.enum_types_by_name[name]
        assert {m.name: m.value for m in enum_cls} == {v.name: v.number for v in d.values}
    # every struct used by an RPC has a Python type
    used = set()
    for s in imotion_pb2.DESCRIPTOR.services_by_name.values():
        for m in s.methods:
            for d in (m.input_type, m.output_type):
                stack = list(d.fields)
                while stack:
                    f = stack.pop()
                    if f.type == FieldDescriptor.TYPE_MESSAGE:
                        if f.message_type.GetOptions().map_entry:
                            continue  # Testing params: a dict of text, no struct
                        used.add(f.message_type.name)
                        stack.extend(f.message_type.fields)
    assert used - {"HgMatrix", "ReturnID"} <= set(MESSAGE_TYPES)


# ---------------------------------------------------------------- conversions in spec units


def test_outputs_in_python_form(client: Client, fake: client_fake.FakeDaemon) -> None:
    fake.handlers[("IntegratedMotion", "GetState")] = lambda _: imotion_pb2.GetStateResponse(
        return_id=imotion_pb2.ReturnID(id=0, comment="ok"), status_id=0x012, message="Ready"
    )
    rid, status, message = client.integrated.getState()
    assert (rid.id, rid.comment, status, message) == (0, "ok", codes.READY, "Ready")
    assert codes.state_name(status) == "Ready"

    rid, pos = client.integrated.getFeedbackPosCartesian(RIGHT, "ORIGINAL_FRAME")
    assert isinstance(pos, CarPosWithElbow)
    np.testing.assert_array_equal(pos.carPos[:, 3], [10.0, 20.0, 30.0])  # p column, mm
    assert rpy_of(pos.carPos) == pytest.approx((0.0, 0.0, 90.0))
    assert (pos.elbow, pos.structFlag) == (1.5, 7)

    rid, alarms = client.integrated.getActiveAlarm()
    assert alarms == [Alarm(7, AlarmType.WARNING, "description text", "module_name text")]
    rid, limits = client.right_arm.getSoftLimitJoint()
    assert limits == [LimitValue(1.5, 1.5)]
    result = client.integrated.isMoving()
    assert result.isMoving is True and result.outputs == {"isMoving": True}


def test_argument_forms(client: Client, fake: client_fake.FakeDaemon) -> None:
    hg = pose([400.0, -200.0, 800.0], [180.0, 0.0, 0.0])
    flat = [float(x) for x in hg.ravel()]
    forms = [
        (hg, CartesianSpeed(50, 30), CartesianAccel(200, 100)),
        (hg.tolist(), (50, 30), [200, 100]),
        (flat, {"translation": 50, "rotation": 30}, {"translation": 200.0, "rotation": 100}),
        (np.vstack([hg, [0, 0, 0, 1]]), imotion_pb2.CartesianSpeed(translation=50, rotation=30),
         (np.float32(200), np.int64(100))),
    ]  # fmt: skip
    requests = []
    for matrix, speed, accel in forms:
        client.integrated.moveLinearCartesianRel("right", "tool", matrix, speed, accel, False)
        requests.append(fake.last().request)
    assert all(r == requests[0] for r in requests)
    r = requests[0]
    assert list(r.rel_hg_mat.m) == flat  # row-major [R | p], p in mm
    assert r.frame_type == imotion_pb2.TOOL_FRAME
    assert (r.speed.translation, r.accel.rotation) == (50.0, 100.0)

    # keywords by original or proto name, enums from controller.vocabulary or numbers
    client.integrated.moveUnitAbs(
        unit=core_enums.UnitType.LUMBER, absPos=[1, 2], speed=[3], accel=np.array([4.0])
    )
    assert fake.last().request == imotion_pb2.MoveUnitAbsRequest(
        unit=imotion_pb2.LUMBER, abs_pos=[1, 2], speed=[3], accel=[4]
    )
    client.integrated.getFeedbackPosJoint(type=3)
    assert fake.last().request.type == imotion_pb2.VEHICLE
    client.arm("LEFT").movePTPCartesianAbs(carPoint=CarPosWithElbow(hg, elbow=30.0))
    sent = fake.last().request
    assert sent.arm == imotion_pb2.LEFT and sent.car_point.elbow == 30.0
    assert client.arm(core_enums.RightLeft.RIGHT) is client.right_arm


def test_nan_reaches_the_daemon(client: Client, fake: client_fake.FakeDaemon) -> None:
    client.right_arm.movePTPJointAbs([0.0, math.nan])
    assert math.isnan(fake.last().request.joint_points[1])


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda c: c.integrated.moveGripper(RIGHT), TypeError, "missing angleRatio"),
        (lambda c: c.integrated.moveGripper(RIGHT, 1, 2), TypeError, "takes type, angleRatio"),
        (lambda c: c.integrated.moveGripper(RIGHT, ratio=3), TypeError, "unknown argument"),
        (lambda c: c.integrated.moveGripper("UP", 3), ArgumentError, "RIGHT, LEFT"),
        (lambda c: c.integrated.moveGripper(RIGHT, 2.5), ArgumentError, "whole number"),
        (lambda c: c.integrated.moveGripper(RIGHT, -1), ArgumentError, "outside 0..4294967295"),
        (lambda c: c.integrated.moveGripper(RIGHT, "50"), ArgumentError, "expected a number"),
        (lambda c: c.integrated.setControlPointOffset(RIGHT, [[1, 2]]), ArgumentError,
         "offset: expected a 3x4 matrix"),
        (lambda c: c.integrated.movePTPCartesianAbs(RIGHT, pose(), 1.0, 2), ArgumentError,
         "isHoldOtherArm: expected a boolean"),
        (lambda c: c.right_arm.setMaxSpeedCartesian((1, 2, 3)), ArgumentError,
         r"CartesianSpeed needs 2 values"),
        (lambda c: c.right_arm.setMaxSpeedCartesian({"x": 1}), ArgumentError, "unknown field 'x'"),
        (lambda c: c.dual.movePTPJointAbs(5, [1]), ArgumentError, "rArm: expected a sequence"),
        (lambda c: c.arm("middle"), ArgumentError, "arm"),
    ],
)  # fmt: skip
def test_bad_arguments_are_refused_before_sending(
    client: Client, fake: client_fake.FakeDaemon, call: Any, error: type, match: str
) -> None:
    with pytest.raises(error, match=match):
        call(client)
    assert not fake.calls


# ---------------------------------------------------------------- connection, security


def test_token_metadata(daemon: tuple[client_fake.FakeDaemon, str]) -> None:
    fake, address = daemon
    fake.reset()
    with Client.connect(address) as anonymous:
        anonymous.integrated.stop()
    assert "authorization" not in fake.last("Stop").metadata
    with Client.connect(address, token="abc") as c:
        c.dual.servoONHand()
        assert fake.last("ServoONHand").metadata["authorization"] == "Bearer abc"
        with c.monitor.stream(5.0) as stream:
            next(stream)
        assert fake.last("StreamState").metadata["authorization"] == "Bearer abc"


def test_unix_socket(tmp_path: Path) -> None:
    address = f"unix:{tmp_path}/imotion.sock"
    server, _, _ = client_fake.start(address)
    try:
        with Client.connect(address) as c:
            assert c.integrated.getVersion()[1] == "version text"
    finally:
        server.stop(None)


@pytest.mark.parametrize("address", ["127.0.0.1:{port}", "unix:{tmp}/absent.sock"])
def test_unreachable_daemon_names_the_address(address: str, tmp_path: Path) -> None:
    address = address.format(port=free_port(), tmp=tmp_path)
    with pytest.raises(DaemonUnavailable, match=f"imotion daemon at {address} unreachable"):
        Client.connect(address, timeout=5.0)


def test_refused_token_and_server_errors(client: Client, fake: client_fake.FakeDaemon) -> None:
    class Deny(grpc.ServerInterceptor):
        def intercept_service(self, continuation: Any, details: Any) -> Any:
            def deny(request: Any, context: grpc.ServicerContext) -> Any:
                context.abort(grpc.StatusCode.UNAUTHENTICATED, "bad token")

            return grpc.unary_unary_rpc_method_handler(deny)

    denying = grpc.server(
        client_fake.futures.ThreadPoolExecutor(max_workers=2), interceptors=[Deny()]
    )
    port = denying.add_insecure_port("127.0.0.1:0")
    denying.start()
    try:
        with pytest.raises(AuthenticationError, match=r"127\.0\.0\.1:\d+ refused .*bad token"):
            Client.connect(f"127.0.0.1:{port}", token="wrong")
    finally:
        denying.stop(None)

    def fail(_: Any) -> Message:
        raise RuntimeError("boom")

    fake.handlers[("IntegratedMotion", "Pause")] = fail
    with pytest.raises(RpcFailed, match=r"IntegratedMotion\.pause failed: UNKNOWN"):
        client.integrated.pause()


def test_client_needs_a_channel() -> None:
    with pytest.raises(TypeError, match=r"use Client\.connect"):
        Client("127.0.0.1:50051")  # type: ignore[arg-type]


def test_is_local() -> None:
    for address in ["127.0.0.1:50051", "localhost:1", "[::1]:50051", "unix:/run/x.sock",
                    "unix:///run/x.sock", "127.5.0.1:2", "dns:///localhost:50051"]:  # fmt: skip
        assert is_local(address), address
    for address in ["10.0.0.2:50051", "robot.local:50051", "[2001:db8::1]:1", "0.0.0.0:1"]:
        assert not is_local(address), address


def _self_signed(tmp_path: Path) -> tuple[bytes, bytes]:
    if shutil.which("openssl") is None:
        pytest.skip("openssl not available")
    key, cert = tmp_path / "key.pem", tmp_path / "cert.pem"
    subprocess.run(
        ["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
         "-subj", "/CN=localhost", "-addext", "subjectAltName=DNS:localhost,IP:127.0.0.1",
         "-keyout", str(key), "-out", str(cert)],
        check=True, capture_output=True,
    )  # fmt: skip
    return key.read_bytes(), cert.read_bytes()


def test_tls_with_root_certificate_and_token(tmp_path: Path) -> None:
    key, cert = _self_signed(tmp_path)
    fake = client_fake.FakeDaemon()
    server = grpc.server(client_fake.futures.ThreadPoolExecutor(max_workers=2))
    imotion_pb2_grpc.add_IntegratedMotionServicer_to_server(
        client_fake._servicer("IntegratedMotion", fake), server
    )
    port = server.add_secure_port("127.0.0.1:0", grpc.ssl_server_credentials([(key, cert)]))
    server.start()
    try:
        (tmp_path / "ca.pem").write_bytes(cert)
        with Client.connect(
            f"127.0.0.1:{port}", token="t", root_certificates=tmp_path / "ca.pem"
        ) as c:
            assert c.integrated.servoOn().ok
        assert fake.last("ServoOn").metadata["authorization"] == "Bearer t"
        # without the root certificate the plain channel cannot talk to a TLS server
        with pytest.raises(DaemonUnavailable):
            Client.connect(f"127.0.0.1:{port}", timeout=5.0)
        with pytest.raises(Exception, match="cannot read the TLS root certificate"):
            Client.connect(f"127.0.0.1:{port}", root_certificates=tmp_path / "none.pem")
    finally:
        server.stop(None)


# ---------------------------------------------------------------- wait, monitor, constants


def test_wait_until_idle(client: Client, fake: client_fake.FakeDaemon) -> None:
    polls = []

    def moving(_: Any) -> Message:
        polls.append(1)
        return imotion_pb2.IsMovingResponse(is_moving=len(polls) < 4)

    fake.handlers[("IntegratedMotion", "IsMoving")] = moving
    assert client.wait_until_idle(timeout=None, poll=0.001) is True
    assert len(polls) == 4

    fake.handlers[("IntegratedMotion", "IsMoving")] = lambda _: imotion_pb2.IsMovingResponse(
        is_moving=True
    )
    assert client.wait_until_idle(timeout=0.05, poll=0.01) is False  # no exception


def test_monitor_stream(client: Client, fake: client_fake.FakeDaemon) -> None:
    sample = client_fake.canned(imotion_pb2.StateSample.DESCRIPTOR)
    fake.samples.extend([sample, sample, sample])
    samples = list(client.monitor.stream(rate_hz=20.0))
    assert len(samples) == 3 and all(isinstance(s, StateSample) for s in samples)
    assert fake.last("StreamState").request.rate_hz == 20.0
    s = samples[0]
    assert s.joints[0].unit is UnitType.LEFT_ARM and s.joints[0].position == [1.0, 2.0, 3.0]
    assert s.controlPoints[0].arm is RightLeft.LEFT
    assert s.controlPoints[0].pose.carPos.shape == (3, 4)
    assert s.loop.compute.p99Us == 1.5 and s.loop.wakeLatency.maxUs == 1.5


def test_codes() -> None:
    assert (codes.OK, codes.NG, codes.STATUS_ERR, codes.VALUE_ERR) == (0, -1, -2, -3)
    assert (codes.NOT_SV_ON_ERR, codes.FULL_MOTION_QUEUE_ERR) == (-4, -5)
    assert codes.CANNOT_REACH_TARGET_ERR == -6
    states = (codes.UNPOWERED, codes.SERVO_OFF, codes.READY, codes.BUSY, codes.PAUSE)
    assert states == (0x10, 0x11, 0x12, 0x13, 0x14) and codes.ALARM == 0x15
    assert codes.state_name(0x13) == "Busy" and "0x099" in codes.state_name(0x99)
    rid = ReturnID(-3, "speed: element 0 is nan")
    assert rid.name == "VALUE_ERR" and not rid.ok
    assert str(rid) == "VALUE_ERR (-3): speed: element 0 is nan"
    assert codes.jara_state_names(0x03) == ["servo on", "moving"]


@pytest.mark.parametrize("rpy", [(10, 20, 30), (-170, 89.9, 5), (0, 90, 0), (30, -90, 0)])
def test_pose_round_trip(rpy: tuple[float, float, float]) -> None:
    hg = pose([1, 2, 3], rpy)
    np.testing.assert_allclose(hg[:, :3] @ hg[:, :3].T, np.eye(3), atol=1e-12)
    assert xyz_of(hg) == (1, 2, 3)
    np.testing.assert_allclose(pose([1, 2, 3], rpy_of(hg)), hg, atol=1e-9)
    assert LEFT == 1

"""controller.gateway.grpc.auth: the token interceptor, read vs motion tokens end to end, and a
TLS + token daemon on 127.0.0.1."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

import grpc
import numpy as np
import pytest

from controller.contract.config import TokensConfig
from controller.gateway.grpc.auth import TokenInterceptor, is_read_only
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import SpecAState as S
from tests.daemon_support import TestDaemon

READ, MOTION = "read-token-1", "motion-token-2"
SPEC_A = "/imotion.v1.IntegratedMotion/"


# ----------------------------------------------------------------------------- unit
@pytest.mark.parametrize(
    "method, read_only",
    [
        (SPEC_A + "GetState", True),
        (SPEC_A + "GetFeedbackPosJoint", True),
        (SPEC_A + "IsMoving", True),
        ("/imotion.v1.Monitor/StreamState", True),
        ("/imotion.v1.ManipulatorCommon/GetSoftLimitJoint", True),
        (SPEC_A + "MoveUnitAbs", False),
        (SPEC_A + "ServoOn", False),
        (SPEC_A + "ClearAlarms", False),
        (SPEC_A + "Abort", False),
        ("/imotion.v1.ManipulatorMiddle/SetSpeedJoint", False),
    ],
)
def test_read_only_methods(method: str, read_only: bool):
    assert is_read_only(method) is read_only


class _Details(NamedTuple):
    method: str
    invocation_metadata: tuple[tuple[str, str], ...]


class _Aborted(Exception):
    pass


class _Context:
    def abort(self, code: grpc.StatusCode, message: str) -> None:
        raise _Aborted(code, message)


def _handler(streaming: bool) -> grpc.RpcMethodHandler:
    if streaming:
        return grpc.unary_stream_rpc_method_handler(lambda req, ctx: iter(["served"]))
    return grpc.unary_unary_rpc_method_handler(lambda req, ctx: "served")


def _call(
    tokens: TokensConfig, method: str, header: str | None, streaming: bool = False
) -> tuple[str, Any]:
    """("served", None) or ("aborted", (code, message))."""
    metadata = (("authorization", header),) if header is not None else ()
    handler = TokenInterceptor(tokens).intercept_service(
        lambda details: _handler(streaming), _Details(method, metadata)
    )
    fn = handler.unary_stream if streaming else handler.unary_unary
    try:
        result = fn(None, _Context())
        return ("served", None) if not streaming else (next(iter(result)), None)
    except _Aborted as exc:
        return "aborted", exc.args


TOKENS = TokensConfig(read=READ, motion=MOTION)


@pytest.mark.parametrize(
    "method, header, expected",
    [
        (SPEC_A + "GetState", f"Bearer {READ}", None),
        (SPEC_A + "GetState", f"Bearer {MOTION}", None),
        (SPEC_A + "MoveUnitAbs", f"Bearer {MOTION}", None),
        (SPEC_A + "MoveUnitAbs", f"Bearer {READ}", grpc.StatusCode.PERMISSION_DENIED),
        (SPEC_A + "GetState", "Bearer nope", grpc.StatusCode.PERMISSION_DENIED),
        (SPEC_A + "GetState", None, grpc.StatusCode.UNAUTHENTICATED),
        (SPEC_A + "GetState", READ, grpc.StatusCode.UNAUTHENTICATED),  # no "Bearer "
        (SPEC_A + "GetState", "Bearer ", grpc.StatusCode.UNAUTHENTICATED),
        (SPEC_A + "MoveUnitAbs", f"Bearer {MOTION}x", grpc.StatusCode.PERMISSION_DENIED),
    ],
)
def test_interceptor_decisions(method: str, header: str | None, expected: Any):
    outcome, details = _call(TOKENS, method, header)
    if expected is None:
        assert outcome == "served"
    else:
        assert outcome == "aborted" and details[0] == expected
        assert details[1]  # says why


def test_interceptor_streaming_and_motion_token_only():
    stream = "/imotion.v1.Monitor/StreamState"
    assert _call(TOKENS, stream, f"Bearer {READ}", streaming=True) == ("served", None)
    outcome, details = _call(TOKENS, stream, None, streaming=True)
    assert outcome == "aborted" and details[0] == grpc.StatusCode.UNAUTHENTICATED
    only_motion = TokensConfig(motion=MOTION)  # reads need the motion token then
    assert _call(only_motion, SPEC_A + "GetState", f"Bearer {MOTION}")[0] == "served"
    outcome, details = _call(only_motion, SPEC_A + "GetState", f"Bearer {READ}")
    assert details[0] == grpc.StatusCode.PERMISSION_DENIED


def test_interceptor_without_tokens_passes_everything_through():
    interceptor = TokenInterceptor(TokensConfig())
    assert not interceptor.enabled
    handler = _handler(False)
    assert interceptor.intercept_service(lambda d: handler, _Details("/x/Y", ())) is handler
    # an unknown method stays unknown (gRPC answers UNIMPLEMENTED)
    assert TokenInterceptor(TOKENS).intercept_service(lambda d: None, _Details("/x/Y", ())) is None


# ----------------------------------------------------------------------------- end to end
def _bearer(token: str) -> tuple[tuple[str, str], ...]:
    return (("authorization", f"Bearer {token}"),)


def _rpc_code(fn: Any, request: Any, token: str | None) -> grpc.StatusCode:
    try:
        fn(request, metadata=_bearer(token) if token else None)
    except grpc.RpcError as exc:
        return exc.code()
    return grpc.StatusCode.OK


@pytest.fixture(scope="module")
def guarded() -> Iterator[TestDaemon]:
    d = TestDaemon(
        "pa10",
        "ideal",
        250.0,
        **{"security.tokens.read": READ, "security.tokens.motion": MOTION},
    )
    try:
        d.spec_a.ServoOn(pb.ServoOnRequest(), metadata=_bearer(MOTION))
        yield d
    finally:
        d.close()


def test_tokens_end_to_end(guarded: TestDaemon):
    s = guarded.spec_a
    get_state = pb.GetStateRequest()
    assert _rpc_code(s.GetState, get_state, None) == grpc.StatusCode.UNAUTHENTICATED
    assert _rpc_code(s.GetState, get_state, "wrong") == grpc.StatusCode.PERMISSION_DENIED
    assert _rpc_code(s.GetState, get_state, READ) == grpc.StatusCode.OK
    assert _rpc_code(s.GetState, get_state, MOTION) == grpc.StatusCode.OK
    state = s.GetState(get_state, metadata=_bearer(READ))
    assert state.status_id == S.READY
    move = pb.MoveUnitRelRequest(
        unit=pb.RIGHT_ARM, rel_pos=[5, 0, 0, 0, 0, 0, 0], speed=[30], accel=[100]
    )
    before = guarded.ctx.snapshot().q
    for token in (None, READ, "wrong"):
        code = _rpc_code(s.MoveUnitRel, move, token)
        assert code in (grpc.StatusCode.UNAUTHENTICATED, grpc.StatusCode.PERMISSION_DENIED)
        assert _rpc_code(s.ServoOff, pb.ServoOffRequest(), token) == code
    # rejected before the motion core: nothing moved, nothing changed state
    assert guarded.ctx.snapshot().started == 0
    np.testing.assert_array_equal(guarded.ctx.snapshot().q, before)
    assert s.GetState(get_state, metadata=_bearer(READ)).status_id == S.READY
    reply = s.MoveUnitRel(move, metadata=_bearer(MOTION))
    assert reply.return_id.id == 0, reply.return_id.comment
    assert s.IsMoving(pb.IsMovingRequest(), metadata=_bearer(READ)).is_moving
    s.Abort(pb.AbortRequest(), metadata=_bearer(MOTION))
    # the monitor stream is a read operation
    stream = guarded.monitor.StreamState(pb.StreamStateRequest(), metadata=_bearer(READ))
    assert next(iter(stream)).status_id == S.READY
    stream.cancel()
    with pytest.raises(grpc.RpcError) as err:
        next(iter(guarded.monitor.StreamState(pb.StreamStateRequest())))
    assert err.value.code() == grpc.StatusCode.UNAUTHENTICATED


def test_undecodable_bytes_without_a_token_learn_nothing(guarded: TestDaemon):
    """The token comes first: bad bytes without a token are UNAUTHENTICATED, not
    INVALID_ARGUMENT; with the motion token they are INVALID_ARGUMENT."""
    bad = b"\x0a\xff"  # never decodes
    for method, other, other_code in (
        ("ServoOn", READ, grpc.StatusCode.PERMISSION_DENIED),
        ("GetState", READ, grpc.StatusCode.INVALID_ARGUMENT),
    ):
        raw = guarded.channel.unary_unary(f"/imotion.v1.IntegratedMotion/{method}")
        assert _rpc_code(raw, bad, None) == grpc.StatusCode.UNAUTHENTICATED
        assert _rpc_code(raw, bad, "wrong") == grpc.StatusCode.PERMISSION_DENIED
        assert _rpc_code(raw, bad, other) == other_code
        assert _rpc_code(raw, bad, MOTION) == grpc.StatusCode.INVALID_ARGUMENT


# ----------------------------------------------------------------------------- TLS
def _self_signed(directory: Path) -> tuple[Path, Path]:
    """A certificate for 127.0.0.1 / localhost made with the openssl CLI."""
    cert, key = directory / "cert.pem", directory / "key.pem"
    subprocess.run(
        [
            "openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
            "-keyout", str(key), "-out", str(cert), "-subj", "/CN=localhost",
            "-addext", "subjectAltName=IP:127.0.0.1,DNS:localhost",
        ],
        check=True,
        capture_output=True,
        timeout=60,
    )  # fmt: skip
    return cert, key


@pytest.mark.skipif(
    shutil.which("openssl") is None,
    reason="neither the cryptography package nor the openssl CLI is available to make a cert",
)
def test_tls_and_token_daemon_on_loopback(tmp_path: Path):
    cert, key = _self_signed(tmp_path)
    d = TestDaemon(
        "pa10",
        "ideal",
        250.0,
        **{
            "security.tls_cert": str(cert),
            "security.tls_key": str(key),
            "security.tokens.motion": MOTION,
        },
    )
    try:
        creds = grpc.ssl_channel_credentials(root_certificates=cert.read_bytes())
        with grpc.secure_channel(d.address, creds) as channel:
            stub = pb_grpc.IntegratedMotionStub(channel)
            state = stub.GetState(pb.GetStateRequest(), metadata=_bearer(MOTION), timeout=30)
            assert state.status_id == S.SERVO_OFF
            code = _rpc_code(stub.ServoOn, pb.ServoOnRequest(), None)
            assert code == grpc.StatusCode.UNAUTHENTICATED
            assert stub.GetState(pb.GetStateRequest(), metadata=_bearer(MOTION)).status_id == (
                S.SERVO_OFF
            )
            # token credentials as a client library would attach them
            call_creds = grpc.access_token_call_credentials(MOTION)
            both = grpc.composite_channel_credentials(creds, call_creds)
            with grpc.secure_channel(d.address, both) as with_token:
                version = pb_grpc.IntegratedMotionStub(with_token).GetVersion(
                    pb.GetVersionRequest(), timeout=30
                )
                assert "pa10" in version.version
        # plaintext to a TLS port fails
        with grpc.insecure_channel(d.address) as plain:
            with pytest.raises(grpc.RpcError) as err:
                pb_grpc.IntegratedMotionStub(plain).GetState(
                    pb.GetStateRequest(), metadata=_bearer(MOTION), timeout=5
                )
            assert err.value.code() == grpc.StatusCode.UNAVAILABLE
    finally:
        d.close()

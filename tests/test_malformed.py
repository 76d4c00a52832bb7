"""controller.gateway.grpc.malformed: undecodable request bytes -> INVALID_ARGUMENT, one line."""

from __future__ import annotations

import logging
from collections.abc import Iterator

import grpc
import pytest

from controller.gateway.grpc.malformed import _RateLimitedLog
from tests.daemon_support import TestDaemon

BAD = b"\x0a\xff"  # field 1, length-delimited, truncated length: never decodes


@pytest.fixture(scope="module")
def d() -> Iterator[TestDaemon]:
    daemon = TestDaemon("pa10")
    try:
        yield daemon
    finally:
        daemon.close()


def _raw(d: TestDaemon, method: str, streaming: bool = False):  # type: ignore[no-untyped-def]
    make = d.channel.unary_stream if streaming else d.channel.unary_unary
    return make(method, request_serializer=None, response_deserializer=None)


@pytest.mark.parametrize(
    "method",
    [
        "/imotion.v1.IntegratedMotion/ServoOn",  # a command: the thread pool
        "/imotion.v1.IntegratedMotion/MoveLinearCartesianRel",
        "/imotion.v1.IntegratedMotion/GetState",  # a read: the event loop
        "/imotion.v1.IntegratedMotion/Stop",  # urgent: a pool of its own
        "/imotion.v1.ManipulatorMiddle/MovePTPJointAbs",
    ],
)
def test_undecodable_bytes_answer_invalid_argument_without_traceback(
    d: TestDaemon, method: str, caplog: pytest.LogCaptureFixture
):
    before = d.controller.started
    with caplog.at_level(logging.INFO), pytest.raises(grpc.RpcError) as err:
        _raw(d, method)(BAD, timeout=30.0)
    assert err.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    assert "malformed request" in (err.value.details() or "")
    assert d.controller.started == before  # nothing ran
    assert not [r for r in caplog.records if r.exc_info], "a traceback was logged"


def test_a_stream_with_undecodable_bytes_is_refused(d: TestDaemon):
    with pytest.raises(grpc.RpcError) as err:
        list(_raw(d, "/imotion.v1.Monitor/StreamState", streaming=True)(BAD, timeout=30.0))
    assert err.value.code() == grpc.StatusCode.INVALID_ARGUMENT


def test_good_requests_still_work_after_bad_ones(d: TestDaemon):
    from controller.rpc import imotion_pb2 as pb

    reply = d.spec_a.GetState(pb.GetStateRequest(), timeout=30.0)
    assert reply.return_id.id == 0


def test_repeated_reports_are_rate_limited(caplog: pytest.LogCaptureFixture):
    now = [0.0]
    log = _RateLimitedLog(10.0, clock=lambda: now[0])
    with caplog.at_level(logging.WARNING, logger="imotiond.gateway"):
        for _ in range(5):
            log.warn("/x/Y", "bad")
        now[0] = 11.0
        log.warn("/x/Y", "bad")
        log.warn("/x/Z", "bad")
    lines = [r.getMessage() for r in caplog.records]
    assert lines == [
        "undecodable request to /x/Y: bad",
        "undecodable request to /x/Y: bad (4 more since the last report)",
        "undecodable request to /x/Z: bad",
    ]

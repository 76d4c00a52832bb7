"""controller.gateway.grpc.monitor: StreamState limits, slots and sample contents (pa10, ideal).

The linear-move-on-the-line check through StreamState lives in test_service_spec_a.py.
"""

from __future__ import annotations

from collections.abc import Iterator

import grpc
import pytest

from controller.gateway.grpc.replies import SpecAState as S
from controller.rpc import imotion_pb2 as pb
from tests.daemon_support import TestDaemon


@pytest.fixture(scope="module")
def d() -> Iterator[TestDaemon]:
    daemon = TestDaemon("pa10", "ideal", 250.0, **{"monitor.max_streams": 1})
    try:
        yield daemon
    finally:
        daemon.close()


def _first(stream: grpc.Future) -> pb.StateSample:
    return next(iter(stream))  # type: ignore[call-overload]


def test_a_cancelled_slow_stream_frees_its_slot_at_once(d: TestDaemon):
    slow = d.monitor.StreamState(pb.StreamStateRequest(rate_hz=0.001))  # raised to 0.01 Hz
    assert _first(slow).sequence == 0
    busy = d.monitor.StreamState(pb.StreamStateRequest(rate_hz=10.0))
    with pytest.raises(grpc.RpcError) as err:
        _first(busy)
    assert err.value.code() == grpc.StatusCode.RESOURCE_EXHAUSTED
    assert "at most 1" in str(err.value.details())
    slow.cancel()
    free = False
    for _ in range(100):  # the slot comes back within a moment, not after 100 s
        again = d.monitor.StreamState(pb.StreamStateRequest(rate_hz=10.0))
        try:
            free = _first(again).sequence == 0
        except grpc.RpcError as exc:
            assert exc.code() == grpc.StatusCode.RESOURCE_EXHAUSTED
        again.cancel()
        if free:
            break
        d.wait_for(lambda: False, 0.05)
    assert free


def test_samples(d: TestDaemon):
    stream = d.monitor.StreamState(pb.StreamStateRequest(rate_hz=0.0))  # server default
    it = iter(stream)
    first, second = next(it), next(it)
    stream.cancel()
    assert (first.sequence, second.sequence) == (0, 1)
    assert second.stamp_s > first.stamp_s
    assert first.status_id == S.SERVO_OFF and first.status_message.startswith("ServoOff")
    assert [j.unit for j in first.joints] == [pb.RIGHT_ARM]  # pa10: one arm, no waist/vehicle
    assert len(first.joints[0].position) == 7
    assert [c.arm for c in first.control_points] == [pb.RIGHT]
    assert len(first.control_points[0].pose.car_pos.m) == 12
    assert not first.alarms
    assert second.loop.cycles > first.loop.cycles > 0

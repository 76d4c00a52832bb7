"""controller.gateway.grpc.monitor: StreamState limits, slots and sample contents (pa10, ideal).

The linear-move-on-the-line check through StreamState lives in test_service_spec_a.py.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import grpc
import pytest

from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import SpecAState as S
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


def _open(d: TestDaemon, rate_hz: float) -> tuple[grpc.Future, Iterator[pb.StateSample]]:
    """A stream and its samples, once the daemon's one stream slot is free: a stream the
    previous test cancelled gives its slot back a moment later, not at once."""
    for _ in range(200):
        stream = d.monitor.StreamState(pb.StreamStateRequest(rate_hz=rate_hz))
        samples = iter(stream)  # type: ignore[call-overload]
        try:
            first = next(samples)
        except grpc.RpcError as exc:
            assert exc.code() == grpc.StatusCode.RESOURCE_EXHAUSTED, exc
            stream.cancel()
            d.wait_for(lambda: False, 0.05)
            continue
        return stream, itertools.chain([first], samples)
    raise AssertionError("the stream slot never came free")


def test_a_cancelled_slow_stream_frees_its_slot_at_once(d: TestDaemon):
    slow, samples = _open(d, 0.001)  # raised to 0.01 Hz
    assert next(samples).sequence == 0
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
    stream, it = _open(d, 0.0)  # server default
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


def test_samples_name_joints_with_limits_commands_motion_and_wall_time(d: TestDaemon):
    """What `imotion watch` shows: joint names and limits, commanded vs measured, the
    running motion and the queue, the daemon's wall-clock time."""
    d.reset()
    assert d.wait_for(lambda: d.state() == S.READY)
    probe, samples = _open(d, 50.0)
    before = next(samples)
    probe.cancel()
    arm = before.joints[0]
    assert list(arm.names) == list(d.ctx.robot.unit_joints("RIGHT_ARM"))
    assert len(arm.commanded) == len(arm.limits) == len(arm.position) == 7
    assert all(lim.upper > lim.lower for lim in arm.limits)
    assert all(lim.lower <= p <= lim.upper for lim, p in zip(arm.limits, arm.position, strict=True))
    assert before.wall_time_s > 1.6e9  # seconds since the Unix epoch, not a monotonic clock
    assert before.motion.queue_depth == d.cfg.queue_depth and before.motion.queued == 0
    assert not before.motion.active
    target = list(arm.position)
    target[0] += 20.0
    reply = d.middle.MovePTPJointAbs(
        pb.ManipulatorMiddleMovePTPJointAbsRequest(arm=pb.RIGHT, joint_points=target)
    )
    assert reply.return_id.id == 0, reply.return_id.comment
    stream, samples = _open(d, 250.0)
    moving = None
    for sample in samples:
        if sample.motion.active:
            moving = sample
            break
        if sample.motion.finished > before.motion.finished:
            break  # ended before a sample caught it (a very slow machine)
    stream.cancel()
    assert moving is None or moving.motion.started == before.motion.started + 1
    assert d.wait_idle()
    probe, samples = _open(d, 50.0)
    after = next(samples)
    probe.cancel()
    assert after.motion.started == after.motion.finished == before.motion.started + 1
    assert after.joints[0].commanded[0] == pytest.approx(target[0], abs=0.01)

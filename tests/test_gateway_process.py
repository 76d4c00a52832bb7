"""controller.gateway.process: the gRPC gateway under many concurrent readers (issue 17.12):
reads, a move and its stop are all answered."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator

import grpc
import pytest

from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import SpecAState as S
from tests.daemon_support import TestDaemon

#: Deadline of every wait below [s] (a condition, never a measured time).
DEADLINE = 60.0
READERS = 32


def _wait(predicate: Callable[[], bool]) -> bool:
    end = time.monotonic() + DEADLINE
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.005)
    return False


@pytest.fixture(scope="module")
def d() -> Iterator[TestDaemon]:
    daemon = TestDaemon("pa10")
    try:
        yield daemon
    finally:
        daemon.close()


class Readers:
    """``READERS`` clients, a channel each, calling getState / getFeedbackPosCartesian
    back to back until stopped; every answer and every error is counted."""

    def __init__(self, address: str):
        self.address = address
        self.done = threading.Event()
        self.errors: list[str] = []
        self.answers = 0
        self._lock = threading.Lock()
        self.threads = [threading.Thread(target=self._run, args=(k,)) for k in range(READERS)]

    def __enter__(self) -> Readers:
        for t in self.threads:
            t.start()
        return self

    def __exit__(self, *_: object) -> None:
        self.done.set()
        for t in self.threads:
            t.join(DEADLINE)

    def _run(self, k: int) -> None:
        channel = grpc.insecure_channel(self.address)
        stub = pb_grpc.IntegratedMotionStub(channel)
        pose = pb.GetFeedbackPosCartesianRequest(type=pb.RIGHT)
        try:
            while not self.done.is_set():
                if k & 1:
                    rid = stub.GetFeedbackPosCartesian(pose, timeout=DEADLINE).return_id
                else:
                    rid = stub.GetState(pb.GetStateRequest(), timeout=DEADLINE).return_id
                with self._lock:
                    self.answers += 1
                    if rid.id != 0:
                        self.errors.append(rid.comment)
        except grpc.RpcError as exc:
            self.errors.append(f"{exc.code().name}: {exc.details()}")
        finally:
            channel.close()


def test_many_concurrent_readers_do_not_hold_up_a_move_nor_its_stop(d: TestDaemon):
    d.reset()
    assert _wait(lambda: d.state() == S.READY)
    with Readers(d.address) as readers:
        assert _wait(lambda: readers.answers >= 2 * READERS), "the readers got no answers"
        move = pb.MoveUnitRelRequest(
            unit=pb.RIGHT_ARM, rel_pos=[40, 0, 0, 0, 0, 0, 0], speed=[4.0], accel=[20.0]
        )
        reply = d.spec_a.MoveUnitRel(move, timeout=DEADLINE)
        assert reply.return_id.id == 0, reply.return_id.comment
        assert _wait(lambda: d.state() == S.BUSY)
        seen = readers.answers
        assert d.spec_a.Stop(pb.StopRequest(), timeout=DEADLINE).return_id.id == 0
        assert _wait(lambda: not d.spec_a.IsMoving(pb.IsMovingRequest()).is_moving)
        assert d.state() == S.READY
        assert _wait(lambda: readers.answers > seen)  # still answering after the stop
        assert d.spec_a.Abort(pb.AbortRequest(), timeout=DEADLINE).return_id.id == 0
        assert d.spec_a.ServoOff(pb.ServoOffRequest(), timeout=DEADLINE).return_id.id == 0
        assert d.spec_a.ServoOn(pb.ServoOnRequest(), timeout=DEADLINE).return_id.id == 0
    assert not readers.errors, readers.errors[:3]


def test_a_stream_and_readers_together(d: TestDaemon):
    d.reset()
    stream = d.monitor.StreamState(pb.StreamStateRequest(rate_hz=100.0), timeout=DEADLINE)
    try:
        with Readers(d.address) as readers:
            assert _wait(lambda: readers.answers >= 2 * READERS)
            samples = iter(stream)
            first = next(samples).sequence
            assert next(samples).sequence == first + 1
        assert not readers.errors, readers.errors[:3]
    finally:
        stream.cancel()


def test_streams_never_take_the_threads_of_the_unary_calls():
    """Monitor streams run in a pool of their own (controller/gateway/grpc/registrar.py):
    with two worker threads and four streams open, the unary calls are all answered, a
    fifth stream is refused at once, and a command still runs."""
    daemon = TestDaemon("pa10", workers=2, **{"monitor.max_streams": 4})
    streams = []
    try:
        for _ in range(4):
            stream = daemon.monitor.StreamState(pb.StreamStateRequest(rate_hz=1.0))
            streams.append(stream)
            assert next(iter(stream)).sequence == 0  # open, holding its thread
        extra = daemon.monitor.StreamState(pb.StreamStateRequest(rate_hz=1.0), timeout=DEADLINE)
        with pytest.raises(grpc.RpcError) as err:
            next(iter(extra))
        assert err.value.code() == grpc.StatusCode.RESOURCE_EXHAUSTED
        with Readers(daemon.address) as readers:
            assert _wait(lambda: readers.answers >= 4 * READERS), "reads starved"
            reply = daemon.spec_a.ServoOn(pb.ServoOnRequest(), timeout=DEADLINE)
            assert reply.return_id.id == 0, reply.return_id.comment
        assert not readers.errors, readers.errors[:3]
    finally:
        for stream in streams:
            stream.cancel()
        daemon.close()

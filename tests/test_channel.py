"""controller.contract.channel: the authenticated Unix-socket command channel."""

from __future__ import annotations

import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from controller.contract.channel import KEY_NAME, ChannelError, CommandClient, CommandServer
from controller.control.process import Request
from controller.vocabulary import ReturnCode


class FakeController:
    """Answers like Controller.submit: ``echo`` returns its arguments, ``refuse`` refuses."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, dict]] = []
        self.slow_started = threading.Event()
        self.release_slow = threading.Event()

    def submit(self, name: str, timeout: float = 5.0, **args: Any) -> Request:
        self.calls.append((name, args))
        request = Request(name, args)
        if name == "slow":  # like a servoOn waiting for the drives
            self.slow_started.set()
            assert self.release_slow.wait(30.0)
            request.ok = True
        elif name == "refuse":
            request.code, request.message = ReturnCode.STATUS_ERR, "not now"
        else:
            request.ok, request.value = True, {"echo": args}
        request.done.set()
        return request


@pytest.fixture
def runtime() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="imd-"))
    try:
        yield path
    finally:
        for child in path.iterdir():
            child.unlink()
        path.rmdir()


@pytest.fixture
def server(runtime: Path) -> Iterator[tuple[CommandServer, FakeController]]:
    fake = FakeController()
    srv = CommandServer(fake, runtime)  # type: ignore[arg-type]
    srv.start()
    try:
        yield srv, fake
    finally:
        srv.close()


def test_calls_and_refusals(runtime: Path, server):
    _, fake = server
    client = CommandClient(runtime)
    try:
        assert client.call("echo", x=1, y=[2.0]) == (True, {"echo": {"x": 1, "y": [2.0]}}, "")
        assert client.call("refuse") == (False, ReturnCode.STATUS_ERR, "not now")
    finally:
        client.close()
    assert [c[0] for c in fake.calls] == ["echo", "refuse"]
    assert (runtime / KEY_NAME).stat().st_mode & 0o777 == 0o600


def test_one_client_many_threads(runtime: Path, server):
    client = CommandClient(runtime)
    results: list[tuple[bool, Any, str]] = []

    def worker(k: int) -> None:
        for i in range(20):
            results.append(client.call("echo", k=k, i=i))

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30.0)
    client.close()
    assert len(results) == 80 and all(ok for ok, _, _ in results)
    assert {(v["echo"]["k"], v["echo"]["i"]) for _, v, _ in results} == {
        (k, i) for k in range(4) for i in range(20)
    }


def test_a_wrong_key_is_rejected(runtime: Path, server):
    _, fake = server
    (runtime / KEY_NAME).write_bytes(b"0" * 32)  # a client with another key
    intruder = CommandClient(runtime)
    with pytest.raises(ChannelError, match="did not accept our key"):
        intruder.call("echo", x=1)
    assert not fake.calls


def test_a_slow_call_holds_up_no_other_caller(runtime: Path, server):
    """A stop must not wait behind a slow command of another client (issue 9)."""
    _, fake = server
    client = CommandClient(runtime)
    slow = threading.Thread(target=client.call, args=("slow",))
    slow.start()
    try:
        assert fake.slow_started.wait(30.0)
        # The slow call is still in the control process; this one gets through regardless.
        assert client.call("stop") == (True, {"echo": {}}, "")
        assert slow.is_alive()
    finally:
        fake.release_slow.set()
        slow.join(30.0)
        client.close()
    assert [name for name, _ in fake.calls] == ["slow", "stop"]


def test_an_unpicklable_argument_leaves_the_client_usable(runtime: Path, server):
    client = CommandClient(runtime)
    try:
        with pytest.raises(Exception, match="pickle"):
            client.call("echo", x=lambda: None)
        assert client.call("echo", x=1) == (True, {"echo": {"x": 1}}, "")
    finally:
        client.close()


def test_control_process_gone(runtime: Path, server):
    srv, _ = server
    srv.close()
    client = CommandClient(runtime)
    with pytest.raises(ChannelError, match="not reachable"):
        client.call("echo")
    client.close()

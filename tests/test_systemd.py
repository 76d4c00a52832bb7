"""controller.daemon.systemd: sd_notify datagrams and the watchdog period (no libsystemd)."""

from __future__ import annotations

import os
import socket
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from controller.daemon import systemd


@pytest.fixture
def listener() -> Iterator[tuple[str, socket.socket]]:
    directory = Path(tempfile.mkdtemp(prefix="imd-"))
    path = directory / "notify"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(str(path))
    sock.settimeout(2.0)
    try:
        yield str(path), sock
    finally:
        sock.close()
        path.unlink()
        directory.rmdir()


def test_notify_outside_systemd_does_nothing(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.delenv("NOTIFY_SOCKET", raising=False)
    assert systemd.notify("READY=1") is False


def test_notify_sends_one_datagram(monkeypatch: pytest.MonkeyPatch, listener):
    path, sock = listener
    monkeypatch.setenv("NOTIFY_SOCKET", path)
    assert systemd.notify("READY=1", "STATUS=ready on 127.0.0.1:50051")
    assert sock.recv(4096) == b"READY=1\nSTATUS=ready on 127.0.0.1:50051"


def test_notify_abstract_socket(monkeypatch: pytest.MonkeyPatch):
    name = f"imotion-test-{os.getpid()}"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind("\0" + name)
        sock.settimeout(2.0)
        monkeypatch.setenv("NOTIFY_SOCKET", "@" + name)
        assert systemd.notify("WATCHDOG=1")
        assert sock.recv(100) == b"WATCHDOG=1"


def test_notify_to_a_missing_socket_is_false(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    monkeypatch.setenv("NOTIFY_SOCKET", str(tmp_path / "nobody"))
    assert systemd.notify("READY=1") is False


@pytest.mark.parametrize(
    "usec, pid, period",
    [
        (None, None, None),
        ("2000000", None, 2.0),
        ("500000", "self", 0.5),
        ("500000", "1", None),  # the watchdog is another process's
        ("0", None, None),
        ("soon", None, None),
    ],
)
def test_watchdog_period(monkeypatch: pytest.MonkeyPatch, usec, pid, period):
    for key, value in (("WATCHDOG_USEC", usec), ("WATCHDOG_PID", pid)):
        if value is None:
            monkeypatch.delenv(key, raising=False)
        else:
            monkeypatch.setenv(key, str(os.getpid()) if value == "self" else value)
    assert systemd.watchdog_period() == period

"""The command channel between the gateway and the control process (a Unix socket).

Requests are ``(name, args)`` tuples, answers ``(ok, value_or_code, message)``; both are
pickled by :mod:`multiprocessing.connection`, which also authenticates the peer with a
random key kept in the (private, 0700) runtime directory. The control side runs one thread
per connection; each thread only forwards to :meth:`Controller.submit` and waits (without
holding the GIL) for the loop's answer.
"""

from __future__ import annotations

import logging
import os
import secrets
import threading
from multiprocessing import AuthenticationError
from multiprocessing.connection import Client, Connection, Listener
from pathlib import Path
from typing import Any, Protocol

from controller.errors import ChannelError
from controller.vocabulary import ReturnCode


class Answer(Protocol):
    """The loop's answer to one command."""

    @property
    def ok(self) -> bool: ...
    @property
    def value(self) -> Any: ...
    @property
    def code(self) -> int:
        """A ReturnCode value (when not ``ok``)."""
        ...

    @property
    def message(self) -> str: ...


class CommandSink(Protocol):
    """What the control process offers the channel: run one command, wait for its answer."""

    def submit(self, name: str, timeout: float = ..., **args: Any) -> Answer: ...


_log = logging.getLogger("imotiond.channel")

SOCKET_NAME = "control.sock"
KEY_NAME = "control.key"


class CommandServer:
    """Accepts gateway connections and forwards their commands to the loop."""

    def __init__(self, controller: CommandSink, runtime_dir: Path):
        self.controller = controller
        key = secrets.token_bytes(32)
        key_path = Path(runtime_dir) / KEY_NAME
        fd = os.open(key_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(key)
        self.address = str(Path(runtime_dir) / SOCKET_NAME)
        self.listener = Listener(self.address, family="AF_UNIX", authkey=key)
        self._closed = False
        self.thread = threading.Thread(target=self._accept, name="command-accept", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def _accept(self) -> None:
        while not self._closed:
            try:
                conn = self.listener.accept()
            except Exception as exc:
                if not self._closed:
                    _log.warning("command channel: rejected a connection: %s", exc)
                continue
            threading.Thread(
                target=self._serve, args=(conn,), name="command-conn", daemon=True
            ).start()

    def _serve(self, conn: Connection) -> None:
        with conn:
            while True:
                try:
                    name, args = conn.recv()
                except (EOFError, OSError):
                    return
                except Exception as exc:
                    conn.send((False, int(ReturnCode.NG), f"malformed command: {exc}"))
                    continue
                request = self.controller.submit(name, **args)
                if request.ok:
                    conn.send((True, request.value, ""))
                else:
                    conn.send((False, int(request.code), request.message))

    def close(self) -> None:
        self._closed = True
        try:
            self.listener.close()
        except OSError:
            pass


class CommandClient:
    """The gateway side; thread-safe. Each call uses a connection of its own (taken from a
    pool of idle ones, opened when none is idle), so a slow command never holds up another
    caller: a stop sent while a servoOn waits for the drives reaches the loop at once."""

    def __init__(self, runtime_dir: Path):
        runtime_dir = Path(runtime_dir)
        self._key = (runtime_dir / KEY_NAME).read_bytes()
        self._address = str(runtime_dir / SOCKET_NAME)
        self._lock = threading.Lock()  # guards the pool only, never held during a call
        self._idle: list[Connection] = []
        self._closed = False

    def _connect(self) -> Connection:
        with self._lock:
            if self._idle:
                return self._idle.pop()
        try:
            return Client(self._address, family="AF_UNIX", authkey=self._key)
        except OSError as exc:
            raise ChannelError(f"control process not reachable: {exc}") from None
        except AuthenticationError:
            raise ChannelError(
                f"control process not reachable: {self._address} did not accept our key "
                "(another daemon's runtime directory?)"
            ) from None

    def call(self, name: str, **args: Any) -> tuple[bool, Any, str]:
        """``(True, value, "")`` or ``(False, code, message)`` (code: a ReturnCode value)."""
        conn = self._connect()
        try:
            conn.send((name, args))
            reply: tuple[bool, Any, str] = conn.recv()
        except (EOFError, OSError) as exc:
            conn.close()
            raise ChannelError(f"control process not reachable: {exc}") from None
        except BaseException:
            conn.close()  # e.g. an argument that cannot be pickled: the stream is unusable
            raise
        with self._lock:
            if self._closed:
                conn.close()
            else:
                self._idle.append(conn)
        return reply

    def close(self) -> None:
        with self._lock:
            self._closed = True
            idle, self._idle = self._idle, []
        for conn in idle:
            conn.close()

"""Connection to the imotion daemon and the per-service proxies.

``Client.connect()`` opens a gRPC channel (TCP ``host:port`` or ``unix:/path``), checks that the
daemon answers, and offers the operations of each interface family under their original
names: ``client.integrated`` (Spec A), ``client.arm(RIGHT|LEFT)`` / ``client.right_arm`` /
``client.left_arm`` (JARA_ARM Common + Middle), ``client.dual`` (JARA_ARM_DUAL Common +
Middle) and ``client.monitor``.

Security: on a loopback or Unix-socket address the channel is plain unless
``root_certificates`` is given; on any other address it is always TLS (with the given roots,
or the system's). A ``token`` is sent with every call as ``authorization: Bearer <token>``.
"""

from __future__ import annotations

import ipaddress
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import grpc
from google.protobuf.message import Message

from controller.client.codes import ReturnID
from controller.client.convert import resolve_enum
from controller.client.errors import ClientError, from_rpc_error
from controller.client.monitor import Monitor
from controller.client.service import ServiceProxy
from controller.client.types import RightLeft
from controller.rpc import imotion_pb2, imotion_pb2_grpc

DEFAULT_ADDRESS = "127.0.0.1:50051"
#: Seconds the connection check may take [s].
DEFAULT_CONNECT_TIMEOUT = 5.0
#: Deadline of one unary call [s]; motion commands return when motion has started.
DEFAULT_CALL_TIMEOUT = 30.0
_LOCAL_SCHEMES = ("unix:", "unix-abstract:")


def host_of(address: str) -> str:
    """The host part of a gRPC target (``"[::1]:50051"`` -> ``"::1"``); "" for Unix sockets."""
    if address.startswith(_LOCAL_SCHEMES):
        return ""
    target = address
    for prefix in ("dns:///", "dns:", "ipv4:", "ipv6:"):
        if target.startswith(prefix):
            target = target[len(prefix) :]
            break
    if target.startswith("["):
        return target[1 : target.find("]")] if "]" in target else target[1:]
    if target.count(":") > 1:  # bare IPv6 without port
        return target
    return target.rsplit(":", 1)[0] if ":" in target else target


def is_local(address: str) -> bool:
    """True for Unix sockets, ``localhost`` and loopback IP addresses."""
    if address.startswith(_LOCAL_SCHEMES):
        return True
    host = host_of(address)
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _read_roots(root_certificates: str | os.PathLike[str] | bytes) -> bytes:
    if isinstance(root_certificates, bytes):
        return root_certificates
    try:
        return Path(root_certificates).read_bytes()
    except OSError as exc:
        raise ClientError(
            f"cannot read the TLS root certificate {root_certificates}: {exc.strerror}"
        ) from None


def open_channel(
    address: str, root_certificates: str | os.PathLike[str] | bytes | None = None
) -> grpc.Channel:
    """A gRPC channel to ``address``: plain when local without roots, else TLS."""
    if root_certificates is None and is_local(address):
        return grpc.insecure_channel(address)
    roots = None if root_certificates is None else _read_roots(root_certificates)
    return grpc.secure_channel(address, grpc.ssl_channel_credentials(root_certificates=roots))


class Transport:
    """The channel plus what every call carries (token metadata, deadline, error mapping)."""

    def __init__(
        self, channel: grpc.Channel, address: str, token: str | None, call_timeout: float | None
    ) -> None:
        self.channel = channel
        self.address = address
        self.call_timeout = call_timeout
        self.metadata: tuple[tuple[str, str], ...] = (
            (("authorization", f"Bearer {token}"),) if token else ()
        )

    def unary(self, label: str, rpc: Callable[..., Any], request: Message) -> Any:
        try:
            return rpc(request, timeout=self.call_timeout, metadata=self.metadata or None)
        except grpc.RpcError as exc:
            raise from_rpc_error(exc, self.address, label) from None


class Client:
    """The imotion daemon's interfaces; use :meth:`connect` (or the module's ``connect``)."""

    def __init__(
        self,
        channel: grpc.Channel,
        address: str = DEFAULT_ADDRESS,
        token: str | None = None,
        call_timeout: float | None = DEFAULT_CALL_TIMEOUT,
    ) -> None:
        if isinstance(channel, str):
            raise TypeError(f"Client() takes a grpc.Channel; use Client.connect({channel!r})")
        self.address = address
        self.channel = channel
        self.transport = Transport(channel, address, token, call_timeout)
        #: Spec A IntegratedMotionInterface.
        self.integrated = ServiceProxy(self.transport, ["IntegratedMotion"], label="integrated")
        #: JARA_ARM (Common + Middle) of the right arm (the only arm on a one-arm robot).
        self.right_arm = ServiceProxy(
            self.transport,
            ["ManipulatorCommon", "ManipulatorMiddle"],
            bound={"arm": RightLeft.RIGHT},
            label="arm RIGHT",
        )
        #: JARA_ARM_LEFT (Common + Middle).
        self.left_arm = ServiceProxy(
            self.transport,
            ["ManipulatorCommon", "ManipulatorMiddle"],
            bound={"arm": RightLeft.LEFT},
            label="arm LEFT",
        )
        #: JARA_ARM_DUAL (Common + Middle).
        self.dual = ServiceProxy(
            self.transport, ["DualManipulatorCommon", "DualManipulatorMiddle"], label="dual"
        )
        #: Live state stream.
        self.monitor = Monitor(channel, address, self.transport.metadata)

    @classmethod
    def connect(
        cls,
        address: str | None = None,
        token: str | None = None,
        root_certificates: str | os.PathLike[str] | bytes | None = None,
        timeout: float = DEFAULT_CONNECT_TIMEOUT,
        call_timeout: float | None = DEFAULT_CALL_TIMEOUT,
        check: bool = True,
    ) -> Client:
        """Open a connection to the daemon at ``address`` (default ``127.0.0.1:50051``).

        ``token``: bearer token sent with every call. ``root_certificates``: PEM file (path or
        bytes) of the CA that signed the daemon's certificate; enables TLS. ``timeout`` [s]
        bounds the connection check, ``call_timeout`` [s] every later call (None: no limit).
        With ``check`` the daemon is asked ``getVersion`` once, so that an unreachable daemon
        or a refused token raises here (:class:`DaemonUnavailable`,
        :class:`AuthenticationError`) with the address in the message.
        """
        address = address or DEFAULT_ADDRESS
        try:
            channel = open_channel(address, root_certificates)
        except ValueError as exc:  # malformed target
            raise ClientError(f"bad daemon address {address!r}: {exc}") from None
        client = cls(channel, address, token, call_timeout)
        if check:
            saved = client.transport.call_timeout
            client.transport.call_timeout = timeout
            try:
                client.integrated.getVersion()
            except ClientError:
                channel.close()
                raise
            finally:
                client.transport.call_timeout = saved
        return client

    def arm(self, side: RightLeft | str | int) -> ServiceProxy:
        """The JARA_ARM operations of one arm (``RIGHT``/``LEFT``, enum, name or number)."""
        number = resolve_enum(imotion_pb2.RightLeft.DESCRIPTOR, side, "arm")
        return self.right_arm if number == RightLeft.RIGHT else self.left_arm

    def wait_until_idle(self, timeout: float | None = None, poll: float = 0.05) -> bool:
        """Poll ``isMoving`` until no axis moves: True when idle, False after ``timeout`` [s].

        ``None`` waits without limit. A timeout is not an error; a lost daemon raises.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            result = self.integrated.isMoving()
            if not result.isMoving:
                return True
            if deadline is not None and time.monotonic() >= deadline:
                return False
            delay = poll if deadline is None else min(poll, max(0.0, deadline - time.monotonic()))
            time.sleep(delay)

    # ------------------------------------------------------------------ testing (hal hil)
    def inject_fault(self, kind: str, target: str = "", **params: object) -> ReturnID:
        """Inject fault ``kind`` into drive (joint name) or bus ``target`` of the drive
        emulator (``imotiond --hal hil`` with ``testing.fault_injection: true``). ``params``
        by name, e.g. ``code=0x8110``, ``cycles=2``, ``fault=False``."""
        request = imotion_pb2.TestingInjectFaultRequest(
            kind=kind, target=target, params={k: _param_text(v) for k, v in params.items()}
        )
        stub = imotion_pb2_grpc.TestingStub(self.channel)
        reply = self.transport.unary("inject", stub.InjectFault, request)
        return ReturnID(reply.return_id.id, reply.return_id.comment)

    def clear_faults(self, kind: str = "", target: str = "") -> tuple[ReturnID, int]:
        """Clear lasting injected faults (all of them by default); ``(ReturnID, cleared)``."""
        request = imotion_pb2.TestingClearFaultsRequest(kind=kind, target=target)
        stub = imotion_pb2_grpc.TestingStub(self.channel)
        reply = self.transport.unary("clear faults", stub.ClearFaults, request)
        return ReturnID(reply.return_id.id, reply.return_id.comment), int(reply.cleared)

    def close(self) -> None:
        self.channel.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<imotion Client {self.address}>"


def connect(
    address: str | None = None,
    token: str | None = None,
    root_certificates: str | os.PathLike[str] | bytes | None = None,
    timeout: float = DEFAULT_CONNECT_TIMEOUT,
    call_timeout: float | None = DEFAULT_CALL_TIMEOUT,
    check: bool = True,
) -> Client:
    """Shorthand for :meth:`Client.connect`."""
    return Client.connect(address, token, root_certificates, timeout, call_timeout, check)


def _param_text(value: object) -> str:
    """A fault parameter as the Testing service reads it (bools as true/false)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)

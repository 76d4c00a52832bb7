"""An in-process fake imotion daemon for the client and CLI tests.

Every RPC of every imotion.v1 service is served by one generic handler: it records the call
(service, RPC, request, metadata) and answers ``ReturnID(OK, "<Rpc> done")`` plus canned
outputs derived from the response descriptor (:func:`canned`). Tests override single RPCs
with ``fake.handlers[(service, rpc)] = fn(request) -> response``.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from concurrent import futures
from dataclasses import dataclass, field
from typing import Any

import grpc
from google.protobuf.descriptor import Descriptor, FieldDescriptor
from google.protobuf.message import Message

from controller.rpc import imotion_pb2, imotion_pb2_grpc

SERVICES = [
    "IntegratedMotion",
    "ManipulatorCommon",
    "ManipulatorMiddle",
    "DualManipulatorCommon",
    "DualManipulatorMiddle",
]
#: The canned HgMatrix: 90° about z, p = (10, 20, 30) mm.
CANNED_HG = [0.0, -1.0, 0.0, 10.0, 1.0, 0.0, 0.0, 20.0, 0.0, 0.0, 1.0, 30.0]


def canned_value(f: FieldDescriptor) -> Any:
    """A fixed non-default value for one field (the single element for repeated fields)."""
    if f.type == FieldDescriptor.TYPE_MESSAGE:
        return canned(f.message_type)
    if f.type == FieldDescriptor.TYPE_ENUM:
        return 1
    return {
        FieldDescriptor.TYPE_DOUBLE: 1.5,
        FieldDescriptor.TYPE_BOOL: True,
        FieldDescriptor.TYPE_STRING: f"{f.name} text",
        FieldDescriptor.TYPE_INT32: -1,
    }.get(f.type, 7)


def canned(descriptor: Descriptor) -> Message:
    """A message of this type with every field set to its canned value."""
    cls = getattr(imotion_pb2, descriptor.name)
    if descriptor.name == "HgMatrix":
        return cls(m=CANNED_HG)  # type: ignore[no-any-return]
    values: dict[str, Any] = {}
    for f in descriptor.fields:
        if f.name == "return_id":
            continue
        if f.is_repeated and f.type == FieldDescriptor.TYPE_DOUBLE:
            values[f.name] = [1.0, 2.0, 3.0]
        elif f.is_repeated:
            values[f.name] = [canned_value(f)]
        else:
            values[f.name] = canned_value(f)
    return cls(**values)  # type: ignore[no-any-return]


@dataclass
class Call:
    service: str
    rpc: str
    request: Message
    metadata: dict[str, str]


@dataclass
class FakeDaemon:
    calls: list[Call] = field(default_factory=list)
    handlers: dict[tuple[str, str], Callable[[Any], Message]] = field(default_factory=dict)
    samples: list[Message] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def handle(self, service: str, rpc: str, request: Message, context: Any) -> Message:
        metadata = {k: v for k, v in context.invocation_metadata()}
        with self.lock:
            self.calls.append(Call(service, rpc, request, metadata))
            handler = self.handlers.get((service, rpc))
        if handler is not None:
            return handler(request)
        method = imotion_pb2.DESCRIPTOR.services_by_name[service].methods_by_name[rpc]
        response = canned(method.output_type)
        response.return_id.CopyFrom(imotion_pb2.ReturnID(id=0, comment=f"{rpc} done"))  # type: ignore[attr-defined]
        return response

    def stream(self, request: Message, context: Any) -> Iterator[Message]:
        metadata = {k: v for k, v in context.invocation_metadata()}
        with self.lock:
            self.calls.append(Call("Monitor", "StreamState", request, metadata))
        samples = self.samples or [canned(imotion_pb2.StateSample.DESCRIPTOR)]
        yield from samples

    def last(self, rpc: str | None = None) -> Call:
        with self.lock:
            calls = [c for c in self.calls if rpc is None or c.rpc == rpc]
        assert calls, f"no call of {rpc}"
        return calls[-1]

    def reset(self) -> None:
        with self.lock:
            self.calls.clear()
            self.handlers.clear()
            self.samples.clear()


def _servicer(service: str, fake: FakeDaemon) -> Any:
    base = getattr(imotion_pb2_grpc, f"{service}Servicer")
    methods: dict[str, Any] = {}
    for method in imotion_pb2.DESCRIPTOR.services_by_name[service].methods:

        def handler(self: Any, request: Message, context: Any, _rpc: str = method.name) -> Any:
            return fake.handle(service, _rpc, request, context)

        methods[method.name] = handler
    return type(f"Fake{service}", (base,), methods)()


class _FakeMonitor(imotion_pb2_grpc.MonitorServicer):
    def __init__(self, fake: FakeDaemon) -> None:
        self.fake = fake

    def StreamState(self, request: Any, context: Any) -> Iterator[Message]:
        return self.fake.stream(request, context)


def start(address: str = "127.0.0.1:0") -> tuple[grpc.Server, FakeDaemon, str]:
    """A running fake daemon: (server, fake, the address to connect to)."""
    fake = FakeDaemon()
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=8))
    for service in SERVICES:
        getattr(imotion_pb2_grpc, f"add_{service}Servicer_to_server")(
            _servicer(service, fake), server
        )
    imotion_pb2_grpc.add_MonitorServicer_to_server(_FakeMonitor(fake), server)
    port = server.add_insecure_port(address)
    server.start()
    if address.startswith("unix:"):
        return server, fake, address
    return server, fake, f"127.0.0.1:{port}"

"""controller.gateway.grpc.registrar: handlers changed once at registration, and methods
run in a thread pool of their own (grpcio's ``experimental_thread_pool``)."""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import grpc

from controller.gateway.grpc.registrar import Registrar, chain, in_pool, streams_in_pool

DEADLINE = 30.0


class _Details:
    def __init__(self, method: str):
        self.method = method
        self.invocation_metadata = ()


def _handler() -> grpc.RpcMethodHandler:
    return grpc.unary_unary_rpc_method_handler(lambda r, c: r, lambda b: b, lambda r: r)


class _Generic(grpc.GenericRpcHandler):
    def __init__(self, handlers: dict[str, grpc.RpcMethodHandler]):
        self.handlers = handlers

    def service(self, handler_call_details: Any) -> Any:
        return self.handlers.get(handler_call_details.method)


class _Sink:
    """Records what a Registrar registers."""

    def __init__(self) -> None:
        self.generic: list[grpc.GenericRpcHandler] = []
        self.registered: dict[str, dict[str, grpc.RpcMethodHandler]] = {}

    def add_generic_rpc_handlers(self, handlers: Any) -> None:
        self.generic.extend(handlers)

    def add_registered_method_handlers(self, service: str, handlers: Any) -> None:
        self.registered[service] = handlers


def test_handlers_are_wrapped_once_at_registration():
    calls: list[str] = []

    def wrap(method: str, handler: grpc.RpcMethodHandler) -> grpc.RpcMethodHandler:
        calls.append(method)
        return _handler()

    sink = _Sink()
    first = _handler()
    registrar = Registrar(sink, wrap)  # type: ignore[arg-type]
    registrar.add_registered_method_handlers("x.S", {"Y": first})
    assert calls == ["/x.S/Y"] and sink.registered["x.S"]["Y"] is not first
    generic = {"/x.S/Y": first}
    registrar.add_generic_rpc_handlers((_Generic(generic),))
    (wrapped,) = sink.generic
    a = wrapped.service(_Details("/x.S/Y"))  # type: ignore[attr-defined]
    assert a is not first and wrapped.service(_Details("/x.S/Y")) is a  # type: ignore[attr-defined]
    assert calls == ["/x.S/Y", "/x.S/Y"]  # once per method, not per call
    generic["/x.S/Y"] = _handler()  # another handler for the method: wrapped anew
    assert wrapped.service(_Details("/x.S/Y")) is not a  # type: ignore[attr-defined]
    assert wrapped.service(_Details("/x.S/Z")) is None  # type: ignore[attr-defined]


def test_chain_applies_in_order():
    seen: list[str] = []

    def mark(tag: str) -> Any:
        def wrap(method: str, handler: grpc.RpcMethodHandler) -> grpc.RpcMethodHandler:
            seen.append(tag)
            return handler

        return wrap

    chain(mark("a"), mark("b"))("/x.S/Y", _handler())
    assert seen == ["a", "b"]


def test_methods_run_in_their_own_pool():
    """grpcio runs a method whose function carries ``experimental_thread_pool`` in that pool
    (the Monitor streams rely on it: if grpcio stopped honouring it, this fails)."""
    main = ThreadPoolExecutor(max_workers=2, thread_name_prefix="main")
    own = ThreadPoolExecutor(max_workers=2, thread_name_prefix="own")
    server = grpc.server(main)

    def name(request: bytes, context: Any) -> bytes:
        return threading.current_thread().name.encode()

    def names(request: bytes, context: Any) -> Any:
        yield threading.current_thread().name.encode()

    handlers = {
        "Plain": grpc.unary_unary_rpc_method_handler(name),
        "Own": grpc.unary_unary_rpc_method_handler(name),
        "Stream": grpc.unary_stream_rpc_method_handler(names),
    }

    def wrap(method: str, handler: grpc.RpcMethodHandler) -> grpc.RpcMethodHandler:
        return in_pool(handler, own) if method.endswith("/Own") else handler

    registrar = Registrar(server, chain(wrap, streams_in_pool(own)))
    registrar.add_registered_method_handlers("x.S", handlers)
    port = server.add_insecure_port("127.0.0.1:0")
    server.start()
    channel = grpc.insecure_channel(f"127.0.0.1:{port}")
    try:
        plain = channel.unary_unary("/x.S/Plain", _registered_method=True)(b"", timeout=DEADLINE)
        mine = channel.unary_unary("/x.S/Own", _registered_method=True)(b"", timeout=DEADLINE)
        stream = channel.unary_stream("/x.S/Stream", _registered_method=True)(b"", timeout=DEADLINE)
        (streamed,) = list(stream)
        assert plain.startswith(b"main") and mine.startswith(b"own"), (plain, mine)
        assert streamed.startswith(b"own"), streamed
    finally:
        channel.close()
        server.stop(None)
        own.shutdown()

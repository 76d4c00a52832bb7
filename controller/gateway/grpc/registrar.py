"""Method handlers changed once, when the servicers are registered, instead of per call.

The generated ``add_*Servicer_to_server`` functions hand every method's handler to the
server; :class:`Registrar` stands in for the server there and passes each handler through a
function first (the undecodable-request guard, the thread pool of the streams). A server
interceptor would do the same work again on every call, before every call.

:func:`in_pool` runs a method in a thread pool of its own: grpcio (the synchronous server)
runs a method whose function has an ``experimental_thread_pool`` attribute (a
ThreadPoolExecutor) in that pool instead of the server's. The Monitor streams use it: each
stream holds its thread for as long as it runs, and in a pool of their own they never take
the threads the unary calls are answered from (tests/test_registrar.py pins that grpcio
still honours the attribute).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import grpc

#: How a handler is changed at registration: (full method name, handler) -> handler.
Wrap = Callable[[str, grpc.RpcMethodHandler], grpc.RpcMethodHandler]


class _WrappedGeneric(grpc.GenericRpcHandler):
    """A generic handler whose answers pass through ``wrap`` (once per method)."""

    def __init__(self, inner: grpc.GenericRpcHandler, wrap: Wrap):
        self.inner = inner
        self.wrap = wrap
        self._known: dict[str, tuple[grpc.RpcMethodHandler, grpc.RpcMethodHandler]] = {}

    def service(self, handler_call_details: grpc.HandlerCallDetails) -> Any:
        handler = self.inner.service(handler_call_details)
        if handler is None:
            return None
        method = handler_call_details.method
        known = self._known.get(method)
        if known is None or known[0] is not handler:
            known = self._known[method] = (handler, self.wrap(method, handler))
        return known[1]


class Registrar:
    """What the generated ``add_*Servicer_to_server(servicer, server)`` functions get as
    their ``server``: registers on ``server`` every handler as ``wrap`` changed it."""

    def __init__(self, server: grpc.Server, wrap: Wrap):
        self.server = server
        self.wrap = wrap

    def add_generic_rpc_handlers(self, handlers: Sequence[grpc.GenericRpcHandler]) -> None:
        self.server.add_generic_rpc_handlers(tuple(_WrappedGeneric(h, self.wrap) for h in handlers))

    def add_registered_method_handlers(
        self, service: str, handlers: dict[str, grpc.RpcMethodHandler]
    ) -> None:
        wrapped = {name: self.wrap(f"/{service}/{name}", h) for name, h in handlers.items()}
        self.server.add_registered_method_handlers(service, wrapped)


def chain(*wraps: Wrap) -> Wrap:
    """One wrap applying ``wraps`` in order (the last one outermost)."""

    def wrap(method: str, handler: grpc.RpcMethodHandler) -> grpc.RpcMethodHandler:
        for w in wraps:
            handler = w(method, handler)
        return handler

    return wrap


def in_pool(handler: grpc.RpcMethodHandler, pool: ThreadPoolExecutor) -> grpc.RpcMethodHandler:
    """``handler`` (unary-unary or unary-stream) running in ``pool`` instead of the server's
    thread pool."""
    if handler.unary_stream is not None:
        behaviour, make = handler.unary_stream, grpc.unary_stream_rpc_method_handler
    elif handler.unary_unary is not None:
        behaviour, make = handler.unary_unary, grpc.unary_unary_rpc_method_handler
    else:
        raise ValueError("in_pool: only unary-unary and unary-stream methods")

    def run(request: Any, context: grpc.ServicerContext) -> Any:
        return behaviour(request, context)

    run.experimental_thread_pool = pool  # type: ignore[attr-defined]
    return make(run, handler.request_deserializer, handler.response_serializer)


def streams_in_pool(pool: ThreadPoolExecutor) -> Wrap:
    """A wrap running every server-streaming method in ``pool``."""

    def wrap(method: str, handler: grpc.RpcMethodHandler) -> grpc.RpcMethodHandler:
        return in_pool(handler, pool) if handler.unary_stream is not None else handler

    return wrap

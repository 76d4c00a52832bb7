"""Requests whose bytes do not decode: INVALID_ARGUMENT and one (rate-limited) log line.

grpcio answers an undecodable request with INTERNAL and logs a traceback per call. This
guard wraps every method's deserializer: a request that does not decode becomes a marker
the handler turns into ``INVALID_ARGUMENT`` with a comment, before any servicer runs.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

import grpc

_log = logging.getLogger("imotiond.gateway")

#: At most one log line per method in this many seconds; the rest are counted.
LOG_INTERVAL = 10.0


class _Undecodable:
    """Stands for a request whose bytes did not decode."""

    def __init__(self, error: Exception):
        self.reason = str(error) or type(error).__name__


class _RateLimitedLog:
    def __init__(self, interval: float, clock: Callable[[], float] = time.monotonic):
        self.interval = interval
        self.clock = clock
        self._last: dict[str, float] = {}
        self._suppressed: dict[str, int] = {}

    def warn(self, method: str, reason: str) -> None:
        now = self.clock()
        last = self._last.get(method)
        if last is not None and now - last < self.interval:
            self._suppressed[method] = self._suppressed.get(method, 0) + 1
            return
        more = self._suppressed.pop(method, 0)
        extra = f" ({more} more since the last report)" if more else ""
        self._last[method] = now
        _log.warning("undecodable request to %s: %s%s", method, reason, extra)


class MalformedRequestGuard:
    """Turns undecodable requests into INVALID_ARGUMENT (see the module docstring).

    :meth:`wrap` is applied to every method's handler once, when the servicers are
    registered (controller/gateway/grpc/registrar.py): a call pays one more function call
    for it, no interceptor.
    """

    def __init__(self, interval: float = LOG_INTERVAL):
        self.log = _RateLimitedLog(interval)

    def wrap(self, method: str, handler: grpc.RpcMethodHandler) -> grpc.RpcMethodHandler:
        """``handler`` with a deserializer that never raises and a refusal of what it
        could not decode."""
        decode = handler.request_deserializer
        if decode is None:
            return handler

        def safe_decode(data: bytes) -> Any:
            try:
                return decode(data)
            except Exception as exc:
                return _Undecodable(exc)

        def refuse(request: _Undecodable, context: grpc.ServicerContext) -> None:
            self.log.warn(method, request.reason)
            context.abort(
                grpc.StatusCode.INVALID_ARGUMENT,
                f"malformed request: the bytes do not decode as {method}'s request message",
            )

        if handler.unary_unary is not None:
            inner_uu = handler.unary_unary

            def unary_unary(request: Any, context: grpc.ServicerContext) -> Any:
                if isinstance(request, _Undecodable):
                    return refuse(request, context)
                return inner_uu(request, context)

            return grpc.unary_unary_rpc_method_handler(
                unary_unary, safe_decode, handler.response_serializer
            )
        if handler.unary_stream is not None:
            inner_us = handler.unary_stream

            def unary_stream(request: Any, context: grpc.ServicerContext) -> Any:
                if isinstance(request, _Undecodable):
                    refuse(request, context)
                    return
                yield from inner_us(request, context)

            return grpc.unary_stream_rpc_method_handler(
                unary_stream, safe_decode, handler.response_serializer
            )
        return handler

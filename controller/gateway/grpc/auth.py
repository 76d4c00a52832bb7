"""Client tokens: checked before a call reaches any servicer (and so the motion core).

When tokens are configured every call must carry ``authorization: Bearer <token>``
metadata. Read-only operations (``Get*``, ``Is*``, ``StreamState``) accept the read token or
the motion token; everything else only the motion token. Without configured tokens (the
loopback / Unix-socket default) calls are not checked.
"""

from __future__ import annotations

import hmac
from collections.abc import Callable
from typing import Any

import grpc

from controller.contract.config import TokensConfig


def is_read_only(method: str) -> bool:
    """``/imotion.v1.Service/Rpc`` names a read-only operation."""
    name = method.rsplit("/", 1)[-1]
    return name.startswith(("Get", "Is")) or name == "StreamState"


def _deny(code: grpc.StatusCode, message: str, streaming: bool) -> grpc.RpcMethodHandler:
    def abort(request: Any, context: grpc.ServicerContext) -> Any:
        context.abort(code, message)

    if streaming:
        return grpc.unary_stream_rpc_method_handler(abort)
    return grpc.unary_unary_rpc_method_handler(abort)


class TokenInterceptor(grpc.ServerInterceptor):
    """The token check of every call (the one interceptor of the gateway). Per method, the
    tokens it accepts are worked out once (a call then costs a metadata scan and one
    constant-time comparison per accepted token)."""

    def __init__(self, tokens: TokensConfig):
        self.motion = tokens.motion
        self.read = tokens.read
        #: method -> the tokens (bytes) it accepts
        self._allowed: dict[str, tuple[bytes, ...]] = {}
        #: Tokens are configured: calls are checked.
        self.enabled = bool(self.motion or self.read)

    def _tokens_for(self, method: str) -> tuple[bytes, ...]:
        allowed = self._allowed.get(method)
        if allowed is None:
            tokens = [self.motion] + ([self.read] if is_read_only(method) else [])
            allowed = self._allowed[method] = tuple(t.encode() for t in tokens if t)
        return allowed

    def _accepts(self, method: str, token: str) -> bool:
        given = token.encode()
        return any(hmac.compare_digest(t, given) for t in self._tokens_for(method))

    def intercept_service(
        self,
        continuation: Callable[[grpc.HandlerCallDetails], grpc.RpcMethodHandler],
        handler_call_details: grpc.HandlerCallDetails,
    ) -> grpc.RpcMethodHandler:
        handler = continuation(handler_call_details)
        if not self.enabled or handler is None:
            return handler
        method = handler_call_details.method
        header: object = ""
        for key, value in handler_call_details.invocation_metadata or ():
            if key == "authorization":
                header = value  # the last one, as a dict of the metadata would keep
        token = header[7:] if isinstance(header, str) and header.startswith("Bearer ") else ""
        streaming = handler.unary_stream is not None
        if not token:
            return _deny(
                grpc.StatusCode.UNAUTHENTICATED,
                "missing token: send metadata 'authorization: Bearer <token>'",
                streaming,
            )
        if not self._accepts(method, token):
            what = "read-only" if is_read_only(method) else "motion"
            return _deny(
                grpc.StatusCode.PERMISSION_DENIED,
                f"the token is not valid for {what} operations ({method})",
                streaming,
            )
        return handler

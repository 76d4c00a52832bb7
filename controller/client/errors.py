"""Exceptions of the client library; every message names the daemon address."""

from __future__ import annotations

import grpc

from controller import errors


class ClientError(Exception):
    """Base class: the client could not get an answer to an operation."""


class DaemonUnavailable(ClientError, ConnectionError):
    """The daemon cannot be reached (not running, wrong address, TLS mismatch, timeout)."""


class AuthenticationError(ClientError, PermissionError):
    """The daemon refused the call: token missing or wrong."""


class RpcFailed(ClientError):
    """The daemon answered with a gRPC error status instead of a ReturnID."""

    def __init__(self, message: str, code: grpc.StatusCode | None = None) -> None:
        super().__init__(message)
        self.code = code


class ArgumentError(ClientError, errors.ArgumentError):
    """An argument cannot be converted to the contract's type; nothing was sent (VALUE_ERR)."""


_UNREACHABLE = (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.DEADLINE_EXCEEDED)
_REFUSED = (grpc.StatusCode.UNAUTHENTICATED, grpc.StatusCode.PERMISSION_DENIED)


def from_rpc_error(error: grpc.RpcError, address: str, operation: str) -> ClientError:
    """The :class:`ClientError` for a failed call of ``operation`` on the daemon at ``address``."""
    code = error.code() if isinstance(error, grpc.Call) else None
    details = (error.details() if isinstance(error, grpc.Call) else None) or str(error)
    details = " ".join(details.split())
    if code in _UNREACHABLE:
        if code == grpc.StatusCode.DEADLINE_EXCEEDED:
            why = "no answer in time"
        else:
            why = details
        return DaemonUnavailable(f"imotion daemon at {address} unreachable ({operation}): {why}")
    if code in _REFUSED:
        return AuthenticationError(
            f"imotion daemon at {address} refused {operation}: {details} "
            "(give a valid token: token= / --token / IMOTION_TOKEN)"
        )
    name = code.name if code is not None else "error"
    return RpcFailed(f"imotion daemon at {address}: {operation} failed: {name}: {details}", code)

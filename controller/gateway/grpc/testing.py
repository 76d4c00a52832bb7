"""The Testing service: fault injection into the drive emulator of ``--hal hil``.

Off unless the configuration sets ``testing.fault_injection``; a motion call (the token
interceptor asks for the motion token). Parameters arrive as text and are read here:
integers (decimal or ``0x`` hex), ``true``/``false``, otherwise the text itself (a bus name).
The emulator checks kinds, targets and parameter names (VALUE_ERR naming what is wrong).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from controller.errors import ArgumentError, StateError
from controller.gateway.grpc.base import rpc
from controller.gateway.services.context import Context
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc

#: Longest text of a kind, target, parameter name or value.
MAX_TEXT = 64


def _text(value: str, name: str) -> str:
    if len(value) > MAX_TEXT or not value.isprintable():
        raise ArgumentError(f"{name}: at most {MAX_TEXT} printable characters")
    return value


def parse_params(params: Mapping[str, str]) -> dict[str, Any]:
    """Parameter texts as values: int (``12``, ``0x8110``), bool (``true``/``false``), text."""
    out: dict[str, Any] = {}
    for key, text in params.items():
        _text(key, "params")
        _text(text, f"params[{key}]")
        low = text.strip().lower()
        if low in ("true", "false"):
            out[key] = low == "true"
            continue
        try:
            out[key] = int(low, 0)
        except ValueError:
            out[key] = text.strip()
    return out


class TestingServicer(pb_grpc.TestingServicer):
    __test__ = False  # not a pytest class

    def __init__(self, ctx: Context):
        self.ctx = ctx

    def _require_enabled(self) -> None:
        if not self.ctx.config.testing.fault_injection:
            raise StateError(
                "fault injection is off: start imotiond with --set testing.fault_injection=true "
                "(HIL only, never on a real robot)"
            )

    @rpc(pb.TestingInjectFaultResponse)
    def InjectFault(self, request: pb.TestingInjectFaultRequest) -> str:
        kind = _text(request.kind, "kind")
        target = _text(request.target, "target")
        params = parse_params(request.params)
        self._require_enabled()
        self.ctx.call("inject_fault", kind=kind, target=target, params=params)
        where = f" into {target}" if target else ""
        return f"OK: {kind} injected{where}"

    @rpc(pb.TestingClearFaultsResponse)
    def ClearFaults(self, request: pb.TestingClearFaultsRequest) -> dict[str, Any]:
        kind = _text(request.kind, "kind")
        target = _text(request.target, "target")
        self._require_enabled()
        cleared = int(self.ctx.call("clear_faults", kind=kind, target=target))
        return {"cleared": cleared, "comment": f"OK: {cleared} lasting fault(s) cleared"}

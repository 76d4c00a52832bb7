"""Monitor.StreamState as a Python iterator of :class:`~controller.client.types.StateSample`."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import grpc

from controller.client.convert import from_message
from controller.client.errors import from_rpc_error
from controller.client.types import StateSample
from controller.rpc import imotion_pb2, imotion_pb2_grpc


class StateStream(Iterator[StateSample]):
    """Samples until :meth:`cancel` (or leaving the ``with`` block); daemon errors raise."""

    def __init__(self, call: Any, address: str) -> None:
        self._call = call
        self._address = address
        self._cancelled = False

    def __next__(self) -> StateSample:
        try:
            message = next(self._call)
        except grpc.RpcError as exc:
            if self._cancelled or (
                isinstance(exc, grpc.Call) and exc.code() == grpc.StatusCode.CANCELLED
            ):
                raise StopIteration from None
            raise from_rpc_error(exc, self._address, "Monitor.StreamState") from None
        sample: StateSample = from_message(message)
        return sample

    def cancel(self) -> None:
        """End the stream (the daemon stops sending)."""
        self._cancelled = True
        self._call.cancel()

    def __enter__(self) -> StateStream:
        return self

    def __exit__(self, *exc: object) -> None:
        self.cancel()


class Monitor:
    """imotion's own Monitor service."""

    def __init__(self, channel: grpc.Channel, address: str, metadata: tuple[tuple[str, str], ...]):
        self._stub = imotion_pb2_grpc.MonitorStub(channel)
        self._address = address
        self._metadata = metadata

    def stream(self, rate_hz: float = 0.0) -> StateStream:
        """Live state samples at ``rate_hz`` [Hz] (0: the daemon's default rate)."""
        request = imotion_pb2.StreamStateRequest(rate_hz=float(rate_hz))
        call = self._stub.StreamState(request, metadata=self._metadata or None)
        return StateStream(call, self._address)

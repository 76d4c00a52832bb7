"""A small Foxglove WebSocket protocol client (``foxglove.websocket.v1``) and message decoding.

Enough to look at imotiond's live view from Python or the shell (``imotion view``) and to
test it: the server's channels, subscriptions with decoded messages, parameters and assets.
Protobuf channels are decoded with the schema the server sends (a FileDescriptorSet), JSON
channels with ``json``; MCAP files written with the same schemas decode the same way
(:func:`decoder`).
"""

from __future__ import annotations

import base64
import json
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, json_format, message_factory
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

SUBPROTOCOL = "foxglove.sdk.v1"
OP_MESSAGE_DATA = 0x01
OP_FETCH_ASSET_RESPONSE = 0x04

Decoder = Callable[[bytes], dict[str, Any]]


def decoder(encoding: str, schema_name: str, schema: bytes) -> Decoder:
    """A function turning one message of a channel into a dict.

    ``encoding``: the message encoding (``json`` or ``protobuf``); ``schema``: for protobuf
    the binary FileDescriptorSet of ``schema_name``.
    """
    if encoding == "json":
        return lambda data: dict(json.loads(data))
    if encoding != "protobuf":
        raise ValueError(f"no decoder for message encoding {encoding!r}")
    files = descriptor_pb2.FileDescriptorSet.FromString(schema)
    pool = descriptor_pool.DescriptorPool()
    for f in files.file:
        pool.Add(f)
    cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))

    def decode(data: bytes) -> dict[str, Any]:
        return json_format.MessageToDict(cls.FromString(data), preserving_proto_field_name=True)

    return decode


@dataclass
class ChannelInfo:
    id: int
    topic: str
    encoding: str
    schema_name: str
    decode: Decoder


class LiveViewClient:
    """A connection to a Foxglove-protocol server, e.g. ``ws://127.0.0.1:8765``."""

    def __init__(self, url: str, timeout: float = 5.0):
        self.url = url
        self.ws: ClientConnection = connect(
            url,
            subprotocols=[Subprotocol(SUBPROTOCOL)],
            open_timeout=timeout,
            max_size=None,
            legacy=True,
        )
        self.server_info: dict[str, Any] = {}
        self.channels: dict[int, ChannelInfo] = {}
        self._subs: dict[int, ChannelInfo] = {}
        self._next_sub = 1
        self._pending: list[Any] = []
        self.wait_for(lambda m: isinstance(m, dict) and m.get("op") == "serverInfo", timeout)
        self.server_info = self._last
        self.wait_for(lambda _: bool(self.channels), timeout)

    _last: Any = None

    # ------------------------------------------------------------------ receiving
    def _receive(self, timeout: float) -> Any:
        raw = self.ws.recv(timeout=timeout)
        if isinstance(raw, str):
            msg = json.loads(raw)
            if msg.get("op") == "advertise":
                for c in msg["channels"]:
                    self.channels[c["id"]] = self._channel(c)
            elif msg.get("op") == "unadvertise":
                for cid in msg["channelIds"]:
                    self.channels.pop(cid, None)
            return msg
        op = raw[0]
        if op == OP_MESSAGE_DATA:
            sub, stamp = struct.unpack_from("<IQ", raw, 1)
            info = self._subs.get(sub)
            if info is None:
                return None
            return ("message", info.topic, stamp, info.decode(bytes(raw[13:])))
        if op == OP_FETCH_ASSET_RESPONSE:
            request, status, n = struct.unpack_from("<IBI", raw, 1)
            error = bytes(raw[10 : 10 + n]).decode()
            return ("asset", request, status, error, bytes(raw[10 + n :]))
        return None

    @staticmethod
    def _channel(c: dict[str, Any]) -> ChannelInfo:
        encoding = c["encoding"]
        schema = c.get("schema", "")
        if encoding == "protobuf":
            data = base64.b64decode(schema)
        else:
            data = schema.encode()
        return ChannelInfo(c["id"], c["topic"], encoding, c.get("schemaName", ""),
                           decoder(encoding, c.get("schemaName", ""), data))  # fmt: skip

    def wait_for(self, match: Callable[[Any], bool], timeout: float = 5.0) -> Any:
        """The first received item for which ``match`` holds (TimeoutError after ``timeout``).

        Items: JSON control messages as dicts; ``("message", topic, log_time_ns, dict)``;
        ``("asset", request_id, status, error, data)``.
        """
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"{self.url}: nothing matching within {timeout:g} s")
            try:
                item = self._receive(left)
            except TimeoutError:
                continue
            self._last = item
            if item is not None and match(item):
                return item

    # ------------------------------------------------------------------ requests
    def topics(self) -> dict[str, ChannelInfo]:
        return {c.topic: c for c in self.channels.values()}

    def subscribe(self, *topics: str) -> None:
        """Subscribe to ``topics`` (all advertised channels when none is given)."""
        wanted = [c for c in self.channels.values() if not topics or c.topic in topics]
        subs = []
        for c in wanted:
            self._subs[self._next_sub] = c
            subs.append({"id": self._next_sub, "channelId": c.id})
            self._next_sub += 1
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def next_message(self, topic: str, timeout: float = 5.0) -> dict[str, Any]:
        """The next decoded message on a subscribed ``topic``."""
        item = self.wait_for(
            lambda m: isinstance(m, tuple) and m[0] == "message" and m[1] == topic, timeout
        )
        return dict(item[3])

    def parameters(self, *names: str, timeout: float = 5.0) -> dict[str, Any]:
        """Parameter values by name (all parameters when no name is given)."""
        self.ws.send(json.dumps({"op": "getParameters", "parameterNames": list(names),
                                 "id": "imotion"}))  # fmt: skip
        reply = self.wait_for(
            lambda m: isinstance(m, dict) and m.get("op") == "parameterValues", timeout
        )
        return {p["name"]: p.get("value") for p in reply["parameters"]}

    def fetch_asset(self, uri: str, timeout: float = 5.0) -> bytes | None:
        """The asset's bytes, or None when the server has no such asset."""
        request = self._next_sub + 100000
        self.ws.send(json.dumps({"op": "fetchAsset", "uri": uri, "requestId": request}))
        reply = self.wait_for(
            lambda m: isinstance(m, tuple) and m[0] == "asset" and m[1] == request, timeout
        )
        return reply[4] if reply[2] == 0 else None

    def close(self) -> None:
        """Closes the connection, reading what still comes until the server's close frame.

        A subscribed connection that is not read fills websockets' incoming buffer within
        a fraction of a second (every channel at the view rate); websockets then stops
        reading the socket, so a plain ``close()`` never saw the server's close frame and
        waited out its close timeout: 10 s on every exit of ``imotion view --listen``."""
        closer = threading.Thread(target=self.ws.close, name="live-view-close", daemon=True)
        closer.start()
        try:
            while True:  # ends with the close handshake (or websockets' close timeout)
                self.ws.recv()
        except ConnectionClosed:
            pass
        closer.join()

    def __enter__(self) -> LiveViewClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

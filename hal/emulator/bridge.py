"""Serving the emulator's buses to other processes with python-can-remote (no vcan needed).

Each emulated bus is a python-can ``virtual`` channel inside the emulator's process. A
:class:`can_remote.RemoteServer` per bus listens on TCP (``host``, ``port + i``; port 0 =
any free port) and opens, for every client that connects, a new ``virtual`` bus on that
channel: a master in another process joins bus ``i`` with python-can
``interface="remote", channel="ws://host:port_i/"``. One endpoint per bus because a
python-can-remote server serves exactly one channel (the URL path is not used).

All of it stays on the host given (use 127.0.0.1; never a multicast transport).
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass

from can_remote import RemoteServer

log = logging.getLogger(__name__)


@dataclass
class Endpoint:
    """One served bus."""

    bus: str
    url: str
    server: RemoteServer
    thread: threading.Thread


class BusBridge:
    """python-can-remote servers for ``channels`` (bus name -> virtual channel)."""

    def __init__(self, channels: dict[str, str], host: str = "127.0.0.1", port: int = 0):
        if not 0 <= port <= 65535:
            raise ValueError(f"port must be in 0..65535, got {port}")
        self.endpoints: list[Endpoint] = []
        try:
            for i, (bus, channel) in enumerate(channels.items()):
                wanted = port + i if port else 0
                try:
                    server = RemoteServer(host, wanted, interface="virtual", channel=channel)
                except OSError as exc:
                    raise OSError(f"bus {bus}: cannot listen on {host}:{wanted}: {exc}") from exc
                bound = server.server_address[1]
                thread = threading.Thread(
                    target=server.serve_forever, kwargs={"poll_interval": 0.1},
                    name=f"bridge-{bus}", daemon=True,
                )  # fmt: skip
                self.endpoints.append(Endpoint(bus, f"ws://{host}:{bound}/", server, thread))
        except BaseException:
            self.close()
            raise

    def start(self) -> None:
        for endpoint in self.endpoints:
            endpoint.thread.start()
            log.info("serving bus %s on %s", endpoint.bus, endpoint.url)

    def close(self) -> None:
        for endpoint in self.endpoints:
            if endpoint.thread.is_alive():
                endpoint.server.shutdown()
            endpoint.server.server_close()
        self.endpoints = []

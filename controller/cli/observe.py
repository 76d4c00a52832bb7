"""``imotion record``, ``imotion plot`` and ``imotion view``: record, plot, look.

imotion record FILE.mcap [--seconds N] [--rate HZ]   StreamState to MCAP (Ctrl-C ends)
imotion plot FILE.mcap [--out DIR]                  PNG plots of a recording / black box
imotion view [--url ws://127.0.0.1:8765]            check the daemon's live view
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any
from urllib.parse import quote

from controller.client.client import Client
from controller.client.errors import ClientError

DEFAULT_VIEW_URL = "ws://127.0.0.1:8765"
FOXGLOVE_APP = "https://app.foxglove.dev/~/view?ds=foxglove-websocket&ds.url="


def _finite_positive(name: str, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value}")


def arm_limits(client: Client) -> dict[str, dict[str, Any]]:
    """JARA soft joint limits of each arm the robot has, by recorded name [rad]."""
    out: dict[str, dict[str, Any]] = {}
    for side, unit in (("RIGHT", "RIGHT_ARM"), ("LEFT", "LEFT_ARM")):
        try:
            result = client.arm(side).getSoftLimitJoint()
        except ClientError:
            continue
        if not result.ok:  # e.g. no left arm
            continue
        for k, limit in enumerate(result[1]):
            out[f"{unit}/{k + 1}"] = {
                "kind": "revolute",
                "lower": math.radians(limit.lower),
                "upper": math.radians(limit.upper),
            }
    return out


def record(client: Client, path: Path, seconds: float | None, rate: float, address: str
           ) -> dict[str, Any]:  # fmt: skip
    """Record StreamState at ``rate`` [Hz] for ``seconds`` (None: until Ctrl-C)."""
    from controller.client.recording import Recorder

    start = time.monotonic()
    limits = json.dumps(arm_limits(client))
    meta = {"address": address, "rate_hz": f"{rate:g}", "limits": limits}
    with Recorder(path, meta) as rec:
        stream = client.monitor.stream(rate)
        try:
            for sample in stream:
                rec.add(sample, time.time())
                if seconds is not None and time.monotonic() - start >= seconds:
                    break
        except KeyboardInterrupt:
            pass
        finally:
            stream.cancel()
        samples = rec.samples
    return {"file": str(path), "samples": samples,
            "seconds": round(time.monotonic() - start, 3)}  # fmt: skip


def view_info(url: str, timeout: float, listen_s: float) -> dict[str, Any]:
    """The live view's server name, channels (with a message count over ``listen_s``)."""
    from controller.client.foxglove_ws import LiveViewClient

    with LiveViewClient(url, timeout) as c:
        topics = c.topics()
        counts = dict.fromkeys(topics, 0)
        if listen_s > 0:
            c.subscribe()
            end = time.monotonic() + listen_s
            while (left := end - time.monotonic()) > 0:
                try:
                    item = c.wait_for(lambda m: isinstance(m, tuple), left)
                except TimeoutError:
                    break
                if item[0] == "message":
                    counts[item[1]] += 1
        urdf = c.parameters("/robot_description").get("/robot_description") or ""
        return {
            "url": url,
            "server": c.server_info.get("name", ""),
            "channels": {
                t: {"schema": ch.schema_name, "messages": counts[t]}
                for t, ch in sorted(topics.items())
            },
            "robot_description_chars": len(urdf),
            "open_in_foxglove": FOXGLOVE_APP + quote(url, safe=""),
        }


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, metavar="FILE.mcap", help="output file (replaced)")
    parser.add_argument("--seconds", type=float, metavar="N",
                        help="stop after N s (default: at Ctrl-C)")  # fmt: skip
    parser.add_argument("--rate", type=float, default=50.0, metavar="HZ",
                        help="samples per second (default 50; at most the loop rate)")  # fmt: skip


def add_plot_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, metavar="FILE.mcap", help="a recording or black box")
    parser.add_argument("--out", type=Path, metavar="DIR",
                        help="where the PNGs go (default: next to the file)")  # fmt: skip


def add_view_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--url",
        default=DEFAULT_VIEW_URL,
        help=f"the daemon's live view (view.listen; default {DEFAULT_VIEW_URL})",
    )
    parser.add_argument("--listen", type=float, default=1.0, metavar="SEC",
                        help="count messages per channel for SEC s (default 1)")  # fmt: skip


def print_result(data: dict[str, Any], as_json: bool, lines: list[str]) -> None:
    if as_json:
        print(json.dumps(data))
    else:
        print("\n".join(lines))


def view_lines(info: dict[str, Any]) -> list[str]:
    lines = [f"live view {info['url']} ({info['server']}), "
             f"URDF {info['robot_description_chars']} characters"]  # fmt: skip
    for topic, ch in info["channels"].items():
        lines.append(f"  {topic:26} {ch['schema']:28} {ch['messages']} messages")
    lines.append(f"open in Foxglove: {info['open_in_foxglove']}")
    lines.append("(or in Lichtblick / Foxglove desktop: open connection, Foxglove WebSocket, "
                 f"{info['url']})")  # fmt: skip
    return lines

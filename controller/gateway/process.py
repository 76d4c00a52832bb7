"""The gRPC gateway: every servicer, authentication, TLS, the listening socket.

Runs in its own process (``python -m controller.gateway.process --runtime DIR``, started by
imotiond) so client load never competes with the control loop for the GIL: it reads the
loop's state from shared memory and sends commands over the control channel. It can also
run inside another process (tests) through :func:`start_gateway`.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import signal
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import grpc

from controller.contract.channel import CommandClient
from controller.contract.config import DaemonConfig, parse_listen
from controller.contract.snapshot import SnapshotReader
from controller.gateway.grpc.auth import TokenInterceptor
from controller.gateway.grpc.jara import add_jara_servicers
from controller.gateway.grpc.malformed import MalformedRequestInterceptor
from controller.gateway.grpc.monitor import MonitorServicer
from controller.gateway.grpc.spec_a import IntegratedMotionServicer
from controller.gateway.grpc.testing import TestingServicer
from controller.gateway.observe.blackbox_writer import BlackBoxWriter
from controller.gateway.observe.live_view import LiveView, start_live_view
from controller.gateway.planning.planner import Planner
from controller.gateway.planning.robot_view import RobotView
from controller.gateway.services.context import Context
from controller.logs import setup_logging
from controller.model.robot import load_robot
from controller.rpc import imotion_pb2_grpc as pb_grpc

_log = logging.getLogger("imotiond.gateway")

JOINTS_NAME = "joints.json"
SNAPSHOT_NAME = "snapshot"
BLACKBOX_NAME = "blackbox"


@dataclass
class Observers:
    """What the gateway runs besides gRPC: the live view and the black box's writer."""

    live_view: LiveView | None = None
    blackbox: BlackBoxWriter | None = None

    def close(self) -> None:
        if self.live_view is not None:
            self.live_view.close()
        if self.blackbox is not None:
            self.blackbox.close()


def build_context(cfg: DaemonConfig, runtime_dir: Path) -> Context:
    robot = load_robot(cfg.robot)
    joints = json.loads((runtime_dir / JOINTS_NAME).read_text())
    view = RobotView(robot, SnapshotReader(runtime_dir / SNAPSHOT_NAME, len(joints)), joints)
    plan_view = RobotView(robot, SnapshotReader(runtime_dir / SNAPSHOT_NAME, len(joints)), joints)
    planner = Planner(plan_view, cfg.period, cfg.obstacles)
    return Context(cfg, view, planner, CommandClient(runtime_dir))


def own_view(ctx: Context, runtime_dir: Path) -> RobotView:
    """A RobotView of its own (its own kinematics and lock) on the same snapshot."""
    view = ctx.view
    reader = SnapshotReader(runtime_dir / SNAPSHOT_NAME, len(view.hw_joints))
    return RobotView(view.robot, reader, view.hw_joints)


def start_observers(cfg: DaemonConfig, runtime_dir: Path, ctx: Context) -> Observers:
    """Live view (``view.listen``) and black-box writer (``blackbox.dir``), as configured.

    Both only read shared memory (the snapshot, the black-box ring): the control loop does
    not see them (tools/bench_view.py).
    """
    out = Observers()
    try:
        if cfg.view.listen is not None:
            out.live_view = start_live_view(cfg, own_view(ctx, runtime_dir))
        if cfg.blackbox.dir is not None:
            out.blackbox = BlackBoxWriter(
                runtime_dir / BLACKBOX_NAME,
                cfg.blackbox.dir,
                cfg.blackbox.after_s,
                own_view(ctx, runtime_dir),
            )
    except Exception:
        out.close()
        raise
    return out


def add_servicers(server: grpc.Server, ctx: Context) -> None:
    pb_grpc.add_IntegratedMotionServicer_to_server(IntegratedMotionServicer(ctx), server)
    pb_grpc.add_MonitorServicer_to_server(MonitorServicer(ctx), server)
    add_jara_servicers(server, ctx)
    pb_grpc.add_TestingServicer_to_server(TestingServicer(ctx), server)


def bind(server: grpc.Server, cfg: DaemonConfig) -> str:
    """Bind the configured address (TLS when configured); returns the bound address."""
    kind, host, port = parse_listen(cfg.listen)
    host_text = str(host)
    if kind == "unix":
        target = cfg.listen
    else:
        target = f"[{host_text}]:{port}" if ":" in host_text else f"{host_text}:{port}"
    sec = cfg.security
    if sec.tls_cert is not None and sec.tls_key is not None:
        creds = grpc.ssl_server_credentials(
            [(Path(sec.tls_key).read_bytes(), Path(sec.tls_cert).read_bytes())]
        )
        bound = server.add_secure_port(target, creds)
    else:
        bound = server.add_insecure_port(target)
    if kind == "tcp" and bound == 0:
        raise OSError(f"cannot listen on {cfg.listen} (address in use or not available)")
    if kind == "tcp" and port == 0:
        return f"{host}:{bound}"
    return cfg.listen


def start_gateway(cfg: DaemonConfig, runtime_dir: Path) -> tuple[grpc.Server, str, Context]:
    ctx = build_context(cfg, runtime_dir)
    tokens = TokenInterceptor(cfg.security.tokens)
    # Tokens first: an unauthenticated caller learns nothing, not even that its bytes are bad.
    interceptors: list[grpc.ServerInterceptor] = [tokens] if tokens.enabled else []
    interceptors.append(MalformedRequestInterceptor())
    server = grpc.server(
        ThreadPoolExecutor(max_workers=cfg.workers, thread_name_prefix="grpc"),
        interceptors=interceptors,
        maximum_concurrent_rpcs=cfg.workers * 8,
    )
    add_servicers(server, ctx)
    address = bind(server, cfg)
    server.start()
    return server, address, ctx


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="imotion gRPC gateway (started by imotiond)")
    parser.add_argument("--runtime", type=Path, required=True)
    args = parser.parse_args(argv)
    # The configuration (tokens included) comes through a pipe from imotiond, never through
    # a file: nothing else on the machine can read it.
    cfg = DaemonConfig.model_validate_json(sys.stdin.readline())
    setup_logging(cfg.log_level, "gateway")
    try:
        server, address, ctx = start_gateway(cfg, args.runtime)
        observers = start_observers(cfg, args.runtime, ctx)
    except Exception as exc:
        _log.error("gateway failed to start: %s", exc)
        print(f"FAILED {exc}", flush=True)
        return 1
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    signal.signal(signal.SIGINT, lambda *_: done.set())
    parent = os.getppid()

    def watch_parent() -> None:  # imotiond killed outright: do not serve on as an orphan
        while not done.wait(0.5):
            if os.getppid() != parent:
                _log.error("imotiond (pid %d) is gone: stopping", parent)
                done.set()

    threading.Thread(target=watch_parent, name="parent-watch", daemon=True).start()
    print(f"READY {address}", flush=True)
    _log.info("serving on %s", address)
    done.wait()
    observers.close()
    server.stop(grace=0.3).wait(1.0)
    return 0


if __name__ == "__main__":
    sys.exit(main())

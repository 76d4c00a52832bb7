"""The gateway: every gRPC servicer, authentication, TLS, the listening socket, and the
CORBA servants when ``corba.enabled`` (controller/gateway/corba/).

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
from typing import Any

import grpc

from controller.contract.blackbox import BLACKBOX_NAME
from controller.contract.channel import CommandClient
from controller.contract.config import DaemonConfig, parse_listen
from controller.contract.snapshot import JOINTS_NAME, SNAPSHOT_NAME, SnapshotReader
from controller.gateway.grpc.auth import TokenInterceptor
from controller.gateway.grpc.jara import add_jara_servicers
from controller.gateway.grpc.malformed import MalformedRequestGuard
from controller.gateway.grpc.monitor import MonitorServicer
from controller.gateway.grpc.registrar import Registrar, chain, streams_in_pool
from controller.gateway.grpc.spec_a import IntegratedMotionServicer
from controller.gateway.grpc.testing import TestingServicer
from controller.gateway.observe.blackbox_writer import BlackBoxWriter
from controller.gateway.observe.live_view import LiveView, start_live_view
from controller.gateway.planning.planner import Planner
from controller.gateway.planning.robot_view import RobotView
from controller.gateway.scheduling import apply_nice, freeze_heap, leave_real_time
from controller.gateway.services.context import Context
from controller.gateway.services.registry import Services
from controller.logs import setup_logging
from controller.model.robot import load_robot
from controller.rpc import imotion_pb2_grpc as pb_grpc

_log = logging.getLogger("imotiond.gateway")


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


def add_servicers(server: grpc.Server | Registrar, services: Services) -> None:
    ctx = services.ctx
    pb_grpc.add_IntegratedMotionServicer_to_server(
        IntegratedMotionServicer(ctx, services.spec_a), server
    )
    pb_grpc.add_MonitorServicer_to_server(MonitorServicer(ctx), server)
    add_jara_servicers(server, services)
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


@dataclass
class Gateway:
    """A running gateway: the gRPC server and its address, the services every transport
    shares, and the CORBA server (None unless ``corba.enabled``)."""

    server: grpc.Server
    address: str
    ctx: Context
    services: Services
    streams: ThreadPoolExecutor | None = None  #: the Monitor streams' threads
    corba: Any = None  #: controller.gateway.corba.server.CorbaServer
    rtc: Any = None  #: controller.gateway.corba.rtc.RtComponent (corba.rtc.enabled)

    def stop(self, grace: float | None = None) -> None:
        if self.rtc is not None:  # before the ORB goes: it tells its consumers
            self.rtc.close()
            self.rtc = None
        if self.corba is not None:
            self.corba.close()
            self.corba = None
        self.server.stop(grace).wait(1.0 if grace else None)
        if self.streams is not None:  # the streams ended with the server: free their threads
            self.streams.shutdown(wait=False)


def start_corba_if_enabled(cfg: DaemonConfig, services: Services, runtime_dir: Path) -> Any:
    """The CORBA servants (None when ``corba.enabled`` is false); omniORB is imported only
    then, so the daemon works without the ``corba`` extra."""
    if not cfg.corba.enabled:
        return None
    try:
        from controller.gateway.corba.server import start_corba
    except ImportError as exc:
        raise RuntimeError(
            f"corba.enabled is true but omniORBpy cannot be imported ({exc}): "
            "pip install 'imotion[corba]', or set corba.enabled: false"
        ) from None
    return start_corba(cfg, services, runtime_dir)


def stream_pool_size(cfg: DaemonConfig) -> int:
    """Threads of the Monitor streams' own pool: one per allowed stream, and two more that
    answer a stream over the limit (RESOURCE_EXHAUSTED) at once."""
    return cfg.monitor.max_streams + 2


#: Unary calls in progress or waiting for a worker thread, at least (beyond:
#: RESOURCE_EXHAUSTED): 32 polling clients and a few commands fit with any ``workers``.
MIN_QUEUED_CALLS = 128


def max_calls(cfg: DaemonConfig) -> int:
    """Calls the server takes at once (grpcio's ``maximum_concurrent_rpcs``): eight waiting
    per worker thread, at least :data:`MIN_QUEUED_CALLS`, plus the streams' pool."""
    return max(cfg.workers * 8, MIN_QUEUED_CALLS) + stream_pool_size(cfg)


def start_gateway(cfg: DaemonConfig, runtime_dir: Path) -> Gateway:
    ctx = build_context(cfg, runtime_dir)
    services = Services.build(ctx)
    tokens = TokenInterceptor(cfg.security.tokens)
    # Tokens are the one interceptor (a call's metadata is only known then); everything
    # else is done to the handlers once, at registration. Tokens run first: an
    # unauthenticated caller learns nothing, not even that its bytes are bad.
    workers = ThreadPoolExecutor(max_workers=cfg.workers, thread_name_prefix="grpc")
    streams = ThreadPoolExecutor(max_workers=stream_pool_size(cfg), thread_name_prefix="stream")
    server = grpc.server(
        workers,
        interceptors=[tokens] if tokens.enabled else None,
        maximum_concurrent_rpcs=max_calls(cfg),
    )
    # Streams in a pool of their own: however many are open, the unary calls keep all of
    # the ``workers`` threads.
    guard = MalformedRequestGuard()
    add_servicers(Registrar(server, chain(guard.wrap, streams_in_pool(streams))), services)
    address = bind(server, cfg)
    server.start()
    gateway = Gateway(server, address, ctx, services, streams)
    try:
        gateway.corba = start_corba_if_enabled(cfg, services, runtime_dir)
        if gateway.corba is not None:
            from controller.gateway.corba.rtc.start import start_rtc

            gateway.rtc = start_rtc(cfg, gateway.corba)
    except Exception:
        gateway.stop(0)
        raise
    return gateway


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="imotion gateway: gRPC and CORBA (started by imotiond)"
    )
    parser.add_argument("--runtime", type=Path, required=True)
    args = parser.parse_args(argv)
    # The configuration (tokens included) comes through a pipe from imotiond, never through
    # a file: nothing else on the machine can read it.
    cfg = DaemonConfig.model_validate_json(sys.stdin.readline())
    setup_logging(cfg.log_level, "gateway")
    # A thread planning a move (~20-30 ms of Python) keeps the GIL until another thread has
    # waited a switch interval, and a read needs the GIL several times on its way (gRPC's
    # poll thread, a worker, the poll thread again): at Python's 5 ms a read arriving during
    # planning waited up to ~20 ms (docs/daemon.md, "Reads under client load").
    sys.setswitchinterval(cfg.gateway_switch_interval_s)
    # Before gRPC starts its threads (they inherit both): an ordinary process (never
    # real-time, whoever started it), with its share of the CPU against the machine's other
    # work (docs/daemon.md, "Reads under client load").
    warning = leave_real_time()
    if warning is not None:
        _log.warning("%s", warning)
    if cfg.realtime.enabled:  # the loop is real-time: out of the CFS competition
        warning = apply_nice(cfg.gateway_nice)
        if warning is not None:
            _log.warning("%s", warning)
    else:  # an ordinary loop thread: the gateway must not outrank it
        _log.info("gateway_nice not applied: realtime.enabled is false")
    try:
        gateway = start_gateway(cfg, args.runtime)
    except Exception as exc:
        _log.error("gateway failed to start: %s", exc)
        print(f"FAILED {exc}", flush=True)
        return 1
    address = gateway.address
    try:
        observers = start_observers(cfg, args.runtime, gateway.ctx)
    except Exception as exc:
        gateway.stop(0)
        _log.error("gateway failed to start: %s", exc)
        print(f"FAILED {exc}", flush=True)
        return 1
    # Everything is built: out of the full collections from now on (130-200 ms each, every
    # read waiting for the GIL meanwhile).
    _log.info("%d objects frozen out of the full garbage collections", freeze_heap())
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
    gateway.stop(grace=0.3)
    return 0


if __name__ == "__main__":
    sys.exit(main())

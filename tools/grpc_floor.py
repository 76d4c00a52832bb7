#!/usr/bin/env python3
"""grpcio's floor: a synchronous gRPC server shaped like the gateway (``--workers`` threads,
the same call limit and GIL switch interval) whose getState and getFeedbackPosCartesian
answer a constant message. What a read costs here is what grpcio costs, with none of ours.

Usage: python tools/grpc_floor.py [--workers 16] [--switch-interval 0.0005] [--nice N] [--aio]

Prints ``READY host:port`` once listening (127.0.0.1, a port chosen by the system), then
serves until stdin closes or SIGTERM. tools/bench_clients.py ``--floor`` runs it beside the
daemon and points its paced clients at it, in the same minute as at the gateway. ``--aio``
serves the same replies from a grpc.aio server (one event loop, no worker threads) instead,
to compare the two (docs/daemon.md).
"""

from __future__ import annotations

import argparse
import asyncio
import signal
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import grpc

from controller.gateway.scheduling import apply_nice
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc

_OK = pb.ReturnID(id=0, comment="OK")
STATE = pb.GetStateResponse(return_id=_OK, status_id=2, message="busy")
POSE = pb.GetFeedbackPosCartesianResponse(
    return_id=_OK,
    pos=pb.CarPosWithElbow(
        car_pos=pb.HgMatrix(m=[1.0, 0.0, 0.0, 412.5, 0.0, 1.0, 0.0, -230.1, 0.0, 0.0, 1.0, 815.3]),
        elbow=12.5,
    ),
)


class ConstantServicer(pb_grpc.IntegratedMotionServicer):
    """getState and getFeedbackPosCartesian: the same ready message every time."""

    def GetState(self, request: Any, context: Any) -> Any:
        return STATE

    def GetFeedbackPosCartesian(self, request: Any, context: Any) -> Any:
        return POSE


class AioConstantServicer(pb_grpc.IntegratedMotionServicer):
    """The same replies as coroutines, for a grpc.aio server."""

    async def GetState(self, request: Any, context: Any) -> Any:
        return STATE

    async def GetFeedbackPosCartesian(self, request: Any, context: Any) -> Any:
        return POSE


def serve_aio(done: threading.Event) -> None:
    """The grpc.aio server: "READY host:port", then serve until ``done``."""

    async def run() -> None:
        server = grpc.aio.server(maximum_concurrent_rpcs=128 + 10)
        pb_grpc.add_IntegratedMotionServicer_to_server(AioConstantServicer(), server)
        port = server.add_insecure_port("127.0.0.1:0")
        await server.start()
        print(f"READY 127.0.0.1:{port}", flush=True)
        await asyncio.get_running_loop().run_in_executor(None, done.wait)
        await server.stop(0)

    asyncio.run(run())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=16)
    parser.add_argument("--switch-interval", type=float, default=0.0005, help="[s]")
    parser.add_argument("--nice", type=int, help="this nice value (as the gateway's)")
    parser.add_argument("--aio", action="store_true", help="a grpc.aio server instead")
    args = parser.parse_args()
    sys.setswitchinterval(args.switch_interval)
    if args.nice is not None:
        warning = apply_nice(args.nice)
        if warning is not None:
            print(warning, file=sys.stderr)
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())

    def until_stdin_closes() -> None:
        sys.stdin.read()
        done.set()

    threading.Thread(target=until_stdin_closes, daemon=True).start()
    if args.aio:
        serve_aio(done)
        return 0
    server = grpc.server(
        ThreadPoolExecutor(max_workers=args.workers), maximum_concurrent_rpcs=128 + 10
    )
    pb_grpc.add_IntegratedMotionServicer_to_server(ConstantServicer(), server)
    port = server.add_insecure_port("127.0.0.1:0")
    server.start()
    print(f"READY 127.0.0.1:{port}", flush=True)
    done.wait()
    server.stop(0).wait(1.0)
    return 0


if __name__ == "__main__":
    sys.exit(main())

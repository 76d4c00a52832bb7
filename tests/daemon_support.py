"""A daemon for end-to-end tests: control loop in a thread, gRPC gateway in-process or as
the real child process, clients over real gRPC on 127.0.0.1."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import grpc

from controller.contract.config import load_config
from controller.daemon.main import Daemon
from controller.gateway.process import start_gateway
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc


class TestDaemon:
    """Daemon with the loop in a background thread; ``stubs`` for every service."""

    __test__ = False  # not a test class

    def __init__(
        self, robot: str = "smartpal5", hal: str = "ideal", rate: float = 250.0, **sets: Any
    ):
        overrides = {"robot": robot, "hal": hal, "loop.rate_hz": rate, "listen": "127.0.0.1:0"}
        overrides["realtime.enabled"] = False
        overrides.update(sets)
        self.cfg = load_config(None, overrides)
        self.daemon = Daemon(self.cfg)
        self.thread = threading.Thread(target=self.daemon.run, name="loop", daemon=True)
        self.thread.start()
        self.gateway = start_gateway(self.cfg, self.daemon.runtime)
        self.server, self.address, self.ctx = (
            self.gateway.server,
            self.gateway.address,
            self.gateway.ctx,
        )
        self.channel = grpc.insecure_channel(self.address)
        self.spec_a = pb_grpc.IntegratedMotionStub(self.channel)
        self.common = pb_grpc.ManipulatorCommonStub(self.channel)
        self.middle = pb_grpc.ManipulatorMiddleStub(self.channel)
        self.dual_common = pb_grpc.DualManipulatorCommonStub(self.channel)
        self.dual_middle = pb_grpc.DualManipulatorMiddleStub(self.channel)
        self.monitor = pb_grpc.MonitorStub(self.channel)

    @property
    def controller(self) -> Any:
        return self.daemon.controller

    def state(self) -> int:
        return self.spec_a.GetState(pb.GetStateRequest()).status_id

    def wait_idle(self, timeout: float = 60.0) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            r = self.spec_a.IsMoving(pb.IsMovingRequest())
            if not r.is_moving:
                return True
            time.sleep(0.02)
        return False

    def wait_for(self, predicate: Callable[[], bool], timeout: float = 30.0) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return True
            time.sleep(0.01)
        return False

    def reset(self) -> None:
        """Back to Ready at home-ish state: abort, clear alarms, servo on."""
        self.spec_a.Abort(pb.AbortRequest())
        self.spec_a.ClearAlarms(pb.ClearAlarmsRequest())
        self.spec_a.ServoOn(pb.ServoOnRequest())

    def close(self) -> None:
        self.channel.close()
        self.gateway.stop(0)
        self.daemon.request_shutdown()
        self.thread.join(5.0)
        self.daemon.close()

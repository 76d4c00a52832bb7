"""The real ``imotiond`` with CORBA enabled, as a subprocess, and CORBA clients built from the
product's IDL (controller/corba/stubs) beside gRPC stubs on the same daemon.

The daemon writes an IOR file per servant (``corba.ior_dir``): no naming service and no
fixed port are needed (the ORB listens on ``giop:tcp:127.0.0.1:0``). The gRPC address comes
from the daemon's "ready" log line (port 0 too). Nothing here picks a free port.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import grpc
import numpy as np

from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import SpecAState

REPO = Path(__file__).resolve().parents[1]
START_BOUND = 120.0
UNITS = (
    pb.RIGHT_ARM,
    pb.LEFT_ARM,
    pb.LUMBER,
    pb.VEHICLE,
)  # s: "starts at all" on a loaded machine, not a timing figure

_orb: Any = None


def client_orb() -> Any:
    """This process's ORB, as a client (it never serves: loopback endpoint anyway)."""
    global _orb
    if _orb is None:
        from omniORB import CORBA

        _orb = CORBA.ORB_init(["pytest", "-ORBendPoint", "giop:tcp:127.0.0.1:0"], CORBA.ORB_ID)
    return _orb


#: "Nothing moved" [deg, mm]: a robot at rest in the simulation still shifts by ~1e-5 deg
#: between two reads (servo holding against gravity), and a motion started by a refused
#: command would move far more than this within a cycle or two of its start.
NOTHING_MOVED = 1e-3


class CorbaDaemon:
    """``python -m controller.daemon.main`` with CORBA on, its IORs and both kinds of
    client."""

    __test__ = False

    def __init__(self, *sets: str, robot: str = "smartpal5", hal: str = "sim"):
        self.dir = Path(tempfile.mkdtemp(prefix="imd-corba-"))
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")])
        env.pop("NOTIFY_SOCKET", None)
        cmd = [
            sys.executable, "-m", "controller.daemon.main", "--robot", robot, "--hal", hal,
            "--listen", "127.0.0.1:0", "--set", "realtime.enabled=false",
            "--set", "loop.rate_hz=250", "--set", "corba.enabled=true",
            "--set", f"corba.ior_dir={self.dir / 'ior'}", *(a for s in sets for a in ("--set", s)),
        ]  # fmt: skip
        self.proc = subprocess.Popen(
            cmd, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
        )
        self.lines: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()
        try:
            self.address = self.wait_line(r"msg=\"ready: .* listening on (\S+?)\"").group(1)
        except AssertionError:
            self._stop()
            raise
        self.channel = grpc.insecure_channel(self.address)
        self.spec_a_grpc = pb_grpc.IntegratedMotionStub(self.channel)
        self.common_grpc = pb_grpc.ManipulatorCommonStub(self.channel)
        self.middle_grpc = pb_grpc.ManipulatorMiddleStub(self.channel)
        self.dual_common_grpc = pb_grpc.DualManipulatorCommonStub(self.channel)
        self.dual_middle_grpc = pb_grpc.DualManipulatorMiddleStub(self.channel)
        self.orb = client_orb()
        self.start_pose = {unit: self.unit_joints(unit) for unit in UNITS}

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))

    def wait_line(self, pattern: str, timeout: float = START_BOUND, start: int = 0) -> Any:
        regex = re.compile(pattern)
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for line in self.lines[start:]:
                if m := regex.search(line):
                    return m
            if self.proc.poll() is not None:
                raise AssertionError(f"imotiond exited ({self.proc.returncode}):\n{self.log}")
            time.sleep(0.05)
        raise AssertionError(f"no {pattern!r} within {timeout} s:\n{self.log}")

    @property
    def log(self) -> str:
        return "\n".join(self.lines[-200:])

    def ior(self, key: str) -> str:
        return (self.dir / "ior" / f"{key}.ior").read_text().strip()

    def ref(self, key: str, iface: Any) -> Any:
        obj = self.orb.string_to_object(self.ior(key))
        return obj._narrow(iface)

    # ------------------------------------------------------------------ state
    def state(self) -> int:
        return int(self.spec_a_grpc.GetState(pb.GetStateRequest()).status_id)

    def wait_for(self, predicate: Callable[[], bool], timeout: float = 60.0) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return True
            time.sleep(0.02)
        return False

    def moving(self) -> bool:
        return bool(self.spec_a_grpc.IsMoving(pb.IsMovingRequest()).is_moving)

    def wait_idle(self, timeout: float = 60.0) -> None:
        assert self.wait_for(lambda: not self.moving(), timeout), "still moving"

    def unit_joints(self, unit: int) -> list[float]:
        """One unit's measured joints (deg, vehicle mm/deg; empty if the robot lacks it)."""
        r = self.spec_a_grpc.GetFeedbackPosJoint(pb.GetFeedbackPosJointRequest(type=unit))
        return list(r.position)

    def joints(self) -> np.ndarray:
        """Every unit's measured joints (deg, vehicle mm/deg), over gRPC."""
        return np.array([q for unit in UNITS for q in self.unit_joints(unit)])

    def back_to_start(self) -> None:
        """Every unit back to where it was at start-up (each test module begins there, so
        one module's moves do not leave the next near a limit)."""
        self.ready()
        for unit, q in self.start_pose.items():
            if not q:
                continue
            vehicle = unit == pb.VEHICLE
            request = pb.MoveUnitAbsRequest(
                unit=unit,
                abs_pos=q,
                speed=[200.0, 30.0] if vehicle else [10.0],
                accel=[400.0, 60.0] if vehicle else [40.0],
            )
            r = self.spec_a_grpc.MoveUnitAbs(request).return_id
            assert r.id == 0, r.comment
            self.wait_idle()

    def ready(self) -> None:
        """Back to Ready with nothing moving: abort, clear alarms, servo on, hands on."""
        s = self.spec_a_grpc
        s.Abort(pb.AbortRequest())
        s.ClearAlarms(pb.ClearAlarmsRequest())
        s.ServoOn(pb.ServoOnRequest())
        self.dual_common_grpc.ServoONHand(pb.DualManipulatorCommonServoONHandRequest())
        assert self.wait_for(lambda: self.state() == SpecAState.READY), self.log
        self.wait_idle()

    def close(self) -> None:
        self.channel.close()
        self._stop()

    def _stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(30.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10.0)
        for path in sorted(self.dir.rglob("*"), reverse=True):
            path.rmdir() if path.is_dir() else path.unlink()
        self.dir.rmdir()


class UnixOmniNames:
    """omniNames on a Unix socket in a private directory: no TCP port, so nothing to race
    for; ``uri`` is its corbaloc. ``restart`` starts a fresh one (no memory of bindings) on
    the same socket, as a naming service that crashed and came back."""

    def __init__(self, directory: Path):
        self.dir = directory
        self.sock = directory / "ns.sock"
        self.uri = f"corbaloc:omniunix:{self.sock}:/NameService"
        self.proc: subprocess.Popen[bytes] | None = None
        self.runs = 0
        self.start()

    def start(self) -> None:
        from controller.gateway.corba.server import omninames_binary

        self.runs += 1
        data = self.dir / f"data{self.runs}"
        data.mkdir()
        log = data / "omniNames.log"
        self.sock.unlink(missing_ok=True)
        cmd = [
            str(omninames_binary()), "-start", "-always", "-datadir", str(data),
            "-errlog", str(log), "-ORBendPoint", f"giop:unix:{self.sock}",
        ]  # fmt: skip
        self.proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        end = time.monotonic() + START_BOUND
        while time.monotonic() < end:
            if log.is_file() and "Checkpointing completed" in log.read_text(errors="replace"):
                return
            assert self.proc.poll() is None, "omniNames exited"
            time.sleep(0.02)
        raise AssertionError("omniNames did not start")

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(10.0)

    def restart(self) -> None:
        self.stop()
        self.start()

    def resolve(self, name: str) -> Any:
        """The object bound under ``name`` (CosNaming string name); None if not bound."""
        import CosNaming

        root = client_orb().string_to_object(self.uri)._narrow(CosNaming.NamingContextExt)
        try:
            return root.resolve_str(name)
        except CosNaming.NamingContext.NotFound:
            return None

"""tools/bench_clients.py's client side and tools/grpc_floor.py (grpcio's floor): paced
clients against the constant-reply server, figures present; no daemon (the full benchmark
takes minutes: run it by hand, docs/daemon.md)."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import grpc
import pytest

from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import bench_clients  # noqa: E402


class NoLoop:
    """Stands in for the daemon beside the floor server: no loop cycles to count."""

    def cycles(self) -> int:
        return 0


@pytest.mark.parametrize("server", [[], ["--aio"]], ids=["sync", "aio"])
def test_the_floor_server_answers_constant_replies_and_stops_when_stdin_closes(server):
    """The synchronous server (as the gateway's) and, with --aio, a grpc.aio one."""
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / "tools" / "grpc_floor.py"), *server],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        assert proc.stdout is not None and proc.stdin is not None
        line = proc.stdout.readline().strip()
        assert line.startswith("READY 127.0.0.1:")
        with grpc.insecure_channel(line.split(" ", 1)[1]) as channel:
            stub = pb_grpc.IntegratedMotionStub(channel)
            state = stub.GetState(pb.GetStateRequest(), timeout=30.0)
            pose = stub.GetFeedbackPosCartesian(pb.GetFeedbackPosCartesianRequest(), timeout=30.0)
        assert (state.return_id.id, state.status_id) == (0, 2)
        assert len(pose.pos.car_pos.m) == 12
        proc.stdin.close()
        assert proc.wait(30.0) == 0
    finally:
        proc.kill()
        proc.wait()


def test_paced_clients_at_the_floor_report_latency_cpu_and_nice():
    mine = os.getpriority(os.PRIO_PROCESS, 0)
    floor = bench_clients.Floor(NoLoop(), 0.0005, min(19, mine + 1))  # type: ignore[arg-type]
    try:
        args = argparse.Namespace(clients=4, procs=1, seconds=1.0)
        out = bench_clients.run_clients(floor, args, 20.0, idle_cpu=0.0)
    finally:
        floor.stop()
    assert out["errors"] == 0 and out["calls_per_s"] > 0
    assert out["getstate_p99_ms"] >= out["getstate_p50_ms"] > 0
    assert 0 < out["getstate_p99_from_send_ms"] and out["client_late_p99_ms"] >= 0
    assert out["gateway_cpu_us_per_call"] == out["gateway_net_cpu_us_per_call"]
    assert out["gateway_nice"] == min(19, mine + 1)  # the value asked for, applied
    assert out["control_cpu_ms_per_s"] == 0.0  # no control process beside this floor


def test_the_control_process_cpu_is_read_beside_the_floor():
    """Each client phase gives the control process's CPU (the loop's share of the cores,
    higher while a move runs): read from /proc for the daemon's pid (here: this process)."""

    class ThisProcess(NoLoop):
        def control_pid(self) -> int:
            return os.getpid()

    floor = bench_clients.Floor(ThisProcess(), 0.0005, None)  # type: ignore[arg-type]
    try:
        args = argparse.Namespace(clients=2, procs=1, seconds=0.5)
        out = bench_clients.run_clients(floor, args, 20.0, idle_cpu=0.0)
    finally:
        floor.stop()
    assert out["control_cpu_ms_per_s"] >= 0.0
    assert floor.control_pid() == os.getpid()


def test_the_burner_stands_in_for_a_moves_loop_cost_and_reports_its_cpu():
    """--burn-us: a thread busy part of every period (what a running move adds to the loop),
    so its effect on the reads can be seen without a move; it reports the CPU it used."""
    cmd = [sys.executable, str(ROOT / "tools" / "bench_clients.py"), "--burn", "200"]
    cmd += ["--rate", "1000", "--seconds", "0.3"]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout.strip().splitlines()[-1])
    assert isinstance(data["fifo"], bool)
    assert data["cpu_s"] > 0.0

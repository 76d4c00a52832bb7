#!/usr/bin/env python3
"""CORBA benchmark: getState round trips over CORBA and gRPC on the same daemon, and the
control loop's wake latency with CORBA clients hammering versus gRPC clients.

Usage: python tools/bench_corba.py [--calls 3000] [--clients 8] [--procs 4] [--seconds 5]
                                   [--rate 500]

Starts ``imotiond --hal sim`` (SmartPal V, servos on, a linear hand move kept running as in
tools/bench_clients.py) with ``corba.enabled`` and IOR files, then:

1. *round trips*: ``--calls`` sequential getState calls from one client over CORBA
   (IntegratedMotionInterface, omniORBpy) and over gRPC, interleaved in blocks of 100 (both
   see the same machine load); p50/p99 [us] (target: CORBA p50 <= 150 us);
2. *load* (``--seconds`` > 0): the loop's wake latency idle, then with ``--clients``
   CORBA clients (``--procs`` processes of threads) calling getState and
   getFeedbackPosCartesian as fast as they can, then the same with gRPC clients; the CORBA
   p99 rise over idle must not exceed the gRPC one (or zero, when the gRPC phase came out
   below idle) by more than 10 us of noise.

Prints a table and, as the last line, a JSON object.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

import grpc  # noqa: E402
import numpy as np  # noqa: E402
from bench_clients import Daemon, Mover, phase_stats  # noqa: E402

from controller.rpc import imotion_pb2 as pb  # noqa: E402
from controller.rpc import imotion_pb2_grpc as pb_grpc  # noqa: E402

#: Target: CORBA getState round trip p50 [us] (issue 11).
MAX_CORBA_P50_US = 150.0
#: Noise allowed when comparing the loaded p99 of CORBA against gRPC [us].
P99_NOISE_US = 10.0


def corba_stub(ior: str) -> Any:
    from omniORB import CORBA

    from controller.corba.stubs import _GlobalIDL

    orb = CORBA.ORB_init(["bench", "-ORBendPoint", "giop:tcp:127.0.0.1:0"], CORBA.ORB_ID)
    return orb.string_to_object(ior)._narrow(_GlobalIDL.IntegratedMotionInterface)


def client_main(kind: str, target: str, threads: int, seconds: float) -> int:
    """One client process (``kind`` corba: ``target`` is an IOR; grpc: an address): connects
    its threads, prints READY, starts at the monotonic time read from stdin, prints a JSON
    line with the number of calls."""
    counts = [0] * threads
    connected = threading.Barrier(threads + 1)
    go = threading.Event()
    start_at = [0.0]
    corba = corba_stub(target) if kind == "corba" else None

    def worker(k: int) -> None:
        if corba is not None:
            from controller.corba.stubs import _GlobalIDL as A

            calls = (
                corba.getState,
                lambda: corba.getFeedbackPosCartesian(A.RIGHT, A.ORIGINAL_FRAME),
            )
        else:
            stub = pb_grpc.IntegratedMotionStub(grpc.insecure_channel(target))
            state, pose = pb.GetStateRequest(), pb.GetFeedbackPosCartesianRequest(type=pb.RIGHT)
            calls = (lambda: stub.GetState(state, timeout=5.0),
                     lambda: stub.GetFeedbackPosCartesian(pose, timeout=5.0))  # fmt: skip
        calls[0]()
        connected.wait()
        go.wait()
        while time.monotonic() < start_at[0]:
            time.sleep(0.001)
        end, n = start_at[0] + seconds, 0
        while time.monotonic() < end:
            calls[n & 1]()
            n += 1
        counts[k] = n

    pool = [threading.Thread(target=worker, args=(k,)) for k in range(threads)]
    for t in pool:
        t.start()
    connected.wait()
    print("READY", flush=True)
    start_at[0] = float(sys.stdin.readline())
    go.set()
    for t in pool:
        t.join()
    print(json.dumps({"calls": sum(counts)}))
    return 0


def round_trips(corba: Any, grpc_stub: Any, calls: int) -> dict[str, Any]:
    out: dict[str, list[float]] = {"corba": [], "grpc": []}
    request = pb.GetStateRequest()
    for _ in range(20):  # warm up both paths
        corba.getState()
        grpc_stub.GetState(request)
    for _ in range(max(1, calls // 100)):
        for _ in range(100):
            t0 = time.perf_counter()
            corba.getState()
            out["corba"].append((time.perf_counter() - t0) * 1e6)
        for _ in range(100):
            t0 = time.perf_counter()
            grpc_stub.GetState(request)
            out["grpc"].append((time.perf_counter() - t0) * 1e6)
    result: dict[str, Any] = {}
    for kind, samples in out.items():
        p50, p99 = np.percentile(samples, [50.0, 99.0])
        result[f"{kind}_getstate_p50_us"] = round(float(p50), 1)
        result[f"{kind}_getstate_p99_us"] = round(float(p99), 1)
    return result


def hammer(
    kind: str, target: str, args: argparse.Namespace, daemon: Daemon
) -> tuple[int, int, int]:
    """(first cycle, last cycle, calls) of a phase with ``kind`` clients hammering."""
    threads = -(-args.clients // args.procs)
    cmd = [sys.executable, __file__, "--client", kind, target, "--threads", str(threads),
           "--seconds", str(args.seconds)]  # fmt: skip
    procs = [
        subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=ROOT)
        for _ in range(args.procs)
    ]
    for proc in procs:
        assert proc.stdout is not None
        if proc.stdout.readline().strip() != "READY":
            raise RuntimeError(f"a {kind} client did not connect")
    start_at = time.monotonic() + 0.5
    for proc in procs:
        assert proc.stdin is not None
        proc.stdin.write(f"{start_at!r}\n")
        proc.stdin.flush()
    time.sleep(max(0.0, start_at - time.monotonic()))
    c0 = daemon.cycles()
    time.sleep(max(0.0, start_at + args.seconds - time.monotonic()))
    c1 = daemon.cycles()
    calls = 0
    for proc in procs:
        out, _ = proc.communicate(timeout=120.0)
        calls += int(json.loads(out.strip().splitlines()[-1]).get("calls", 0))
    return c0, c1, calls


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=3000)
    parser.add_argument("--clients", type=int, default=8)
    parser.add_argument("--procs", type=int, default=4)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--rate", type=float, default=500.0)
    parser.add_argument("--client", nargs=2, metavar=("KIND", "TARGET"), help=argparse.SUPPRESS)
    parser.add_argument("--threads", type=int, default=1, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.client:
        return client_main(args.client[0], args.client[1], args.threads, args.seconds)

    work = Path(tempfile.mkdtemp(prefix="imotion-bench-corba-"))
    stats = work / "stats.npz"
    sets = ["corba.enabled=true", f"corba.ior_dir={work / 'ior'}"]
    daemon = Daemon("process", args.rate, stats, work / "imotiond.log", None, sets)
    mover: Mover | None = None
    result: dict[str, Any] = {"rate_hz": args.rate, "clients": args.clients}
    phases: dict[str, tuple[int, int]] = {}
    try:
        daemon.wait_ready()
        ior = (work / "ior" / "spec_a.ior").read_text().strip()
        corba = corba_stub(ior)
        if corba.servoOn().id != 0:
            raise RuntimeError("servoOn refused")
        mover = Mover(daemon.address)
        mover.start()
        time.sleep(1.0)
        result.update(round_trips(corba, daemon.a, args.calls))
        if args.seconds > 0:
            c0 = daemon.cycles()
            time.sleep(args.seconds)
            phases["idle"] = (c0, daemon.cycles())
            for kind, target in (("corba", ior), ("grpc", daemon.address)):
                a, b, calls = hammer(kind, target, args, daemon)
                phases[kind] = (a, b)
                result[f"{kind}_calls_per_s"] = round(calls / args.seconds, 1)
    finally:
        if mover is not None:
            mover.stop()
            result["moves"] = mover.moves
        result["exit_code"] = daemon.stop()
    if phases:
        data = np.load(stats)
        first, period_us = int(data["first_cycle"]), float(data["period_us"])
        for name, (a, b) in phases.items():
            sl = slice(max(0, a - first), max(0, b - first))
            result[f"loop_{name}"] = phase_stats(
                data["wake_us"][sl], data["compute_us"][sl], period_us
            )
        rise = {k: result[f"loop_{k}"]["wake_p99_us"] - result["loop_idle"]["wake_p99_us"]
                for k in ("corba", "grpc")}  # fmt: skip
        result["p99_rise_corba_us"] = round(rise["corba"], 1)
        result["p99_rise_grpc_us"] = round(rise["grpc"], 1)
        # a negative rise (loaded below idle) is noise: compare against no rise at all then
        result["load_pass"] = bool(rise["corba"] <= max(rise["grpc"], 0.0) + P99_NOISE_US)
    result["round_trip_pass"] = bool(result.get("corba_getstate_p50_us", 1e9) <= MAX_CORBA_P50_US)
    print(f"{'':24}{'p50 [us]':>10}{'p99 [us]':>10}")
    for kind in ("corba", "grpc"):
        if f"{kind}_getstate_p50_us" in result:
            print(f"getState over {kind:<10}{result[f'{kind}_getstate_p50_us']:>10}"
                  f"{result[f'{kind}_getstate_p99_us']:>10}")  # fmt: skip
    for name in ("idle", "corba", "grpc"):
        if f"loop_{name}" in result:
            s = result[f"loop_{name}"]
            print(f"loop wake, {name:<8} clients: p50 {s['wake_p50_us']} us, p99 "
                  f"{s['wake_p99_us']} us, late {s['late']}")  # fmt: skip
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Live-view benchmark: does a subscribed Foxglove client disturb imotiond's control loop?

Usage: python tools/bench_view.py [--seconds 10] [--rate 1000] [--view-rate 50] [--rounds 2]
                                  [--blackbox] [--keep DIR]

Starts ``imotiond --hal sim`` at ``--rate`` (SCHED_FIFO when allowed, e.g. as root) with the
live view on 127.0.0.1 (port 0, read back from the log), ``loop.stats_file`` set, servos on
and a linear hand move always running (tools/bench_clients.py's Mover). Then, in the same
run, ``--rounds`` times: ``--seconds`` with no viewer (*idle*), then ``--seconds`` with a
Foxglove-protocol client subscribed to every channel and reading every message
(*subscribed*). ``--blackbox`` also turns the black box on (ring written every cycle).

Wake latency = wake time minus deadline of every cycle, from the daemon's stats file; each
phase's cycles are found from the cycle counter of Monitor.StreamState at its start and end
(as in tools/bench_clients.py). Prints per phase the wake latency p50/p99/max, late cycles
and compute p99, the p99 rise with a subscriber against the target (<= 10 us) and, as the
last line, a JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import grpc
import numpy as np
from bench_clients import Mover, phase_stats

from controller.client.foxglove_ws import LiveViewClient
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc

ROOT = Path(__file__).resolve().parents[1]
#: Acceptance: p99 wake-latency rise with a subscribed viewer [us].
MAX_P99_RISE_US = 10.0
START_TIMEOUT = 90.0


class Daemon:
    """imotiond on 127.0.0.1 (gRPC and live view on ports it picks, read from its log)."""

    def __init__(self, args: argparse.Namespace, stats: Path, log: Path, bb: Path | None):
        cmd = [sys.executable, "-m", "controller.daemon.main", "--robot", "smartpal5",
               "--hal", "sim", "--rate", f"{args.rate:g}", "--listen", "127.0.0.1:0",
               "--set", "view.listen=127.0.0.1:0", "--set", f"view.rate_hz={args.view_rate:g}",
               "--set", f"loop.stats_file={stats}"]  # fmt: skip
        if bb is not None:
            cmd += ["--set", f"blackbox.dir={bb}"]
        self.log_path = log
        self._log = open(log, "w")  # closed in stop()
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        self.proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=self._log, stderr=self._log)
        self.address, self.view_url = self._wait_addresses()
        self.channel = grpc.insecure_channel(self.address)
        self.a = pb_grpc.IntegratedMotionStub(self.channel)
        self.monitor = pb_grpc.MonitorStub(self.channel)

    def _wait_addresses(self) -> tuple[str, str]:
        end = time.monotonic() + START_TIMEOUT
        while time.monotonic() < end:
            if self.proc.poll() is not None:
                raise RuntimeError(f"imotiond exited early: see {self.log_path}")
            text = self.log_path.read_text()
            view = re.search(r"live view on (ws://[0-9.:]+)", text)
            grpc_at = re.search(r"listening on ([0-9.:]+)", text)
            if view and grpc_at:
                return grpc_at.group(1), view.group(1)
            time.sleep(0.2)
        raise RuntimeError(f"imotiond did not start within {START_TIMEOUT:g} s")

    def cycles(self) -> int:
        stream = self.monitor.StreamState(pb.StreamStateRequest(rate_hz=1000.0), timeout=30.0)
        try:
            return int(next(iter(stream)).loop.cycles)
        finally:
            stream.cancel()

    def stop(self) -> int | None:
        self.channel.close()
        self.proc.send_signal(signal.SIGTERM)
        try:
            code: int | None = self.proc.wait(15.0)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            code = None
        self._log.close()
        return code


class Viewer:
    """A Foxglove client subscribed to every channel, reading until stopped."""

    def __init__(self, url: str):
        self.client = LiveViewClient(url)
        self.client.subscribe()
        self.messages = 0
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.done.is_set():
            try:
                self.client.wait_for(lambda m: isinstance(m, tuple), 0.5)
                self.messages += 1
            except TimeoutError:
                continue

    def stop(self) -> int:
        self.done.set()
        self.thread.join(5.0)
        self.client.close()
        return self.messages


def run(args: argparse.Namespace, work: Path) -> dict[str, Any]:
    stats_path = work / "view.npz"
    bb = work / "blackbox" if args.blackbox else None
    daemon = Daemon(args, stats_path, work / "view.log", bb)
    mover: Mover | None = None
    result: dict[str, Any] = {"view_url": daemon.view_url}
    bounds: list[tuple[str, int, int]] = []
    try:
        rid = daemon.a.ServoOn(pb.ServoOnRequest()).return_id
        if rid.id != 0:
            raise RuntimeError(f"servoOn refused: {rid.comment}")
        mover = Mover(daemon.address)
        mover.start()
        time.sleep(args.warmup)
        received = 0
        for k in range(args.rounds):
            c0 = daemon.cycles()
            time.sleep(args.seconds)
            c1 = daemon.cycles()
            bounds.append((f"idle{k}", c0, c1))
            viewer = Viewer(daemon.view_url)
            time.sleep(0.5)  # the subscription settles
            c2 = daemon.cycles()
            time.sleep(args.seconds)
            c3 = daemon.cycles()
            received += viewer.stop()
            bounds.append((f"subscribed{k}", c2, c3))
        result["viewer_messages_per_s"] = round(received / (args.rounds * args.seconds), 1)
    finally:
        if mover is not None:
            mover.stop()
            result["moves"] = mover.moves
        result["exit_code"] = daemon.stop()
    data = np.load(stats_path)
    first, period_us = int(data["first_cycle"]), float(data["period_us"])
    wake, compute = data["wake_us"], data["compute_us"]
    pooled: dict[str, list[slice]] = {"idle": [], "subscribed": []}
    for name, a, b in bounds:
        sl = slice(max(0, a - first), max(0, b - first))
        result[name] = phase_stats(wake[sl], compute[sl], period_us)
        pooled[name.rstrip("0123456789")].append(sl)
    for name, slices in pooled.items():
        result[name] = phase_stats(
            np.concatenate([wake[s] for s in slices]),
            np.concatenate([compute[s] for s in slices]),
            period_us,
        )
    result["p99_rise_us"] = round(
        result["subscribed"]["wake_p99_us"] - result["idle"]["wake_p99_us"], 1
    )
    result["pass"] = bool(result["p99_rise_us"] <= MAX_P99_RISE_US)
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="per phase [s]")
    parser.add_argument("--rate", type=float, default=1000.0, help="loop rate [Hz]")
    parser.add_argument("--view-rate", type=float, default=50.0, help="view.rate_hz [Hz]")
    parser.add_argument("--rounds", type=int, default=2, help="idle + subscribed pairs")
    parser.add_argument("--blackbox", action="store_true", help="black box on as well")
    parser.add_argument("--warmup", type=float, default=2.0, help="[s] before measuring")
    parser.add_argument("--keep", type=Path, help="keep the daemon's log and stats file here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench_view-") as tmp:
        work = Path(tmp)
        if args.keep is not None:
            work = args.keep.resolve()
            work.mkdir(parents=True, exist_ok=True)
        result = run(args, work)
    print(f"\n{args.rate:g} Hz loop, view at {args.view_rate:g} Hz, {args.seconds:g} s per "
          f"phase, {args.rounds} rounds, black box {'on' if args.blackbox else 'off'}")  # fmt: skip
    head = f"{'phase':12s} {'cycles':>7s} {'wake p50':>9s} {'p99':>7s} {'max':>8s} {'late':>5s}"
    print(head + f" {'compute p99':>12s}")
    names = [k for k in result if k.startswith(("idle", "subscribed"))]
    for name in names:
        s = result[name]
        print(f"{name:12s} {s['cycles']:7d} {s['wake_p50_us']:9.1f} {s['wake_p99_us']:7.1f} "
              f"{s['wake_max_us']:8.1f} {s['late']:5d} {s['compute_p99_us']:12.1f}")  # fmt: skip
    verdict = "PASS" if result["pass"] else "FAIL"
    print(f"p99 rise with a subscribed viewer {result['p99_rise_us']:+.1f} us (limit "
          f"{MAX_P99_RISE_US:g}): {verdict}; viewer got {result['viewer_messages_per_s']} "
          f"messages/s; daemon exit {result['exit_code']}")  # fmt: skip
    print(json.dumps({"rate_hz": args.rate, "view_rate_hz": args.view_rate,
                      "seconds": args.seconds, "blackbox": args.blackbox, **result}))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())

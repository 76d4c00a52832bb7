#!/usr/bin/env python3
"""Client-load benchmark: does gRPC traffic disturb imotiond's control loop, and how fast
does the gateway answer reads under it?

Usage: python tools/bench_clients.py [--seconds 10] [--clients 32] [--procs 4] [--rate 1000]
                                     [--poll-hz 20] [--set KEY=VALUE ...] [--root DIR]
                                     [--modes process,thread] [--floor] [--no-mover]
                                     [--burn-us US]

For each gateway mode (``process``: gRPC in its own process, the shipped design; ``thread``:
gRPC inside the control process, the peer) it starts ``imotiond --hal sim`` at ``--rate``
(SCHED_FIFO when allowed, e.g. as root) with ``loop.stats_file`` set, servos on and keeps a
linear hand move running (100 mm up and down, one after the other). Then:

1. *idle*: ``--seconds`` with only the move running;
2. *loaded* (saturated): ``--seconds`` with ``--clients`` concurrent clients (``--procs``
   processes of threads, one channel each, so the client side is not GIL-bound) calling
   getState and getFeedbackPosCartesian alternately as fast as they can. Closed loop: each
   client waits for its answer, so a round trip is (clients / calls per second) whatever the
   server does: this phase measures throughput, and the loop's wake latency under it;
3. *paced*: ``--seconds`` with the same clients each calling ``--poll-hz`` times a second
   (a dashboard polling; random phases), a round trip counted from its scheduled start.
   This is the getState latency target (p99 <= 5 ms, issue 17.12): the server's answer time
   at a given load, not the clients' own queueing.

The clients run on the same cores as the daemon: for each loaded phase it prints the CPU time
per call of the gateway process (from /proc) and of the clients (their own process time), so
one sees who the cores were busy with; and the 1-minute load average (other work on the
machine shows there). ``--root DIR`` runs imotiond from another checkout with these same
clients (before/after comparisons).

The loop's wake latency (wake time minus deadline) and compute time of every cycle come from
the daemon's ``loop.stats_file`` (written at SIGTERM); each phase's cycles are found from the
cycle counter of Monitor.StreamState at its start and end. Prints per mode and phase the wake
latency p50/p99/max, cycles late by more than half a period, compute p99 and the client call
rate, the getState round trip p50/p99 of both client phases against the target, the p99
rise under load against its target (<= 30 us, no late cycle), and as the last line a JSON
object (``<mode>.saturated`` and ``<mode>.paced``: getstate_p50_ms, getstate_p99_ms,
calls_per_s, gateway_cpu_us_per_call, client_cpu_us_per_call; ``max_getstate_p99_ms``).
To say where a tail comes from, each client phase also gives the getState p99 of the reads
that overlapped a move command of the mover (the gateway was planning it;
``getstate_p99_during_moves_ms``, ``reads_during_moves``) and of the others
(``getstate_p99_other_ms``), and how long the gateway's threads waited for a CPU while
runnable (``gateway_runqueue_ms_per_s``, from /proc/PID/task/*/schedstat: the machine's
share of the tail). The paced phase also gives the round trip from the client's send
(``getstate_p99_from_send_ms``) and how late the clients sent (``client_late_p99_ms``: they
share the cores and wait for a CPU too); each client phase the gateway's CPU per call net of
what it uses without clients (``gateway_net_cpu_us_per_call``; the mover's calls and
planning: ``gateway_idle_cpu_ms_per_s``) and its nice value, and the control process's CPU
(``control_cpu_ms_per_s``; without clients ``control_idle_cpu_ms_per_s``): the loop, real-time
when permitted, takes that share of the cores first, and a running move costs it about
twice a still robot's. ``--floor`` then points the
same paced clients at a constant-reply grpcio server shaped like the gateway
(tools/grpc_floor.py, at the gateway's nice value) beside the running daemon: grpcio's own
cost and latency in the same minute (``<mode>.floor``). ``--no-mover`` runs without the move;
``--burn-us US`` adds a SCHED_FIFO thread (priority 1) busy US of every loop period, a
stand-in for what a running move adds to the loop's CPU: with ``--no-mover`` it tells the
move's cost to the cores from the gateway's own work during a move. For reference it first
measures the machine's floor (tools/machine_floor.py): a bare SCHED_FIFO thread that only
sleeps to 1 ms deadlines (on shared virtual cores even that is late now and then).
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
import machine_floor
import numpy as np

from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc

ROOT = Path(__file__).resolve().parents[1]
#: Acceptance: p99 wake-latency rise under load [us].
MAX_P99_RISE_US = 30.0
#: Acceptance: getState round trip p99 with the clients hammering [ms] (issue 17.12).
MAX_GETSTATE_P99_MS = 5.0
START_TIMEOUT = 90.0
#: Each client's call rate in the paced phase [Hz].
POLL_HZ = 20.0


# ---------------------------------------------------------------------- client processes
def client_main(address: str, threads: int, seconds: float, hz: float) -> int:
    """One client process: ``threads`` threads, connected, then "READY" on stdout; hammering
    starts at the monotonic time (shared by all processes on Linux) read from stdin and lasts
    ``seconds``. ``hz`` 0: each thread calls as fast as it can (closed loop); else each thread
    calls ``hz`` times a second on a fixed schedule (a random phase each), and a round trip
    counts from its scheduled time (a late start is the server's delay too). Prints
    {"calls", "errors", "cpu_s", "getstate_us"} (cpu_s: this process's CPU time while
    hammering; getstate_us: every getState round trip [us])."""
    counts = [0] * threads
    errors = [0] * threads
    latencies: list[list[float]] = [[] for _ in range(threads)]
    late: list[list[float]] = [[] for _ in range(threads)]  #: sent after the due time [us]
    starts: list[list[float]] = [[] for _ in range(threads)]  # monotonic [s]
    connected = threading.Barrier(threads + 1)
    go = threading.Event()
    start_at = [0.0]
    rng = np.random.default_rng()
    phases = rng.uniform(0.0, 1.0 / hz, threads) if hz > 0 else np.zeros(threads)

    def worker(k: int) -> None:
        channel = grpc.insecure_channel(address)
        stub = pb_grpc.IntegratedMotionStub(channel)
        state, pose = pb.GetStateRequest(), pb.GetFeedbackPosCartesianRequest(type=pb.RIGHT)
        stub.GetState(state, timeout=60.0)  # connected before the start
        connected.wait()
        go.wait()
        while time.monotonic() < start_at[0]:
            time.sleep(0.001)
        end = start_at[0] + seconds
        n = 0
        while True:
            due = start_at[0] + float(phases[k]) + n / hz if hz > 0 else time.monotonic()
            if due >= end:
                break
            wait = due - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            try:
                if n & 1:
                    stub.GetFeedbackPosCartesian(pose, timeout=5.0)
                else:
                    behind = max(0.0, time.monotonic() - due)
                    t0 = time.perf_counter() - behind
                    stub.GetState(state, timeout=5.0)
                    latencies[k].append((time.perf_counter() - t0) * 1e6)
                    late[k].append(behind * 1e6)
                    starts[k].append(due)
                counts[k] += 1
            except grpc.RpcError:
                errors[k] += 1
            n += 1
        channel.close()

    pool = [threading.Thread(target=worker, args=(k,)) for k in range(threads)]
    for t in pool:
        t.start()
    connected.wait()
    print("READY", flush=True)
    start_at[0] = float(sys.stdin.readline())
    go.set()
    while time.monotonic() < start_at[0]:
        time.sleep(0.001)
    cpu0 = time.process_time()
    for t in pool:
        t.join()
    cpu_s = time.process_time() - cpu0
    samples = [round(x, 1) for per_thread in latencies for x in per_thread]
    begun = [round(x, 5) for per_thread in starts for x in per_thread]
    out = {
        "calls": sum(counts),
        "errors": sum(errors),
        "cpu_s": cpu_s,
        "getstate_us": samples,
        "getstate_late_us": [round(x, 1) for per_thread in late for x in per_thread],
        "getstate_start_s": begun,
    }
    print(json.dumps(out))
    return 0


def burn_main(busy_us: float, rate: float, seconds: float) -> int:
    """A stand-in for a running move's cost to the loop: a SCHED_FIFO thread (priority 1,
    below the loop's) busy ``busy_us`` of every period for ``seconds`` (0: until killed).
    Prints {"fifo", "cpu_s"} at the end."""
    fifo = True
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
    except (OSError, AttributeError):
        fifo = False
    period = 1.0 / rate
    end = time.monotonic() + seconds if seconds > 0 else float("inf")
    cpu0 = time.process_time()
    deadline = time.monotonic()
    while deadline < end:
        busy_end = time.monotonic() + busy_us * 1e-6
        while time.monotonic() < busy_end:
            pass
        deadline += period
        wait = deadline - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        else:  # fell behind (preempted): start again from now, no catching up
            deadline = time.monotonic()
    print(json.dumps({"fifo": fifo, "cpu_s": round(time.process_time() - cpu0, 3)}), flush=True)
    return 0


def start_burn(busy_us: float, rate: float) -> subprocess.Popen[str]:
    """:func:`burn_main` in a process of its own, until stopped (SIGTERM)."""
    cmd = [sys.executable, __file__, "--burn", f"{busy_us:g}", "--rate", f"{rate:g}"]
    cmd += ["--seconds", "0"]
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, text=True, cwd=ROOT)


# ---------------------------------------------------------------------- the daemon side
class Daemon:
    def __init__(
        self,
        mode: str,
        rate: float,
        stats: Path,
        log: Path,
        switch_interval: float | None,
        sets: list[str] | None = None,
        root: Path = ROOT,
    ):
        self.mode = mode
        self.address = ""  # read from the daemon's "ready" line (it binds port 0)
        self.stats = stats
        cmd = [sys.executable, "-m", "controller.daemon.main", "--robot", "smartpal5"]
        if switch_interval is not None:  # the same daemon with another GIL switch interval
            code = (
                f"import sys; sys.setswitchinterval({switch_interval!r}); "
                "from controller.daemon.main import main; sys.exit(main())"
            )
            cmd = [sys.executable, "-c", code, "--robot", "smartpal5"]
        cmd += ["--hal", "sim", "--rate", f"{rate:g}", "--listen", "127.0.0.1:0"]
        cmd += ["--set", f"gateway={mode}", "--set", f"loop.stats_file={stats}"]
        for item in sets or []:
            cmd += ["--set", item]
        env = dict(os.environ, PYTHONPATH=str(root))
        self._log = open(log, "w")  # closed in stop()
        self.log_path = log
        self.proc = subprocess.Popen(cmd, cwd=root, env=env, stdout=self._log, stderr=self._log)

    def wait_ready(self) -> None:
        end = time.monotonic() + START_TIMEOUT
        ready = re.compile(r"listening on (\S+?)\"?$")
        while time.monotonic() < end:
            if self.proc.poll() is not None:
                raise RuntimeError(f"imotiond exited early: see {self.log_path}")
            for line in self.log_path.read_text().splitlines():
                match = ready.search(line) if "ready" in line else None
                if match:
                    self.address = match.group(1)
                    self.channel = grpc.insecure_channel(self.address)
                    self.a = pb_grpc.IntegratedMotionStub(self.channel)
                    self.monitor = pb_grpc.MonitorStub(self.channel)
                    self.a.GetState(pb.GetStateRequest(), timeout=30.0)
                    return
            time.sleep(0.2)
        raise RuntimeError(f"imotiond did not get ready within {START_TIMEOUT:g} s")

    def gateway_pid(self) -> int | None:
        """The process serving gRPC: imotiond's child (gateway=process) or imotiond."""
        if self.mode != "process":
            return self.proc.pid
        for task in Path(f"/proc/{self.proc.pid}/task").glob("*"):
            try:
                children = (task / "children").read_text().split()
            except OSError:
                continue
            if children:
                return int(children[0])
        return None

    def control_pid(self) -> int:
        """imotiond, the control process (the loop; the gateway too when gateway=thread)."""
        return self.proc.pid

    def cycles(self) -> int:
        """The loop's cycle counter now (one StreamState sample)."""
        stream = self.monitor.StreamState(pb.StreamStateRequest(rate_hz=1000.0), timeout=30.0)
        try:
            return int(next(iter(stream)).loop.cycles)
        finally:
            stream.cancel()

    def stop(self) -> int | None:
        if self.address:
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


class Mover:
    """Keeps a linear move of the right hand running: 100 mm up, 100 mm down, ..."""

    def __init__(self, address: str):
        self.channel = grpc.insecure_channel(address)
        self.a = pb_grpc.IntegratedMotionStub(self.channel)
        self.done = threading.Event()
        self.moves = 0
        self.refused: list[str] = []
        #: (sent, answered) of every move command [s, monotonic]: the gateway planned then.
        self.commands: list[tuple[float, float]] = []
        self.thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> None:
        self.thread.start()

    def _run(self) -> None:
        sign = 1.0
        while not self.done.is_set():
            try:
                if self.a.IsMoving(pb.IsMovingRequest(), timeout=10.0).is_moving:
                    time.sleep(0.02)
                    continue
                request = pb.MoveLinearCartesianRelRequest(
                    type=pb.RIGHT,
                    frame_type=pb.BASE_FRAME,
                    rel_hg_mat=pb.HgMatrix(m=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 100.0 * sign]),
                    speed=pb.CartesianSpeed(translation=50.0, rotation=30.0),
                    accel=pb.CartesianAccel(translation=100.0, rotation=60.0),
                )
                sent = time.monotonic()
                rid = self.a.MoveLinearCartesianRel(request, timeout=30.0).return_id
                self.commands.append((sent, time.monotonic()))
            except grpc.RpcError as exc:
                self.refused.append(f"{exc.code().name}")
                time.sleep(0.1)
                continue
            if rid.id == 0:
                self.moves += 1
                sign = -sign
                time.sleep(0.1)  # the snapshot shows the move a cycle after the OK
            else:  # e.g. a joint too near its limit for that line: the other way then
                self.refused.append(f"{rid.id}: {rid.comment}")
                sign = -sign
                time.sleep(0.1)

    def stop(self) -> None:
        self.done.set()
        self.thread.join(30.0)
        self.channel.close()


class Floor:
    """tools/grpc_floor.py (a constant-reply grpcio server shaped like the gateway) beside
    the daemon: the same clients at it give grpcio's own cost and latency at that minute."""

    def __init__(self, daemon: Daemon, switch_interval: float, nice: int | None):
        self.daemon = daemon
        cmd = [sys.executable, str(ROOT / "tools" / "grpc_floor.py")]
        cmd += ["--switch-interval", f"{switch_interval:g}"]
        if nice is not None:  # the gateway's, for a like-for-like comparison
            cmd += ["--nice", str(nice)]
        self.proc = subprocess.Popen(
            cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=ROOT
        )
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline().strip()
        if not line.startswith("READY "):
            self.proc.kill()
            raise RuntimeError(f"tools/grpc_floor.py did not start: {line!r}")
        self.address = line.split(" ", 1)[1]

    def gateway_pid(self) -> int:
        return self.proc.pid

    def control_pid(self) -> int | None:
        return control_pid(self.daemon)

    def cycles(self) -> int:
        return self.daemon.cycles()

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10.0)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def phase_stats(wake: np.ndarray, compute: np.ndarray, period_us: float) -> dict[str, Any]:
    if wake.size == 0:
        return {"cycles": 0}
    p50, p99 = np.percentile(wake, [50.0, 99.0])
    return {
        "cycles": int(wake.size),
        "wake_p50_us": round(float(p50), 1),
        "wake_p99_us": round(float(p99), 1),
        "wake_max_us": round(float(wake.max()), 1),
        "late": int(np.count_nonzero(wake > 0.5 * period_us)),
        "compute_p99_us": round(float(np.percentile(compute, 99.0)), 1),
        "compute_max_us": round(float(compute.max()), 1),
        "over_period": int(np.count_nonzero(wake + compute > period_us)),
    }


def control_pid(daemon: Any) -> int | None:
    """The control process's pid (None when there is none, e.g. a stand-in)."""
    get = getattr(daemon, "control_pid", None)
    return get() if get is not None else None


def cpu_seconds(pid: int | None) -> float:
    """CPU time [s] a process has used so far (0 when unknown)."""
    if pid is None:
        return 0.0
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def nice_of(pid: int | None) -> int | None:
    """The nice value of a process's main thread (None when unknown)."""
    if pid is None:
        return None
    try:
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[16])
    except (OSError, IndexError, ValueError):
        return None


def runqueue_seconds(pid: int | None) -> float:
    """Time [s] the threads of a process have waited for a CPU while runnable so far
    (``/proc/PID/task/*/schedstat``; 0 when unknown)."""
    total = 0
    for task in Path(f"/proc/{pid}/task").glob("*") if pid is not None else ():
        try:
            total += int((task / "schedstat").read_text().split()[1])
        except (OSError, IndexError, ValueError):
            continue
    return total / 1e9


def split_by_commands(
    starts: np.ndarray, round_trips_us: np.ndarray, commands: list[tuple[float, float]]
) -> dict[str, Any]:
    """getState p99 [ms] of the round trips that overlap a move command (the gateway was
    planning it) and of the others: says whether planning sets the tail."""
    during = np.zeros(starts.size, dtype=bool)
    ends = starts + round_trips_us / 1e6
    for sent, answered in commands:
        during |= (starts < answered) & (ends > sent)
    out: dict[str, Any] = {"reads_during_moves": int(during.sum())}
    for name, mask in (("during_moves", during), ("other", ~during)):
        if mask.any():
            out[f"getstate_p99_{name}_ms"] = round(
                float(np.percentile(round_trips_us[mask], 99.0)) / 1e3, 2
            )
    return out


def run_clients(
    daemon: Daemon | Floor,
    args: argparse.Namespace,
    hz: float,
    mover: Mover | None = None,
    idle_cpu: float = 0.0,
) -> dict[str, Any]:
    """``--clients`` clients (``--procs`` processes) for ``--seconds``: as fast as they can
    (``hz`` 0) or each ``hz`` calls a second. getState round trips (all; those overlapping a
    move command of ``mover`` and the others), call rate, the CPU time per call of the
    gateway process (also net of ``idle_cpu``, its CPU rate without clients [s/s]) and of
    the clients [us], and how long the gateway's threads waited for a CPU [ms per s]."""
    threads = -(-args.clients // args.procs)
    client_cmd = [sys.executable, __file__, "--client", daemon.address, "--hz", f"{hz:g}"]
    client_cmd += ["--threads", str(threads), "--seconds", str(args.seconds)]
    clients = [
        subprocess.Popen(
            client_cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=ROOT
        )
        for _ in range(args.procs)
    ]
    for proc in clients:  # every client connected (imports take seconds on a busy host)
        assert proc.stdout is not None
        if proc.stdout.readline().strip() != "READY":
            raise RuntimeError("a client process did not connect")
    start_at = time.monotonic() + 0.5
    for proc in clients:
        assert proc.stdin is not None
        proc.stdin.write(f"{start_at!r}\n")
        proc.stdin.flush()
    time.sleep(max(0.0, start_at - time.monotonic()))
    gateway_cpu = cpu_seconds(daemon.gateway_pid())
    control_cpu = cpu_seconds(control_pid(daemon))
    waited = runqueue_seconds(daemon.gateway_pid())
    c2 = daemon.cycles()
    time.sleep(max(0.0, start_at + args.seconds - time.monotonic()))
    c3 = daemon.cycles()
    gateway_cpu = cpu_seconds(daemon.gateway_pid()) - gateway_cpu
    control_cpu = cpu_seconds(control_pid(daemon)) - control_cpu
    waited = runqueue_seconds(daemon.gateway_pid()) - waited
    calls = errors = 0
    client_cpu = 0.0
    getstate: list[float] = []
    starts: list[float] = []
    late: list[float] = []  # how late the client thread sent each getState [us]
    for proc in clients:
        stdout, _ = proc.communicate(timeout=120.0)
        line = stdout.strip().splitlines()[-1] if stdout.strip() else "{}"
        data = json.loads(line)
        calls += int(data.get("calls", 0))
        errors += int(data.get("errors", 0))
        client_cpu += float(data.get("cpu_s", 0.0))
        getstate += data.get("getstate_us", [])
        starts += data.get("getstate_start_s", [])
        late += data.get("getstate_late_us", [])
    out: dict[str, Any] = {"poll_hz": hz}
    if getstate:
        p50, p99 = np.percentile(getstate, [50.0, 99.0])
        out["getstate_p50_ms"] = round(float(p50) / 1e3, 2)
        out["getstate_p99_ms"] = round(float(p99) / 1e3, 2)
        if hz > 0 and len(late) == len(getstate):
            # The round trip from the moment the client sent: without the client's own
            # wait for a CPU at its due time (on a busy machine the clients starve too).
            sent = np.array(getstate) - np.array(late)
            out["getstate_p99_from_send_ms"] = round(float(np.percentile(sent, 99.0)) / 1e3, 2)
            out["client_late_p99_ms"] = round(float(np.percentile(late, 99.0)) / 1e3, 2)
        if mover is not None and len(starts) == len(getstate):
            out.update(split_by_commands(np.array(starts), np.array(getstate), mover.commands))
    out["calls_per_s"] = round(calls / args.seconds, 1)
    out["errors"] = errors
    if calls:
        out["gateway_cpu_us_per_call"] = round(gateway_cpu / calls * 1e6, 1)
        net = gateway_cpu - idle_cpu * args.seconds
        out["gateway_net_cpu_us_per_call"] = round(net / calls * 1e6, 1)
        out["client_cpu_us_per_call"] = round(client_cpu / calls * 1e6, 1)
    out["gateway_runqueue_ms_per_s"] = round(waited / args.seconds * 1e3, 1)
    # The control process's CPU (the loop, at a real-time priority when permitted): what
    # the cores had left for the gateway and the clients; a running move costs the loop
    # more per cycle than a still robot.
    out["control_cpu_ms_per_s"] = round(control_cpu / args.seconds * 1e3, 1)
    out["load"] = round(os.getloadavg()[0], 2)
    out["gateway_nice"] = nice_of(daemon.gateway_pid())
    out["cycles"] = (c2, c3)
    out["clients"] = threads * args.procs
    return out


def run_mode(mode: str, args: argparse.Namespace, work: Path) -> dict[str, Any]:
    stats_path = work / f"{mode}.npz"
    daemon = Daemon(
        mode,
        args.rate,
        stats_path,
        work / f"{mode}.log",
        args.switch_interval,
        args.set,
        args.root.resolve(),
    )
    mover: Mover | None = None
    burn: subprocess.Popen[str] | None = None
    result: dict[str, Any] = {"mode": mode, "burn_us": args.burn_us}
    try:
        daemon.wait_ready()
        rid = daemon.a.ServoOn(pb.ServoOnRequest()).return_id
        if rid.id != 0:
            raise RuntimeError(f"servoOn refused: {rid.comment}")
        if args.burn_us > 0:  # the loop's extra cost of a move, without the move
            burn = start_burn(args.burn_us, args.rate)
        if not args.no_mover:
            mover = Mover(daemon.address)
            mover.start()
        time.sleep(args.warmup)
        c0 = daemon.cycles()
        idle_cpu = cpu_seconds(daemon.gateway_pid())
        control_cpu = cpu_seconds(daemon.control_pid())
        t_idle = time.monotonic()
        time.sleep(args.seconds)
        elapsed = time.monotonic() - t_idle
        idle_cpu = (cpu_seconds(daemon.gateway_pid()) - idle_cpu) / elapsed
        control_cpu = (cpu_seconds(daemon.control_pid()) - control_cpu) / elapsed
        c1 = daemon.cycles()
        # What the gateway does without clients (the mover's calls and planning included).
        result["gateway_idle_cpu_ms_per_s"] = round(idle_cpu * 1e3, 1)
        result["control_idle_cpu_ms_per_s"] = round(control_cpu * 1e3, 1)
        loaded = run_clients(daemon, args, 0.0, mover, idle_cpu)
        c2, c3 = loaded.pop("cycles")
        result["clients"] = loaded.pop("clients")
        result["saturated"] = loaded
        result["phase_cycles"] = [c0, c1, c2, c3]
        if args.poll_hz > 0:
            paced = run_clients(daemon, args, args.poll_hz, mover, idle_cpu)
            del paced["cycles"], paced["clients"]
            result["paced"] = paced
            if args.floor:
                nice = nice_of(daemon.gateway_pid())
                floor = Floor(daemon, args.switch_interval or 0.0005, nice)
                try:
                    grpcio = run_clients(floor, args, args.poll_hz)
                finally:
                    floor.stop()
                del grpcio["cycles"], grpcio["clients"]
                result["floor"] = grpcio
    finally:
        if burn is not None:
            burn.terminate()
            burn.wait(10.0)
        if mover is not None:
            mover.stop()
            result["moves"] = mover.moves
            result["moves_refused"] = mover.refused[:5]
        result["exit_code"] = daemon.stop()
    data = np.load(stats_path)
    first = int(data["first_cycle"])
    period_us = float(data["period_us"])
    wake, compute = data["wake_us"], data["compute_us"]
    for name, (a, b) in {"idle": (c0, c1), "loaded": (c2, c3)}.items():
        sl = slice(max(0, a - first), max(0, b - first))
        result[name] = phase_stats(wake[sl], compute[sl], period_us)
    result["p99_rise_us"] = round(
        result["loaded"]["wake_p99_us"] - result["idle"]["wake_p99_us"], 1
    )
    result["pass"] = bool(
        result["p99_rise_us"] <= MAX_P99_RISE_US and result["loaded"]["late"] == 0
    )
    warnings = [
        line.strip()
        for line in (work / f"{mode}.log").read_text().splitlines()
        if "level=warning" in line or "level=error" in line
    ]
    result["daemon_warnings"] = warnings[:5]
    return result


def print_table(results: list[dict[str, Any]], args: argparse.Namespace) -> None:
    period = 1e6 / args.rate
    print(
        f"\n{args.rate:g} Hz (period {period:.0f} us), {args.seconds:g} s per phase, "
        f"{args.clients} clients in {args.procs} processes, "
        + ("no move running" if args.no_mover else "a linear move always running")
        + (f", a SCHED_FIFO thread busy {args.burn_us:g} us per period" if args.burn_us else "")
    )
    head = (
        f"{'gateway':8s} {'phase':7s} {'cycles':>7s} {'wake p50':>9s} {'p99':>7s} {'max':>8s} "
        f"{'late>T/2':>9s} {'compute p99':>12s} {'calls/s':>9s}"
    )
    print(head)
    print("-" * len(head))
    for r in results:
        for phase in ("idle", "loaded"):
            s = r[phase]
            rate = r.get("saturated", {}).get("calls_per_s", 0)
            calls = f"{rate:9.0f}" if phase == "loaded" else f"{0:9d}"
            print(
                f"{r['mode']:8s} {phase:7s} {s['cycles']:7d} {s['wake_p50_us']:9.1f} "
                f"{s['wake_p99_us']:7.1f} {s['wake_max_us']:8.1f} {s['late']:9d} "
                f"{s['compute_p99_us']:12.1f} {calls}"
            )
    print()
    for r in results:
        verdict = "PASS" if r["pass"] else "FAIL"
        phases = (
            ("saturated", "as fast as they can"),
            ("paced", "polling"),
            ("floor", "polling grpcio's floor (tools/grpc_floor.py)"),
        )
        for name, what in phases:
            g = r.get(name)
            if g is None or "getstate_p99_ms" not in g:
                continue
            ok = "PASS" if g["getstate_p99_ms"] <= MAX_GETSTATE_P99_MS else "FAIL"
            how = f"{what} at {g['poll_hz']:g} Hz each" if g["poll_hz"] else what
            print(
                f"{r['mode']:8s} getState, {r['clients']} clients {how}: "
                f"p50 {g['getstate_p50_ms']:.2f} ms, p99 {g['getstate_p99_ms']:.2f} ms "
                f"(target {MAX_GETSTATE_P99_MS:g} ms): {ok}; {g['calls_per_s']:.0f} calls/s, "
                f"CPU per call: gateway {g.get('gateway_cpu_us_per_call', 0):.0f} us, "
                f"clients {g.get('client_cpu_us_per_call', 0):.0f} us; load {g['load']:.2f}"
            )
            if name != "floor":
                idle = r["gateway_idle_cpu_ms_per_s"]
                print(
                    f"{'':8s}   gateway CPU per call net of its {idle:.0f} ms/s without "
                    "clients (the mover): "
                    f"{g.get('gateway_net_cpu_us_per_call', 0):.0f} us; gateway nice "
                    f"{g.get('gateway_nice')}; the control process used "
                    f"{g.get('control_cpu_ms_per_s', 0):.0f} ms/s of CPU (without clients "
                    f"{r.get('control_idle_cpu_ms_per_s', 0):.0f})"
                )
            if "getstate_p99_from_send_ms" in g:
                sent, late = g["getstate_p99_from_send_ms"], g["client_late_p99_ms"]
                print(
                    f"{'':8s}   from the client's send: p99 {sent:.2f} ms; the clients sent "
                    f"late by up to {late:.2f} ms (p99; their own wait for a CPU)"
                )
            if "getstate_p99_during_moves_ms" in g:
                print(
                    f"{'':8s}   p99 of the {g['reads_during_moves']} reads during a move "
                    f"command (planning) {g['getstate_p99_during_moves_ms']:.2f} ms, of the "
                    f"others {g.get('getstate_p99_other_ms', 0):.2f} ms; the gateway's threads "
                    f"waited {g['gateway_runqueue_ms_per_s']:.0f} ms/s for a CPU"
                )
        print(
            f"{r['mode']:8s} p99 rise under load {r['p99_rise_us']:+.1f} us (limit "
            f"{MAX_P99_RISE_US:g}), late cycles {r['loaded']['late']}: {verdict}; "
            f"{r.get('moves', 0)} moves, daemon exit {r['exit_code']}"
        )
        for w in r["daemon_warnings"]:
            print(f"         daemon: {w}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="per phase [s]")
    parser.add_argument("--clients", type=int, default=32)
    parser.add_argument("--procs", type=int, default=4, help="client processes")
    parser.add_argument("--rate", type=float, default=1000.0, help="loop rate [Hz]")
    parser.add_argument("--modes", default="process,thread")
    parser.add_argument(
        "--switch-interval",
        type=float,
        help="run the daemon with this sys.setswitchinterval [s] (default: as shipped)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a daemon setting (imotiond --set), e.g. --set workers=4; repeatable",
    )
    parser.add_argument("--keep", type=Path, help="keep the daemons' logs and stats files here")
    parser.add_argument("--warmup", type=float, default=2.0, help="[s] before measuring")
    parser.add_argument("--client", metavar="ADDRESS", help=argparse.SUPPRESS)
    parser.add_argument("--threads", type=int, default=8, help=argparse.SUPPRESS)
    parser.add_argument("--hz", type=float, default=0.0, help=argparse.SUPPRESS)
    parser.add_argument(
        "--poll-hz",
        type=float,
        default=POLL_HZ,
        help="each client's call rate in the paced phase [Hz] (0: no paced phase)",
    )
    parser.add_argument(
        "--no-mover",
        action="store_true",
        help="no move running (no planning in the gateway): to tell its share of the reads' "
        "tail from the rest",
    )
    parser.add_argument(
        "--burn-us",
        type=float,
        default=0.0,
        help="a SCHED_FIFO thread (priority 1) busy this long of every loop period [us] "
        "while the daemon runs: with --no-mover, what a running move's extra loop CPU does "
        "to the reads without the move",
    )
    parser.add_argument("--burn", type=float, help=argparse.SUPPRESS)
    parser.add_argument(
        "--floor",
        action="store_true",
        help="after the paced phase, the same clients at a constant-reply grpcio server "
        "(tools/grpc_floor.py) beside the daemon: grpcio's own cost and latency",
    )
    parser.add_argument(
        "--root",
        type=Path,
        default=ROOT,
        help="run imotiond from this checkout (e.g. another branch, to compare)",
    )
    args = parser.parse_args()
    if args.client:
        return client_main(args.client, args.threads, args.seconds, args.hz)
    if args.burn is not None:
        return burn_main(args.burn, args.rate, args.seconds)
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    bad = [m for m in modes if m not in ("process", "thread")]
    if bad or args.procs < 1 or args.clients < 1:
        print(f"--modes: {bad} not in process, thread (or --procs/--clients < 1)", file=sys.stderr)
        return 2
    print("measuring the machine's floor (a bare SCHED_FIFO sleep loop) ...", flush=True)
    bare = machine_floor.measure(args.rate, args.seconds)
    results = []
    with tempfile.TemporaryDirectory(prefix="bench_clients-") as tmp:
        work = Path(tmp)
        if args.keep is not None:
            work = args.keep.resolve()
            work.mkdir(parents=True, exist_ok=True)
        for mode in modes:
            print(f"running gateway={mode} ...", flush=True)
            results.append(run_mode(mode, args, work))
    print_table(results, args)
    print(
        f"machine floor: a bare SCHED_FIFO sleep loop (fifo {bare.get('fifo')}) over "
        f"{args.seconds:g} s: wake p99 {bare.get('wake_p99_us')} us, max "
        f"{bare.get('wake_max_us')} us, {bare.get('late')} late cycles"
    )
    summary = {
        "rate_hz": args.rate,
        "seconds": args.seconds,
        "clients": args.clients,
        "procs": args.procs,
        "max_p99_rise_us": MAX_P99_RISE_US,
        "poll_hz": args.poll_hz,
        "max_getstate_p99_ms": MAX_GETSTATE_P99_MS,
        "switch_interval_s": args.switch_interval,
        "bare_loop": bare,
        **{r["mode"]: {k: v for k, v in r.items() if k != "mode"} for r in results},
    }
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())

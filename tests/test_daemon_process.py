"""The real ``imotiond`` as a subprocess: start-up, listening, signals, configuration errors,
security refusal, sd_notify and structured logs.

Only generous upper bounds on time (the machine is shared and noisy): an exit "within 20 s"
checks that the daemon exits by itself, not how fast.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import grpc
import pytest

from controller.contract.config import load_config
from controller.daemon import main as daemon_main
from controller.daemon.main import Daemon
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import CoreState
from controller.vocabulary import SpecAState as S

REPO = Path(__file__).resolve().parents[1]
EXIT_BOUND = 20.0  # s: "exits by itself", not a timing figure
START_BOUND = 90.0  # s: robot model, hardware and the gateway child on a loaded machine
LOGFMT = re.compile(r"^ts=\S+ level=(debug|info|warning|error|critical) proc=\S+ logger=\S+ msg=")


class Imotiond:
    """One ``python -m controller.daemon.main`` child with its stderr collected by a thread."""

    def __init__(self, *args: str, env: dict[str, str] | None = None):
        full_env = dict(os.environ)
        full_env["PYTHONPATH"] = os.pathsep.join([str(REPO), full_env.get("PYTHONPATH", "")])
        full_env.pop("JOURNAL_STREAM", None)
        full_env.pop("NOTIFY_SOCKET", None)
        full_env.update(env or {})
        cmd = [sys.executable, "-m", "controller.daemon.main", *args]
        self.proc = subprocess.Popen(
            cmd, cwd=REPO, env=full_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        self.lines: list[str] = []
        self.stdout = ""
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))

    def wait_line(self, pattern: str, timeout: float = START_BOUND) -> re.Match[str]:
        end = time.monotonic() + timeout
        regex = re.compile(pattern)
        while time.monotonic() < end:
            for line in list(self.lines):
                match = regex.search(line)
                if match:
                    return match
            if self.proc.poll() is not None:
                self._reader.join(2.0)
                for line in self.lines:
                    if match := regex.search(line):
                        return match
                raise AssertionError(
                    f"imotiond exited ({self.proc.returncode}) before {pattern!r}:\n" + self.log
                )
            time.sleep(0.05)
        raise AssertionError(f"no {pattern!r} within {timeout} s:\n" + self.log)

    def wait_ready(self) -> str:
        """The address from the 'ready ... listening on ADDRESS' line."""
        return self.wait_line(r"msg=\"ready: .* listening on (\S+?)\"").group(1)

    def wait_exit(self, timeout: float = EXIT_BOUND) -> int:
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise AssertionError(f"imotiond still running after {timeout} s:\n{self.log}") from None
        assert self.proc.stdout is not None
        self.stdout = self.proc.stdout.read()
        self._reader.join(5.0)
        return self.proc.returncode

    @property
    def log(self) -> str:
        return "\n".join(self.lines)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10.0)


@pytest.fixture
def short_dir() -> Iterator[Path]:
    """A short directory for Unix sockets (their paths are limited to ~100 bytes)."""
    path = Path(tempfile.mkdtemp(prefix="imd-"))
    try:
        yield path
    finally:
        for child in path.iterdir():
            child.unlink()
        path.rmdir()


def _run(*args: str) -> Imotiond:
    return Imotiond(*args, "--set", "realtime.enabled=false")


def _stub(address: str) -> tuple[grpc.Channel, pb_grpc.IntegratedMotionStub]:
    channel = grpc.insecure_channel(address)
    grpc.channel_ready_future(channel).result(timeout=30.0)
    return channel, pb_grpc.IntegratedMotionStub(channel)


def _children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        text = (task / "children").read_text().split()
        found += [int(x) for x in text]
    return found


# ----------------------------------------------------------------------------- running
def test_sigterm_during_motion_decelerates_servo_off_exit_0():
    d = _run("--hal", "ideal", "--listen", "127.0.0.1:0", "--rate", "250")
    try:
        address = d.wait_ready()
        assert re.fullmatch(r"127\.0\.0\.1:\d+", address) and not address.endswith(":0")
        channel, stub = _stub(address)
        with channel:
            state = stub.GetState(pb.GetStateRequest())
            assert state.status_id == S.SERVO_OFF
            assert "hal ideal" in stub.GetVersion(pb.GetVersionRequest()).version
            assert stub.ServoOn(pb.ServoOnRequest()).return_id.id == 0
            move = pb.MoveUnitRelRequest(
                unit=pb.RIGHT_ARM, rel_pos=[40, 0, 0, 0, 0, 0, 0], speed=[4], accel=[20]
            )
            reply = stub.MoveUnitRel(move)
            assert reply.return_id.id == 0, reply.return_id.comment
            assert stub.IsMoving(pb.IsMovingRequest()).is_moving
            d.proc.send_signal(signal.SIGTERM)
            assert d.wait_exit() == 0, d.log
    finally:
        d.kill()
    log = d.log
    decel = log.index("shutdown: decelerating to a stop")
    off = log.index("shutdown: servo off")
    assert decel < off < log.index("msg=stopped")
    lines = [line for line in d.lines if line.strip()]
    bad = [line for line in lines if not LOGFMT.match(line)]
    assert not bad, "not logfmt:\n" + "\n".join(bad)
    assert any("proc=gateway" in line for line in lines)  # the gateway child logs too


def test_unix_socket_config_file_set_overrides_sd_notify_and_sigint(short_dir: Path):
    """A Unix-socket listener; --set wins over the file; READY/STATUS/WATCHDOG/STOPPING
    datagrams arrive; SIGINT stops like SIGTERM."""
    config = short_dir / "imotiond.yaml"
    config.write_text("robot: smartpal5\nhal: ideal\nloop:\n  rate_hz: 250\n")
    notify_path = short_dir / "notify"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(str(notify_path))
    sock.settimeout(0.2)
    listen = f"unix:{short_dir / 'api.sock'}"
    d = Imotiond(
        "--config",
        str(config),
        "--listen",
        listen,
        "--set",
        "robot=pa10",
        "--set",
        "realtime.enabled=false",
        env={"NOTIFY_SOCKET": str(notify_path), "WATCHDOG_USEC": "300000"},
    )
    messages: list[str] = []
    try:
        assert d.wait_ready() == listen
        channel, stub = _stub(listen)
        with channel:
            version = stub.GetVersion(pb.GetVersionRequest()).version
            assert "robot pa10" in version  # --set beats the file
            assert len(stub.GetFeedbackPosJoint(pb.GetFeedbackPosJointRequest()).position) == 7
            end = time.monotonic() + START_BOUND
            while time.monotonic() < end and sum("WATCHDOG=1" in m for m in messages) < 2:
                try:
                    messages.append(sock.recv(4096).decode())
                except TimeoutError:
                    pass
            d.proc.send_signal(signal.SIGINT)
            assert d.wait_exit() == 0, d.log
        while True:
            try:
                messages.append(sock.recv(4096).decode())
            except TimeoutError:
                break
    finally:
        d.kill()
        sock.close()
    text = "\n".join(messages)
    assert "READY=1" in text
    assert re.search(r"^STATUS=starting", text, re.M)
    assert re.search(r"^STATUS=ready on unix:", text, re.M)
    assert re.search(r"^STATUS=servo off, 0 alarm\(s\)", text, re.M)
    assert sum("WATCHDOG=1" in m for m in messages) >= 2
    assert "STOPPING=1" in text
    assert text.index("READY=1") < text.index("STOPPING=1")


def test_gateway_death_without_restarts_stops_the_daemon():
    d = _run(
        "--hal", "ideal", "--listen", "127.0.0.1:0", "--rate", "250",
        "--set", "gateway_restarts=0",
    )  # fmt: skip
    try:
        d.wait_ready()
        (gateway,) = _children(d.proc.pid)
        os.kill(gateway, signal.SIGKILL)
        assert d.wait_exit() == 1, d.log
    finally:
        d.kill()
    assert "the gateway process exited" in d.log and "shutting down" in d.log


def test_a_killed_gateway_is_restarted_in_place():
    """Issue 17.10: SIGKILL of the gateway: the loop stops the robot and starts a new gateway;
    clients reconnect (to the new address when the port was chosen by the system).

    Also ``gateway_nice`` with real time off: the loop is an ordinary thread, the gateway
    keeps the inherited value, and the log says so (was a daemon of its own in
    test_the_gateway_process_runs_at_gateway_nice_with_its_heap_frozen)."""
    mine = os.getpriority(os.PRIO_PROCESS, 0)
    nice = f"gateway_nice={min(19, mine + 4)}"
    d = _run("--hal", "ideal", "--listen", "127.0.0.1:0", "--rate", "250", "--set", nice)
    try:
        address = d.wait_ready()
        channel, stub = _stub(address)
        assert stub.ServoOn(pb.ServoOnRequest(), timeout=30.0).return_id.id == 0
        channel.close()
        (gateway,) = _children(d.proc.pid)
        assert _nice_values(gateway) == {mine}  # realtime.enabled false: not applied
        os.kill(gateway, signal.SIGKILL)
        new_address = d.wait_line(r"gateway restarted, listening on (\S+?)\"").group(1)
        assert d.proc.poll() is None
        (new_gateway,) = _children(d.proc.pid)
        assert new_gateway != gateway
        channel, stub = _stub(new_address)
        state = stub.GetState(pb.GetStateRequest(), timeout=30.0)
        assert state.status_id == S.READY  # servos still on, robot held
        channel.close()
        d.proc.send_signal(signal.SIGTERM)
        assert d.wait_exit() == 0, d.log
    finally:
        d.kill()
    assert "stopping motion, restarting it" in d.log
    assert "gateway_nice not applied: realtime.enabled is false" in d.log


def test_the_early_gateway_is_the_one_configured_and_dies_with_a_failed_start(
    monkeypatch: pytest.MonkeyPatch,
):
    """imotiond starts its gateway before it builds the controller (the gateway loads its
    modules meanwhile): that process is the one that then serves; a start that fails
    kills it."""
    cfg = load_config(
        None, {"robot": "pa10", "hal": "ideal", "listen": "127.0.0.1:0", "realtime.enabled": False}
    )
    d = Daemon(cfg, early_gateway=True)
    try:
        assert d.gateway is not None and d.gateway.poll() is None
        early = d.gateway.pid
        address = d.start_gateway_process()
        assert d.gateway.pid == early and address.startswith("127.0.0.1:")
    finally:
        d.close()
    spawned: list[subprocess.Popen[str]] = []
    spawn = Daemon._spawn_gateway

    def recorded(self: Daemon) -> subprocess.Popen[str]:
        spawned.append(spawn(self))
        return spawned[-1]

    monkeypatch.setattr(Daemon, "_spawn_gateway", recorded)

    def no_hardware(*_: object) -> None:
        raise OSError("no such hardware")

    monkeypatch.setattr(daemon_main, "make_hardware", no_hardware)
    with pytest.raises(OSError, match="no such hardware"):
        Daemon(cfg, early_gateway=True)
    (gateway,) = spawned
    assert gateway.returncode is not None  # killed and reaped


def test_the_gateway_answers_servo_off_before_the_loop_runs(short_dir: Path):
    """imotiond is ready (READY=1, the "ready" line) once its gateway listens, before the
    loop's first cycle: the snapshot the gateway reads then already shows the hardware it
    configured (power_on_at_start), ServoOff, not the Unpowered of the controller's first
    snapshot (a HIL run at load ~3 read Unpowered in that window), and the joints it
    measures, not the zeros the snapshot held until the loop's first read."""
    cfg = load_config(
        None,
        {"robot": "pa10", "hal": "ideal", "listen": f"unix:{short_dir / 'api.sock'}"},
        ["realtime.enabled=false"],
    )
    d = Daemon(cfg)
    try:
        address = d.start_gateway_process()  # what imotiond waits for before READY=1
        assert d.controller.core.cycles == 0  # the loop has not run
        with grpc.insecure_channel(address) as channel:
            stub = pb_grpc.IntegratedMotionStub(channel)
            reply = stub.GetState(pb.GetStateRequest(), timeout=START_BOUND)
            joints = stub.GetFeedbackPosJoint(
                pb.GetFeedbackPosJointRequest(type=pb.RIGHT_ARM), timeout=START_BOUND
            )
        assert reply.status_id == S.SERVO_OFF, reply
        # ... and the measured joints (PA10's home: J2 30, J4 60, J6 60 deg), not zeros
        assert joints.return_id.id == 0, joints.return_id.comment
        assert [round(x, 6) for x in joints.position] == [0, 30, 0, 60, 0, 60, 0], joints
    finally:
        d.close()


def test_the_loop_is_built_as_the_realtime_section_says(short_dir: Path):
    """``realtime.spin_us`` and ``realtime.collect_in_slack`` reach the control loop."""
    cfg = load_config(
        None,
        {"robot": "pa10", "hal": "ideal", "listen": f"unix:{short_dir / 'api.sock'}"},
        ["realtime.enabled=false", "realtime.spin_us=300", "realtime.collect_in_slack=false"],
    )
    d = Daemon(cfg)
    try:
        assert d.controller.loop.spin_ns == 300_000
        assert d.controller.collector is None
    finally:
        d.close()


# ----------------------------------------------------------------------------- refusals
def _refused(*args: str) -> Imotiond:
    d = _run(*args)
    try:
        assert d.wait_exit() == 2, d.log
    finally:
        d.kill()
    return d


@pytest.mark.parametrize(
    "text, where",
    [
        ("loop:\n  rate_hz: 5\n", "loop.rate_hz"),
        ("bogus: 1\n", "bogus"),
        ("hal: can2\n", "hal"),
        ("listen: nowhere\n", "listen"),
        ("loop: [1, 2\n", "not valid YAML"),
        ("- a list\n", "mapping"),
    ],
)
def test_configuration_errors_exit_2_naming_file_and_key(tmp_path: Path, text: str, where: str):
    config = tmp_path / "bad.yaml"
    config.write_text(text)
    d = _refused("--config", str(config))
    assert str(config) in d.log and where in d.log
    assert "Traceback" not in d.log


def test_bad_set_and_missing_file_exit_2(tmp_path: Path):
    d = _refused("--set", "loop.rate_hz=fast")
    assert "--set" in d.log and "loop.rate_hz" in d.log
    missing = tmp_path / "nope.yaml"
    d = _refused("--config", str(missing))
    assert str(missing) in d.log and "cannot read" in d.log


def test_any_address_without_tls_and_token_refuses_to_start():
    d = _refused("--listen", "0.0.0.0:50551", "--hal", "ideal")
    assert "refusing to start" in d.log
    assert "TLS is required" in d.log and "token is required" in d.log
    assert "0.0.0.0:50551" in d.log


def test_tcp_without_a_motion_token_warns_at_start():
    d = _run("--hal", "ideal", "--listen", "127.0.0.1:0", "--check")
    try:
        assert d.wait_exit() == 0, d.log
    finally:
        d.kill()
    assert re.search(r"level=warning .*without a motion token: every user", d.log), d.log


def test_secrets_stay_private_in_an_open_runtime_dir(short_dir: Path):
    """A runtime directory that already exists world-readable (issue 17.6): it is narrowed,
    and the tokens are in no file of it (the gateway gets its configuration by a pipe)."""
    runtime = short_dir / "run"
    runtime.mkdir()
    runtime.chmod(0o755)
    secret = "motion-secret-7f3a"
    d = _run(
        "--hal", "ideal", "--listen", "127.0.0.1:0",
        "--set", f"runtime_dir={runtime}", "--set", f"security.tokens.motion={secret}",
    )  # fmt: skip
    try:
        d.wait_ready()
        assert runtime.stat().st_mode & 0o777 == 0o750
        assert re.search(r"level=warning .*runtime_dir .* had mode 0755", d.log), d.log
        files = [p for p in runtime.iterdir() if p.is_file()]
        assert files
        for path in files:
            assert path.stat().st_mode & 0o077 == 0, f"{path.name} is readable by others"
            assert secret.encode() not in path.read_bytes(), f"{path.name} holds the token"
        d.proc.send_signal(signal.SIGTERM)
        assert d.wait_exit() == 0, d.log
    finally:
        d.kill()
        shutil.rmtree(runtime, ignore_errors=True)


def test_check_validates_only(tmp_path: Path):
    config = tmp_path / "ok.yaml"
    config.write_text("robot: rh\nqueue_depth: 3\n")
    d = _run("--config", str(config), "--check")
    try:
        assert d.wait_exit() == 0, d.log
    finally:
        d.kill()
    assert "configuration OK" in d.stdout


def _gone(pid: int) -> bool:
    """The process has exited (no /proc entry, or a zombie nobody reaped yet)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return True
    return "\nState:\tZ" in status


def _nice_values(pid: int) -> set[int]:
    """The nice values of every thread of process ``pid`` (Linux: nice is per thread)."""
    values = set()
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            values.add(int((task / "stat").read_text().rsplit(")", 1)[1].split()[16]))
        except OSError:  # the thread ended meanwhile
            continue
    return values


def test_the_gateway_process_runs_at_gateway_nice_with_its_heap_frozen():
    """``gateway_nice``: every thread of the gateway child (gRPC's included, started after
    the value was set), and only the gateway, when real time is on (as root the loop is
    then SCHED_FIFO; otherwise it falls back with a warning and the gateway still gets its
    value). A raised value here, which needs no privilege. Its heap is frozen once started
    (no full collection of it while serving). (Real time off, the inherited value: in
    test_a_killed_gateway_is_restarted_in_place.)

    Then, merged here to share the daemon (was test_a_restarted_gateway_is_not_real_time):
    with real time on, imotiond restarts a killed gateway from its supervising thread,
    which runs at SCHED_FIFO 1: the new gateway inherited it in every thread (under client
    load it would have starved every ordinary process). Now the helper threads carry
    SCHED_RESET_ON_FORK, and the gateway would put an inherited policy back itself
    (tests/test_gateway_scheduling.py): every thread of the new one is ordinary, and it
    runs at gateway_nice too. (Where real time is not permitted the loop falls back to an
    ordinary thread and that holds trivially; the test used to be skipped there.)"""
    mine = os.getpriority(os.PRIO_PROCESS, 0)
    target = min(19, mine + 4)
    nice = f"gateway_nice={target}"
    d = Imotiond("--hal", "ideal", "--listen", "127.0.0.1:0", "--rate", "250", "--set", nice)
    try:
        address = d.wait_ready()
        channel, stub = _stub(address)
        assert stub.GetState(pb.GetStateRequest(), timeout=30.0).return_id.id == 0
        channel.close()
        (gateway,) = _children(d.proc.pid)
        assert _nice_values(gateway) == {target}
        assert os.getpriority(os.PRIO_PROCESS, d.proc.pid) == mine  # the control process
        os.kill(gateway, signal.SIGKILL)
        d.wait_line(r"gateway restarted, listening on")
        (new_gateway,) = _children(d.proc.pid)
        policies = {
            os.sched_getscheduler(int(t.name)) for t in Path(f"/proc/{new_gateway}/task").iterdir()
        }
        assert _nice_values(new_gateway) == {target}
        d.proc.send_signal(signal.SIGTERM)
        assert d.wait_exit() == 0, d.log
    finally:
        d.kill()
    assert policies == {os.SCHED_OTHER}
    assert "not in effect" not in d.log  # permitted: no warning
    assert re.search(r"proc=gateway .*msg=\"\d+ objects frozen out of the full garbage", d.log)


def test_gateway_stops_when_imotiond_is_killed():
    """SIGKILL leaves imotiond no time to clean up: the gateway notices its parent is gone and
    stops instead of holding the port as an orphan."""
    d = _run("--hal", "ideal", "--listen", "127.0.0.1:0", "--rate", "250")
    gateway = None
    runtime = None
    try:
        d.wait_ready()
        (gateway,) = _children(d.proc.pid)
        cmdline = Path(f"/proc/{gateway}/cmdline").read_bytes().split(b"\0")
        runtime = Path(cmdline[cmdline.index(b"--runtime") + 1].decode())
        d.proc.kill()
        d.proc.wait(EXIT_BOUND)
        end = time.monotonic() + EXIT_BOUND
        while time.monotonic() < end and not _gone(gateway):
            time.sleep(0.1)
        assert _gone(gateway), "the gateway outlived imotiond"
    finally:
        d.kill()
        if gateway is not None and not _gone(gateway):
            os.kill(gateway, signal.SIGKILL)
        if runtime is not None:  # nobody was left to remove it
            shutil.rmtree(runtime, ignore_errors=True)
    d._reader.join(5.0)  # EOF once the gateway, the last writer of the pipe, has exited
    assert "is gone: stopping" in d.log


# ----------------------------------------------------------------------------- watchdog
class _FakeCore:
    def __init__(self) -> None:
        self.cycles = 0
        self.state = CoreState.READY
        self.alarms: list[object] = []


class _FakeDaemon:
    """What :func:`controller.daemon.main._supervise` looks at."""

    def __init__(self) -> None:
        self.controller = type("Ctl", (), {})()
        self.controller.core = _FakeCore()
        self.controller.shutdown_requested = threading.Event()
        self.exit_code = 0
        self.alive = True
        self.gateway = None
        self.cfg = load_config(None, {"gateway_restarts": 0})  # a dead gateway ends it

    def gateway_alive(self) -> bool:
        return self.alive

    def request_shutdown(self) -> None:
        self.controller.shutdown_requested.set()


def test_watchdog_only_while_the_loop_advances(short_dir: Path, monkeypatch: pytest.MonkeyPatch):
    from controller.daemon.main import _supervise

    path = short_dir / "notify"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(str(path))
    sock.settimeout(0.05)
    monkeypatch.setenv("NOTIFY_SOCKET", str(path))
    monkeypatch.setenv("WATCHDOG_USEC", "30000")  # ping every 10 ms
    monkeypatch.delenv("WATCHDOG_PID", raising=False)
    fake = _FakeDaemon()
    thread = threading.Thread(target=_supervise, args=(fake,), daemon=True)
    thread.start()

    def drain(seconds: float) -> list[str]:
        got, end = [], time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                got.append(sock.recv(4096).decode())
            except TimeoutError:
                pass
        return got

    try:
        for _ in range(20):  # the loop advances: pings
            fake.controller.core.cycles += 1
            time.sleep(0.02)
        advancing = drain(0.1)
        assert advancing.count("WATCHDOG=1") >= 3
        assert "STATUS=ready, 0 alarm(s)" in advancing
        drain(0.1)
        stalled = drain(0.3)  # the loop is stuck: no ping at all
        assert "WATCHDOG=1" not in stalled
        fake.alive = False  # the gateway died: shut down with exit code 1
        thread.join(5.0)
        assert not thread.is_alive()
        assert fake.exit_code == 1 and fake.controller.shutdown_requested.is_set()
    finally:
        fake.controller.shutdown_requested.set()
        sock.close()


def test_a_port_in_use_fails_naming_the_address():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        d = _run("--hal", "ideal", "--listen", f"127.0.0.1:{port}", "--rate", "250")
        try:
            assert d.wait_exit(START_BOUND) == 1, d.log
        finally:
            d.kill()
    assert re.search(rf"level=error .*cannot start the gateway.*127\.0\.0\.1:{port}", d.log)

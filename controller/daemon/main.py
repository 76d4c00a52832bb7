"""``imotiond``: the motion-controller daemon.

Two processes: this one runs the fixed-rate loop (real-time where allowed) and owns the
hardware; a gateway child (``controller.gateway.process``) serves gRPC. They meet in a
private runtime directory: the snapshot (shared memory) and the command socket.

Start-up: configuration → gateway child started (it loads its modules meanwhile) →
hardware up → loop ready → gateway configured and listening → ``READY=1``.
``WATCHDOG=1`` is sent only while the loop advances. SIGTERM/SIGINT: decelerating stop,
servo off, exit 0.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from controller.contract.blackbox import BLACKBOX_NAME
from controller.contract.channel import CommandServer
from controller.contract.config import (
    DaemonConfig,
    load_config,
    security_warnings,
)
from controller.contract.snapshot import JOINTS_NAME, SNAPSHOT_NAME
from controller.control.blackbox import BlackBoxRing
from controller.control.cycle_log import CycleLog
from controller.control.realtime import apply_realtime, restore
from controller.daemon import systemd
from controller.daemon.preflight import preflight
from controller.logs import flush_logs, setup_logging
from controller.model.robot import Robot, load_robot
from controller.model.yaml_source import ConfigError
from controller.version import add_version_argument
from hal.factory import make_hardware

_log = logging.getLogger("imotiond")

#: Longest wait for the gateway to listen [s].
GATEWAY_START_TIMEOUT = 60.0


class RuntimeDirError(RuntimeError):
    """The runtime directory is open to other users and cannot be made private."""


#: Mode bits a runtime directory must not have: anything for others, write for the group
#: (the group may traverse it to reach a gRPC Unix socket, as under the systemd unit).
UNSAFE_RUNTIME_BITS = 0o027


def make_runtime_dir(cfg: DaemonConfig) -> Path:
    """The runtime directory, private to the daemon's user (and readable by its group).

    An existing directory that others could list or write is narrowed (with a warning); one
    that cannot be narrowed (another owner) refuses the start.
    """
    if cfg.runtime_dir is not None:
        path = Path(cfg.runtime_dir)
        path.mkdir(parents=True, exist_ok=True, mode=0o700)
        mode = path.stat().st_mode & 0o777
        if mode & UNSAFE_RUNTIME_BITS:
            safe = mode & ~UNSAFE_RUNTIME_BITS
            try:
                os.chmod(path, safe)
            except OSError as exc:
                raise RuntimeDirError(
                    f"runtime_dir {path} has mode {mode:04o} (others may list or write it) "
                    f"and cannot be changed: {exc}"
                ) from None
            _log.warning(
                "runtime_dir %s had mode %04o (others could list or write it): changed to %04o",
                path,
                mode,
                safe,
            )
        return path
    base = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else None
    return Path(tempfile.mkdtemp(prefix="imotiond-", dir=base))


def _write_private(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` readable by the daemon's user only (0600, any umask)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    os.fchmod(fd, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(text)


class Daemon:
    """The control side of imotiond, usable in-process (tests) or from :func:`main`."""

    def __init__(
        self,
        cfg: DaemonConfig,
        robot: Robot | None = None,
        hal_options: dict[str, Any] | None = None,
        early_gateway: bool = False,
    ):
        """``robot`` and ``hal_options``: as :func:`~controller.daemon.preflight.preflight`
        gave them (loaded / taken from ``cfg`` when None). ``early_gateway``: start the
        gateway process now, so that it loads its modules (gRPC, planning: ~3 s of CPU)
        while this process builds the hardware layer and the controller; it waits for its
        configuration, which :meth:`start_gateway_process` sends."""
        self.cfg = cfg
        self.robot = robot if robot is not None else load_robot(cfg.robot)
        self.runtime = make_runtime_dir(cfg)
        self._own_runtime = cfg.runtime_dir is None
        self.gateway: subprocess.Popen[str] | None = None
        self._gateway_started = False  #: the gateway process got its configuration
        if early_gateway:
            self.gateway = self._spawn_gateway()
        try:
            self._build(hal_options)
        except BaseException:
            if self.gateway is not None:
                self.gateway.kill()
                self.gateway.wait()
            raise
        self._server: Any = None
        self._observers: Any = None  #: live view and black-box writer (gateway thread only)
        self.address: str | None = None
        self.exit_code = 0

    def _build(self, hal_options: dict[str, Any] | None) -> None:
        # Here, not at the top: ``imotiond --check`` and ``--help`` never load the loop's
        # solver, motion and kernel modules (~1.5 s of imports).
        from controller.control.process import Controller

        cfg = self.cfg
        options = cfg.hal_options if hal_options is None else hal_options
        self.hw = make_hardware(cfg.hal, self.robot, cfg.period, options)
        self.controller = Controller(
            self.robot,
            self.hw,
            cfg.loop.rate_hz,
            self.runtime / SNAPSHOT_NAME,
            cfg.queue_depth,
            cfg.loop.solver,
            cfg.obstacles,
            collect_in_slack=cfg.realtime.collect_in_slack,
            spin_us=cfg.realtime.spin_us,
        )
        self.controller.stop_timeout = cfg.stop_timeout_s
        if cfg.blackbox.dir is not None:
            self.controller.blackbox = BlackBoxRing(
                self.runtime / BLACKBOX_NAME,
                len(self.hw.joint_names),
                cfg.loop.rate_hz,
                cfg.blackbox.seconds + cfg.blackbox.after_s,
            )
        if cfg.power_on_at_start:
            # After the controller is built: its models load in C calls that hold the GIL
            # for hundreds of ms, which would starve the CAN master's heartbeat thread.
            self.hw.configure()
            # The controller's first snapshot showed the hardware unconfigured (Unpowered)
            # and the joints at zero; the gateway reads the snapshot and answers before the
            # loop's first cycle (READY=1 comes first): show it configured (ServoOff), with
            # the joints it measures, from the start.
            self.controller.core.adopt_measured()
            self.controller.publish()
        if cfg.loop.stats_file is not None:
            loop = self.controller.loop
            loop.stats = CycleLog(loop.period, loop.stats.capacity)
        _write_private(self.runtime / JOINTS_NAME, json.dumps(list(self.hw.joint_names)))
        self.commands = CommandServer(self.controller, self.runtime)
        self.commands.start()

    # ------------------------------------------------------------------ gateway
    def _spawn_gateway(self) -> subprocess.Popen[str]:
        cmd = [sys.executable, "-m", "controller.gateway.process", "--runtime", str(self.runtime)]
        return subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def start_gateway_process(self) -> str:
        """Configure the early gateway process, or start a new one (none yet, a restart);
        its address once it listens."""
        if self.gateway is None or self._gateway_started or self.gateway.poll() is not None:
            self.gateway = self._spawn_gateway()
        self._gateway_started = True
        assert self.gateway.stdin is not None and self.gateway.stdout is not None
        # The configuration holds the tokens: a pipe, never a file in the runtime directory.
        self.gateway.stdin.write(self.cfg.model_dump_json() + "\n")
        self.gateway.stdin.close()
        line = _readline(self.gateway.stdout, GATEWAY_START_TIMEOUT)
        if not line.startswith("READY "):
            self.gateway.kill()
            raise RuntimeError(f"the gateway did not start: {line.strip() or 'no answer'}")
        self.address = line.split(" ", 1)[1].strip()
        return self.address

    def start_gateway_thread(self) -> str:
        """The gateway inside this process (comparison only: shares the loop's GIL)."""
        from controller.gateway.process import start_gateway, start_observers

        self._server = start_gateway(self.cfg, self.runtime)
        self.address = self._server.address
        self._observers = start_observers(self.cfg, self.runtime, self._server.ctx)
        assert self.address is not None
        return self.address

    def gateway_alive(self) -> bool:
        return self.gateway is None or self.gateway.poll() is None

    # ------------------------------------------------------------------ running
    def run(self) -> None:
        """The loop, in the calling thread, until shutdown."""
        self.controller.run()

    def request_shutdown(self, *_: Any) -> None:
        self.controller.shutdown_requested.set()

    def close(self) -> None:
        if self._observers is not None:
            self._observers.close()
        if self._server is not None:
            self._server.stop(0)
        if self.gateway is not None and self.gateway.poll() is None:
            self.gateway.terminate()
            try:
                self.gateway.wait(1.0)
            except subprocess.TimeoutExpired:
                self.gateway.kill()
        self.commands.close()
        stats = self.controller.loop.stats
        if self.cfg.loop.stats_file is not None and isinstance(stats, CycleLog):
            try:
                stats.save(Path(self.cfg.loop.stats_file))
            except OSError as exc:
                _log.error("cannot write loop.stats_file %s: %s", self.cfg.loop.stats_file, exc)
        try:
            self.hw.shutdown()
        finally:
            self.controller.close()
            if self._own_runtime:
                shutil.rmtree(self.runtime, ignore_errors=True)


def _readline(stream: Any, timeout: float) -> str:
    result: list[str] = []
    reader = threading.Thread(target=lambda: result.append(stream.readline()), daemon=True)
    reader.start()
    reader.join(timeout)
    return result[0] if result else ""


def _supervise(daemon: Daemon) -> None:
    """Watchdog pings while the loop advances; STATUS= on state changes; gateway health;
    the loop-health log line."""
    from controller.daemon.health import LoopHealth

    period = systemd.watchdog_period()
    interval = min(0.5, period / 3) if period else 0.5
    interval = min(interval, daemon.cfg.loop.health_log_s)
    last_cycle = -1
    last_status = ""
    restarts: list[float] = []
    ctl = daemon.controller
    health = LoopHealth(ctl, daemon.cfg.loop.health_log_s)
    while not ctl.shutdown_requested.is_set():
        time.sleep(interval)
        try:
            health.tick(time.monotonic())
        except Exception:  # the watchdog must not stop over a log line
            _log.exception("loop health line failed")
        cycles = ctl.core.cycles
        if cycles != last_cycle:
            systemd.notify("WATCHDOG=1")
            last_cycle = cycles
        status = f"STATUS={ctl.core.state.text}, {len(ctl.core.alarms)} alarm(s)"
        if status != last_status:
            systemd.notify(status)
            last_status = status
        if not daemon.gateway_alive() and not ctl.shutdown_requested.is_set():
            # (during a shutdown close() ends the gateway itself: not an error)
            _restart_gateway(daemon, restarts)


#: The window in which ``gateway_restarts`` restarts are allowed [s].
RESTART_WINDOW = 60.0


def _restart_gateway(daemon: Daemon, restarts: list[float]) -> None:
    """The gateway died: stop any motion (no client can stop it now), then start a new
    gateway, unless it died too often lately: then shut down (exit 1)."""
    ctl = daemon.controller
    code = daemon.gateway.returncode if daemon.gateway is not None else None
    now = time.monotonic()
    restarts[:] = [t for t in restarts if now - t < RESTART_WINDOW]
    if len(restarts) >= daemon.cfg.gateway_restarts:
        _log.error(
            "the gateway process exited (code %s), %d restart(s) in the last %g s: shutting down",
            code,
            len(restarts),
            RESTART_WINDOW,
        )
        daemon.exit_code = 1
        daemon.request_shutdown()
        return
    _log.error("the gateway process exited (code %s): stopping motion, restarting it", code)
    ctl.submit("stop", timeout=5.0)
    restarts.append(now)
    systemd.notify("STATUS=restarting the gateway")
    try:
        address = daemon.start_gateway_process()
    except Exception as exc:
        _log.error("the gateway did not restart: %s: shutting down", exc)
        daemon.exit_code = 1
        daemon.request_shutdown()
        return
    _log.warning("gateway restarted, listening on %s", address)
    systemd.notify(f"STATUS=ready on {address} (gateway restarted)")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="imotiond",
        description="imotion whole-body motion controller daemon",
    )
    p.add_argument("--config", type=Path, help="YAML configuration file")
    p.add_argument("--robot", help="robot id (smartpal5, pa10, rh, seednoid) or profile dir")
    p.add_argument("--hal", choices=["sim", "hil", "can", "ideal"], help="hardware layer")
    p.add_argument("--listen", help="host:port or unix:/path (default 127.0.0.1:50051)")
    p.add_argument("--rate", type=float, help="loop rate [Hz] (loop.rate_hz)")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override any setting, e.g. --set queue_depth=16 (repeatable)",
    )
    p.add_argument("--check", action="store_true", help="validate the configuration and exit")
    add_version_argument(p)
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``imotiond``; every log line is written before it returns."""
    args = parse_args(argv)
    try:
        return _main(args)
    finally:
        flush_logs()


def _main(args: argparse.Namespace) -> int:
    try:
        cfg = load_config(
            args.config,
            {
                "robot": args.robot,
                "hal": args.hal,
                "listen": args.listen,
                "loop.rate_hz": args.rate,
            },
            args.set,
        )
    except ConfigError as exc:
        print(f"imotiond: configuration error:\n{exc}", file=sys.stderr)
        return 2
    setup_logging(cfg.log_level, "imotiond")
    checked = preflight(cfg)
    if checked.problems:
        for problem in checked.problems:
            _log.error("refusing to start: %s", problem)
        return 2
    for warning in security_warnings(cfg):
        _log.warning("%s", warning)
    if args.check:
        print("configuration OK")
        return 0
    systemd.notify("STATUS=starting: loading the robot and the hardware layer")
    try:
        daemon = Daemon(
            cfg, checked.robot, checked.hal_options, early_gateway=cfg.gateway == "process"
        )
    except (ConfigError, ValueError, OSError, RuntimeError) as exc:  # RuntimeDirError too
        _log.error("cannot start: %s", exc)
        return 2
    signal.signal(signal.SIGTERM, daemon.request_shutdown)
    signal.signal(signal.SIGINT, daemon.request_shutdown)
    try:
        if cfg.gateway == "process":
            address = daemon.start_gateway_process()
        else:
            address = daemon.start_gateway_thread()
    except Exception as exc:
        _log.error("cannot start the gateway: %s", exc)
        daemon.close()
        return 1
    # Helper threads first: apply_realtime puts the threads alive at the call at the lowest
    # real-time priority; one the loop thread started later would be an ordinary thread.
    daemon.controller.events.start()
    threading.Thread(target=_supervise, args=(daemon,), name="supervise", daemon=True).start()
    report = (
        apply_realtime(
            cfg.realtime.priority,
            cfg.realtime.lock_memory,
            helper_priority=cfg.realtime.helper_priority,
            cpus=cfg.realtime.loop_cpus,
            switch_interval=cfg.realtime.switch_interval_s,
        )
        if cfg.realtime.enabled
        else None
    )
    _log.info(
        "ready: robot %s, hal %s, %g Hz, listening on %s",
        cfg.robot,
        cfg.hal,
        cfg.loop.rate_hz,
        address,
    )
    if cfg.realtime.spin_us:
        _log.info(
            "the loop busy-waits the last %g us before each deadline (realtime.spin_us): "
            "its CPU stays busy that long every period",
            cfg.realtime.spin_us,
        )
    systemd.notify("READY=1", f"STATUS=ready on {address}")
    try:
        daemon.run()
    finally:
        if report is not None:
            restore(report)
        systemd.notify("STOPPING=1")
        daemon.close()
    _log.info("stopped")
    return daemon.exit_code


if __name__ == "__main__":
    sys.exit(main())

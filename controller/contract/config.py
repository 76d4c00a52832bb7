"""The daemon's configuration: one validated YAML file, every setting overridable.

``imotiond --config FILE`` reads the file (all keys optional; defaults below); the named flags
(``--robot``, ``--hal``, ``--listen``) and ``--set KEY=VALUE`` (dotted keys, YAML values,
e.g. ``--set loop.rate_hz=1000 --set security.tokens.motion=s3cret``) override it. Any
problem is reported as ``where: key: what is wrong`` and the daemon does not start.
"""

from __future__ import annotations

import ipaddress
import math
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from controller.contract.corba_config import CorbaConfig, corba_problems, corba_warnings
from controller.model.obstacles import Obstacle, check_unique
from controller.model.yaml_source import ConfigError

DEFAULT_LISTEN = "127.0.0.1:50051"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class LoopConfig(_Strict):
    #: Control rate [Hz].
    rate_hz: float = Field(default=500.0, ge=10.0, le=4000.0)
    #: QP back end (controller.qp.solver.make_solver names).
    solver: str = "daqp"
    #: Write every cycle's wake latency and compute time here (.npz) when the daemon stops
    #: (benchmarks: tools/bench_clients.py); None: keep only the last second.
    stats_file: Path | None = None
    #: One loop-health log line this often [s] (cycles, overruns, compute and wake-up
    #: latency p99); a warning, at once, when cycles overran since the last line.
    health_log_s: float = Field(default=60.0, gt=0.0)


class RealtimeConfig(_Strict):
    #: Try SCHED_FIFO + mlockall for the loop thread (falls back with a warning).
    enabled: bool = True
    priority: int = Field(default=80, ge=1, le=99)
    #: SCHED_FIFO priority of the control process's other threads (below ``priority``; 0:
    #: leave them ordinary). They share the loop's GIL (controller.control.realtime).
    helper_priority: int = Field(default=1, ge=0, le=98)
    lock_memory: bool = True
    #: Run Python's garbage collector only in the control loop's slack, never mid-cycle
    #: (controller.control.collector). Off: CPython's automatic collection.
    collect_in_slack: bool = True
    #: The control process's GIL switch interval [s]: how long one of its other threads may
    #: keep the GIL from the loop thread once the loop asks for it (Python's default 5 ms
    #: shows up as late cycles; the benchmarks run at 0.1 ms).
    switch_interval_s: float = Field(default=1e-4, ge=1e-5, le=0.1)
    #: Pin the loop thread to these CPUs (a core kept free of other work); None: the
    #: scheduler places it. Refused CPUs leave it unpinned with a warning.
    loop_cpus: list[int] | None = None
    #: Busy-wait the last microseconds before each deadline instead of sleeping them [µs]
    #: (0: sleep up to the deadline). The loop's CPU then does not idle before a cycle: no
    #: wake-up latency, fewer late cycles and a warmer cache, for the price of that CPU
    #: (the loop thread holds the GIL while it spins, as while it computes). The loop still
    #: sleeps a tenth of each period first (the kernel's real-time throttling, see
    #: controller.control.loop.MIN_SLEEP_SHARE). Meant for a core kept for the loop
    #: (``loop_cpus``); below the period (``DaemonConfig`` checks).
    spin_us: float = Field(default=0.0, ge=0.0)

    @field_validator("loop_cpus")
    @classmethod
    def _cpu_numbers(cls, cpus: list[int] | None) -> list[int] | None:
        if cpus is not None and (not cpus or min(cpus) < 0):
            raise ValueError("realtime.loop_cpus: CPU numbers (0 or more), at least one, or null")
        return cpus

    @model_validator(mode="after")
    def _helpers_below_the_loop(self) -> RealtimeConfig:
        if self.helper_priority >= self.priority:
            raise ValueError(
                f"realtime.helper_priority ({self.helper_priority}) must be below "
                f"realtime.priority ({self.priority})"
            )
        return self


class TokensConfig(_Strict):
    #: Token for read-only operations (get*, is*, StreamState). None: the motion token.
    read: str | None = None
    #: Token for everything else (motion, settings, servo). Required off loopback.
    motion: str | None = None


class SecurityConfig(_Strict):
    tls_cert: Path | None = None  #: PEM certificate chain of the server
    tls_key: Path | None = None  #: PEM private key
    tokens: TokensConfig = TokensConfig()
    #: Refuse to start on loopback / a Unix socket without a motion token too. (Configured
    #: tokens are always checked, wherever the daemon listens; without tokens local clients
    #: are trusted.)
    require_tokens_locally: bool = False


class JaraConfig(_Strict):
    #: Command cycle reported by getManipInfo and used by the ...CmdCycle moves [ms].
    cmd_cycle_ms: int = Field(default=20, ge=1, le=1000)
    #: Maximum Cartesian speed (setMaxSpeedCartesian's initial value) [mm/s, deg/s].
    max_speed_cartesian: tuple[float, float] = (250.0, 90.0)
    #: Minimum acceleration times (initial values) [s].
    min_accel_time_cartesian: float = Field(default=0.1, gt=0.0)
    min_accel_time_joint: float = Field(default=0.1, gt=0.0)


class MonitorConfig(_Strict):
    #: StreamState rate when the request asks for 0 [Hz].
    default_rate_hz: float = Field(default=20.0, gt=0.0)
    #: Concurrent StreamState streams (each holds a thread of the streams' own pool, never
    #: one of ``workers``).
    max_streams: int = Field(default=8, ge=1, le=64)


class TestingConfig(_Strict):
    """Test-only services (never on a production robot)."""

    #: Serve the Testing gRPC service: fault injection into the drive emulator of
    #: ``--hal hil`` (a motion call: the motion token applies).
    fault_injection: bool = False


class ViewConfig(_Strict):
    """Live view: a Foxglove-protocol WebSocket server in the gateway process."""

    #: host:port to serve on (port 0: any free port, logged); None: no live view.
    listen: str | None = None
    #: Messages per second on every channel [Hz].
    rate_hz: float = Field(default=50.0, gt=0.0, le=1000.0)
    #: Serve on an address other than loopback. The Foxglove protocol has no authentication:
    #: anyone who reaches the port sees the robot (it cannot command it).
    allow_remote: bool = False

    @field_validator("listen")
    @classmethod
    def _listen(cls, value: str | None) -> str | None:
        if value is not None and parse_listen(value)[0] != "tcp":
            raise ValueError("the live view listens on host:port (no Unix socket)")
        return value


class BlackBoxConfig(_Strict):
    """Black box: the last seconds of every cycle, written to MCAP on every alarm."""

    #: Directory for the files (created if missing); None: no black box.
    dir: Path | None = None
    #: Seconds of cycles kept before an alarm [s].
    seconds: float = Field(default=10.0, gt=0.0, le=120.0)
    #: Seconds of cycles after the alarm added to the file [s].
    after_s: float = Field(default=0.5, ge=0.0, le=10.0)


class DaemonConfig(_Strict):
    robot: str = "smartpal5"
    hal: Literal["sim", "hil", "can", "ideal"] = "sim"
    #: Backend-specific settings (see hal/factory.py).
    hal_options: dict[str, Any] = {}
    #: host:port, [v6]:port, or unix:/path/to.sock
    listen: str = DEFAULT_LISTEN
    loop: LoopConfig = LoopConfig()
    realtime: RealtimeConfig = RealtimeConfig()
    #: JARA_ARM motion queue depth (Spec A never queues).
    queue_depth: int = Field(default=8, ge=1, le=1000)
    #: Configure the hardware at start-up (state ServoOff); False: stay Unpowered until
    #: servoOn.
    power_on_at_start: bool = True
    #: Where the gRPC gateway runs: its own process (default; client load cannot disturb the
    #: loop) or a thread of the control process (for comparison in tools/bench_clients.py).
    gateway: Literal["process", "thread"] = "process"
    #: A gateway process that dies is restarted in place (the loop holds the robot still
    #: meanwhile) at most this many times within a minute; beyond, the daemon shuts down
    #: (exit 1). 0: never restart.
    gateway_restarts: int = Field(default=3, ge=0, le=100)
    #: gRPC worker threads of the gateway, for the unary calls (the StreamState streams
    #: have a pool of their own).
    workers: int = Field(default=16, ge=2, le=256)
    #: The gateway process's GIL switch interval [s] (Python's default 5 ms): how long a
    #: thread planning a move keeps the GIL from the threads answering reads
    #: (docs/daemon.md, "Reads under client load"). ``gateway: process`` only.
    gateway_switch_interval_s: float = Field(default=0.0005, ge=1e-5, le=0.1)
    #: The gateway process's nice value (CFS weight; ordinary processes: 0): below 0, its
    #: threads get the CPU before the machine's other work. Needs root, CAP_SYS_NICE or a
    #: nice limit (the systemd unit's ``LimitNICE=``); else a warning and the inherited
    #: value. Only with ``realtime.enabled`` (an ordinary loop thread must not be outranked
    #: by its gateway). Never real-time. ``gateway: process`` only (docs/daemon.md).
    gateway_nice: int = Field(default=-5, ge=-20, le=19)
    security: SecurityConfig = SecurityConfig()
    jara: JaraConfig = JaraConfig()
    monitor: MonitorConfig = MonitorConfig()
    testing: TestingConfig = TestingConfig()
    view: ViewConfig = ViewConfig()
    blackbox: BlackBoxConfig = BlackBoxConfig()
    #: The original CORBA interfaces beside gRPC (controller/contract/corba_config.py).
    corba: CorbaConfig = CorbaConfig()
    #: Where the control process and the gateway meet (snapshot, command socket);
    #: default: a fresh private directory under /dev/shm or the temp directory.
    runtime_dir: Path | None = None
    #: SIGTERM: longest decelerating stop before the servos go off [s].
    stop_timeout_s: float = Field(default=1.2, gt=0.0, le=10.0)
    log_level: Literal["debug", "info", "warning", "error"] = "info"
    #: Static obstacles (a table, a wall, a mast) in the original frame as set at start-up:
    #: boxes, spheres, capsules, planes (controller.model.obstacles; docs/collision.md).
    #: Cartesian moves whose path would bring the robot within the security distance of
    #: one are refused.
    obstacles: tuple[Obstacle, ...] = ()

    @field_validator("obstacles")
    @classmethod
    def _obstacles(cls, value: tuple[Obstacle, ...]) -> tuple[Obstacle, ...]:
        check_unique(value)
        return value

    @field_validator("listen")
    @classmethod
    def _listen(cls, value: str) -> str:
        parse_listen(value)
        return value

    @field_validator("realtime")
    @classmethod
    def _spin_within_the_period(cls, value: RealtimeConfig, info: ValidationInfo) -> RealtimeConfig:
        loop = info.data.get("loop")  # validated before (declared first); absent if invalid
        if loop is None:
            return value
        period_us = 1e6 / loop.rate_hz
        if value.spin_us >= period_us:
            raise ValueError(
                f"spin_us ({value.spin_us:g}) must be below the loop's period "
                f"({period_us:g} µs at loop.rate_hz {loop.rate_hz:g})"
            )
        return value

    @property
    def period(self) -> float:
        """Loop period [s]."""
        return 1.0 / self.loop.rate_hz


def parse_listen(address: str) -> tuple[str, str | None, int | None]:
    """``("unix", path, None)`` or ``("tcp", host, port)``; ValueError says what is wrong."""
    if address.startswith("unix:"):
        path = address.removeprefix("unix:").removeprefix("//")
        if not path:
            raise ValueError("unix: address needs a socket path, e.g. unix:/run/imotion.sock")
        return "unix", path, None
    host, sep, port_text = address.rpartition(":")
    if not sep or not host:
        raise ValueError(f"{address!r}: expected host:port, [v6addr]:port or unix:/path")
    try:
        port = int(port_text)
    except ValueError:
        raise ValueError(f"{address!r}: port {port_text!r} is not a number") from None
    if not 0 <= port <= 65535:
        raise ValueError(f"{address!r}: port {port} is outside 0..65535")
    return "tcp", host.strip("[]"), port


def is_local(address: str) -> bool:
    """True for Unix sockets and loopback addresses (and ``localhost``)."""
    kind, host, _ = parse_listen(address)
    if kind == "unix":
        return True
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(str(host)).is_loopback
    except ValueError:
        return False  # a host name: may resolve to anything


def security_warnings(cfg: DaemonConfig) -> list[str]:
    """What is allowed but unsafe in this set-up (logged as warnings at start)."""
    kind, _, _ = parse_listen(cfg.listen)
    warnings = corba_warnings(cfg.corba)
    if kind == "tcp" and not cfg.security.tokens.motion:
        warnings.insert(
            0,
            f"listening on TCP {cfg.listen} without a motion token: every user of this "
            "machine can drive the robot (use a Unix socket with group permissions, as the "
            "shipped systemd unit does, or set security.tokens.motion)",
        )
    return warnings


def security_problems(cfg: DaemonConfig) -> list[str]:
    """Why the daemon must refuse to start with this security set-up (empty: fine)."""
    problems = []
    sec = cfg.security
    if (sec.tls_cert is None) != (sec.tls_key is None):
        problems.append("security: tls_cert and tls_key go together")
    for name in ("tls_cert", "tls_key"):
        path = getattr(sec, name)
        if path is not None and not Path(path).is_file():
            problems.append(f"security.{name}: {path} is not a readable file")
    if sec.tokens.read and not sec.tokens.motion:
        problems.append(
            "security.tokens: a read token without a motion token would lock every client out "
            "of motion: set security.tokens.motion"
        )
    elif sec.require_tokens_locally and not sec.tokens.motion:
        problems.append(
            "security.require_tokens_locally: true, but security.tokens.motion is not set"
        )
    if not is_local(cfg.listen):
        if sec.tls_cert is None:
            problems.append(
                f"listen: {cfg.listen} is not loopback or a Unix socket: TLS is required "
                "(security.tls_cert and security.tls_key)"
            )
        if not sec.tokens.motion:
            problems.append(
                f"listen: {cfg.listen} is not loopback or a Unix socket: a client token is "
                "required (security.tokens.motion, optionally security.tokens.read)"
            )
    view = cfg.view.listen
    if view is not None and not is_local(view) and not cfg.view.allow_remote:
        problems.append(
            f"view.listen: {view} is not loopback: the Foxglove protocol has no authentication "
            "(anyone reaching the port sees the robot); set view.allow_remote: true to serve "
            "there anyway"
        )
    problems.extend(corba_problems(cfg.corba))
    return problems


def _set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    parts = key.split(".")
    node = data
    for part in parts[:-1]:
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            raise ConfigError(f"--set {key}: {part} is not a section")
        node = child
    node[parts[-1]] = value


def load_config(
    path: Path | None = None,
    overrides: dict[str, Any] | None = None,
    sets: list[str] | None = None,
) -> DaemonConfig:
    """File, then ``sets`` (``KEY=VALUE`` strings), then ``overrides`` (flag values)."""
    where = str(path) if path else "defaults"
    data: dict[str, Any] = {}
    if path is not None:
        try:
            loaded = yaml.safe_load(Path(path).read_text())
        except OSError as exc:
            raise ConfigError(f"{path}: cannot read: {exc.strerror}") from None
        except yaml.YAMLError as exc:
            raise ConfigError(f"{path}: not valid YAML: {exc}") from None
        if loaded is not None and not isinstance(loaded, dict):
            raise ConfigError(f"{path}: expected a mapping of settings at the top level")
        data = loaded or {}
    for item in sets or []:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise ConfigError(f"--set {item!r}: expected KEY=VALUE, e.g. loop.rate_hz=1000")
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError:
            value = text
        _set_dotted(data, key.strip(), value)
        where = f"{where} + --set"
    for key, value in (overrides or {}).items():
        if value is not None:
            _set_dotted(data, key, value)
    try:
        cfg = DaemonConfig.model_validate(data)
    except ValidationError as exc:
        lines = []
        for err in exc.errors():
            key = ".".join(str(p) for p in err["loc"]) or "(top level)"
            lines.append(f"{where}: {key}: {err['msg']}")
        raise ConfigError("\n".join(lines)) from None
    if not math.isfinite(cfg.period):
        raise ConfigError(f"{where}: loop.rate_hz: must be finite")
    return cfg

"""``imotiond --hal hil``: the CAN backend against the drive emulator (hardware in the loop).

The master is :class:`~hal.can.backend.CanBackend`, the very code of ``--hal can``; the drives
are :class:`~hal.emulator.emulator.DriveEmulator`. Two ways to join them
(``hal_options.emulator``):

* ``process`` (default): the emulator is its own process (``imotion-sim --unix DIR``, its
  own core and GIL), on ``unix`` buses (:mod:`hal.can.unix_bus`) in a private directory.
  The master runs as on real buses: no lockstep, supervision on its own timing. Defaults
  fitted to a partner process on a shared host: ``feedback_wait`` 20 % of the period (read()
  lets a late TPDO come), ``tpdo_timeout`` 0.1 s (0x405 after 0.1 s without TPDO1, not
  after 3 cycles), ``heartbeat_timeout`` 1 s (heartbeat consumers; a busy host may hold a
  process back for hundreds of ms) and ``sdo_timeout`` 2 s (set-up: SDO answers cross two
  processes; 0.3 s was missed under stress). ``emulator_priority`` (1..99) runs the
  emulator's thread under SCHED_FIFO at that priority (default 0: normal scheduling), as
  the loop runs with ``realtime``. The emulator stops when the backend shuts down.
* ``thread``: the emulator in this process, on private python-can ``virtual`` buses, in
  deterministic lockstep: every ``read()`` waits until the emulator has answered the SYNCs
  of the cycle just sent (``lockstep_timeout``, default 1 s). For tests that need it; the
  emulator and the loop share one GIL.

Other options: those of ``--hal can`` (:mod:`hal.can.factory`) except ``buses`` (the buses
are the emulator's). Faults go in through ``backend.emulator.inject(kind, joint, **params)``
in both ways (:class:`EmulatorProcess` sends them over the child's stdin).

This module, not :mod:`hal.can`, knows both sides: ``hal.can`` never imports the emulator.
"""

from __future__ import annotations

import logging
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

from controller.model.robot import Robot
from hal.can.backend import CanBackend
from hal.can.factory import OPTIONS, can_settings, seconds
from hal.can.unix_bus import INTERFACE

log = logging.getLogger(__name__)

EMULATOR_KINDS = ("process", "thread")
HIL_OPTIONS = (
    *(o for o in OPTIONS if o != "buses"),
    "emulator",
    "emulator_priority",
    "lockstep_timeout",
)
#: Longest wait for the emulator process to start, answer a command or stop [s].
PROCESS_TIMEOUT = 60.0


class EmulatorProcess:
    """``imotion-sim`` for ``robot`` at ``period`` [s] on ``unix`` buses under ``directory``
    (default: a new private one, removed at :meth:`close`); ``buses`` are the profile's.

    :attr:`channels` maps each bus to its channel once the child printed it. stdin commands
    (:meth:`inject`, :meth:`clear`, :meth:`command`) are answered on the child's stdout.
    """

    def __init__(
        self,
        robot: Robot,
        period: float,
        buses: list[str],
        drives: Path | None = None,
        directory: Path | None = None,
        log_level: str = "warning",
        priority: int = 0,
    ):
        self._own_directory = directory is None
        self.directory = directory or Path(tempfile.mkdtemp(prefix="imotion-hil-"))
        cmd = [sys.executable, "-m", "hal.emulator.main", "--robot", str(robot.directory),
               "--period", repr(period), "--unix", str(self.directory),
               "--log-level", log_level, "--exit-on-eof"]  # fmt: skip
        if drives is not None:
            cmd += ["--drives", str(drives)]
        if priority:
            cmd += ["--realtime", str(priority)]
        self._lock = threading.Lock()
        self.process = subprocess.Popen(
            cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )
        self.channels: dict[str, str] = {}
        try:
            while True:
                line = self._readline()
                if not line.startswith("bus="):
                    raise OSError(f"imotion-sim: unexpected line {line!r}")
                fields = dict(item.split("=", 1) for item in line.split())
                self.channels[fields["bus"]] = fields["channel"]
                if set(self.channels) >= set(buses):
                    break
        except BaseException:
            self.close()
            raise

    def _readline(self) -> str:
        """One line of the child's stdout within :data:`PROCESS_TIMEOUT`; OSError if none."""
        stdout = self.process.stdout
        assert stdout is not None
        got: list[str] = []
        reader = threading.Thread(target=lambda: got.append(stdout.readline()))
        reader.daemon = True
        reader.start()
        reader.join(PROCESS_TIMEOUT)
        if not got or not got[0]:
            code = self.process.poll()
            raise OSError(f"imotion-sim gave no answer (exit status {code})")
        return got[0].strip()

    def command(self, line: str) -> str:
        """Send one stdin command; its answer line (``ok ...`` / ``error ...``)."""
        assert self.process.stdin is not None
        with self._lock:
            self.process.stdin.write(line.strip() + "\n")
            self.process.stdin.flush()
            return self._readline()

    def inject(self, kind: str, joint: str | None = None, **params: Any) -> None:
        """As :meth:`DriveEmulator.inject`; ValueError with the emulator's reason."""
        words = ["inject", kind, joint or "-"]
        words += [f"{k}={v}" for k, v in params.items()]
        self._checked(" ".join(words))

    def clear(self, kind: str | None = None, joint: str | None = None) -> int:
        """As :meth:`DriveEmulator.clear`: how many faults were cleared."""
        words = ["clear", kind or "-"] + ([joint] if joint else [])
        return int(self._checked(" ".join(words)).split()[-1])

    def _checked(self, line: str) -> str:
        answer = self.command(line)
        if not answer.startswith("ok"):
            raise ValueError(answer.removeprefix("error ").strip())
        return answer

    def close(self) -> None:
        """SIGTERM and wait (kill after :data:`PROCESS_TIMEOUT`); the bus directory goes."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(PROCESS_TIMEOUT)
            except subprocess.TimeoutExpired:
                log.warning("imotion-sim did not stop: killed")
                self.process.kill()
                self.process.wait()
        for stream in (self.process.stdin, self.process.stdout):
            if stream is not None:
                stream.close()
        if self._own_directory:
            shutil.rmtree(self.directory, ignore_errors=True)


def make_hil_backend(robot: Robot, dt: float, options: dict[str, Any] | None = None) -> CanBackend:
    """A CanBackend for ``robot`` at period ``dt`` [s] against the drive emulator (module doc)."""
    options = dict(options or {})
    kind = options.pop("emulator", "process")
    if kind not in EMULATOR_KINDS:
        raise ValueError(f"hal.options.emulator: one of {EMULATOR_KINDS}, got {kind!r}")
    lockstep_timeout = seconds(options, "lockstep_timeout")
    options.pop("lockstep_timeout", None)
    priority = options.pop("emulator_priority", 0)
    if not isinstance(priority, int) or isinstance(priority, bool) or not 0 <= priority <= 99:
        raise ValueError(f"hal.options.emulator_priority: 0 or a SCHED_FIFO priority 1..99, "
                         f"got {priority!r}")  # fmt: skip
    if kind == "process":
        if lockstep_timeout is not None:
            raise ValueError("hal.options.lockstep_timeout: only with emulator 'thread'")
        options.setdefault("feedback_wait", 0.2 * dt)
        options.setdefault("tpdo_timeout", 0.1)
        options.setdefault("heartbeat_timeout", 1.0)
        options.setdefault("sdo_timeout", 2.0)
    elif priority:
        raise ValueError("hal.options.emulator_priority: only with emulator 'process'")
    s = can_settings("hil", robot, dt, options, HIL_OPTIONS)
    if kind == "process":
        drives = Path(options["drives"]) if "drives" in options else None
        child = EmulatorProcess(robot, dt, list(s.profile.buses), drives, priority=priority)
        try:
            buses = {
                b: {"interface": INTERFACE, "channel": c, "hold_pdos": True}
                for b, c in child.channels.items()
            }
            backend = CanBackend(robot, dt, s.profile, s.directory, buses, **s.timing)
        except BaseException:
            child.close()
            raise
        backend.on_shutdown.append(child.close)
        backend.emulator = child
        return backend

    from hal.emulator.emulator import DriveEmulator

    emulator = DriveEmulator(robot, s.profile, period=dt)
    emulator.start()
    try:
        # Lockstep: the emulator is the plant. On a busy host its threads may answer late;
        # waiting for them (an overrun) is right where real drives would be on time.
        timing: dict[str, Any] = dict(s.timing)
        if lockstep_timeout is not None:
            timing["lockstep_timeout"] = lockstep_timeout
        backend = CanBackend(
            robot,
            dt,
            s.profile,
            s.directory,
            bus_factory=lambda name, _kwargs: emulator.open_master_bus(name),
            lockstep=emulator,
            **timing,
        )
    except BaseException:
        emulator.close()
        raise
    backend.on_shutdown.append(emulator.close)
    backend.emulator = emulator
    return backend

"""``imotion-sim``: the drive emulator as its own process, on real or bridged CAN buses.

Usage::

    imotion-sim --robot smartpal5 --unix /tmp/sp5
        # every bus on the ``unix`` transport (hal.can.unix_bus): bus B is the directory
        # /tmp/sp5/B (a plain name such as ``sp5`` goes under $XDG_RUNTIME_DIR/imotion-can)
    imotion-sim --robot smartpal5 --serve 127.0.0.1:54701
        # no vcan (this machine): host one python-can-remote endpoint per bus on 127.0.0.1,
        # ports 54701, 54702, ... in drives.yaml bus order (port 0: any free ports)
    imotion-sim --robot pa10 --interface socketcan --channel arm_a=vcan0 --channel arm_b=vcan1
    imotion-sim --robot rh --interface remote --channel arm=ws://127.0.0.1:54701/ ...
        # join existing buses (one --channel BUS=CHANNEL per bus; a single-bus robot may
        # give --channel CHANNEL); buses not named keep drives.yaml's interface/channel

stdout: one line per bus once every bus is up, ``bus=<name> interface=<i> channel=<c>
drives=<n>``, then answers to commands. stdin (optional): one command per line,

* ``inject <kind> <joint> [key=value ...]`` (kinds of :mod:`hal.emulator.faults`; integer
  values may be hex, e.g. ``code=0x2310``; ``bus_off`` may take ``bus=<name>`` for joint
  ``-``),
* ``clear [<kind>|-] [<joint>]``,
* ``status``: ``ok cycles=<rounds> sim_time=<s> gc=<n0>/<n1>/<n2> gc_ms=<total>
  gc_max_ms=<longest> faults=<kind:target ...>`` (the process's garbage collections per
  generation; what was built before the buses started is frozen out of them);

each answered on stdout by one line ``ok ...`` or ``error ...``. stderr: logfmt log lines.
SIGTERM and SIGINT close the buses and exit 0; a bus that cannot be opened exits 2. SIGUSR1
writes every thread's stack to stderr (a stalled emulator).
"""

from __future__ import annotations

import argparse
import faulthandler
import gc
import logging
import signal
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

from controller.logs import setup_logging, stop_logging
from controller.model import jit
from controller.model.robot import load_robot
from controller.model.yaml_source import ConfigError
from controller.version import add_version_argument
from hal.can.drive_profile import drives_path, load_drive_profile
from hal.can.unix_bus import INTERFACE, bus_directory
from hal.emulator.bridge import BusBridge
from hal.emulator.emulator import DriveEmulator

log = logging.getLogger("imotion-sim")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="imotion-sim", description="CiA 402 drive emulator for hardware-in-the-loop tests"
    )
    parser.add_argument("--robot", required=True, help="robot id or directory (drives.yaml)")
    parser.add_argument("--drives", help="another drive profile (default: the robot's)")
    parser.add_argument("--period", type=float, help="simulated time per SYNC [s]")
    parser.add_argument(
        "--unix", metavar="DIR", help="every bus on interface 'unix', channel DIR/<bus>"
    )
    parser.add_argument(
        "--serve", metavar="HOST:PORT", help="serve every bus with python-can-remote"
    )
    parser.add_argument("--interface", help="python-can interface of the --channel buses")
    parser.add_argument(
        "--channel", action="append", default=[], metavar="[BUS=]CHANNEL",
        help="python-can channel of a bus (repeat per bus)",
    )  # fmt: skip
    parser.add_argument("--log-level", default="info", help="debug, info, warning, error")
    parser.add_argument(
        "--realtime", type=int, default=0, metavar="PRIORITY",
        help="run the emulator thread under SCHED_FIFO at PRIORITY (1..99)",
    )  # fmt: skip
    parser.add_argument(
        "--exit-on-eof", action="store_true",
        help="stop when stdin closes (a child of --hal hil: its parent died)",
    )  # fmt: skip
    add_version_argument(parser)
    return parser


def _channels(args: argparse.Namespace, buses: Sequence[str]) -> dict[str, tuple[str, str]]:
    """Bus -> (interface, channel) from --interface/--channel; ValueError naming the problem."""
    if args.serve and args.unix:
        raise ValueError("--serve or --unix, not both")
    if (args.serve or args.unix) and (args.channel or args.interface):
        option = "--serve" if args.serve else "--unix"
        raise ValueError(f"{option} hosts its own buses: leave out --interface and --channel")
    if args.unix:
        base = bus_directory(args.unix)
        return {bus: (INTERFACE, str(base / bus)) for bus in buses}
    if args.channel and not args.interface:
        raise ValueError("--channel needs --interface (e.g. socketcan or remote)")
    out: dict[str, tuple[str, str]] = {}
    for item in args.channel:
        bus, sep, channel = item.partition("=")
        if not sep:
            if len(buses) != 1:
                raise ValueError(
                    f"--channel {item!r}: this robot has {len(buses)} buses "
                    f"({', '.join(buses)}): give --channel BUS=CHANNEL for each"
                )
            bus, channel = buses[0], item
        if bus not in buses:
            raise ValueError(f"--channel {item!r}: unknown bus {bus!r} (buses: {', '.join(buses)})")
        if not channel:
            raise ValueError(f"--channel {item!r}: empty channel")
        out[bus] = (args.interface, channel)
    return out


def _serve_address(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        raise ValueError(f"--serve {text!r}: expected HOST:PORT, e.g. 127.0.0.1:54701")
    return host, int(port)


class GcWatch:
    """Garbage collections of this process: count per generation, time in all and the
    longest [s] (the ``status`` answer). Collections hold the GIL: one in the middle of a
    SYNC delays that bus's TPDOs for as long."""

    def __init__(self) -> None:
        self.counts = [0, 0, 0]
        self.total = 0.0
        self.longest = 0.0
        self._start = 0.0

    def install(self) -> None:
        if self._on_gc not in gc.callbacks:
            gc.callbacks.append(self._on_gc)

    def _on_gc(self, phase: str, info: dict[str, Any]) -> None:
        if phase == "start":
            self._start = time.perf_counter()
            return
        took = time.perf_counter() - self._start
        self.counts[int(info.get("generation", 0))] += 1
        self.total += took
        self.longest = max(self.longest, took)

    def text(self) -> str:
        """``gc=N0/N1/N2 gc_ms=TOTAL gc_max_ms=LONGEST``."""
        counts = "/".join(str(n) for n in self.counts)
        return f"gc={counts} gc_ms={self.total * 1e3:.1f} gc_max_ms={self.longest * 1e3:.2f}"


#: This process's collections (module doc of :class:`GcWatch`).
GC_WATCH = GcWatch()


def _parse_value(text: str) -> Any:
    lowered = text.lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    try:
        return int(text, 0)
    except ValueError:
        return text


def handle_command(emulator: DriveEmulator, line: str) -> str:
    """Run one stdin command; the answer line (``ok ...`` or ``error ...``)."""
    words = line.split()
    if not words:
        return ""
    verb, rest = words[0], words[1:]
    try:
        if verb == "inject" and len(rest) >= 2:
            params: dict[str, Any] = {}
            for item in rest[2:]:
                key, sep, value = item.partition("=")
                if not sep:
                    return f"error inject: parameter {item!r} is not key=value"
                params[key] = _parse_value(value)
            joint = None if rest[1] == "-" else rest[1]
            emulator.inject(rest[0], joint, **params)
            return f"ok inject {' '.join(rest)}"
        if verb == "clear" and len(rest) <= 2:
            kind = rest[0] if rest and rest[0] != "-" else None
            joint = rest[1] if len(rest) > 1 else None
            return f"ok clear {emulator.clear(kind, joint)}"
        if verb == "status" and not rest:
            faults = " ".join(f"{f.kind.value}:{f.target}" for f in emulator.active_faults)
            return (f"ok cycles={emulator.cycles} sim_time={emulator.sim_time:.3f} "
                    f"{GC_WATCH.text()} faults={faults}")  # fmt: skip
    except ValueError as exc:
        return f"error {exc}"
    return f"error unknown command {line.strip()!r}: inject KIND JOINT [k=v ...] | clear | status"


def _read_commands(
    emulator: DriveEmulator, stdin: TextIO, stdout: TextIO, eof: threading.Event | None = None
) -> None:
    for line in stdin:
        answer = handle_command(emulator, line)
        if answer:
            print(answer, file=stdout, flush=True)
    if eof is not None:
        log.info("stdin closed: stopping")
        eof.set()


def _warn_compiled(kernel: str, seconds: float, thread: str) -> None:
    log.warning(
        "kernel %s was compiled (or loaded from numba's cache) in thread %s while the "
        "emulator ran: %.0f ms without a SYNC answered; report this",
        kernel, thread, seconds * 1e3,
    )  # fmt: skip


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    level = logging.getLevelName(args.log_level.upper())
    if not isinstance(level, int):
        print(f"imotion-sim: --log-level {args.log_level!r}: use debug, info, warning or error",
              file=sys.stderr)  # fmt: skip
        return 2
    root, canopen_log = logging.getLogger(), logging.getLogger("canopen")
    saved = root.level, canopen_log.level, root.handlers[:]
    setup_logging(args.log_level, "imotion-sim")  # the daemon's logfmt lines
    if level > logging.DEBUG:
        canopen_log.setLevel(logging.WARNING)  # one line per SDO otherwise
    try:
        return _run(args)
    finally:
        stop_logging()
        root.handlers[:] = saved[2]
        root.setLevel(saved[0])
        canopen_log.setLevel(saved[1])


def _run(args: argparse.Namespace) -> int:
    try:
        robot = load_robot(args.robot)
        path = drives_path(robot) if args.drives is None else Path(args.drives)
        profile = load_drive_profile(path, robot)
        channels = _channels(args, list(profile.buses))
        serve = _serve_address(args.serve) if args.serve else None
        if not 0 <= args.realtime <= 99:
            raise ValueError(f"--realtime {args.realtime}: a SCHED_FIFO priority 1..99")
        emulator = DriveEmulator(robot, profile, period=args.period, channels=channels)
        emulator.priority = args.realtime
    except (ConfigError, ValueError, OSError) as exc:
        print(f"imotion-sim: {exc}", file=sys.stderr)
        return 2
    bridge = None
    try:
        if serve is not None:
            virtual = {bus: channel for bus, (_, channel) in emulator.channels.items()}
            bridge = BusBridge(virtual, *serve)
        emulator.open()
        # Everything built so far lives as long as the process: out of the collector's
        # passes, which then scan only what the SYNCs allocate (short, and fewer of them).
        gc.freeze()
        GC_WATCH.install()
        emulator.start()
        if bridge is not None:
            bridge.start()
    except OSError as exc:
        print(f"imotion-sim: {exc}", file=sys.stderr)
        emulator.close()
        if bridge is not None:
            bridge.close()
        return 2
    served = {e.bus: e.url for e in bridge.endpoints} if bridge else {}
    for bus, (interface, channel) in emulator.channels.items():
        shown = ("remote", served[bus]) if bus in served else (interface, channel)
        drives = len(profile.drives_on(bus))
        print(f"bus={bus} interface={shown[0]} channel={shown[1]} drives={drives}", flush=True)
    stop = threading.Event()
    faulthandler.register(signal.SIGUSR1, all_threads=True)  # stacks to stderr, for a stall
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    reader = threading.Thread(
        target=_read_commands,
        args=(emulator, sys.stdin, sys.stdout, stop if args.exit_on_eof else None),
        daemon=True,
    )
    reader.start()
    log.info("imotion-sim running: robot %s, %d drives, period %.4f s",
             robot.id, len(emulator.drives), emulator.period)  # fmt: skip
    # Every kernel is compiled or loaded as the emulator is built: one compiled later
    # stalled the SYNC rounds it was in (and the master waiting for them).
    stop_watching = jit.watch_compiles(_warn_compiled)
    while not stop.is_set():
        stop.wait(0.2)
    stop_watching()
    start = time.monotonic()
    if bridge is not None:
        bridge.close()
    emulator.close()
    log.info("imotion-sim stopped after %d cycles (closing took %.2f s)",
             emulator.cycles, time.monotonic() - start)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())

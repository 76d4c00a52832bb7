"""``imotion-can``: look at and move CiA 402 drives on the buses of a robot's drive profile.

Subcommands (``--robot ID`` picks ``config/robots/<id>/drives.yaml``; ``--bus NAME`` limits to
one bus; ``--interface``/``--channel`` override python-can settings of the selected bus, or
``--interface`` of every bus)::

    scan                       NMT state (heartbeat) and identity 0x1018 of every node
    state                      each drive's CiA 402 state, statusword and position (SDO)
    enable DRIVE [--hold S]    enable one drive holding its position, then quick stop + disable
    disable DRIVE              quick stop + disable one drive
    jog DRIVE DELTA [--speed]  move one axis slowly by DELTA ([deg] or [m]) within its limits
    sdo read DRIVE INDEX [SUB]           read an object (hex or decimal)
    sdo write DRIVE INDEX SUB VALUE      write an object
    record FILE --seconds N    record the bus(es) (.log candump, .asc, .blf by extension)
    replay FILE                send a recorded log with its timing (channel = bus name)
    load --seconds N           measure frames/s and load per bus from the traffic
    plan [--rate HZ]           worst-case bus-load table of the profile (no bus needed)

``enable`` and ``jog`` run a small master for the one drive (RPDO1 + SYNC + heartbeat at the
profile's rate); never use them while ``imotiond`` drives the same bus. Exit status: 0 done,
1 a drive or bus failed, 2 bad arguments or configuration.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import can
from canopen.sdo import SdoVariable
from rich.console import Console
from rich.table import Table

from controller.model.robot import Robot, load_robot
from controller.model.yaml_source import ConfigError
from hal.can import busload, pdo
from hal.can.backend import interpolation_period
from hal.can.cia402 import DriveMaster, Goal, State, decode
from hal.can.drive_profile import DEFAULT_EDS, DriveConfig, DriveProfile, drives_path, eds_path
from hal.can.drive_profile import load_drive_profile as _load
from hal.can.setup import SetupNetwork, set_up_drive
from hal.can.supervision import DriveError

#: Fraction of the joint's profile speed a jog uses by default.
JOG_SPEED_FRACTION = 0.1
IDENTITY = ("vendor", "product", "revision", "serial")


class ToolError(Exception):
    """A drive or bus failed (exit status 1)."""


class Context:
    """The robot, its drive profile and the python-can settings of each selected bus."""

    def __init__(self, args: argparse.Namespace):
        self.robot: Robot = load_robot(args.robot)
        path = Path(args.drives) if args.drives else drives_path(self.robot)
        self.profile: DriveProfile = _load(path, self.robot)
        self.directory = path.parent
        if args.bus is not None and args.bus not in self.profile.buses:
            raise ConfigError(
                f"--bus {args.bus!r}: {self.robot.id} has buses {', '.join(self.profile.buses)}"
            )
        self.buses = [args.bus] if args.bus else list(self.profile.buses)
        if args.channel and len(self.buses) != 1:
            raise ConfigError("--channel needs --bus (the profile has several buses)")
        self.kwargs: dict[str, dict[str, Any]] = {}
        for name in self.buses:
            cfg = self.profile.buses[name]
            kw: dict[str, Any] = {"interface": cfg.interface, "channel": cfg.channel}
            if args.interface:
                kw["interface"] = args.interface
            if args.channel:
                kw["channel"] = args.channel
            if kw["interface"] not in ("virtual", "remote"):
                kw["bitrate"] = cfg.bitrate
                if cfg.fd:
                    kw.update(fd=True, data_bitrate=cfg.data_bitrate)
            self.kwargs[name] = kw

    def drive(self, name: str) -> DriveConfig:
        if name not in self.profile.drives:
            raise ConfigError(f"unknown drive {name!r}: one of {', '.join(self.profile.drives)}")
        drive = self.profile.drives[name]
        if drive.bus not in self.buses:
            raise ConfigError(f"drive {name} is on bus {drive.bus}, not on --bus {self.buses[0]}")
        return drive

    @contextmanager
    def bus(self, name: str) -> Iterator[can.BusABC]:
        try:
            bus = can.Bus(**self.kwargs[name])
        except Exception as exc:
            raise ToolError(f"bus {name}: cannot open {self.kwargs[name]}: {exc}") from exc
        try:
            yield bus
        finally:
            bus.shutdown()

    @contextmanager
    def network(self, name: str, sdo_timeout: float) -> Iterator[SetupNetwork]:
        with self.bus(name) as bus:
            net = SetupNetwork(bus, sdo_timeout)
            try:
                yield net
            finally:
                net.close()


def _int(text: str) -> int:
    return int(text, 0)


# ------------------------------------------------------------------------------ commands
def cmd_plan(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    rate = args.rate or ctx.profile.rate_hz
    loads = busload.plan(ctx.profile, rate)
    table = Table(title=f"{ctx.robot.id}: worst-case bus load at {rate:g} Hz")
    for col in ("bus", "kind", "drives", "TPDO2", "frames/s", "µs/cycle", "load", "verdict"):
        table.add_column(col, justify="left" if col in ("bus", "kind", "verdict") else "right")
    for b in loads:
        cfg = ctx.profile.buses[b.bus]
        kind = (
            f"FD {cfg.bitrate // 1000}k/{(cfg.data_bitrate or 0) // 1000}k"
            if cfg.fd
            else (f"classic {cfg.bitrate // 1000}k")
        )
        table.add_row(
            b.bus, kind, str(b.drives), str(b.tpdo2), f"{b.frames_per_s:.0f}",
            f"{b.cycle_time * 1e6:.0f}", f"{b.load * 100:.1f} %", b.verdict,
        )  # fmt: skip
    out.print(table)
    return 1 if busload.worst(loads).load > busload.REFUSE_ABOVE else 0


def cmd_scan(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    table = Table(title=f"{ctx.robot.id}: nodes")
    for col in ("bus", "node", "drive", "NMT", *IDENTITY):
        table.add_column(col)
    missing = 0
    for bus_name in ctx.buses:
        names = {d.node_id: n for n, d in ctx.profile.drives_on(bus_name).items()}
        with ctx.network(bus_name, args.sdo_timeout) as net:
            heard = _listen_heartbeats(net, args.listen)
            nodes = sorted(set(names) | set(heard))
            for node_id in nodes:
                name = names.get(node_id, "?")
                eds = (
                    eds_path(ctx.profile, name, ctx.directory)
                    if name in ctx.profile.drives
                    else (ctx.directory / ctx.profile.eds if ctx.profile.eds else DEFAULT_EDS)
                )
                node = net.node(node_id, eds)
                ident = []
                for sub in range(1, 5):
                    try:
                        ident.append(f"0x{node.sdo[0x1018][sub].raw:08X}")
                    except Exception:
                        ident.append("-")
                nmt = heard.get(node_id)
                known = nmt is not None and nmt in pdo.NmtState._value2member_map_
                state = pdo.NmtState(nmt).name if known and nmt is not None else "-"
                if nmt is None and ident[0] == "-":
                    state = "missing"
                    missing += 1
                table.add_row(bus_name, str(node_id), name, state, *ident)
    out.print(table)
    return 1 if missing else 0


def _listen_heartbeats(net: SetupNetwork, seconds: float) -> dict[int, int]:
    heard: dict[int, int] = {}

    def on_heartbeat(cob_id: int, data: bytearray, _stamp: float) -> None:
        if data:
            heard[cob_id - pdo.HEARTBEAT] = data[0] & 0x7F

    for node_id in range(1, 128):
        net.network.subscribe(pdo.HEARTBEAT + node_id, on_heartbeat)
    time.sleep(seconds)
    return heard


def cmd_state(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    table = Table(title=f"{ctx.robot.id}: drives")
    for col in ("drive", "bus", "node", "state", "statusword", "position [counts]", "position"):
        table.add_column(col)
    failed = 0
    for bus_name in ctx.buses:
        with ctx.network(bus_name, args.sdo_timeout) as net:
            for name, drive in ctx.profile.drives_on(bus_name).items():
                node = net.node(drive.node_id, eds_path(ctx.profile, name, ctx.directory))
                try:
                    sw = int(node.sdo[0x6041].raw)
                    counts = int(node.sdo[0x6064].raw)
                except Exception as exc:
                    failed += 1
                    table.add_row(
                        name, bus_name, str(drive.node_id), f"no answer ({exc})", "", "", ""
                    )
                    continue
                si = drive.scaling().to_si(counts)
                shown = f"{math.degrees(si):.3f} deg" if drive.revolute else f"{si:.5f} m"
                table.add_row(
                    name, bus_name, str(drive.node_id), decode(sw).value, f"0x{sw:04X}",
                    str(counts), shown,
                )  # fmt: skip
    out.print(table)
    return 1 if failed else 0


class OneDriveMaster:
    """RPDO1 + SYNC + heartbeat at the profile rate for one drive (enable, jog, disable)."""

    def __init__(self, ctx: Context, bus: can.BusABC, name: str, dt: float):
        self.drive = ctx.drive(name)
        self.bus = bus
        self.dt = dt
        self.node_id = self.drive.node_id
        self.master = DriveMaster()
        self.statusword: int | None = None
        self.actual = 0
        self.master_id = ctx.profile.master_node_id
        self._rpdo = can.Message(arbitration_id=pdo.RPDO1 + self.node_id, data=bytearray(6),
                                 is_extended_id=False)  # fmt: skip
        self._next_beat = 0.0

    def cycle(self, target: int | None = None) -> State:
        if self.statusword is not None:
            cw = self.master.controlword(self.statusword)
            goal = self.actual if target is None or not self.master.enabled else target
            pdo.RPDO1_STRUCT.pack_into(self._rpdo.data, 0, cw, goal)
            self.bus.send(self._rpdo)
        self.bus.send(can.Message(arbitration_id=pdo.SYNC, data=b"", is_extended_id=False))
        now = time.monotonic()
        if now >= self._next_beat:
            self._next_beat = now + 0.05
            self.bus.send(can.Message(arbitration_id=pdo.HEARTBEAT + self.master_id,
                                      data=b"\x05", is_extended_id=False))  # fmt: skip
        deadline = now + self.dt
        while (left := deadline - time.monotonic()) > 0:
            msg = self.bus.recv(left)
            if msg is not None and msg.arbitration_id == pdo.TPDO1 + self.node_id:
                self.statusword, self.actual = pdo.TPDO1_STRUCT.unpack_from(msg.data)
        return decode(self.statusword) if self.statusword is not None else State.UNKNOWN

    def run_to(self, goal: Goal, timeout: float) -> State:
        self.master.goal = goal
        want = State.OPERATION_ENABLED if goal is Goal.ENABLED else State.SWITCH_ON_DISABLED
        end = time.monotonic() + timeout
        state = State.UNKNOWN
        while time.monotonic() < end:
            state = self.cycle()
            if state is want:
                break
        return state


@contextmanager
def one_drive(ctx: Context, args: argparse.Namespace, name: str) -> Iterator[OneDriveMaster]:
    drive = ctx.drive(name)
    dt = 1.0 / ctx.profile.rate_hz
    with ctx.bus(drive.bus) as bus:
        net = SetupNetwork(bus, args.sdo_timeout)
        try:
            node = net.node(drive.node_id, eds_path(ctx.profile, name, ctx.directory))
            set_up_drive(node, drive, ctx.profile, interpolation_period(dt))
        except Exception as exc:
            raise ToolError(
                f"{name} (node {drive.node_id} on bus {drive.bus}): set-up: {exc}"
            ) from exc
        finally:
            net.close()
        master = OneDriveMaster(ctx, bus, name, dt)
        try:
            yield master
        finally:
            master.run_to(Goal.OFF, 0.5)


def cmd_enable(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    with one_drive(ctx, args, args.drive) as m:
        state = m.run_to(Goal.ENABLED, args.timeout)
        out.print(f"{args.drive}: {state.value}")
        if state is not State.OPERATION_ENABLED:
            raise ToolError(f"{args.drive}: not enabled within {args.timeout} s ({state.value})")
        end = time.monotonic() + args.hold
        while time.monotonic() < end:
            m.cycle()
    out.print(f"{args.drive}: quick stop, disabled")
    return 0


def cmd_disable(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    with one_drive(ctx, args, args.drive) as m:
        m.cycle()
    out.print(f"{args.drive}: {decode(m.statusword or 0).value}")
    return 0


def cmd_jog(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    drive = ctx.drive(args.drive)
    scaling = drive.scaling()
    spec = ctx.robot.joints.get(args.drive)
    to_si = math.radians if drive.revolute else float
    delta = to_si(args.delta)
    if spec is not None:
        speed = JOG_SPEED_FRACTION * spec.velocity
        lower, upper = spec.lower, spec.upper
    else:  # a wheel: 0.5 rad/s
        speed, lower, upper = 0.5, -math.inf, math.inf
    if args.speed is not None:
        speed = min(to_si(args.speed), speed / JOG_SPEED_FRACTION)
    with one_drive(ctx, args, args.drive) as m:
        if m.run_to(Goal.ENABLED, args.timeout) is not State.OPERATION_ENABLED:
            raise ToolError(f"{args.drive}: not enabled within {args.timeout} s")
        start = scaling.to_si(m.actual)
        goal = min(max(start + delta, lower), upper)
        steps = max(1, math.ceil(abs(goal - start) / (speed * m.dt)))
        for k in range(1, steps + 1):
            if m.cycle(scaling.to_counts(start + (goal - start) * k / steps)) is not (
                State.OPERATION_ENABLED
            ):
                raise ToolError(f"{args.drive}: left operation enabled during the jog")
        for _ in range(int(0.2 / m.dt)):
            m.cycle(scaling.to_counts(goal))
        reached = scaling.to_si(m.actual)
    unit, show = ("deg", math.degrees) if drive.revolute else ("m", float)
    clipped = " (clipped to the joint limits)" if goal != start + delta else ""
    out.print(
        f"{args.drive}: {show(start):.4f} -> {show(reached):.4f} {unit} "
        f"(goal {show(goal):.4f}{clipped})"
    )
    return 0


def cmd_sdo(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    drive = ctx.drive(args.drive)
    with ctx.network(drive.bus, args.sdo_timeout) as net:
        node = net.node(drive.node_id, eds_path(ctx.profile, args.drive, ctx.directory))
        try:
            var = node.sdo[args.index]
            if not isinstance(var, SdoVariable):
                var = var[args.subindex or 0]
            if args.action == "write":
                var.raw = args.value
                out.print(
                    f"{args.drive} 0x{args.index:04X}:{args.subindex or 0}: wrote {args.value}"
                )
            else:
                value = var.raw
                shown = (
                    f"{value} (0x{value:X})"
                    if isinstance(value, int) and value >= 0
                    else str(value)
                )
                out.print(f"{args.drive} 0x{args.index:04X}:{args.subindex or 0} = {shown}")
        except Exception as exc:
            raise ToolError(
                f"{args.drive} (node {drive.node_id} on bus {drive.bus}): SDO {args.action} "
                f"0x{args.index:04X}:{args.subindex or 0}: {exc}"
            ) from exc
    return 0


def cmd_record(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    buses = [can.Bus(**ctx.kwargs[n]) for n in ctx.buses]
    count = 0
    try:
        with can.Logger(args.file) as logger:
            end = time.monotonic() + args.seconds
            while time.monotonic() < end:
                idle = True
                for name, bus in zip(ctx.buses, buses, strict=True):
                    msg = bus.recv(0.0)
                    if msg is not None:
                        msg.channel = name
                        logger(msg)
                        count += 1
                        idle = False
                if idle:
                    time.sleep(0.0005)
    finally:
        for bus in buses:
            bus.shutdown()
    out.print(f"recorded {count} frames from {', '.join(ctx.buses)} to {args.file}")
    return 0


def cmd_replay(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    buses = {n: can.Bus(**ctx.kwargs[n]) for n in ctx.buses}
    sent = 0
    try:
        reader = can.LogReader(args.file)
        for msg in can.MessageSync(reader, timestamps=True, skip=args.skip):
            bus = buses.get(str(msg.channel)) if len(buses) > 1 else next(iter(buses.values()))
            if bus is None or msg.is_error_frame:
                continue
            bus.send(msg)
            sent += 1
    finally:
        for bus in buses.values():
            bus.shutdown()
    out.print(f"replayed {sent} frames from {args.file}")
    return 0


def cmd_load(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    buses = {n: can.Bus(**ctx.kwargs[n]) for n in ctx.buses}
    frames = dict.fromkeys(buses, 0)
    bits = dict.fromkeys(buses, 0)
    try:
        end = time.monotonic() + args.seconds
        while time.monotonic() < end:
            idle = True
            for name, bus in buses.items():
                msg = bus.recv(0.0)
                if msg is None:
                    continue
                idle = False
                frames[name] += 1
                bits[name] += busload.classic_frame_bits(min(msg.dlc, 8))
            if idle:
                time.sleep(0.0002)
    finally:
        for bus in buses.values():
            bus.shutdown()
    table = Table(title=f"{ctx.robot.id}: measured over {args.seconds:g} s (worst-case stuffing)")
    for col in ("bus", "frames/s", "load"):
        table.add_column(col)
    for name in buses:
        rate = ctx.profile.buses[name].bitrate
        table.add_row(
            name, f"{frames[name] / args.seconds:.0f}",
            f"{bits[name] / args.seconds / rate * 100:.1f} %",
        )  # fmt: skip
    out.print(table)
    return 0


COMMANDS = {
    "plan": cmd_plan, "scan": cmd_scan, "state": cmd_state, "enable": cmd_enable,
    "disable": cmd_disable, "jog": cmd_jog, "sdo": cmd_sdo, "record": cmd_record,
    "replay": cmd_replay, "load": cmd_load,
}  # fmt: skip


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="imotion-can", description=__doc__.split("\n")[0])
    p.add_argument("--robot", default="smartpal5", help="robot id or directory")
    p.add_argument("--drives", help="another drives.yaml (default: the robot's)")
    p.add_argument("--bus", help="only this bus of the profile")
    p.add_argument("--interface", help="python-can interface (overrides the profile)")
    p.add_argument("--channel", help="python-can channel of --bus (overrides the profile)")
    p.add_argument("--sdo-timeout", type=float, default=0.3, help="[s] per SDO request")
    sub = p.add_subparsers(dest="command", required=True)
    plan = sub.add_parser("plan", help="worst-case bus-load table of the profile")
    plan.add_argument("--rate", type=float, help="[Hz] loop rate (default: the profile's)")
    scan = sub.add_parser("scan", help="NMT state and identity of every node")
    scan.add_argument("--listen", type=float, default=0.3, help="[s] to listen for heartbeats")
    sub.add_parser("state", help="CiA 402 state of every drive")
    for name in ("enable", "disable", "jog"):
        sp = sub.add_parser(name, help=f"{name} one drive")
        sp.add_argument("drive")
        sp.add_argument("--timeout", type=float, default=1.0, help="[s] to reach the state")
        if name == "enable":
            sp.add_argument("--hold", type=float, default=1.0, help="[s] enabled before stopping")
        if name == "jog":
            sp.add_argument("delta", type=float, help="[deg] or [m] (relative)")
            sp.add_argument("--speed", type=float, help="[deg/s] or [m/s]")
    sdo = sub.add_parser("sdo", help="read or write an object")
    sdo.add_argument("action", choices=("read", "write"))
    sdo.add_argument("drive")
    sdo.add_argument("index", type=_int)
    sdo.add_argument("subindex", type=_int, nargs="?")
    sdo.add_argument("value", type=_int, nargs="?")
    rec = sub.add_parser("record", help="record the bus to a log file")
    rec.add_argument("file")
    rec.add_argument("--seconds", type=float, default=10.0)
    rep = sub.add_parser("replay", help="replay a log file")
    rep.add_argument("file")
    rep.add_argument("--skip", type=float, default=60.0, help="[s] longest gap kept")
    load = sub.add_parser("load", help="measure the bus load")
    load.add_argument("--seconds", type=float, default=5.0)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = parser().parse_args(argv)
    out = Console(width=120)
    err = Console(stderr=True, width=120)
    if (
        args.command == "sdo"
        and args.action == "write"
        and (args.value is None or args.subindex is None)
    ):
        err.print("sdo write needs DRIVE INDEX SUB VALUE")
        return 2
    try:
        ctx = Context(args)
        return COMMANDS[args.command](ctx, args, out)
    except ConfigError as exc:
        err.print(str(exc), markup=False, highlight=False)
        return 2
    except (ToolError, DriveError, can.CanError, OSError) as exc:
        err.print(f"error: {exc}", markup=False, highlight=False)
        return 1


if __name__ == "__main__":
    sys.exit(main())

"""``imotion-can`` operations: look at and move CiA 402 drives on a robot's buses.

Each ``cmd_*`` takes the :class:`Context` (robot, drive profile, python-can settings of the
selected buses), the parsed arguments and a console, and returns the exit status (0 done,
1 a drive or bus failed; :class:`ToolError` also means 1). Command-line parsing is
:mod:`hal.can.tool`.

``enable``, ``disable`` and ``jog`` run the backend's own bus set-up, SDO set-up and cycle
I/O for one drive (:mod:`hal.can.one_drive`): RPDO1, SYNC and the master heartbeat at the
profile's rate. ``scan`` only listens and reads 0x1018
over SDO from drive nodes (never from the master's own node id): it does not disturb a
running master.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import Any

import can
from canopen.sdo import SdoVariable
from rich.console import Console
from rich.table import Table

from controller.model.robot import Robot, load_robot
from controller.model.yaml_source import ConfigError
from hal.can import busload, pdo
from hal.can.cia402 import Goal, State, decode
from hal.can.drive_profile import DEFAULT_EDS, DriveConfig, DriveProfile, drives_path, eds_path
from hal.can.drive_profile import load_drive_profile as _load
from hal.can.one_drive import OneDrive, ToolError, one_drive
from hal.can.ports import bus_kwargs
from hal.can.setup import SetupNetwork

#: Fraction of the joint's profile speed a jog uses by default.
JOG_SPEED_FRACTION = 0.1
IDENTITY = ("vendor", "product", "revision", "serial")


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
        #: python-can settings over the profile's, per selected bus.
        self.overrides: dict[str, dict[str, Any]] = {}
        for name in self.buses:
            over: dict[str, Any] = {}
            if args.interface:
                over["interface"] = args.interface
            if args.channel:
                over["channel"] = args.channel
            self.overrides[name] = over
        self.kwargs = {n: bus_kwargs(self.profile, n, self.overrides[n]) for n in self.buses}

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
    """Heartbeats heard, and the identity (0x1018 over SDO) of every drive node. The master's
    own node id is never probed (a running master answers no SDO): its heartbeat only says
    that a master (imotiond) drives the bus."""
    table = Table(title=f"{ctx.robot.id}: nodes")
    for col in ("bus", "node", "drive", "NMT", *IDENTITY):
        table.add_column(col)
    master = ctx.profile.master_node_id
    missing = 0
    masters: list[str] = []
    for bus_name in ctx.buses:
        names = {d.node_id: n for n, d in ctx.profile.drives_on(bus_name).items()}
        with ctx.network(bus_name, args.sdo_timeout) as net:
            heard = _listen_heartbeats(net, args.listen)
            for node_id in sorted(set(names) | set(heard)):
                name = names.get(node_id, "?")
                nmt = heard.get(node_id)
                known = nmt is not None and nmt in pdo.NmtState._value2member_map_
                state = pdo.NmtState(nmt).name if known and nmt is not None else "-"
                if node_id == master and name == "?":
                    masters.append(bus_name)
                    table.add_row(bus_name, str(node_id), name, state, "(master)", "", "", "")
                    continue
                ident = _identity(ctx, net, node_id, name)
                if nmt is None and ident[0] == "-":
                    state = "missing"
                    missing += 1
                table.add_row(bus_name, str(node_id), name, state, *ident)
    out.print(table)
    for bus_name in masters:
        out.print(f"bus {bus_name}: the master's heartbeat (node {master}): a master is running")
    return 1 if missing else 0


def _identity(ctx: Context, net: SetupNetwork, node_id: int, name: str) -> list[str]:
    """0x1018:1..4 of ``node_id`` as hex, "-" where it did not answer."""
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
    return ident


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


def _one_drive(ctx: Context, args: argparse.Namespace) -> AbstractContextManager[OneDrive]:
    ctx.drive(args.drive)  # on a selected bus
    return one_drive(ctx.profile, ctx.directory, args.drive, ctx.overrides, args.sdo_timeout)


def cmd_enable(ctx: Context, args: argparse.Namespace, out: Console) -> int:
    with _one_drive(ctx, args) as m:
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
    with _one_drive(ctx, args) as m:
        m.cycle()
    out.print(f"{args.drive}: {m.state.value}")
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
    with _one_drive(ctx, args) as m:
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

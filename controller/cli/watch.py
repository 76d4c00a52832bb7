"""``imotion watch``: a live terminal view of Monitor.StreamState.

Shows the Spec A state, the joints of every unit (deg; vehicle x, y in mm and θ in deg), the
control-point poses (original frame), the active alarms and the control-loop statistics.
Ctrl-C ends it cleanly; ``--once`` prints the first sample and exits.
"""

from __future__ import annotations

import time
from collections import deque

from rich.console import Console, Group, RenderableType
from rich.live import Live
from rich.markup import escape
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from controller.cli.output import fmt_number
from controller.client import codes
from controller.client.client import Client
from controller.client.poses import rpy_of, xyz_of
from controller.client.types import StateSample, UnitType

#: Shortest time between two drawn frames [s].
MIN_FRAME_PERIOD = 0.05

_STATE_STYLES: dict[int, str] = {
    codes.READY: "green",
    codes.BUSY: "cyan",
    codes.PAUSE: "yellow",
    codes.ALARM: "bold red",
    codes.SERVO_OFF: "magenta",
    codes.UNPOWERED: "dim",
}


def _joint_labels(unit: UnitType | int, count: int) -> list[str]:
    if unit == UnitType.VEHICLE and count == 3:
        return ["x mm", "y mm", "θ deg"]
    return [f"J{i + 1}" for i in range(count)]


def _table(title: str) -> Table:
    return Table(title=escape(title), expand=True, title_justify="left")


def _cell(value: float) -> str:
    text = f"{value:.1f}"
    return "0.0" if text == "-0.0" else text


def render(sample: StateSample, address: str, rate_hz: float | None = None) -> RenderableType:
    """One frame of the view."""
    state = Text.assemble(
        (f"0x{sample.statusId:03X} {codes.state_name(sample.statusId)}",
         _STATE_STYLES.get(sample.statusId, "")),
        f"  {sample.statusMessage}" if sample.statusMessage else "",
    )  # fmt: skip
    rate = f"   {rate_hz:.1f} Hz" if rate_hz else ""
    header = Text.assemble(
        ("imotion ", "bold"),
        f"{address}   sample {sample.sequence}   t {sample.stampS:.3f} s{rate}\n",
        "state ",
        state,
    )

    joints = _table("joints [deg; vehicle x, y mm, θ deg]")
    joints.add_column("unit")
    joints.add_column("values", overflow="fold")
    for unit in sample.joints:
        labels = _joint_labels(unit.unit, len(unit.position))
        values = "  ".join(
            f"{label} {fmt_number(v)}" for label, v in zip(labels, unit.position, strict=False)
        )
        joints.add_row(getattr(unit.unit, "name", str(unit.unit)), values)

    points = _table("control points [original frame]")
    for column in ("arm", "x mm", "y mm", "z mm", "roll", "pitch", "yaw", "elbow"):
        points.add_column(column, justify="left" if column == "arm" else "right")
    for cp in sample.controlPoints:
        hg = cp.pose.carPos
        numbers = [*xyz_of(hg), *rpy_of(hg)] if getattr(hg, "shape", None) == (3, 4) else []
        cells = [_cell(v) for v in numbers] or ["?"] * 6
        points.add_row(getattr(cp.arm, "name", str(cp.arm)), *cells, _cell(cp.pose.elbow))

    alarms = _table("alarms")
    for column in ("code", "type", "module", "description"):
        alarms.add_column(column)
    for alarm in sample.alarms:
        alarms.add_row(
            f"0x{alarm.code:04X}",
            getattr(alarm.type, "name", str(alarm.type)),
            alarm.moduleName,
            alarm.description,
            style="red" if alarm.type == 0 else "yellow",
        )
    if not sample.alarms:
        alarms.add_row("-", "", "", "none")

    loop = sample.loop
    stats = Text(
        f"loop: {loop.cycles} cycles, {loop.overruns} overruns   "
        f"compute p50 {loop.compute.p50Us:.0f} / p99 {loop.compute.p99Us:.0f} / "
        f"max {loop.compute.maxUs:.0f} µs   wake latency p50 {loop.wakeLatency.p50Us:.0f} / "
        f"p99 {loop.wakeLatency.p99Us:.0f} / max {loop.wakeLatency.maxUs:.0f} µs"
    )
    return Panel(Group(header, joints, points, alarms, stats), title="imotion watch")


def run(client: Client, rate_hz: float, once: bool, console: Console) -> int:
    """Show the stream until Ctrl-C (or the daemon ends it); 0 on a clean end."""
    stream = client.monitor.stream(rate_hz)
    try:
        first = next(stream, None)
        if first is None:
            console.print("imotion watch: the daemon sent no sample")
            return 1
        if once:
            console.print(render(first, client.address))
            return 0
        stamps: deque[float] = deque([first.stampS], maxlen=20)
        with Live(
            render(first, client.address), console=console, auto_refresh=False, transient=False
        ) as live:
            shown = time.monotonic()
            for sample in stream:
                stamps.append(sample.stampS)
                if time.monotonic() - shown < MIN_FRAME_PERIOD:
                    continue  # samples faster than the terminal needs: skip the drawing
                shown = time.monotonic()
                span = stamps[-1] - stamps[0]
                rate = (len(stamps) - 1) / span if span > 0 else None
                live.update(render(sample, client.address, rate), refresh=True)
        return 0
    except KeyboardInterrupt:
        return 0
    finally:
        stream.cancel()

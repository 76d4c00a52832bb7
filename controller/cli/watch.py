"""``imotion watch``: a live terminal view of Monitor.StreamState.

Shows the daemon's wall-clock time, the Spec A state, the motion in progress and the JARA
queue; every joint by name with its measured and commanded position, the difference, its
limits and the distance to the nearest one (yellow within 10 % of the range, red within
2 %); the control-point poses (original frame); the active alarms and every alarm seen
since the view started (raised and cleared times); the control-loop statistics, red while
cycles overrun. Ctrl-C ends it cleanly; ``--once`` prints the first sample and exits.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field

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
from controller.client.types import StateSample, UnitJointPositions, UnitType

#: Shortest time between two drawn frames [s].
MIN_FRAME_PERIOD = 0.05
#: Distance to a limit, as a fraction of the joint's range, shown yellow / red.
NEAR_LIMIT = 0.10
AT_LIMIT = 0.02
#: Overruns keep the loop line red this long after the last one [s].
OVERRUN_HOLD_S = 5.0
#: Alarms kept in the history.
HISTORY = 20

_STATE_STYLES: dict[int, str] = {
    codes.READY: "green",
    codes.BUSY: "cyan",
    codes.PAUSE: "yellow",
    codes.ALARM: "bold red",
    codes.SERVO_OFF: "magenta",
    codes.UNPOWERED: "dim",
}


@dataclass
class SeenAlarm:
    code: int
    module: str
    description: str
    fault: bool
    raised: float  #: daemon wall-clock time first seen [s]
    cleared: float | None = None


@dataclass
class WatchHistory:
    """What the view remembers between samples: alarms seen, overruns."""

    alarms: deque[SeenAlarm] = field(default_factory=lambda: deque(maxlen=HISTORY))
    overruns: int | None = None
    overrun_at: float | None = None  #: monotonic time of the last new overrun [s]
    new_overruns: int = 0

    def update(self, sample: StateSample, now: float) -> None:
        """Record what changed since the previous sample (``now``: this machine's
        monotonic clock [s])."""
        wall = sample.wallTimeS or time.time()
        active = {(a.code, a.moduleName, a.description) for a in sample.alarms}
        open_ = {(s.code, s.module, s.description): s for s in self.alarms if s.cleared is None}
        for alarm in sample.alarms:
            key = (alarm.code, alarm.moduleName, alarm.description)
            if key not in open_:
                fault = int(alarm.type) == 0
                self.alarms.append(SeenAlarm(*key, fault=fault, raised=wall))
        for key, seen in open_.items():
            if key not in active:
                seen.cleared = wall
        overruns = sample.loop.overruns
        if self.overruns is not None and overruns > self.overruns:
            self.new_overruns = overruns - self.overruns
            self.overrun_at = now
        self.overruns = overruns

    def overrunning(self, now: float) -> bool:
        return self.overrun_at is not None and now - self.overrun_at < OVERRUN_HOLD_S


def _clock(wall: float) -> str:
    if not wall:
        return "-"
    t = time.localtime(wall)
    return time.strftime("%H:%M:%S", t) + f".{int((wall % 1) * 1000):03d}"


def _table(title: str) -> Table:
    return Table(title=escape(title), expand=True, title_justify="left")


def _cell(value: float) -> str:
    text = f"{value:.1f}"
    return "0.0" if text == "-0.0" else text


def _names(unit: UnitJointPositions) -> list[str]:
    if unit.names:
        return list(unit.names)
    if unit.unit == UnitType.VEHICLE and len(unit.position) == 3:
        return ["x", "y", "theta"]
    return [f"J{i + 1}" for i in range(len(unit.position))]


def _unit_of(unit: UnitJointPositions, name: str) -> str:
    if unit.unit == UnitType.VEHICLE:
        return "deg" if name == "theta" else "mm"
    return "deg"


def joint_rows(unit: UnitJointPositions) -> list[tuple[list[str], str]]:
    """Cells and style of each joint: name, measured, commanded, difference, limits,
    distance to the nearest limit."""
    rows = []
    names = _names(unit)
    for i, value in enumerate(unit.position):
        name = names[i] if i < len(names) else f"J{i + 1}"
        cmd = unit.commanded[i] if i < len(unit.commanded) else None
        diff = "-" if cmd is None else fmt_number(cmd - value)
        style = ""
        limits, margin = "-", "-"
        if i < len(unit.limits):
            upper, lower = unit.limits[i].upper, unit.limits[i].lower
            limits = f"{fmt_number(lower)} .. {fmt_number(upper)}"
            if math.isfinite(upper) and math.isfinite(lower) and upper > lower:
                gap = min(value - lower, upper - value)
                margin = fmt_number(gap)
                if gap <= AT_LIMIT * (upper - lower):
                    style = "bold red"
                elif gap <= NEAR_LIMIT * (upper - lower):
                    style = "yellow"
        cells = [
            escape(f"{name} [{_unit_of(unit, name)}]"),
            fmt_number(value),
            "-" if cmd is None else fmt_number(cmd),
            diff,
            limits,
            margin,
        ]
        rows.append((cells, style))
    return rows


def render(
    sample: StateSample,
    address: str,
    rate_hz: float | None = None,
    history: WatchHistory | None = None,
    now: float | None = None,
) -> RenderableType:
    """One frame of the view (``history``: alarms and overruns seen so far)."""
    if history is None:
        history = WatchHistory()
        history.update(sample, time.monotonic())
    now = time.monotonic() if now is None else now
    state = Text.assemble(
        (f"0x{sample.statusId:03X} {codes.state_name(sample.statusId)}",
         _STATE_STYLES.get(sample.statusId, "")),
        f"  {sample.statusMessage}" if sample.statusMessage else "",
    )  # fmt: skip
    rate = f"   {rate_hz:.1f} Hz" if rate_hz else ""
    motion = sample.motion
    if motion is None or not motion.queueDepth:  # a daemon that does not send it
        motion_text = Text("")
    else:
        running = (
            (f"motion #{motion.started} running", "cyan") if motion.active else ("no motion", "dim")
        )
        queue_style = "yellow" if motion.queueDepth and motion.queued >= motion.queueDepth else ""
        motion_text = Text.assemble(
            "\n",
            running,
            "   queue ",
            (f"{motion.queued}/{motion.queueDepth}", queue_style),
            f"   motions started {motion.started}, finished {motion.finished}",
        )
    header = Text.assemble(
        ("imotion ", "bold"),
        f"{address}   {_clock(sample.wallTimeS)}   sample {sample.sequence}   "
        f"t {sample.stampS:.3f} s{rate}\n",
        "state ",
        state,
        motion_text,
    )

    joints = _table("joints [deg; vehicle x, y mm, θ deg]")
    for column in ("joint", "measured", "commanded", "cmd - meas", "limits", "to limit"):
        joints.add_column(column, justify="left" if column in ("joint", "limits") else "right")
    for unit in sample.joints:
        joints.add_row(getattr(unit.unit, "name", str(unit.unit)), style="bold")
        for cells, style in joint_rows(unit):
            joints.add_row(*cells, style=style or None)

    points = _table("control points [original frame]")
    for column in ("arm", "x mm", "y mm", "z mm", "roll", "pitch", "yaw", "elbow"):
        points.add_column(column, justify="left" if column == "arm" else "right")
    for cp in sample.controlPoints:
        hg = cp.pose.carPos
        numbers = [*xyz_of(hg), *rpy_of(hg)] if getattr(hg, "shape", None) == (3, 4) else []
        cells = [_cell(v) for v in numbers] or ["?"] * 6
        points.add_row(getattr(cp.arm, "name", str(cp.arm)), *cells, _cell(cp.pose.elbow))

    alarms = _table("alarms (active, then seen since the view started)")
    for column in ("code", "type", "module", "description", "raised", "cleared"):
        alarms.add_column(column)
    for seen in reversed(history.alarms):
        active = seen.cleared is None
        style = ("bold red" if seen.fault else "yellow") if active else "dim"
        alarms.add_row(
            f"0x{seen.code:04X}",
            "FAULT" if seen.fault else "WARNING",
            escape(seen.module),
            escape(seen.description),
            _clock(seen.raised),
            "active" if active else _clock(seen.cleared or 0.0),
            style=style,
        )
    if not history.alarms:
        alarms.add_row("-", "", "", "none", "", "")

    loop = sample.loop
    overrunning = history.overrunning(now)
    stats = Text.assemble(
        f"loop: {loop.cycles} cycles, ",
        (
            f"{loop.overruns} overruns" + (f" (+{history.new_overruns})" if overrunning else ""),
            "bold red" if overrunning else "",
        ),
        f"   compute p50 {loop.compute.p50Us:.0f} / p99 {loop.compute.p99Us:.0f} / "
        f"max {loop.compute.maxUs:.0f} µs   wake latency p50 {loop.wakeLatency.p50Us:.0f} / "
        f"p99 {loop.wakeLatency.p99Us:.0f} / max {loop.wakeLatency.maxUs:.0f} µs",
    )
    return Panel(Group(header, joints, points, alarms, stats), title="imotion watch")


def run(client: Client, rate_hz: float, once: bool, console: Console) -> int:
    """Show the stream until Ctrl-C (or the daemon ends it); 0 on a clean end."""
    stream = client.monitor.stream(rate_hz)
    history = WatchHistory()
    try:
        first = next(stream, None)
        if first is None:
            console.print("imotion watch: the daemon sent no sample")
            return 1
        history.update(first, time.monotonic())
        if once:
            console.print(render(first, client.address, history=history))
            return 0
        stamps: deque[float] = deque([first.stampS], maxlen=20)
        with Live(
            render(first, client.address, history=history),
            console=console,
            auto_refresh=False,
            transient=False,
        ) as live:
            shown = time.monotonic()
            for sample in stream:
                stamps.append(sample.stampS)
                history.update(sample, time.monotonic())  # every sample: no alarm missed
                if time.monotonic() - shown < MIN_FRAME_PERIOD:
                    continue  # samples faster than the terminal needs: skip the drawing
                shown = time.monotonic()
                span = stamps[-1] - stamps[0]
                rate = (len(stamps) - 1) / span if span > 0 else None
                live.update(render(sample, client.address, rate, history), refresh=True)
        return 0
    except KeyboardInterrupt:
        return 0
    finally:
        stream.cancel()

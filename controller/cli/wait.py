"""``--wait``: follow a motion command to its end, with a progress bar on stderr.

Progress is the fraction of the distance done, estimated from feedback read before the
command and during it (Cartesian: position, or orientation for pure rotations; joints: the
joint vector; grippers: the opening ratio). When no estimate is possible (CP-hold moves,
circular arcs, JARA grippers, a feedback read refused) the bar pulses with elapsed time.
The motion is over when the state leaves Busy/Pause (Spec A) or the moving/paused bits clear
(JARA_ARM, both arms for dual commands). Ctrl-C while waiting stops the motion.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from rich.console import Console
from rich.progress import (
    BarColumn,
    Progress,
    SpinnerColumn,
    TaskProgressColumn,
    TextColumn,
    TimeElapsedColumn,
)

from controller.cli.arguments import CliOperation
from controller.client import codes
from controller.client.client import Client
from controller.client.errors import ClientError
from controller.client.poses import hg_matrix, rotation_angle
from controller.client.service import ServiceProxy
from controller.client.types import Alarm

#: Poll period of state and feedback [s].
POLL = 0.1
#: Below these totals a distance is not used for the estimate [mm], [deg].
MIN_TRANSLATION = 1.0
MIN_ROTATION = 0.5
_GRIPPER_GOALS = {"openGripper": 100.0, "closeGripper": 0.0}


def is_motion(op: CliOperation) -> bool:
    """Operations that start a motion (and so can be waited for)."""
    return op.name.startswith("move") or op.name in ("goHome", "openGripper", "closeGripper")


@dataclass
class Target:
    """One tracked quantity: feedback reader, goal (absolute) or delta (relative)."""

    read: Callable[[], Any]
    goal: Any
    relative: bool
    pose: bool
    start: Any = None

    def fraction(self) -> float | None:
        now = self.read()
        if self.pose:
            return _pose_fraction(self.start, now, hg_matrix(self.goal), self.relative)
        n = min(len(now), len(self.goal), len(self.start))
        start, current, goal = (
            np.asarray(v[:n], dtype=float) for v in (self.start, now, self.goal)
        )
        if self.relative:
            total = float(np.linalg.norm(goal))
            done = float(np.linalg.norm(current - start))
            return done / total if total > 1e-9 else None
        total = float(np.linalg.norm(goal - start))
        return 1.0 - float(np.linalg.norm(goal - current)) / total if total > 1e-9 else None


def _pose_fraction(start: Any, now: Any, goal: np.ndarray, relative: bool) -> float | None:
    s, n = hg_matrix(start), hg_matrix(now)
    if relative:
        travel = float(np.linalg.norm(goal[:, 3]))
        if travel >= MIN_TRANSLATION:
            return float(np.linalg.norm(n[:, 3] - s[:, 3])) / travel
        turn = rotation_angle(np.eye(3, 4), goal)
        return rotation_angle(s, n) / turn if turn >= MIN_ROTATION else None
    travel = float(np.linalg.norm(goal[:, 3] - s[:, 3]))
    if travel >= MIN_TRANSLATION:
        return 1.0 - float(np.linalg.norm(goal[:, 3] - n[:, 3])) / travel
    turn = rotation_angle(s, goal)
    return 1.0 - rotation_angle(n, goal) / turn if turn >= MIN_ROTATION else None


def _get(value: Any, name: str) -> Any:
    return value[name] if isinstance(value, Mapping) else getattr(value, name)


def _reader(call: Callable[[], Any], pick: Callable[[Any], Any]) -> Callable[[], Any]:
    def read() -> Any:
        result = call()
        if not result.ok:
            raise ClientError(str(result.return_id))
        return pick(result)

    return read


def targets(client: Client, op: CliOperation, args: Mapping[str, Any], side: Any) -> list[Target]:
    """What to track for ``op`` (empty when the progress cannot be estimated)."""
    name = op.name.removesuffix("CmdCycle")
    relative = name.endswith("Rel")
    cartesian = name.startswith(("moveLinearCartesian", "movePTPCartesian"))
    if op.group == "integrated":
        im = client.integrated
        if cartesian:
            arm = args["type"]
            read = _reader(
                lambda: im.getFeedbackPosCartesian(arm, "ORIGINAL_FRAME"), lambda r: r.pos.carPos
            )
            goal = args["relHgMat" if relative else "absHgMat"]
            return [Target(read, goal, relative, pose=True)]
        if name.startswith("moveUnit"):
            unit = args["unit"]
            read = _reader(lambda: im.getFeedbackPosJoint(unit), lambda r: r.position)
            return [Target(read, args["relPos" if relative else "absPos"], relative, pose=False)]
        if name.endswith("Gripper"):
            arm = args["type"]
            read = _reader(lambda: im.getGripperPos(arm), lambda r: [float(r.angleRatio)])
            goal = _GRIPPER_GOALS[name] if name in _GRIPPER_GOALS else args["angleRatio"]
            return [Target(read, [float(goal)], False, pose=False)]
        return []
    if op.group == "arm":
        return _arm_targets(client.arm(side), name, relative, cartesian, args)
    arms = {"rArm": client.right_arm, "lArm": client.left_arm}
    if cartesian or name.startswith("movePTPJoint"):
        out = []
        for key, proxy in arms.items():
            per_arm = {"carPoint": args[key], "jointPoints": args[key]}
            out += _arm_targets(proxy, name, relative, cartesian, per_arm)
        return out
    return []


def _arm_targets(
    proxy: ServiceProxy, name: str, relative: bool, cartesian: bool, args: Mapping[str, Any]
) -> list[Target]:
    if cartesian:
        read = _reader(proxy.getFeedbackPosCartesian, lambda r: r.pos.carPos)
        return [Target(read, _get(args["carPoint"], "carPos"), relative, pose=True)]
    if name.startswith("movePTPJoint"):
        read = _reader(proxy.getFeedbackPosJoint, lambda r: r.pos)
        return [Target(read, list(args["jointPoints"]), relative, pose=False)]
    if name == "goHome":
        read = _reader(proxy.getFeedbackPosJoint, lambda r: r.pos)
        home = proxy.getHome()
        return [Target(read, list(home.jointPoint), False, pose=False)] if home.ok else []
    return []


@dataclass
class Outcome:
    finished: bool
    alarm: bool
    seconds: float
    alarms: list[Alarm]


class Waiter:
    """Prepared before the command is sent (reads the start feedback), then :meth:`wait`."""

    def __init__(self, client: Client, op: CliOperation, args: Mapping[str, Any], side: Any):
        self.client = client
        self.op = op
        self.side = side
        try:
            self.targets = targets(client, op, args, side)
            for t in self.targets:
                t.start = t.read()
        except (ClientError, KeyError, TypeError, ValueError):
            self.targets = []

    def _arms(self) -> list[ServiceProxy]:
        if self.op.group == "arm":
            return [self.client.arm(self.side)]
        return [self.client.right_arm, self.client.left_arm]

    def status(self) -> tuple[bool, bool]:
        """(still busy, in alarm)."""
        if self.op.group == "integrated":
            rid, sid, _ = self.client.integrated.getState()
            return rid.ok and sid in (codes.BUSY, codes.PAUSE), rid.ok and sid == codes.ALARM
        busy = alarm = False
        for proxy in self._arms():
            rid, state = proxy.getState()
            if rid.ok:  # LEFT on a one-arm robot is VALUE_ERR: nothing to wait for there
                busy |= bool(state & (codes.JARA_MOVING | codes.JARA_PAUSED))
                alarm |= bool(state & codes.JARA_ALARM)
        return busy, alarm

    def fraction(self) -> float | None:
        values = []
        for t in self.targets:
            try:
                f = t.fraction()
            except (ClientError, ValueError):
                f = None
            if f is not None:
                values.append(min(1.0, max(0.0, f)))
        return min(values) if values else None

    def alarms(self) -> list[Alarm]:
        if self.op.group == "integrated":
            rid, alarms = self.client.integrated.getActiveAlarm()
            return list(alarms) if rid.ok else []
        out: list[Alarm] = []
        for proxy in self._arms():
            rid, alarms = proxy.getActiveAlarm()
            out += alarms if rid.ok else []
        return out

    def stop(self) -> None:
        """Stop the motion (Ctrl-C while waiting)."""
        if self.op.group == "integrated":
            self.client.integrated.stop()
        else:
            for proxy in self._arms():
                proxy.stop()

    def wait(self, timeout: float | None, console: Console, show: bool = True) -> Outcome:
        """Poll until the motion ends or ``timeout`` [s] passes; progress on ``console``."""
        t0 = time.monotonic()
        label = f"{self.op.name}"
        columns = [SpinnerColumn(), TextColumn("{task.description}"), BarColumn()]
        columns += [TaskProgressColumn(), TimeElapsedColumn()]
        estimable = bool(self.targets)
        best = 0.0
        with Progress(*columns, console=console, disable=not show, transient=False) as bar:
            task = bar.add_task(label, total=None)  # pulses until a fraction is known
            try:
                while True:
                    busy, alarm = self.status()
                    if not busy:
                        if not alarm:
                            bar.update(task, total=100.0, completed=100.0)
                        return Outcome(True, alarm, time.monotonic() - t0, self._maybe(alarm))
                    if timeout is not None and time.monotonic() - t0 >= timeout:
                        return Outcome(False, alarm, time.monotonic() - t0, self._maybe(alarm))
                    if estimable and (f := self.fraction()) is not None:
                        best = max(best, f)
                        bar.update(task, total=100.0, completed=100.0 * best)
                    time.sleep(POLL)
            except KeyboardInterrupt:
                self.stop()
                raise

    def _maybe(self, alarm: bool) -> list[Alarm]:
        return self.alarms() if alarm else []

"""Planning and services without gRPC or a daemon: a RobotView on a snapshot written here,
a Context whose command channel only records the calls."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from controller.contract import snapshot as snap_mod
from controller.contract.config import load_config
from controller.contract.snapshot import Snapshot, StateHeader
from controller.gateway.planning.planner import Planner
from controller.gateway.planning.robot_view import RobotView
from controller.gateway.services.context import Context
from controller.model.kinematics import Kinematics
from controller.model.robot import Robot, load_robot
from controller.vocabulary import CoreState, RightLeft
from hal.interface import HardwareState

_ROBOTS: dict[str, Robot] = {}


def robot(name: str) -> Robot:
    if name not in _ROBOTS:
        _ROBOTS[name] = load_robot(name)
    return _ROBOTS[name]


def snapshot(
    rob: Robot,
    q: dict[str, float] | None = None,
    state: CoreState = CoreState.READY,
    moving: bool = False,
    queue: int = 0,
    motion: bool | None = None,
) -> Snapshot:
    """A published state: home (plus ``q`` [rad, m] by joint name), default frames.
    ``motion``: a whole-body motion exists (default: ``moving``; a paused one does not move)."""
    names = list(rob.joints)
    values = dict(rob.home())
    values.update(q or {})
    kin = Kinematics(rob)
    offsets = np.zeros((2, 3, 4))
    for k, side in enumerate((RightLeft.RIGHT, RightLeft.LEFT)):
        if side in kin.arms:
            offsets[k] = kin.control_point_offset(side).homogeneous[:3]
    flags = snap_mod.F_SERVO_ON
    if moving:
        flags |= snap_mod.F_MOVING
    if moving if motion is None else motion:
        flags |= snap_mod.F_MOTION
    if state == CoreState.PAUSED:
        flags |= snap_mod.F_PAUSED
    return Snapshot(
        cycle=1,
        core_state=state,
        hw_state=HardwareState.ACTIVE,
        flags=flags,
        queue=queue,
        queue_depth=8,
        started=0,
        finished=0,
        overruns=0,
        pid=0,
        stamp=0.0,
        compute_us=np.zeros(3),
        wake_us=np.zeros(3),
        q=np.array([values.get(n, 0.0) for n in names]),
        q_cmd=np.zeros(len(names)),
        original=np.eye(4)[:3],
        original_theta=0.0,
        offsets=offsets,
        alarms=[],
    )


def core_snapshot(core: Any) -> Snapshot:
    """The state a control process would publish for ``core`` (a MotionCore, Ready): its
    measured joints, original frame and control-point offsets, so a plan made on it runs
    on the core as planned (a plain :func:`snapshot` has the original frame at the origin,
    a real core has it where its body is)."""
    rob = core.robot
    kin = core.kin
    snap = snapshot(rob, {n: float(kin.q[kin.index(n)]) for n in kin.joint_names})
    offsets = snap.offsets.copy()
    for k, side in enumerate((RightLeft.RIGHT, RightLeft.LEFT)):
        if side in kin.arms:
            offsets[k] = kin.control_point_offset(side).homogeneous[:3]
    return replace(
        snap,
        original=kin.original_frame.homogeneous[:3].copy(),
        original_theta=float(kin.original_theta),
        offsets=offsets,
    )


class FixedReader:
    """A snapshot reader answering the snapshot it was given (tests replace ``.snap``)."""

    def __init__(self, snap: Snapshot):
        self.snap = snap

    def read(self) -> Snapshot:
        return self.snap

    def read_state(self) -> StateHeader:
        s = self.snap
        return StateHeader(s.cycle, s.core_state, s.hw_state, s.flags, s.queue)


def view(rob: Robot, reader: FixedReader) -> RobotView:
    return RobotView(rob, reader, list(rob.joints))  # type: ignore[arg-type]


@dataclass
class RecordingChannel:
    """Answers every command OK (``start``: "started", or ``answers[name]``) and records it;
    ``refuse[name] = (code, message)`` refuses one."""

    calls: list[tuple[str, dict[str, Any]]] = field(default_factory=list)
    answers: dict[str, Any] = field(default_factory=dict)
    refuse: dict[str, tuple[int, str]] = field(default_factory=dict)

    def call(self, name: str, **args: Any) -> tuple[bool, Any, str]:
        self.calls.append((name, args))
        if name in self.refuse:
            code, message = self.refuse[name]
            return False, code, message
        return True, self.answers.get(name, "started" if name == "start" else None), ""

    def names(self) -> list[str]:
        return [name for name, _ in self.calls]

    def specs(self) -> list[Any]:
        return [args["spec"] for name, args in self.calls if name == "start"]


def context(
    name: str, snap: Snapshot | None = None, obstacles: list[dict[str, Any]] | None = None
) -> tuple[Context, FixedReader, RecordingChannel]:
    """A service context on robot ``name`` at ``snap`` (home, Ready by default), with the
    daemon configuration's ``obstacles`` (none by default)."""
    rob = robot(name)
    reader = FixedReader(snap if snap is not None else snapshot(rob))
    cfg = load_config(None, {"robot": name, "hal": "ideal", "obstacles": obstacles or []})
    channel = RecordingChannel()
    planner = Planner(view(rob, reader), cfg.period, cfg.obstacles)
    ctx = Context(cfg, view(rob, reader), planner, channel)
    return ctx, reader, channel

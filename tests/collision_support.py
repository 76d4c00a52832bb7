"""Random commands in closed loop on MuJoCo, checked for self-collision (issue 10).

Each command draws a configuration uniformly within the joint limits (arms and waist; the
vehicle stays) and sends the robot towards it: the control points to that configuration's
poses (level 1), the elbows and waist axes to its values (level 2). One command in three
moves both arms, one in three one arm only (the other arm's control point held where it
is), one in three sends both hands (of a two-armed robot) to one point near the middle
between them (hands into each other). The targets have no
time law: the tasks' feedback drives the joints as fast as the joint box allows, and every
``cycles`` cycles the next command replaces the targets wherever the robot is. Targets
are often in collision: the collision rows must keep the robot out.

Checked every cycle on MuJoCo's own state: no contact between robot geoms by MuJoCo's contact
detection (a model with the checked pairs as contact pairs, robot.xml has none), and the
smallest distance of the checked pairs (coal, at the measured state) never below d_s.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from controller.control.core import CoreState, MotionCore
from controller.model.collision_pairs import collision_path, load_collision_pairs
from controller.model.kinematics import Kinematics
from controller.model.model_export import export_mjcf
from controller.model.redundant_axes import available_axes, axis_value
from controller.motion.motions import IKSetup, Motion
from controller.qp.tasks import AxisTask, ControlPointTask, PostureTask
from controller.vocabulary import UnitType
from hal.mujoco_backend import MujocoBackend
from tests.support import robot

DT = 0.002


class Targets(Motion):
    """A motion that only holds targets (set from outside) and never ends."""

    def __init__(self, kin: Kinematics):
        self.kin = kin
        self.cp = [ControlPointTask(side, kin.pose(side)) for side in kin.arms]
        self.axes = [
            AxisTask(a, axis_value(kin, a)) for a in available_axes(kin) if not a.is_vehicle
        ]
        self.posture = PostureTask(kin.q.copy(), np.arange(kin.nv))
        frozen = np.zeros(kin.nv, dtype=bool)
        if kin.has_vehicle:
            frozen[kin.unit_indices(UnitType.VEHICLE)] = True
        self._setup = IKSetup([*self.cp, *self.axes, self.posture], frozen)

    def setup(self) -> IKSetup:
        return self._setup

    def apply(self, s0: float, s1: float, dt: float) -> None:
        pass

    def advance(self, dt: float | None = None) -> None:
        pass

    @property
    def finished(self) -> bool:
        return False

    @property
    def paused(self) -> bool:
        return False

    def stop(self) -> None:
        pass


@dataclass
class Stats:
    robot: str
    commands: int = 0
    cycles: int = 0
    contact_cycles: int = 0
    contacts: set[tuple[str, str]] = field(default_factory=set)
    min_distance: float = np.inf
    below_security: int = 0
    qp_failures: int = 0
    failures: list[str] = field(default_factory=list)
    security: float = 0.0

    @property
    def ok(self) -> bool:
        return not self.contact_cycles and not self.below_security and not self.qp_failures


def contact_model(robot_id: str) -> mujoco.MjModel:
    """The robot's MJCF with its checked pairs as contact pairs."""
    r = robot(robot_id)
    checked = load_collision_pairs(collision_path(r)).checked
    return mujoco.MjModel.from_xml_string(export_mjcf(r.model, r.profile, checked))


def run(
    robot_id: str,
    commands: int,
    seed: int,
    cycles: int = 100,
    tol: float = 1e-4,
    progress: int = 0,
    **overrides: float,
) -> Stats:
    """``commands`` random commands of ``cycles`` cycles each; ``tol`` [m]: how far below d_s
    counts as below (the distance is measured on the drives' state, which lags the
    commands)."""
    r = robot(robot_id)
    hw = MujocoBackend(r, DT)
    core = MotionCore(r, hw, DT)
    assert core.collision is not None, f"{robot_id}: no collision rows"
    for key, value in overrides.items():  # experiments: other d_i, d_s, ξ
        setattr(core.collision, key, value)
    core.servo_on()
    core.cycle()
    model = contact_model(robot_id)
    data = mujoco.MjData(model)
    sim = hw.model
    assert model.nq == sim.nq
    kin = core.kin
    planning = Kinematics(r)
    rng = np.random.default_rng(seed)
    lo = np.array([r.joints[n].lower for n in kin.joint_names])
    hi = np.array([r.joints[n].upper for n in kin.joint_names])
    vehicle = kin.unit_indices(UnitType.VEHICLE) if kin.has_vehicle else np.zeros(0, dtype=int)
    security = core.collision.security
    stats = Stats(robot_id, security=security)
    motion = Targets(kin)
    core.start(motion)
    for _ in range(commands):
        q = rng.uniform(np.nan_to_num(lo, neginf=0.0), np.nan_to_num(hi, posinf=0.0))
        q[vehicle] = kin.q[vehicle]
        planning.update(q)
        kind = rng.integers(3)
        moved = [kin.arms[rng.integers(len(kin.arms))]] if kind == 1 else kin.arms
        middle = np.mean([kin.pose(side).translation for side in kin.arms], axis=0)
        middle += rng.normal(0.0, 0.05, 3)
        for task in motion.cp:
            pose = planning.pose(task.side) if task.side in moved else kin.pose(task.side)
            if kind == 2 and len(kin.arms) == 2:
                pose.translation = middle
            task.set_target(pose)
        for axis in motion.axes:
            axis.set_target(axis_value(planning, axis.axis))
        stats.commands += 1
        if progress and stats.commands % progress == 0:
            print(
                f"{robot_id}: {stats.commands} commands, min {stats.min_distance:.4f} m", flush=True
            )
        for _ in range(cycles):
            core.cycle()
            stats.cycles += 1
            if core.state != CoreState.BUSY:  # a failed QP: recover and go on
                stats.qp_failures += 1
                stats.failures.extend(a.description for a in core.alarms)
                core.clear_alarms()
                core.servo_on()
                motion = Targets(kin)
                core.start(motion)
                break
            d = float(core.collision.distances.distances.min())
            stats.min_distance = min(stats.min_distance, d)
            stats.below_security += d < security - tol
            data.qpos[:] = hw.data.qpos
            mujoco.mj_kinematics(model, data)
            mujoco.mj_collision(model, data)
            if data.ncon:
                stats.contact_cycles += 1
                for c in data.contact[: data.ncon]:
                    a, b = (model.geom(g).name.rsplit("/", 1)[0] for g in (c.geom1, c.geom2))
                    stats.contacts.add((a, b))
    return stats

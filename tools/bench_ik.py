#!/usr/bin/env python3
"""Benchmark one whole-body IK step of imotion against Pink and mink on the same problem.

Usage: python tools/bench_ik.py --robot smartpal5 [--steps 2000] [--rate 500] [--profile]
       python tools/bench_ik.py --scenario arms-close [--gap 0.03]   (collision rows active:
       see tools/bench_ik_collision.py)

One IK step = kinematics update + QP build + QP solve (plus setting the cycle's targets), timed
with ``time.perf_counter_ns`` after ``--warmup`` cycles. Each library runs its own closed loop
on a kinematic simulation (no physics): it integrates its own ``q += v·dt`` and never sees the
others' state.

The problem, identical for every library as far as their APIs allow:

* Model: the robot's generated files. imotion and Pink share the same reduced Pinocchio model
  (gripper joints locked, control-point OP frames added by :class:`Kinematics`); Pink gets a
  fresh ``Data``. mink loads ``robot.mjcf_path`` (gripper joints included) and gets one site
  per control point, added with ``MjSpec`` on the flange body at the profile's tool offset, so
  its frame task regulates the very same point and axes (no target re-mapping needed).
* Motion: every control point starts at its home pose (``kin.home()``) and follows a
  figure-eight of ``--radius`` in the original frame's y-z plane (lateral ±r, vertical ±r/2)
  with a ``--wobble`` orientation wobble, period ``--period``; both fade in over
  :data:`RAMP` seconds so the start is at rest.
* Tasks: one frame task per control point and a posture task to the home pose. imotion's
  :class:`ControlPointTask` weights rows by 1 (translation) and ``ROTATION_SCALE²`` = 0.09
  (rotation); Pink and mink multiply their ``cost`` into both the Jacobian and the error, so
  the Hessian holds ``cost²``: ``orientation_cost = ROTATION_SCALE · position_cost`` (0.3, not
  0.09) gives the same Hessian. Posture: imotion's ``PostureTask`` (weight
  ``POSTURE_WEIGHT``, gain 1/s); Pink/mink ``cost = √POSTURE_WEIGHT`` and ``gain = dt·1/s``
  (their gain acts on a displacement per cycle). Tikhonov damping: imotion's ``DAMPING`` for
  all three (Pink's and mink's ``damping`` is the same term in Δq units). The constants are
  imported, so the benchmark follows imotion's current values.
* Feedback, each library as it is meant to be used: imotion gets the target at the cycle's
  start ``T(t_k)``, a feed-forward twist (``--twist secant``: the mean velocity from ``t_k``
  to ``t_k+1``; ``instant``: the velocity at ``t_k``) and its default gain
  (``DEFAULT_GAIN`` = 20/s); Pink and mink (no feed-forward in their frame tasks) get the
  pose to reach at the cycle's end ``T(t_k+1)`` with their default dead-beat gain 1.
  Tracking errors are measured against ``T(t_k+1)`` after integration, for all three with
  imotion's FK (mink's qpos mapped to ``kin``'s q by joint name). With a gain below 1/dt,
  imotion's steady error is ~1/(gain·dt) times the per-cycle linearisation error (25× at
  20/s and 500 Hz): micrometres here, by design.
* Limits: joint position and velocity limits for all three. Pink: ``ConfigurationLimit``
  (its default gain 0.5) and ``VelocityLimit``; mink: ``ConfigurationLimit`` (default gain
  0.95) and ``VelocityLimit``. imotion uses its own joint box, which also enforces the
  acceleration limit and the braking distance to the position limits (stricter than the
  peers'). Pink's ``AccelerationLimit`` is left out to keep Pink and mink alike.
* Frozen joints: the vehicle and waist joints are frozen for all three (only the arms move):
  imotion through ``ik.configure``; Pink through a ``v = 0`` limit on them
  (:class:`FrozenJoints`: Pink's ``VelocityLimit`` ignores limits below 1e-10, so zero
  limits would free them instead); mink through zero ``VelocityLimit`` entries. mink's
  gripper joints (absent from the Pinocchio model) are held still the same way and by its
  posture task, which covers every dof. Every QP keeps all ``nv`` variables (mink's
  ``nv`` counts the gripper joints too).
* Solvers: imotion's default back end as the daemon uses it (``controller.qp.solver``:
  DAQP with a persistent workspace; ``--ours-solver proxqp`` or ``qpsolvers:<name>`` try
  another). Pink and mink go
  through ``qpsolvers``; every solver of ``--peer-solvers`` that is installed is run, with
  the solvers' default tolerances unless ``--peer-tol`` gives one (as a velocity: Pink and
  mink solve for Δq = v·dt, so the defaults, 1e-5 for ProxQP and 1e-6 for DAQP on Δq, allow
  5e-3 and 5e-4 rad/s at 500 Hz). The JSON's ``pink_us`` / ``mink_us`` are each library's
  fastest run without failed solves.

Violations count cycles where a joint ends outside its position limits or a commanded
|v| exceeds its velocity limit (frozen and gripper joints: 0), each with tolerance 1e-9.

The last line of the output is a JSON object: robot, ours_us, pink_us, mink_us,
speedup_vs_best (= min(pink_us, mink_us) / ours_us) and extra details.
"""

from __future__ import annotations

import argparse
import cProfile
import gc
import json
import math
import pstats
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import mink
import mujoco
import numpy as np
import pink
import pinocchio as pin
import qpsolvers
from mink.exceptions import MinkError
from pink.exceptions import PinkError
from pink.limits import ConfigurationLimit as PinkConfigurationLimit
from pink.limits import Limit as PinkLimit
from pink.limits import VelocityLimit as PinkVelocityLimit

from controller.model.kinematics import Kinematics
from controller.model.robot import Robot, load_robot
from controller.qp.ik import DAMPING, WholeBodyIK
from controller.qp.solver import DEFAULT_SOLVER
from controller.qp.tasks import (
    DEFAULT_GAIN,
    POSTURE_WEIGHT,
    ROTATION_SCALE,
    ControlPointTask,
    PostureTask,
)
from controller.vocabulary import RightLeft, UnitType

#: Time [s] over which the figure-eight and the wobble fade in from rest.
RAMP = 1.0
#: Tolerance on position [rad, m] and velocity [rad/s, m/s] limits when counting violations.
TOL = 1e-9
#: Step [s] of the central difference giving the targets' feed-forward twist.
FD_STEP = 1e-5
#: Posture gain [1/s] (imotion's PostureTask default).
POSTURE_GAIN = 1.0
#: Units held still in every library.
FROZEN_UNITS = (UnitType.VEHICLE, UnitType.LUMBER)


# --------------------------------------------------------------------------- the motion
class Trajectory:
    """Control-point targets in the original frame: figure-eight plus orientation wobble."""

    def __init__(
        self, home: dict[RightLeft, pin.SE3], radius: float, period: float, wobble_deg: float
    ):
        self.home = home
        self.radius = radius
        self.omega = 2.0 * math.pi / period
        self.wobble = math.radians(wobble_deg)

    @staticmethod
    def envelope(t: float) -> float:
        """0 at rest, 1 after :data:`RAMP`, C¹-smooth in between (and 0 before t = 0)."""
        if t <= 0.0:
            return 0.0
        if t >= RAMP:
            return 1.0
        return 0.5 * (1.0 - math.cos(math.pi * t / RAMP))

    def pose(self, side: RightLeft, t: float) -> pin.SE3:
        home = self.home[side]
        env = self.envelope(t)
        s = 1.0 if side == RightLeft.RIGHT else -1.0  # mirror the left arm's lateral motion
        wt = self.omega * t
        offset = env * self.radius * np.array([0.0, s * math.sin(wt), 0.5 * math.sin(2 * wt)])
        theta = env * self.wobble * np.array([math.sin(wt), 0.5 * math.sin(2 * wt), 0.0])
        return pin.SE3(pin.exp3(theta) @ home.rotation, home.translation + offset)

    def twist(self, side: RightLeft, t: float, span: float = 0.0) -> np.ndarray:
        """Linear and angular velocity [m/s, rad/s] in the original frame's axes.

        ``span`` 0: the instantaneous velocity at ``t``; else the mean velocity from ``t`` to
        ``t + span`` (the secant: what carries ``pose(t)`` exactly to ``pose(t + span)``).
        """
        a, b = (t - FD_STEP, t + FD_STEP) if span == 0.0 else (t, t + span)
        return secant(self.pose(side, a), self.pose(side, b), b - a)


def secant(a: pin.SE3, b: pin.SE3, dt: float) -> np.ndarray:
    """Linear and angular velocity [m/s, rad/s] (world axes) that move ``a`` to ``b`` in dt."""
    out = np.empty(6)
    out[:3] = (b.translation - a.translation) / dt
    out[3:] = pin.log3(b.rotation @ a.rotation.T) / dt
    return out


@dataclass
class Targets:
    """Precomputed per-cycle targets (index k = time k·dt), so no runner pays for them."""

    sides: list[RightLeft]
    original: list[dict[RightLeft, pin.SE3]]  # original frame
    twist: list[dict[RightLeft, np.ndarray]]  # original frame's axes
    world: list[dict[RightLeft, pin.SE3]]  # Pinocchio / MuJoCo world
    mink_world: list[dict[RightLeft, mink.SE3]]


def make_targets(
    kin: Kinematics, traj: Trajectory, dt: float, cycles: int, secant_twist: bool
) -> Targets:
    sides = kin.arms
    original, twist, world, mink_world = [], [], [], []
    span = dt if secant_twist else 0.0
    for k in range(cycles + 1):
        t = k * dt
        o = {s: traj.pose(s, t) for s in sides}
        w = {s: kin.original_frame * o[s] for s in sides}
        original.append(o)
        twist.append({s: traj.twist(s, t, span) for s in sides})
        world.append(w)
        mink_world.append({s: mink.SE3.from_matrix(w[s].homogeneous) for s in sides})
    return Targets(sides, original, twist, world, mink_world)


# ------------------------------------------------------------------------------ runners
class Runner:
    """One library's closed loop. :meth:`step` is the timed part; the rest is bookkeeping."""

    name: str
    dt: float
    #: Commanded velocity of the last step, in the runner's own dof order.
    v: np.ndarray
    #: Configuration, in the runner's own order.
    q: np.ndarray
    #: Limits in the runner's own order: position [lo, hi] and velocity (0 = frozen).
    q_lo: np.ndarray
    q_hi: np.ndarray
    v_lim: np.ndarray

    def step(self, k: int) -> bool:
        """Set the targets of cycle ``k``, update kinematics, build and solve; False = failed."""
        raise NotImplementedError

    def integrate(self) -> None:
        self.q = self.q + self.v * self.dt

    def q_kin(self) -> np.ndarray:
        """The configuration in ``kin``'s joint order."""
        return self.q


def frozen_mask(kin: Kinematics) -> np.ndarray:
    mask = np.zeros(kin.nv, dtype=bool)
    for unit in FROZEN_UNITS:
        mask[kin.unit_indices(unit)] = True
    return mask


def profile_velocities(kin: Kinematics) -> np.ndarray:
    """The profile's velocity limits in ``kin``'s order (frozen joints included)."""
    return np.array([kin.robot.joints[n].velocity for n in kin.joint_names])


def kin_limits(kin: Kinematics) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Profile position limits and velocity limits (0 for frozen joints) in ``kin``'s order."""
    specs = [kin.robot.joints[n] for n in kin.joint_names]
    lo = np.array([s.lower for s in specs])
    hi = np.array([s.upper for s in specs])
    vel = profile_velocities(kin)
    vel[frozen_mask(kin)] = 0.0
    return lo, hi, vel


class ImotionRunner(Runner):
    def __init__(
        self,
        robot: Robot,
        targets: Targets,
        dt: float,
        solver: str = DEFAULT_SOLVER,
        gain: float = DEFAULT_GAIN,
    ):
        label = solver.removeprefix("qpsolvers:")
        if gain != DEFAULT_GAIN:
            label += f", gain {gain:g}/s"
        self.name = f"imotion ({label})"
        self.dt = dt
        self.targets = targets
        self.kin = kin = Kinematics(robot)
        self.ik = ik = WholeBodyIK(kin, dt, solver)
        ik.configure(frozen_mask(kin))
        home = kin.home()
        self.cp_tasks = [
            ControlPointTask(s, targets.original[0][s], gain=gain) for s in targets.sides
        ]
        posture = PostureTask(home, np.arange(kin.nv), gain=POSTURE_GAIN, weight=POSTURE_WEIGHT)
        ik.tasks = [*self.cp_tasks, posture]
        self.q = home.copy()
        self.v = np.zeros(kin.nv)
        self.q_lo, self.q_hi, self.v_lim = kin_limits(kin)

    def step(self, k: int) -> bool:
        original, twist = self.targets.original[k], self.targets.twist[k]
        for task in self.cp_tasks:
            task.set_target(original[task.side], twist[task.side])
        self.kin.update(self.q)
        result = self.ik.solve(self.q, self.v)
        self.v = result.velocity
        return result.ok


class FrozenJoints(PinkLimit):
    """Pink limit ``Δq = 0`` on some joints (``VelocityLimit`` skips zero limits)."""

    def __init__(self, nv: int, indices: np.ndarray):
        eye = np.eye(nv)[indices]
        self.G = np.vstack([eye, -eye])
        self.h = np.zeros(2 * len(indices))

    def compute_qp_inequalities(
        self, configuration: pink.Configuration, dt: float
    ) -> tuple[np.ndarray, np.ndarray] | None:
        return (self.G, self.h) if len(self.h) else None


def solver_options(solver: str, tol: float | None, dt: float) -> dict[str, Any]:
    """qpsolvers keyword arguments for a tolerance ``tol`` [rad/s] on v (None: defaults).

    Pink and mink solve for Δq = v·dt, so a tolerance on v is ``tol·dt`` on their variable.
    """
    if tol is None:
        return {}
    if solver == "proxqp":
        return {"eps_abs": tol * dt, "eps_rel": 0.0}
    if solver == "daqp":
        return {"primal_tol": tol * dt}
    raise ValueError(f"--peer-tol: no tolerance setting known for {solver!r}")


class PinkRunner(Runner):
    def __init__(
        self, robot: Robot, targets: Targets, dt: float, solver: str, tol: float | None = None
    ):
        self.name = f"pink ({solver})"
        self.dt = dt
        self.solver = solver
        self.solver_options = solver_options(solver, tol, dt)
        self.targets = targets
        # A Kinematics of its own only to get the same reduced model with the same OP frames;
        # Pink attaches attributes to the model it is given, so imotion's stays untouched.
        kin = Kinematics(robot)
        model = kin.model
        home = kin.home()
        self.configuration = pink.Configuration(model, model.createData(), home)
        self.frame_tasks = {
            s: pink.tasks.FrameTask(
                f"control_point_{s.name.lower()}",
                position_cost=1.0,
                orientation_cost=ROTATION_SCALE,  # squared in the Hessian: 0.09
            )
            for s in targets.sides
        }
        posture = pink.tasks.PostureTask(cost=math.sqrt(POSTURE_WEIGHT), gain=POSTURE_GAIN * dt)
        posture.set_target(home)
        self.tasks = [*self.frame_tasks.values(), posture]
        self.q_lo, self.q_hi, self.v_lim = kin_limits(kin)
        self.limits = [
            PinkConfigurationLimit(model),
            PinkVelocityLimit(model, profile_velocities(kin)),
            FrozenJoints(model.nv, np.flatnonzero(frozen_mask(kin))),
        ]
        self.q = home.copy()
        self.v = np.zeros(model.nv)

    def step(self, k: int) -> bool:
        world = self.targets.world[k + 1]
        for side, task in self.frame_tasks.items():
            task.set_target(world[side])
        self.configuration.update(self.q)
        try:
            self.v = pink.solve_ik(
                self.configuration,
                self.tasks,
                self.dt,
                solver=self.solver,
                damping=DAMPING,
                limits=self.limits,
                **self.solver_options,
            )
        except PinkError:
            self.v = np.zeros_like(self.v)
            return False
        return True


def mink_model(robot: Robot, kin: Kinematics) -> mujoco.MjModel:
    """The robot's MJCF with a site ``control_point_<side>`` at each control point."""
    spec = mujoco.MjSpec.from_file(str(robot.mjcf_path))
    for side_name, arm in robot.profile.arms.items():
        side = RightLeft[side_name]
        offset = kin.control_point_offset(side)
        quat = pin.Quaternion(offset.rotation)
        spec.body(arm.flange).add_site(
            name=f"control_point_{side.name.lower()}",
            pos=offset.translation.tolist(),
            quat=[quat.w, quat.x, quat.y, quat.z],
        )
    return spec.compile()


class MinkRunner(Runner):
    def __init__(
        self, robot: Robot, targets: Targets, dt: float, solver: str, tol: float | None = None
    ):
        self.name = f"mink ({solver})"
        self.dt = dt
        self.solver = solver
        self.solver_options = solver_options(solver, tol, dt)
        self.targets = targets
        kin = Kinematics(robot)
        self.model = model = mink_model(robot, kin)
        # kin order <-> MuJoCo qpos / dof addresses (all joints here are 1-dof).
        self.qadr = np.array([model.joint(n).qposadr[0] for n in kin.joint_names])
        names = [model.joint(j).name for j in range(model.njnt)]
        dofadr = [int(model.jnt_dofadr[j]) for j in range(model.njnt)]
        assert model.nq == model.nv == model.njnt, "benchmark models have 1-dof joints only"
        home = np.zeros(model.nq)  # gripper joints at 0, as in imotion's reduced model
        home[self.qadr] = kin.home()
        self.configuration = mink.Configuration(model, home)
        self.frame_tasks = {
            s: mink.FrameTask(
                f"control_point_{s.name.lower()}",
                "site",
                position_cost=1.0,
                orientation_cost=ROTATION_SCALE,  # squared in the Hessian: 0.09
            )
            for s in targets.sides
        }
        posture = mink.PostureTask(model, cost=math.sqrt(POSTURE_WEIGHT), gain=POSTURE_GAIN * dt)
        posture.set_target(home)
        self.tasks = [*self.frame_tasks.values(), posture]
        frozen = {kin.joint_names[i] for i in np.flatnonzero(frozen_mask(kin))}
        specs = robot.joints  # unit and gripper joints
        grippers = set(robot.gripper_joints)
        velocity = {n: 0.0 if n in frozen or n in grippers else specs[n].velocity for n in names}
        self.limits = [mink.ConfigurationLimit(model), mink.VelocityLimit(model, velocity)]
        self.q_lo = np.empty(model.nv)
        self.q_hi = np.empty(model.nv)
        self.v_lim = np.empty(model.nv)
        for name, adr in zip(names, dofadr, strict=True):
            self.q_lo[adr], self.q_hi[adr] = specs[name].lower, specs[name].upper
            self.v_lim[adr] = velocity[name]
        self.q = home.copy()
        self.v = np.zeros(model.nv)
        # Same world, same point: the site must sit where imotion's control point is.
        kin.update(kin.home())
        for side in kin.arms:
            sid = model.site(f"control_point_{side.name.lower()}").id
            data = self.configuration.data
            cp = kin.original_frame * kin.pose(side)
            dp = np.abs(data.site_xpos[sid] - cp.translation).max()
            dr = np.abs(data.site_xmat[sid].reshape(3, 3) - cp.rotation).max()
            assert dp < 1e-9 and dr < 1e-9, f"MJCF and URDF disagree at {side.name}: {dp}, {dr}"

    def step(self, k: int) -> bool:
        world = self.targets.mink_world[k + 1]
        for side, task in self.frame_tasks.items():
            task.set_target(world[side])
        self.configuration.update(self.q)
        try:
            self.v = mink.solve_ik(
                self.configuration,
                self.tasks,
                self.dt,
                solver=self.solver,
                damping=DAMPING,
                limits=self.limits,
                **self.solver_options,
            )
        except MinkError:
            self.v = np.zeros_like(self.v)
            return False
        return True

    def q_kin(self) -> np.ndarray:
        return self.q[self.qadr]


# ----------------------------------------------------------------------------- the loop
@dataclass
class Result:
    name: str
    times_us: np.ndarray  # timed cycles only (after the warm-up)
    pos_err: np.ndarray  # [m] per cycle and control point
    rot_err: np.ndarray  # [rad]
    q_viol: int
    v_viol: int
    q_excess: float  # worst excess beyond a position limit [rad, m]
    v_excess: float  # worst excess beyond a velocity limit [rad/s, m/s]
    failures: int

    @property
    def median_us(self) -> float:
        return float(np.median(self.times_us))

    @property
    def p99_us(self) -> float:
        return float(np.percentile(self.times_us, 99))

    @property
    def pos_max_mm(self) -> float:
        return float(self.pos_err.max() * 1e3)

    def summary(self) -> dict[str, float | int]:
        return {
            "median_us": round(self.median_us, 1),
            "p99_us": round(self.p99_us, 1),
            "pos_max_mm": float(f"{self.pos_err.max() * 1e3:.4g}"),
            "pos_rms_mm": float(f"{math.sqrt(np.mean(self.pos_err**2)) * 1e3:.4g}"),
            "rot_max_deg": float(f"{math.degrees(self.rot_err.max()):.4g}"),
            "rot_rms_deg": float(f"{math.degrees(math.sqrt(np.mean(self.rot_err**2))):.4g}"),
            "q_viol": self.q_viol,
            "v_viol": self.v_viol,
            "failures": self.failures,
        }


#: ``--clock``: wall time (what a step takes on this machine now, preemption included) or
#: the thread's CPU time (the step's own cost: steadier on a shared, loaded machine).
CLOCKS = {"wall": time.perf_counter_ns, "cpu": time.thread_time_ns}
CLOCK = ["wall"]


def run(runner: Runner, judge: Kinematics, targets: Targets, warmup: int, cycles: int) -> Result:
    times = np.empty(cycles)
    n_sides = len(targets.sides)
    pos_err = np.empty((cycles, n_sides))
    rot_err = np.empty((cycles, n_sides))
    q_viol = v_viol = failures = 0
    q_excess = v_excess = 0.0
    clock = CLOCKS[CLOCK[0]]
    gc.collect()
    for k in range(cycles):
        t0 = clock()
        ok = runner.step(k)
        t1 = clock()
        times[k] = (t1 - t0) * 1e-3
        failures += not ok
        v_over = float(np.max(np.abs(runner.v) - runner.v_lim))
        runner.integrate()
        q_over = float(max(np.max(runner.q_lo - runner.q), np.max(runner.q - runner.q_hi)))
        v_viol += v_over > TOL
        q_viol += q_over > TOL
        v_excess = max(v_excess, v_over)
        q_excess = max(q_excess, q_over)
        judge.update(runner.q_kin())
        for i, side in enumerate(targets.sides):
            target = targets.original[k + 1][side]
            pose = judge.pose(side)
            pos_err[k, i] = np.linalg.norm(target.translation - pose.translation)
            rot_err[k, i] = np.linalg.norm(pin.log3(target.rotation @ pose.rotation.T))
    return Result(
        runner.name,
        times[warmup:],
        pos_err,
        rot_err,
        q_viol,
        v_viol,
        q_excess,
        v_excess,
        failures,
    )


def profile_imotion(
    robot: Robot, targets: Targets, dt: float, cycles: int, top: int, solver: str
) -> None:
    """cProfile of imotion's step over a whole run (printed, sorted by own time)."""
    runner = ImotionRunner(robot, targets, dt, solver)
    profiler = cProfile.Profile()
    profiler.enable()
    for k in range(cycles):
        runner.step(k)
        runner.integrate()
    profiler.disable()
    print(f"\ncProfile of imotion's step ({cycles} cycles), by own time:")
    pstats.Stats(profiler, stream=sys.stdout).sort_stats("tottime").print_stats(top)


# ------------------------------------------------------------------------------- output
def print_table(robot: Robot, kin: Kinematics, args: argparse.Namespace, results: list[Result]):
    frozen = [kin.joint_names[i] for i in np.flatnonzero(frozen_mask(kin))]
    print(
        f"robot {robot.id}: nv={kin.nv} (frozen: {', '.join(frozen) or 'none'}), "
        f"arms {', '.join(s.name for s in kin.arms)}, {args.rate:g} Hz, "
        f"{args.steps} timed steps after {args.warmup} warm-up"
    )
    print(
        f"motion: figure-eight ±{args.radius * 1e3:.0f} mm, wobble ±{args.wobble:g} deg, "
        f"period {args.period:g} s"
    )
    head = (
        f"{'library':<28}{'median µs':>10}{'p99 µs':>9}{'pos max':>10}{'pos rms':>10}"
        f"{'rot max':>10}{'rot rms':>10}{'q viol':>8}{'v viol':>8}{'fail':>6}"
    )
    print(head)
    print(f"{'':<37}{'[mm]':>10}{'[mm]':>10}{'[deg]':>10}{'[deg]':>10}")
    print("-" * len(head))
    for r in results:
        s = r.summary()
        print(
            f"{r.name:<28}{s['median_us']:>10.1f}{s['p99_us']:>9.1f}"
            f"{s['pos_max_mm']:>10.4f}{s['pos_rms_mm']:>10.4f}"
            f"{s['rot_max_deg']:>10.4f}{s['rot_rms_deg']:>10.4f}"
            f"{s['q_viol']:>8d}{s['v_viol']:>8d}{s['failures']:>6d}"
        )
    worst = [(r.name, r.q_excess, r.v_excess) for r in results if r.q_viol or r.v_viol]
    for name, qe, ve in worst:
        print(f"  {name}: worst excess position {qe:.3g}, velocity {ve:.3g} (SI)")


def fastest(results: list[Result]) -> Result:
    """The fastest run without failed solves (a failing run can be fast by giving up early);
    the fastest of all when every run failed somewhere."""
    clean = [r for r in results if not r.failures] or results
    return min(clean, key=lambda r: r.median_us)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="smartpal5", help="robot id or directory")
    parser.add_argument("--steps", type=int, default=2000, help="timed cycles")
    parser.add_argument("--warmup", type=int, default=100, help="untimed cycles first")
    parser.add_argument(
        "--clock",
        choices=tuple(CLOCKS),
        default="wall",
        help="wall: perf_counter; cpu: the thread's CPU time (steadier under load)",
    )
    parser.add_argument("--rate", type=float, default=500.0, help="control rate [Hz]")
    parser.add_argument("--radius", type=float, default=0.06, help="figure-eight size [m]")
    parser.add_argument("--wobble", type=float, default=5.0, help="orientation wobble [deg]")
    parser.add_argument("--period", type=float, default=4.0, help="figure-eight period [s]")
    parser.add_argument(
        "--ours-solver",
        default="daqp",
        help="imotion's QP back end: daqp (default, as the daemon), proxqp or qpsolvers:<name>",
    )
    parser.add_argument(
        "--peer-solvers", default="proxqp,daqp", help="qpsolvers back ends for Pink and mink"
    )
    parser.add_argument(
        "--twist",
        choices=("secant", "instant"),
        default="secant",
        help="imotion's feed-forward: mean velocity over the cycle or velocity at its start",
    )
    parser.add_argument(
        "--peer-tol",
        type=float,
        default=None,
        help="Pink/mink QP tolerance as a velocity [rad/s] (default: the solvers' own)",
    )
    parser.add_argument("--profile", action="store_true", help="also cProfile imotion's step")
    parser.add_argument(
        "--scenario",
        choices=("figure-eight", "arms-close"),
        default="figure-eight",
        help="arms-close: hands close together with the collision limits of all three "
        "(tools/bench_ik_collision.py)",
    )
    parser.add_argument(
        "--gap", type=float, default=0.03, help="arms-close: the hands' starting gap [m]"
    )
    args = parser.parse_args()
    CLOCK[0] = args.clock
    if args.scenario == "arms-close":
        import bench_ik_collision

        return int(bench_ik_collision.main(args))

    dt = 1.0 / args.rate
    cycles = args.warmup + args.steps
    robot = load_robot(args.robot)
    kin = Kinematics(robot)
    kin.update(kin.home())
    traj = Trajectory({s: kin.pose(s) for s in kin.arms}, args.radius, args.period, args.wobble)
    targets = make_targets(kin, traj, dt, cycles, args.twist == "secant")
    solvers = [s for s in args.peer_solvers.split(",") if s in qpsolvers.available_solvers]
    if not solvers:
        parser.error(f"none of {args.peer_solvers} is installed ({qpsolvers.available_solvers})")

    factories: list[Callable[[], Runner]] = [
        partial(ImotionRunner, robot, targets, dt, args.ours_solver),
        # The peers' own setting: dead-beat feedback (gain 1/dt), for equal-gain tracking.
        partial(ImotionRunner, robot, targets, dt, args.ours_solver, 1.0 / dt),
    ]
    factories += [partial(PinkRunner, robot, targets, dt, s, args.peer_tol) for s in solvers]
    factories += [partial(MinkRunner, robot, targets, dt, s, args.peer_tol) for s in solvers]
    results = [run(make(), kin, targets, args.warmup, cycles) for make in factories]
    print_table(robot, kin, args, results)
    if args.profile:
        profile_imotion(robot, targets, dt, cycles, 25, args.ours_solver)

    ours, ours_deadbeat = results[0], results[1]
    pink_best = fastest([r for r in results if r.name.startswith("pink")])
    mink_best = fastest([r for r in results if r.name.startswith("mink")])
    out: dict[str, Any] = {
        "robot": robot.id,
        "clock": args.clock,
        "ours_us": round(ours.median_us, 1),
        "pink_us": round(pink_best.median_us, 1),
        "mink_us": round(mink_best.median_us, 1),
        "speedup_vs_best": round(min(pink_best.median_us, mink_best.median_us) / ours.median_us, 2),
        "pink_solver": pink_best.name.split("(")[1].rstrip(")"),
        "mink_solver": mink_best.name.split("(")[1].rstrip(")"),
        "ours_p99_us": round(ours.p99_us, 1),
        "pink_p99_us": round(pink_best.p99_us, 1),
        "mink_p99_us": round(mink_best.p99_us, 1),
        "ours_pos_max_mm": round(ours.pos_max_mm, 5),
        "ours_deadbeat_us": round(ours_deadbeat.median_us, 1),
        "ours_deadbeat_pos_max_mm": round(ours_deadbeat.pos_max_mm, 5),
        "peer_pos_max_mm": round(min(pink_best.pos_max_mm, mink_best.pos_max_mm), 5),
        "rate_hz": args.rate,
        "steps": args.steps,
        "runs": {r.name: r.summary() for r in results},
    }
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())

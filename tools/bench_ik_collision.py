"""bench_ik's ``--scenario arms-close``: both hands close together, collision rows active.

The problem of :mod:`bench_ik` (same tasks, limits, frozen units, figure-eight, solvers),
with two changes:

* Start: both control points moved towards each other until their hands' shapes are about
  ``--gap`` apart (solved once, offline, with imotion's IK), so the figure-eight (mirrored
  laterally: the hands swing towards and away from each other) keeps several checked pairs
  inside the influence distance d_i.
* Collision limits on the same pairs (the robot's checked pairs, ``collision.yaml``), with the
  profile's d_s and d_i, for all three: imotion's :class:`CollisionAvoidance` rows (its
  distances updated in the step, after the kinematics, as the control loop does); Pink's
  ``SelfCollisionBarrier`` (hpp-fcl through Pinocchio, on imotion's own coal geometry, the
  closest ``max_rows`` pairs, ``d_min`` = d_s); mink's ``CollisionAvoidanceLimit`` (MuJoCo's
  ``mj_geomDistance`` on the collision geoms of robot.xml, the same link pairs,
  ``minimum_distance_from_collisions`` = d_s, ``collision_detection_distance`` = d_i; the
  collision geoms get contype/conaffinity 1 in mink's model, else its limit skips them).

It also runs imotion without the collision rows on the same scenario: the difference of the
medians is the extra cost of the rows per cycle. The JSON line adds ``ours_no_rows_us``,
``rows_extra_us``, ``rows_active_median`` (rows in the QP per cycle), ``pairs_in_range_median``
(pairs within reach of d_i: their rows, less those the joint box implies) and ``min_distance_mm``
per library (the smallest checked distance along the run, measured with imotion's coal
model after each integration, outside the timed step).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

import mink
import numpy as np
import pink
import pinocchio as pin
from bench_ik import (
    ImotionRunner,
    MinkRunner,
    PinkRunner,
    Result,
    Runner,
    Targets,
    Trajectory,
    fastest,
    frozen_mask,
    make_targets,
    print_table,
    run,
)
from pink.barriers import SelfCollisionBarrier

from controller.model.collision import CollisionDistances
from controller.model.collision_pairs import collision_path, load_collision_pairs
from controller.model.kinematics import Kinematics
from controller.model.robot import Robot, load_robot
from controller.qp.constraints.collision import collision_avoidance
from controller.qp.ik import DAMPING, WholeBodyIK
from controller.qp.tasks import ControlPointTask, PostureTask
from controller.vocabulary import RightLeft


def close_start(robot: Robot, gap: float, dt: float) -> np.ndarray:
    """A configuration with the hands about ``gap`` [m] apart (their closest checked pair),
    reached from home by imotion's IK with its collision rows."""
    kin = Kinematics(robot)
    ik = WholeBodyIK(kin, dt)
    rows = collision_avoidance(kin, dt)
    assert rows is not None
    ik.add(rows)
    ik.configure(frozen_mask(kin))
    q = kin.home()
    kin.update(q)
    right, left = kin.pose(RightLeft.RIGHT), kin.pose(RightLeft.LEFT)
    middle = 0.5 * (right.translation + left.translation)
    tasks = []
    hands = [
        i
        for i, (a, b) in enumerate(rows.distances.pair_links)
        if {a[:2], b[:2]} == {"r_", "l_"} and "arm_link" not in a + b
    ]
    for pose, side in ((right, RightLeft.RIGHT), (left, RightLeft.LEFT)):
        target = pose.copy()
        target.translation = middle + (pose.translation - middle) * 0.05
        tasks.append(ControlPointTask(side, target))
    ik.tasks = [*tasks, PostureTask(q.copy(), np.arange(kin.nv))]
    v = np.zeros(kin.nv)
    for _ in range(5000):
        kin.update(q)
        rows.distances.update(kin.data, kin.q)
        if hands and float(rows.distances.distances[hands].min()) < gap:
            break
        result = ik.solve(q, v)
        v = result.velocity
        q = q + v * dt
    # come to rest there
    for task in tasks:
        task.set_target(kin.pose(task.side))
    for _ in range(500):
        kin.update(q)
        rows.distances.update(kin.data, kin.q)
        v = ik.solve(q, v).velocity
        q = q + v * dt
    return q


class CollisionImotion(ImotionRunner):
    """imotion with (``rows``) or without its collision rows, from ``start``."""

    def __init__(self, robot: Robot, targets: Targets, dt: float, start: np.ndarray, rows: bool):
        super().__init__(robot, targets, dt)
        self.q = start.copy()
        self.rows = collision_avoidance(self.kin, dt) if rows else None
        self.name = "imotion (daqp, rows)" if rows else "imotion (daqp, no rows)"
        self.active: list[int] = []  # rows in the QP per cycle
        self.in_range: list[int] = []  # pairs in range (rows the box implies left out)
        if self.rows is not None:
            self.ik.add(self.rows)
            self.ik.configure(frozen_mask(self.kin))

    def step(self, k: int) -> bool:
        original, twist = self.targets.original[k], self.targets.twist[k]
        for task in self.cp_tasks:
            task.set_target(original[task.side], twist[task.side])
        self.kin.update(self.q)
        if self.rows is not None:
            self.rows.distances.update(self.kin.data, self.kin.q)
        result = self.ik.solve(self.q, self.v)
        self.v = result.velocity
        if self.rows is not None:
            self.in_range.append(len(self.rows.pairs))
            self.active.append(len(self.rows.row_pairs))
        return result.ok


class CollisionPink(PinkRunner):
    def __init__(self, robot: Robot, targets: Targets, dt: float, solver: str, start: np.ndarray):
        super().__init__(robot, targets, dt, solver)
        self.name = f"pink ({solver}, barrier)"
        kin = Kinematics(robot)
        pairs = load_collision_pairs(collision_path(robot)).checked
        dist = CollisionDistances(kin.model, robot.model, pairs)
        settings = robot.profile.collision_avoidance
        model = self.configuration.model
        self.configuration = pink.Configuration(
            model,
            model.createData(),
            start,
            collision_model=dist.geometry,
            collision_data=pin.GeometryData(dist.geometry),
        )
        self.barrier = SelfCollisionBarrier(
            n_collision_pairs=min(settings.max_rows, len(dist)), d_min=settings.security
        )
        self.q = start.copy()

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
                barriers=[self.barrier],
                safety_break=False,
                **self.solver_options,
            )
        except Exception:
            self.v = np.zeros_like(self.v)
            return False
        return True


class CollisionMink(MinkRunner):
    def __init__(self, robot: Robot, targets: Targets, dt: float, solver: str, start: np.ndarray):
        super().__init__(robot, targets, dt, solver)
        self.name = f"mink ({solver}, collision limit)"
        model = self.model
        pairs = load_collision_pairs(collision_path(robot)).checked
        geoms: dict[str, list[str]] = {}
        for g in range(model.ngeom):
            name = model.geom(g).name
            if "/" in name:
                geoms.setdefault(name.rsplit("/", 1)[0], []).append(name)
                # robot.xml keeps contype/conaffinity 0 (no contacts); mink's limit skips
                # such geoms: make the collision geoms eligible (kinematics only here).
                model.geom_contype[g] = model.geom_conaffinity[g] = 1
        settings = robot.profile.collision_avoidance
        geom_pairs = [(geoms[a], geoms[b]) for a, b in pairs if a in geoms and b in geoms]
        self.limits.append(
            mink.CollisionAvoidanceLimit(
                model,
                geom_pairs,
                minimum_distance_from_collisions=settings.security,
                collision_detection_distance=settings.influence,
            )
        )
        self.q[self.qadr] = start
        self.configuration.update(self.q)


def main(args: Any) -> int:
    """Run the scenario for ``args`` (bench_ik's parsed arguments); prints the table and a
    JSON line like bench_ik's."""
    import json

    import qpsolvers

    dt = 1.0 / args.rate
    cycles = args.warmup + args.steps
    robot = load_robot(args.robot)
    if len(robot.profile.arms) != 2:
        raise SystemExit("--scenario arms-close needs a two-armed robot")
    start = close_start(robot, args.gap, dt)
    kin = Kinematics(robot)
    kin.update(start)
    traj = Trajectory({s: kin.pose(s) for s in kin.arms}, args.radius, args.period, args.wobble)
    targets = make_targets(kin, traj, dt, cycles, args.twist == "secant")
    solvers = [s for s in args.peer_solvers.split(",") if s in qpsolvers.available_solvers]
    makers: list[Callable[[], Runner]] = [
        partial(CollisionImotion, robot, targets, dt, start, rows=True),
        partial(CollisionImotion, robot, targets, dt, start, rows=False),
    ]
    makers += [partial(CollisionPink, robot, targets, dt, s, start) for s in solvers]
    makers += [partial(CollisionMink, robot, targets, dt, s, start) for s in solvers]
    judge = Kinematics(robot)
    pairs = load_collision_pairs(collision_path(robot)).checked
    measure = CollisionDistances(judge.model, robot.model, pairs)
    results: list[Result] = []
    closest: dict[str, float] = {}
    active: list[int] = []
    in_range: list[int] = []
    for make in makers:
        runner = make()
        seen = [np.inf]
        integrate = runner.integrate

        def measured(runner: Any = runner, integrate: Any = integrate, seen: Any = seen) -> None:
            integrate()  # untimed: the smallest checked distance along the run
            measure.compute(runner.q_kin())
            seen[0] = min(seen[0], float(measure.distances.min()))

        runner.integrate = measured  # type: ignore[method-assign]
        result = run(runner, judge, targets, args.warmup, cycles)
        results.append(result)
        closest[result.name] = seen[0]
        if isinstance(runner, CollisionImotion) and runner.rows is not None:
            active = runner.active[args.warmup :]
            in_range = runner.in_range[args.warmup :]
    print_table(robot, kin, args, results)
    ours, bare = results[0], results[1]
    pink_best = fastest([r for r in results if r.name.startswith("pink")])
    mink_best = fastest([r for r in results if r.name.startswith("mink")])
    best = min(pink_best.median_us, mink_best.median_us)
    print(
        f"pairs in range per cycle: median {np.median(in_range):.0f}, max {max(in_range)}; "
        f"rows in the QP (the rest implied by the joint box): median "
        f"{np.median(active):.0f}, max {max(active)}; "
        f"extra cost of the rows: {ours.median_us - bare.median_us:.1f} µs median"
    )
    print(f"ours vs the faster peer: {best / ours.median_us:.2f}x")
    out = {
        "robot": robot.id,
        "clock": args.clock,
        "scenario": "arms-close",
        "ours_us": round(ours.median_us, 1),
        "ours_no_rows_us": round(bare.median_us, 1),
        "rows_extra_us": round(ours.median_us - bare.median_us, 1),
        "rows_active_median": float(np.median(active)),
        "pairs_in_range_median": float(np.median(in_range)),
        "pink_us": round(pink_best.median_us, 1),
        "mink_us": round(mink_best.median_us, 1),
        "speedup_vs_best": round(best / ours.median_us, 2),
        "min_distance_mm": {k: round(v * 1e3, 2) for k, v in closest.items()},
        "runs": {r.name: r.summary() for r in results},
        "failures": {r.name: r.failures for r in results},
    }
    print(json.dumps(out))
    return 0

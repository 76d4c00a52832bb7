#!/usr/bin/env python3
"""Cost of the self-collision distances of one robot (default: SmartPal V).

Usage: python tools/bench_collision.py [--robot smartpal5] [--configs 2000] [--rows 10]

At seeded random configurations within the joint limits it times, per configuration:
``distances`` (coal on every checked shape pair, C++ only), ``update`` (geometry placements,
distances and reading them into numpy: what a control cycle pays), ``jacobian_rows`` (witness
points and Jacobian rows of the ``--rows`` closest pairs, ``jacobian_into`` as the control
cycle calls it), ``jacobian_all``, and ``constraint``: the QP rows of the collision constraint
(``CollisionAvoidance.compute_qp_inequalities`` with the cycle's joint box, the pairs within
the profile's influence distance, Jacobians included). ``update + constraint`` is the
per-cycle extra cost of the rows before the QP (which then has more rows: see
``tools/bench_ik.py --scenario arms-close`` for the whole step). Configurations are drawn near
home (σ = 0.5 rad) so that some pairs are in range. Prints medians and p99 in microseconds,
then one JSON line.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from controller.model.collision import CollisionDistances
from controller.model.collision_pairs import collision_path, load_collision_pairs
from controller.model.kinematics import Kinematics
from controller.model.robot import load_robot
from controller.qp.constraints import CycleState, JointBox, RowBlock
from controller.qp.constraints.collision import collision_avoidance


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="smartpal5")
    parser.add_argument("--configs", type=int, default=2000)
    parser.add_argument("--rows", type=int, default=10, help="rows for jacobian_rows")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    robot = load_robot(args.robot)
    kin = Kinematics(robot)
    pairs = load_collision_pairs(collision_path(robot)).checked
    dist = CollisionDistances(kin.model, robot.model, pairs)
    model = kin.model
    lo = np.where(np.abs(model.lowerPositionLimit) > 100, -1.0, model.lowerPositionLimit)
    hi = np.where(np.abs(model.upperPositionLimit) > 100, 1.0, model.upperPositionLimit)
    rng = np.random.default_rng(args.seed)
    kinds = {"capsule-capsule": 0, "with sphere": 0, "with box": 0}
    # the same geometry with only the pairs without a box (closed-form distances in coal)
    no_box = dist.geometry.copy()
    no_box.removeAllCollisionPairs()
    for cp in dist.geometry.collisionPairs:
        names = {
            type(dist.geometry.geometryObjects[i].geometry).__name__ for i in (cp.first, cp.second)
        }
        key = "with box" if "Box" in names else "with sphere" if "Sphere" in names else None
        kinds[key or "capsule-capsule"] += 1
        if key != "with box":
            no_box.addCollisionPair(pin.CollisionPair(cp.first, cp.second))
    no_box_data = pin.GeometryData(no_box)

    times: dict[str, list[float]] = {
        k: [] for k in ("distances", "update", "rows", "all", "no_box", "constraint")
    }
    rows_used: list[int] = []
    constraint = collision_avoidance(kin, 0.002)
    assert constraint is not None
    box = JointBox(kin, 0.002)
    block = RowBlock(
        np.zeros((constraint.max_rows, model.nv)),
        np.zeros(constraint.max_rows),
        np.zeros(constraint.max_rows),
    )
    out_rows = np.zeros((args.rows, model.nv))
    clock = time.perf_counter
    home = kin.home()
    for _ in range(args.configs):
        q = np.clip(home + rng.normal(0.0, 0.5, model.nv), lo, hi)
        kin.update(q)
        t0 = clock()
        dist.update(kin.data, kin.q)
        t1 = clock()
        pin.computeDistances(dist.geometry, dist.geometry_data)
        t2 = clock()
        closest = np.argsort(dist.distances)[: args.rows]
        dist.jacobian_into(closest, out_rows)
        t3 = clock()
        dist.jacobian()
        t4 = clock()
        pin.updateGeometryPlacements(model, kin.data, no_box, no_box_data)
        t5 = clock()
        pin.computeDistances(no_box, no_box_data)
        t6 = clock()
        times["no_box"].append(t6 - t5)
        v = np.zeros(model.nv)
        lb, ub = box.compute_qp_bounds(q, v)
        constraint.distances.update(kin.data, kin.q)
        cycle = CycleState(kin, q, v, lb, ub)
        t7 = clock()
        rows_used.append(constraint.compute_qp_inequalities(cycle, block))
        t8 = clock()
        times["constraint"].append(t8 - t7)
        times["update"].append(t1 - t0)
        times["distances"].append(t2 - t1)
        times["rows"].append(t3 - t2)
        times["all"].append(t4 - t3)

    def med(key: str) -> float:
        return float(np.median(times[key]) * 1e6)

    def p99(key: str) -> float:
        return float(np.percentile(times[key], 99) * 1e6)

    n = len(dist)
    print(f"robot {robot.id}: {len(pairs)} checked link pairs, {n} shape pairs {kinds}")
    for key, label in (
        ("distances", "coal distances (C++)"),
        ("update", "update (placements + distances + read)"),
        ("rows", f"jacobian, {args.rows} closest rows"),
        ("all", f"jacobian, all {n} rows"),
        ("constraint", f"constraint rows (median {np.median(rows_used):.0f} in range)"),
    ):
        print(f"  {label:42s} median {med(key):8.1f} us   p99 {p99(key):8.1f} us")
    print(f"  per shape pair (coal): {med('distances') / n:.2f} us")
    extra = np.add(times["update"], times["constraint"])
    print(
        f"  per-cycle extra before the QP (update + constraint): median "
        f"{np.median(extra) * 1e6:.1f} us, p99 {np.percentile(extra, 99) * 1e6:.1f} us"
    )
    nb = no_box.collisionPairs.__len__()
    print(f"  coal on the {nb} pairs without a box: median {med('no_box'):.1f} us")
    out = {
        "robot": robot.id,
        "link_pairs": len(pairs),
        "shape_pairs": n,
        "shape_pair_kinds": kinds,
        "configs": args.configs,
        "distances_us": round(med("distances"), 1),
        "update_us": round(med("update"), 1),
        "update_p99_us": round(p99("update"), 1),
        "jacobian_rows": args.rows,
        "jacobian_rows_us": round(med("rows"), 1),
        "jacobian_all_us": round(med("all"), 1),
        "per_shape_pair_us": round(med("distances") / n, 3),
        "constraint_us": round(med("constraint"), 1),
        "constraint_rows_median": float(np.median(rows_used)),
        "per_cycle_extra_us": round(float(np.median(extra)) * 1e6, 1),
        "no_box_pairs": nb,
        "no_box_distances_us": round(med("no_box"), 1),
    }
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Self-collision property run: random commands in closed loop on MuJoCo (issue 10).

Usage: python tools/collision_property.py [--commands 10000] [--robots smartpal5,seednoid,rh,pa10]
       [--seed 0] [--cycles 100]

The commands are split evenly over the robots; see ``tests/collision_support.py`` for what a
command is and what is checked (MuJoCo contacts between robot geoms, the smallest checked
distance against d_s). Prints one line per robot, then one JSON line.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from config import robot_ids
from tests.collision_support import run


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--commands", type=int, default=10_000, help="in total")
    parser.add_argument("--robots", default=",".join(robot_ids()))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cycles", type=int, default=100, help="per command (2 ms each)")
    parser.add_argument("--progress", type=int, default=0, help="print every N commands")
    args = parser.parse_args()
    robots = args.robots.split(",")
    out = []
    for i, robot_id in enumerate(robots):
        n = args.commands // len(robots) + (1 if i < args.commands % len(robots) else 0)
        t0 = time.perf_counter()
        s = run(robot_id, n, args.seed, args.cycles, progress=args.progress)
        wall = time.perf_counter() - t0
        print(
            f"{robot_id:10s} {s.commands} commands, {s.cycles} cycles: min distance "
            f"{s.min_distance * 1e3:.2f} mm (d_s {s.security * 1e3:g} mm), "
            f"{s.below_security} cycles below d_s, {s.contact_cycles} cycles with contacts "
            f"{sorted(s.contacts)}, {s.qp_failures} QP failures ({wall:.0f} s)",
            flush=True,
        )
        out.append(
            {
                "robot": robot_id,
                "commands": s.commands,
                "cycles": s.cycles,
                "min_distance_mm": round(s.min_distance * 1e3, 3),
                "security_mm": s.security * 1e3,
                "below_security_cycles": s.below_security,
                "contact_cycles": s.contact_cycles,
                "contacts": sorted(s.contacts),
                "qp_failures": s.qp_failures,
            }
        )
    print(json.dumps({"seed": args.seed, "cycles_per_command": args.cycles, "robots": out}))
    return (
        0
        if all(
            not r["contact_cycles"] and not r["below_security_cycles"] and not r["qp_failures"]
            for r in out
        )
        else 1
    )


if __name__ == "__main__":
    sys.exit(main())

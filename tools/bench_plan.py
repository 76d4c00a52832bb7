"""CPU time the gateway spends planning a Spec A linear move (reachability check, path
clearance, time-law limits): moveLinearCartesianRel of 100 mm along ±x, ±y, ±z for each
hand from home, through the service in-process (no gRPC, no daemon), measured with
``time.thread_time`` after one warm-up round. Prints one line per move (median [ms] and
the answer) and a final JSON line.

    PYTHONPATH=. python tools/bench_plan.py [--robot smartpal5] [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from controller.errors import Refused
from controller.gateway.services.spec_a import SpecAService
from controller.vocabulary import RightLeft
from tests.motion_support import make_core
from tests.planning_support import context, core_snapshot

SPEED, ACCEL = (50.0, 20.0), (100.0, 40.0)  # mm/s, deg/s; mm/s², deg/s²


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robot", default="smartpal5")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    core = make_core(args.robot, "ideal")
    ctx, reader, _ = context(args.robot)
    reader.snap = core_snapshot(core)
    service = SpecAService(ctx)
    moves: dict[str, tuple[RightLeft, list[float]]] = {}
    for side in (RightLeft.RIGHT, RightLeft.LEFT):
        if side not in ctx.view.kin.arms:
            continue
        for axis in range(3):
            for sign in (1.0, -1.0):
                change = [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0]
                change[4 * axis + 3] = 100.0 * sign
                moves[f"{side.name.lower()}_{'+-'[sign < 0]}{'xyz'[axis]}"] = (side, change)

    def plan(side: RightLeft, change: list[float]) -> str:
        try:
            service.move_linear(side, change, SPEED, ACCEL, False, False, "rel_hg_mat")
        except Refused as exc:
            return f"refused ({exc.comment[:60]}...)"
        return "ok"

    for side, change in moves.values():
        plan(side, change)  # warm-up: compiled kernels, the clearance model
    times: dict[str, list[float]] = {name: [] for name in moves}
    answers: dict[str, str] = {}
    for _ in range(args.rounds):
        for name, (side, change) in moves.items():
            t = time.thread_time()
            answers[name] = plan(side, change)
            times[name].append(time.thread_time() - t)
    for name, values in times.items():
        print(f"{name}: median {1e3 * statistics.median(values):.2f} ms, {answers[name]}")
    every = [v for values in times.values() for v in values]
    print(
        json.dumps(
            {
                "robot": args.robot,
                "moves": len(every),
                "mean_ms": round(1e3 * statistics.fmean(every), 3),
                "median_ms": round(1e3 * statistics.median(every), 3),
                "max_ms": round(1e3 * max(every), 3),
                "refused": sorted(n for n, a in answers.items() if a != "ok"),
            }
        )
    )


if __name__ == "__main__":
    main()

"""How long a refused request takes (issues 16.1, 16.12): round trips of requests the argument
bounds, the reach bound and the longest-motion rule refuse, against getState as a reference.

One daemon (SmartPal V, --hal ideal, realtime off, servo on), gRPC on 127.0.0.1. Prints one
line per request (code, median and max round trip [ms]) and a final JSON line.

    PYTHONPATH=. python tools/bench_refusals.py [--calls 30]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from controller.rpc import imotion_pb2 as pb
from tests.daemon_support import TestDaemon


def hg(x: float = 0.0, z: float = 0.0) -> pb.HgMatrix:
    return pb.HgMatrix(m=[1.0, 0, 0, x, 0, 1.0, 0, 0, 0, 0, 1.0, z])


def cases(d: TestDaemon) -> dict[str, Callable[[], object]]:
    speed = pb.CartesianSpeed(translation=100.0, rotation=30.0)
    accel = pb.CartesianAccel(translation=500.0, rotation=100.0)
    a = d.spec_a
    return {
        "linear_rel_1e12mm": lambda: a.MoveLinearCartesianRel(
            pb.MoveLinearCartesianRelRequest(rel_hg_mat=hg(1e12), speed=speed, accel=accel)
        ),
        "ptp_rel_1e9mm": lambda: a.MovePTPCartesianRel(
            pb.MovePTPCartesianRelRequest(rel_hg_mat=hg(z=1e9), time=2.0)
        ),
        "linear_rel_20000mm_reach": lambda: a.MoveLinearCartesianRel(
            pb.MoveLinearCartesianRelRequest(rel_hg_mat=hg(20_000.0), speed=speed, accel=accel)
        ),
        "ptp_abs_20000mm_reach": lambda: a.MovePTPCartesianAbs(
            pb.MovePTPCartesianAbsRequest(abs_hg_mat=hg(20_000.0), time=2.0)
        ),
        "cp_hold_1e-9_deg_per_s": lambda: a.MoveCPHoldRel(
            pb.MoveCPHoldRelRequest(
                rel_pos=pb.RedundantPos(elbow=5.0),
                speed=pb.RedundantSpeed(elbow=1e-9),
                accel=pb.RedundantAccel(elbow=100.0),
            )
        ),
        "get_state_reference": lambda: a.GetState(pb.GetStateRequest()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--calls", type=int, default=30)
    args = parser.parse_args()
    d = TestDaemon("smartpal5")
    try:
        d.reset()
        d.wait_for(lambda: d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on)
        figures = {}
        for name, call in cases(d).items():
            times = []
            for _ in range(args.calls):
                t = time.perf_counter()
                reply = call()
                times.append(time.perf_counter() - t)
            code = reply.return_id.id  # type: ignore[attr-defined]
            figures[name] = {
                "code": code,
                "median_ms": round(1e3 * statistics.median(times), 3),
                "max_ms": round(1e3 * max(times), 3),
            }
            print(f"{name}: code {code}, median {1e3 * statistics.median(times):.2f} ms, "
                  f"max {1e3 * max(times):.2f} ms", flush=True)  # fmt: skip
        print(json.dumps({"calls": args.calls, "requests": figures}))
    finally:
        d.close()


if __name__ == "__main__":
    main()

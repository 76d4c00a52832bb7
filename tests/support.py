"""Test helpers: loaded robots (cached), fresh kinematics, random configurations, the
benchmark tools run as a user runs them, the compiled kernels' signatures."""

from __future__ import annotations

import functools
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from config import robot_ids
from controller.model import jit
from controller.model.kinematics import Kinematics
from controller.model.obstacles import Obstacle
from controller.model.robot import Robot, load_robot

ROBOT_IDS = robot_ids()
#: The robots with collision shapes.
SHAPED_ROBOTS = ["smartpal5", "pa10", "seednoid"]
#: One static obstacle of each kind near the arms (table and mast tilted: no axis-aligned
#: luck; the table and the robot's boxes: coal's pairs).
OBSTACLES = [
    Obstacle(name="table", type="box", pos=(0.6, 0, 0.7), rpy=(0.1, 0.2, 0.3),
             half_extents=(0.3, 0.4, 0.02)),
    Obstacle(name="wall", type="plane", pos=(1.0, 0, 0), rpy=(0, -1.5708, 0)),
    Obstacle(name="mast", type="capsule", pos=(0.4, 0.5, 1.0), rpy=(0.3, 0, 0), radius=0.05,
             length=0.8),
    Obstacle(name="ball", type="sphere", pos=(0.5, -0.4, 1.0), radius=0.1),
]  # fmt: skip
#: Range [m] / [rad] drawn for unbounded vehicle axes in random configurations.
VEHICLE_SPAN = 5.0


@functools.cache
def robot(robot_id: str) -> Robot:
    return load_robot(robot_id)


def kinematics(robot_id: str) -> Kinematics:
    """A fresh Kinematics (tests change offsets and frames, so none is shared)."""
    return Kinematics(robot(robot_id))


def random_configuration(kin: Kinematics, rng: np.random.Generator) -> np.ndarray:
    """A configuration uniformly inside the joint limits (vehicle within ±VEHICLE_SPAN)."""
    q = np.empty(kin.nv)
    for name in kin.joint_names:
        spec = kin.robot.joints[name]
        lo = max(spec.lower, -VEHICLE_SPAN)
        hi = min(spec.upper, VEHICLE_SPAN)
        q[kin.index(name)] = rng.uniform(lo, hi)
    return q


ROOT = Path(__file__).resolve().parents[1]


def run_tool(name: str, *args: str) -> tuple[list[str], Any]:
    """``python tools/<name> args`` from the project root: its output lines and the JSON
    object of its last line (every benchmark ends with one). A tool that fails fails the
    test with the end of its output (what it said before it exited)."""
    done = subprocess.run(
        [sys.executable, str(ROOT / "tools" / name), *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    if done.returncode != 0:
        raise AssertionError(
            f"tools/{name} {' '.join(args)} exited {done.returncode}:\n"
            f"{done.stdout[-3000:]}\n--- stderr ---\n{done.stderr[-3000:]}"
        )
    lines = done.stdout.strip().splitlines()
    return lines, json.loads(lines[-1])


def count_solves(monkeypatch: Any) -> list[int]:
    """Counts the position-level IK solves (``PositionIK.solve``; a retry without the elbow
    counts as one) from now on, through ``monkeypatch``: ``[count]``."""
    from controller.motion.position_ik import PositionIK

    count = [0]
    solve = PositionIK.solve

    def counted(self: Any, *args: Any, **kwargs: Any) -> Any:
        count[0] += 1
        return solve(self, *args, **kwargs)

    monkeypatch.setattr(PositionIK, "solve", counted)
    return count


def kernel_signatures() -> dict[str, int]:
    """How many signatures every compiled kernel loaded so far has (by qualified name):
    equal before and after control cycles when none compiled in them."""
    return {name: len(kernel.signatures) for name, kernel in jit.loaded_kernels().items()}


def kernels_gained(before: dict[str, int]) -> dict[str, list[int]]:
    """The kernels that gained a signature since ``before`` (a :func:`kernel_signatures`),
    with their counts then and now (0 then: not loaded yet)."""
    return {name: [before.get(name, 0), n] for name, n in kernel_signatures().items()
            if n != before.get(name, 0)}  # fmt: skip

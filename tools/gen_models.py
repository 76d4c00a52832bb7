#!/usr/bin/env python3
"""Regenerate robot.urdf, collision.yaml and robot.xml of every shipped robot from model.yaml +
profile.yaml.

collision.yaml (the checked self-collision pairs) comes from sampling the joint space of the
generated URDF with a fixed seed (docs/collision.md); robot.xml has the collision geoms but no
contact pairs (they halve the simulation's speed; contact tests add them in memory).

Usage: python tools/gen_models.py [--check] [ROBOT_ID ...]
With --check nothing is written; the exit status is 1 when a committed file is stale.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from config import robot_ids
from controller.model.collision_pairs import classify_pairs, collision_path, render, rest_poses
from controller.model.model_export import export_mjcf, export_urdf
from controller.model.robot import Robot, load_robot
from controller.model.yaml_source import ConfigError


def generated_files(robot_id: str) -> dict[Path, str]:
    """The text each generated file of ``robot_id`` should have."""
    robot = load_robot(robot_id)
    urdf = export_urdf(robot.model, robot.profile)
    model = pin.buildModelFromXML(urdf)
    pairs = classify_pairs(robot.model, model, sampled_limits(robot), rest=rest_poses(robot))
    return {
        robot.urdf_path: urdf,
        collision_path(robot): render(pairs),
        # No contact pairs in the shipped MJCF: they halve MuJoCo's speed (measured on
        # tests/test_motions.py); contact tests export them in memory (issue 10).
        robot.mjcf_path: export_mjcf(robot.model, robot.profile),
    }


def sampled_limits(robot: Robot) -> dict[str, tuple[float, float]]:
    """Joint ranges [rad or m] the pair sampling draws from (unbounded axes stay at 0)."""
    return {name: (spec.lower, spec.upper) for name, spec in robot.joints.items()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("robots", nargs="*", help="robot ids (default: all shipped)")
    parser.add_argument("--check", action="store_true", help="only report stale files")
    args = parser.parse_args()
    stale = 0
    for rid in args.robots or robot_ids():
        for path, text in generated_files(rid).items():
            current = path.read_text(encoding="utf-8") if path.exists() else None
            if current == text:
                continue
            stale += 1
            if args.check:
                print(f"stale: {path}")
            else:
                path.write_text(text, encoding="utf-8")
                print(f"wrote {path}")
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except ConfigError as exc:  # a broken or unknown robot: say which and why
        print(exc, file=sys.stderr)
        sys.exit(2)

"""controller.model.collision_pairs: the committed collision.yaml of every shipped robot."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from config import robot_ids
from controller.model.collision import CollisionDistances
from controller.model.collision_pairs import (
    DEFAULT_MARGIN,
    DEFAULT_SAMPLES,
    DEFAULT_SEED,
    CollisionPairs,
    classify_pairs,
    collision_path,
    load_collision_pairs,
    render,
    rest_poses,
)
from controller.model.collision_shapes import collision_shapes
from controller.model.model_source import ModelSource
from controller.model.robot import Robot, load_robot
from controller.model.yaml_source import ConfigError

ROBOTS = robot_ids()
REGENERATE = "run `make models` to regenerate it"


@cache
def robot(robot_id: str) -> Robot:
    return load_robot(robot_id)


@cache
def committed(robot_id: str) -> CollisionPairs:
    return load_collision_pairs(collision_path(robot(robot_id)))


def limits(r: Robot) -> dict[str, tuple[float, float]]:
    return {n: (s.lower, s.upper) for n, s in r.joints.items()}


# ------------------------------------------------------------------------------- staleness
@pytest.mark.parametrize("robot_id", ROBOTS)
def test_committed_collision_yaml_is_up_to_date(robot_id: str) -> None:
    """Regenerate with the fixed seed and sample count and compare the text."""
    r = robot(robot_id)
    model = pin.buildModelFromUrdf(str(r.urdf_path))
    fresh = render(classify_pairs(r.model, model, limits(r), rest=rest_poses(r)))
    path = collision_path(r)
    assert path.read_text(encoding="utf-8") == fresh, f"{path} is stale: {REGENERATE}"


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_committed_file_uses_the_defaults(robot_id: str) -> None:
    pairs = committed(robot_id)
    assert (pairs.samples, pairs.seed, pairs.margin) == (
        DEFAULT_SAMPLES,
        DEFAULT_SEED,
        DEFAULT_MARGIN,
    )
    assert pairs.robot == robot_id


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_every_pair_of_shaped_links_is_listed_once(robot_id: str) -> None:
    pairs = committed(robot_id)
    shaped = {s.link for s in collision_shapes(robot(robot_id).model)}
    listed = [frozenset(p) for p in pairs.checked] + [frozenset(a[:2]) for a in pairs.allowed]
    assert len(listed) == len(set(listed))
    n = len(shaped)
    assert len(listed) == n * (n - 1) // 2
    assert all(p <= shaped and len(p) == 2 for p in listed)


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_adjacent_links_are_allowed_and_checked_pairs_can_meet(robot_id: str) -> None:
    r = robot(robot_id)
    pairs = committed(robot_id)
    allowed = {(a, b): why for a, b, why in pairs.allowed}
    parent = {j.child: j.parent for j in r.model.joints}
    shaped = {s.link for s in collision_shapes(r.model)}
    for link in shaped:
        p = parent.get(link)
        while p is not None and p not in shaped:
            p = parent.get(p)
        if p is not None:
            assert allowed.get((p, link)) == "adjacent", (p, link)
    assert pairs.checked  # every shipped robot has something to check


def test_smartpal_checks_hand_against_hand_and_forearm_against_torso() -> None:
    checked = set(committed("smartpal5").checked)
    assert ("r_flange", "l_flange") in checked
    assert ("lumbar_upper_link", "r_arm_link5") in checked
    assert ("lumbar_upper_link", "l_arm_link5") in checked


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_never_pairs_stay_apart_on_fresh_samples(robot_id: str) -> None:
    """Pairs ruled out by sampling stay beyond 0 on other seeded samples (a spot check)."""
    r = robot(robot_id)
    model = pin.buildModelFromUrdf(str(r.urdf_path))
    never = [(a, b) for a, b, why in committed(robot_id).allowed if why == "never"]
    dist = CollisionDistances(model, r.model, never)
    rng = np.random.default_rng(12345)
    lo = np.array([max(model.lowerPositionLimit[i], -np.pi) for i in range(model.nq)])
    hi = np.array([min(model.upperPositionLimit[i], np.pi) for i in range(model.nq)])
    lo[np.abs(lo) > 100] = 0.0  # vehicle axes
    hi[np.abs(hi) > 100] = 0.0
    for _ in range(300):
        dist.compute(rng.uniform(lo, hi))
        assert dist.distances.min() > 0.0


# ------------------------------------------------------------------------------ classifying
def two_arm_model() -> ModelSource:
    """A torso with two one-joint arms that can swing into each other, and a fixed cap."""
    return ModelSource.model_validate(
        {
            "robot": "toy",
            "root": "torso",
            "link_radius": 0.05,
            "links": {
                "torso": {"radius": 0, "geoms": [{"type": "sphere", "size": [0.1]}]},
                "cap": {"radius": 0, "geoms": [{"type": "sphere", "size": [0.05]}]},
                "far": {"radius": 0, "geoms": [{"type": "sphere", "size": [0.05]}]},
            },
            "joints": [
                {
                    "name": "cap_joint",
                    "type": "fixed",
                    "parent": "torso",
                    "child": "cap",
                    "xyz": [0, 0, 0.5],
                },
                {
                    "name": "far_joint",
                    "type": "fixed",
                    "parent": "torso",
                    "child": "far",
                    "xyz": [0, 0, -2],
                },
                {
                    "name": "r",
                    "type": "revolute",
                    "parent": "torso",
                    "child": "r_arm",
                    "xyz": [0, -0.3, 0],
                    "axis": [0, 0, 1],
                },
                {
                    "name": "r_tip",
                    "type": "fixed",
                    "parent": "r_arm",
                    "child": "r_end",
                    "xyz": [0.4, 0, 0],
                },
                {
                    "name": "l",
                    "type": "revolute",
                    "parent": "torso",
                    "child": "l_arm",
                    "xyz": [0, 0.3, 0],
                    "axis": [0, 0, 1],
                },
                {
                    "name": "l_tip",
                    "type": "fixed",
                    "parent": "l_arm",
                    "child": "l_end",
                    "xyz": [0.4, 0, 0],
                },
            ],
        }
    )


def toy_pin_model(source: ModelSource) -> pin.Model:
    from controller.model.model_export import export_urdf
    from controller.model.profile import RobotProfile

    profile = RobotProfile.model_construct(joints={})
    return pin.buildModelFromXML(export_urdf(source, profile))


def test_classify_sorts_adjacent_rigid_never_and_checked() -> None:
    source = two_arm_model()
    model = toy_pin_model(source)
    pairs = classify_pairs(source, model, {"r": (-3.0, 3.0), "l": (-3.0, 3.0)}, samples=500)
    allowed = {(a, b): why for a, b, why in pairs.allowed}
    assert allowed[("torso", "r_arm")] == "adjacent"
    assert allowed[("torso", "cap")] == "adjacent"
    assert allowed[("cap", "far")] == "rigid"
    assert allowed[("far", "r_arm")] == "never"
    assert ("r_arm", "l_arm") in pairs.checked


def test_render_round_trips(tmp_path: Path) -> None:
    pairs = CollisionPairs(
        robot="x",
        samples=3,
        seed=1,
        margin=0.05,
        checked=(("a", "b"),),
        allowed=(("a", "c", "never"),),
    )
    path = tmp_path / "collision.yaml"
    path.write_text(render(pairs), encoding="utf-8")
    assert load_collision_pairs(path) == pairs


def test_bad_reason_is_rejected(tmp_path: Path) -> None:
    path = tmp_path / "collision.yaml"
    path.write_text(
        "robot: x\nsamples: 1\nseed: 0\nmargin: 0.05\nchecked: []\nallowed:\n  - [a, b, maybe]\n",
        encoding="utf-8",
    )
    with pytest.raises(ConfigError, match="allowed"):
        load_collision_pairs(path)


def test_pairs_in_collision_at_a_rest_pose_are_allowed_as_default() -> None:
    source = two_arm_model()
    model = toy_pin_model(source)
    crossed = {"r": np.pi / 2, "l": -np.pi / 2}  # both arms point at each other
    pairs = classify_pairs(
        source, model, {"r": (-3.0, 3.0), "l": (-3.0, 3.0)}, samples=200, rest=[crossed]
    )
    allowed = {(a, b): why for a, b, why in pairs.allowed}
    assert allowed[("r_arm", "l_arm")] == "default"

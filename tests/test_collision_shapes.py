"""controller.model.collision_shapes and the ``collision`` schema of model.yaml."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from config import robot_ids
from controller.model.collision_shapes import (
    align_z,
    collision_shapes,
    link_collision_shapes,
)
from controller.model.model_source import CollisionGeom, Link, ModelSource
from controller.model.robot import load_robot

ROBOTS = robot_ids()


def tiny_model(**link: object) -> ModelSource:
    return ModelSource.model_validate(
        {
            "robot": "tiny",
            "root": "base",
            "link_radius": 0.05,
            "links": {"a": link} if link else {},
            "joints": [
                {
                    "name": "j1",
                    "type": "revolute",
                    "parent": "base",
                    "child": "a",
                    "axis": [0, 0, 1],
                },
                {
                    "name": "j2",
                    "type": "revolute",
                    "parent": "a",
                    "child": "b",
                    "xyz": [0, 0, 0.3],
                    "axis": [0, 1, 0],
                },
                {"name": "j3", "type": "revolute", "parent": "a", "child": "c", "axis": [1, 0, 0]},
            ],
        }
    )


# -------------------------------------------------------------------------------- schema
@pytest.mark.parametrize(
    ("data", "word"),
    [
        ({"type": "capsule", "size": [0.05]}, "fromto"),
        ({"type": "capsule", "size": [0.05], "fromto": [0, 0, 0, 0, 0, 0]}, "differ"),
        ({"type": "sphere", "size": [0.05], "fromto": [0, 0, 0, 0, 0, 1]}, "pos"),
        ({"type": "box", "size": [0.05]}, "3 size"),
        ({"type": "sphere", "size": [0.0]}, "greater than 0"),
        ({"type": "sphere", "size": [-0.1]}, "greater than 0"),
        ({"type": "sphere", "size": [math.nan]}, "finite"),
        ({"type": "sphere", "size": [0.1], "pos": [0, math.inf, 0]}, "finite"),
        ({"type": "cylinder", "size": [0.1], "fromto": [0, 0, 0, 0, 0, 1]}, "capsule"),
        ({"type": "sphere", "size": [0.1], "color": "arm"}, "extra"),
    ],
)
def test_bad_collision_geom_is_rejected(data: dict[str, object], word: str) -> None:
    with pytest.raises(ValidationError, match=word):
        CollisionGeom.model_validate(data)


def test_link_collision_defaults_to_derived() -> None:
    assert Link().collision is None


# ------------------------------------------------------------------------------ deriving
def test_derived_capsules_follow_the_radius_segments() -> None:
    shapes = link_collision_shapes(tiny_model(), "a")
    assert [s.type for s in shapes] == ["capsule"]  # the zero-length segment to c is skipped
    (s,) = shapes
    assert s.radius == 0.05 and s.length == pytest.approx(0.3)
    np.testing.assert_allclose(s.pos, [0, 0, 0.15])


def test_derived_cylinder_becomes_a_capsule_and_boxes_spheres_stay() -> None:
    model = tiny_model(
        radius=0,
        geoms=[
            {"type": "cylinder", "size": [0.1], "fromto": [0, 0, 0, 0, 0, 0.2]},
            {"type": "box", "size": [0.1, 0.2, 0.3], "pos": [1, 2, 3]},
            {"type": "sphere", "size": [0.07], "pos": [0, 0, 1]},
        ],
    )
    shapes = link_collision_shapes(model, "a")
    assert [(s.type, s.size) for s in shapes] == [
        ("capsule", (0.1,)),
        ("box", (0.1, 0.2, 0.3)),
        ("sphere", (0.07,)),
    ]
    assert shapes[1].radius == 0.0 and shapes[1].length == 0.0


def test_authored_collision_list_replaces_the_derived_one() -> None:
    model = tiny_model(collision=[{"type": "sphere", "size": [0.2], "pos": [0, 0, 0.1]}])
    (s,) = link_collision_shapes(model, "a")
    assert s.type == "sphere" and s.radius == 0.2


def test_empty_collision_list_means_no_shapes() -> None:
    assert link_collision_shapes(tiny_model(collision=[]), "a") == []


def test_align_z_is_a_rotation_onto_the_direction() -> None:
    rng = np.random.default_rng(1)
    for _ in range(50):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        r = align_z(d)
        np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(r[:, 2], d, atol=1e-12)
        assert np.linalg.det(r) == pytest.approx(1.0)


# ------------------------------------------------------------------------ shipped robots
@pytest.mark.parametrize("robot_id", ROBOTS)
def test_every_arm_link_and_gripper_has_collision_shapes(robot_id: str) -> None:
    robot = load_robot(robot_id)
    with_shapes = {s.link for s in collision_shapes(robot.model)}
    for arm in robot.profile.arms.values():
        assert arm.flange in with_shapes, arm.flange
    for gripper in robot.profile.grippers.values():
        for joint in gripper.joints:
            assert robot.model.joint(joint).child in with_shapes, joint


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_shipped_shapes_are_capsules_spheres_or_boxes(robot_id: str) -> None:
    for s in collision_shapes(load_robot(robot_id).model):
        assert s.type in ("capsule", "sphere", "box")
        assert all(v > 0 and math.isfinite(v) for v in s.size)

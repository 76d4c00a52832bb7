"""controller.model.obstacles: the obstacle schema, and obstacles as extra geometry in
CollisionDistances (analytic distances, pairs, finite-difference Jacobian rows)."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pinocchio as pin
import pytest
from pydantic import ValidationError

from config import robot_ids
from controller.model.collision import CollisionDistances
from controller.model.collision_pairs import collision_path, load_collision_pairs
from controller.model.kinematics import Kinematics
from controller.model.obstacles import Obstacle, is_obstacle
from controller.model.robot import load_robot

STEP = 1e-6
FD_TOL = 1e-6


@cache
def kinematics(robot_id: str) -> Kinematics:
    return Kinematics(load_robot(robot_id))


def with_obstacles(robot_id: str, obstacles: list[Obstacle], pairs: bool = True):
    k = kinematics(robot_id)
    checked = load_collision_pairs(collision_path(k.robot)).checked if pairs else []
    return CollisionDistances(
        k.model, k.robot.model, checked, 1e-12, obstacles=obstacles, origin=k.original_frame
    )


def obstacle_rows(dist: CollisionDistances, name: str) -> dict[str, list[int]]:
    rows: dict[str, list[int]] = {}
    for i, (link, other) in enumerate(dist.pair_links):
        if other == f"obstacle:{name}":
            rows.setdefault(link, []).append(i)
    return rows


# ---------------------------------------------------------------------------------- schema
def test_each_type_needs_its_sizes_and_takes_no_others() -> None:
    Obstacle(name="t", type="box", half_extents=(0.1, 0.2, 0.3))
    Obstacle(name="s", type="sphere", radius=0.1)
    Obstacle(name="c", type="capsule", radius=0.1, length=0.5)
    Obstacle(name="floor", type="plane")
    with pytest.raises(ValidationError, match="a box needs half_extents"):
        Obstacle(name="t", type="box", radius=0.1)
    with pytest.raises(ValidationError, match="a capsule needs length"):
        Obstacle(name="c", type="capsule", radius=0.1)
    with pytest.raises(ValidationError, match="a plane takes no radius"):
        Obstacle(name="p", type="plane", radius=0.1)


@pytest.mark.parametrize(
    "bad",
    [
        {"half_extents": (0.1, 0.0, 0.3)},
        {"half_extents": (0.1, -0.2, 0.3)},
        {"half_extents": (0.1, math.inf, 0.3)},
        {"pos": (0.0, math.nan, 0.0)},
        {"rpy": (math.inf, 0.0, 0.0)},
        {"name": "a/b"},
        {"name": ""},
        {"colour": "red"},
    ],
)
def test_bad_values_are_refused(bad: dict) -> None:
    args = {"name": "t", "type": "box", "half_extents": (0.1, 0.2, 0.3), **bad}
    with pytest.raises(ValidationError):
        Obstacle(**args)


def test_placement_is_rpy_in_radians() -> None:
    wall = Obstacle(name="wall", type="plane", pos=(1.0, 0.0, 0.0), rpy=(0.0, -math.pi / 2, 0))
    np.testing.assert_allclose(wall.placement().rotation[:, 2], [-1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(wall.placement().translation, [1, 0, 0])
    assert wall.label == "obstacle:wall" and is_obstacle(wall.label)


# ------------------------------------------------------------------------------- distances
def test_floor_plane_distance_is_the_lowest_point_height() -> None:
    """SmartPal V at zero: the base box's underside is 0.04 m above the ground; the original
    frame is the waist origin 0.4365 m above it."""
    floor = Obstacle(name="floor", type="plane", pos=(0.0, 0.0, -0.4365))
    dist = with_obstacles("smartpal5", [floor], pairs=False)
    dist.compute(np.zeros(dist.model.nq))
    rows = obstacle_rows(dist, "floor")
    assert dist.distances[rows["base_link"]].min() == pytest.approx(0.04, abs=1e-9)
    # the vehicle moving or turning keeps the base's height above the floor
    q = np.zeros(dist.model.nq)
    q[:3] = (1.5, -2.0, 0.7)
    dist.compute(q)
    assert dist.distances[rows["base_link"]].min() == pytest.approx(0.04, abs=1e-9)


def test_sphere_obstacle_distance_to_the_hanging_forearm() -> None:
    """A ball beside SmartPal V's right forearm (hanging at x 0, y -0.2 from the shoulder
    down, radius 0.045): the gap is the centre's distance to the axis minus both radii."""
    shoulder = (-0.025, -0.2, 0.21 + 0.48)  # lumbar_upper 0.21 above the origin, + the joint
    ball_at = (shoulder[0], -0.4, shoulder[2] - 0.4)
    ball = Obstacle(name="ball", type="sphere", radius=0.05, pos=ball_at)
    dist = with_obstacles("smartpal5", [ball], pairs=False)
    dist.compute(np.zeros(dist.model.nq))
    forearm = obstacle_rows(dist, "ball")["r_arm_link5"]
    assert dist.distances[forearm].min() == pytest.approx(0.2 - 0.05 - 0.045, abs=1e-9)
    _, _, n = dist.witness(forearm[0])
    np.testing.assert_allclose(n, [0, 1, 0], atol=1e-9)  # from the ball towards the arm


def test_obstacles_pair_with_every_moving_link_after_the_link_pairs() -> None:
    table = Obstacle(name="table", type="box", half_extents=(0.3, 0.5, 0.02), pos=(0.8, 0, -0.2))
    plain = with_obstacles("smartpal5", [])
    dist = with_obstacles("smartpal5", [table])
    assert dist.pair_links[: len(plain)] == plain.pair_links
    links = set(obstacle_rows(dist, "table"))
    assert "base_link" in links  # the vehicle moves it
    assert {"r_flange", "l_thumb", "lumbar_upper_link"} <= links
    # a fixed-base robot's base never moves: no pair
    pa10 = with_obstacles("pa10", [table])
    assert "base_link" not in obstacle_rows(pa10, "table")
    assert "flange" in obstacle_rows(pa10, "table")


def test_two_obstacles_with_one_name_are_refused() -> None:
    ball = Obstacle(name="x", type="sphere", radius=0.1)
    with pytest.raises(ValueError, match="two obstacles are named 'x'"):
        with_obstacles("pa10", [ball, ball])


@pytest.mark.parametrize("robot_id", robot_ids())
def test_obstacle_rows_match_central_differences(robot_id: str) -> None:
    """World-fixed shapes ride joint 0: their side of the row is zero, and the rows still
    equal the differenced distances (vehicle axes included)."""
    obstacles = [
        Obstacle(name="table", type="box", half_extents=(0.3, 0.4, 0.02), pos=(0.5, 0.1, -0.3)),
        Obstacle(name="pole", type="capsule", radius=0.05, length=1.0, pos=(0.3, -0.4, 0.2)),
        Obstacle(name="ball", type="sphere", radius=0.1, pos=(0.4, 0.3, 0.3)),
        Obstacle(name="wall", type="plane", pos=(1.2, 0, 0), rpy=(0, -math.pi / 2, 0)),
    ]
    dist = with_obstacles(robot_id, obstacles, pairs=False)
    model = dist.model
    lo = np.where(np.abs(model.lowerPositionLimit) > 100, -1.0, model.lowerPositionLimit)
    hi = np.where(np.abs(model.upperPositionLimit) > 100, 1.0, model.upperPositionLimit)
    rng = np.random.default_rng(7)
    compared = 0
    for _ in range(4):
        q = rng.uniform(lo, hi)
        dist.compute(q)
        separated = dist.distances > 1e-3
        jac = dist.jacobian()
        fd = np.zeros_like(jac)
        for i in range(model.nv):
            step = np.zeros(model.nv)
            step[i] = STEP
            dist.compute(q + step)
            plus = dist.distances.copy()
            dist.compute(q - step)
            fd[:, i] = (plus - dist.distances) / (2 * STEP)
        np.testing.assert_allclose(jac[separated], fd[separated], atol=FD_TOL, rtol=0)
        compared += int(separated.sum())
    assert compared > 0


def test_origin_places_obstacles_in_the_original_frame() -> None:
    """The same ball given in the original frame (waist origin) and in the world with the
    original frame's offset added is the same distance away."""
    k = kinematics("smartpal5")
    ball = Obstacle(name="ball", type="sphere", radius=0.05, pos=(0.5, 0.0, 0.0))
    z = k.original_frame.translation[2]
    in_world = Obstacle(name="ball", type="sphere", radius=0.05, pos=(0.5, 0.0, z))
    a = with_obstacles("smartpal5", [ball], pairs=False)
    b = CollisionDistances(k.model, k.robot.model, [], obstacles=[in_world])
    q = np.zeros(k.model.nq)
    a.compute(q)
    b.compute(q)
    np.testing.assert_allclose(a.distances, b.distances, atol=1e-12)
    assert isinstance(k.original_frame, pin.SE3)

"""controller.model.collision_kernel: compiled placements, distances and rows against coal."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from controller.model import collision_kernel as ck
from controller.model import jit, joint_chain
from controller.model.collision import CollisionDistances
from controller.model.collision_pairs import robot_distances
from controller.model.kinematics import Kinematics
from controller.model.obstacles import Obstacle
from tests.support import OBSTACLES, SHAPED_ROBOTS, kinematics

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba not installed")

ROBOTS = SHAPED_ROBOTS


def both(kin: Kinematics, monkeypatch: pytest.MonkeyPatch) -> tuple[CollisionDistances, ...]:
    """The robot's distances with the obstacles: compiled, and coal alone (tight GJK)."""
    compiled = robot_distances(kin, OBSTACLES)
    monkeypatch.setenv("IMOTION_JIT", "0")
    coal_only = robot_distances(kin, OBSTACLES)
    monkeypatch.delenv("IMOTION_JIT")
    for request in coal_only.geometry_data.distanceRequests:
        request.gjk_tolerance = 1e-12
    assert compiled.compiled and not coal_only.compiled
    return compiled, coal_only


def configurations(kin: Kinematics, count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.uniform(-1.5, 1.5, kin.nv) for _ in range(count)]


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_placements_are_pinocchios(robot_id: str) -> None:
    """Joint placements, Jacobian columns and shape placements equal Pinocchio's."""
    kin = kinematics(robot_id)
    dist = robot_distances(kin, OBSTACLES)
    kernel = dist.kernel
    assert kernel is not None
    data = kin.model.createData()
    for q in configurations(kin, 20, seed=1):
        dist.compute(q)
        pin.computeJointJacobians(kin.model, data, q)
        pin.updateGeometryPlacements(kin.model, data, dist.geometry, dist.geometry_data)
        for j in range(1, kin.model.njoints):
            np.testing.assert_allclose(kernel.joint_world[j, :3], data.oMi[j].rotation, atol=1e-12)
            np.testing.assert_allclose(
                kernel.joint_world[j, 3], data.oMi[j].translation, atol=1e-12
            )
        jac = data.J
        for v in range(kin.nv):
            axis, origin = kernel.columns[v]
            if kernel.column_kind[v] == joint_chain.REVOLUTE:  # (v_O, w) = (origin x axis, axis)
                np.testing.assert_allclose(jac[3:, v], axis, atol=1e-12)
                np.testing.assert_allclose(jac[:3, v], np.cross(origin, axis), atol=1e-12)
            else:
                np.testing.assert_allclose(jac[:3, v], axis, atol=1e-12)
        for g, placement in enumerate(dist.geometry_data.oMg):
            np.testing.assert_allclose(kernel.shape_world[g, :3], placement.rotation, atol=1e-12)
            np.testing.assert_allclose(kernel.shape_world[g, 3], placement.translation, atol=1e-12)


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_distances_witnesses_and_rows_equal_coals(
    robot_id: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every pair kind (capsule, sphere, box, half-space): separated pairs to 1e-9 m with
    the same witness points and rows; overlapping ones overlap for both."""
    kin = kinematics(robot_id)
    compiled, coal_only = both(kin, monkeypatch)
    kinds = compiled.kernel.kinds[compiled.kernel.pairs[:, :2]]  # type: ignore[union-attr]
    assert {ck.BOX, ck.HALFSPACE} <= set(kinds.ravel().tolist())
    overlaps = compared = matched = 0
    same: list[int] = []
    for q in configurations(kin, 60, seed=2):
        kin.update(q)
        compiled.update(kin.data, q)
        coal_only.update(kin.data, q)
        a, b = compiled.distances, coal_only.distances
        np.testing.assert_array_equal(a > 0, b > 0)
        apart = np.flatnonzero(b > 1e-4)
        np.testing.assert_allclose(a[apart], b[apart], atol=1e-9, rtol=0)
        overlaps += int(np.count_nonzero(b < 0))
        # p1 − p2 = d n, |n| = 1, for every pair
        gap = compiled.points1 - compiled.points2
        np.testing.assert_allclose(gap, a[:, None] * compiled.normals, atol=1e-9)
        np.testing.assert_allclose(np.linalg.norm(compiled.normals, axis=1), 1.0, atol=1e-12)
        # Witness points where they are unique (not a capsule lying parallel to a face or
        # to another capsule: then both are right): coal's, and the same rows.
        for k in apart:
            mine, theirs = compiled.witness(k), coal_only.witness(k)
            compared += 1
            if max(float(np.abs(x - y).max()) for x, y in zip(mine, theirs, strict=True)) < 1e-6:
                same.append(int(k))
        np.testing.assert_allclose(compiled.jacobian(same), coal_only.jacobian(same), atol=1e-6)
        matched += len(same)
        same.clear()
    assert overlaps > 0  # random poses do overlap (the table): the sign was checked there
    assert matched >= 0.9 * compared  # witnesses are unique almost everywhere


def test_box_box_pairs_are_left_to_coal(monkeypatch: pytest.MonkeyPatch) -> None:
    """The vehicle's box against a box obstacle: coal computes that pair, in the same update."""
    kin = kinematics("smartpal5")
    crate = Obstacle(name="crate", type="box", pos=(0.9, 0.1, 0.2), rpy=(0, 0, 0.4),
                     half_extents=(0.2, 0.2, 0.2))  # fmt: skip
    compiled = robot_distances(kin, [crate])
    monkeypatch.setenv("IMOTION_JIT", "0")
    coal_only = robot_distances(kin, [crate])
    kernel = compiled.kernel
    assert kernel is not None and len(kernel.other) == 1
    k = int(kernel.other[0])
    assert compiled.pair_links[k] == ("base_link", "obstacle:crate")
    for x in (0.0, 0.3, 0.45):  # drive towards it: 0.3 m apart, 0.05 m apart, overlapping
        q = kin.home()
        q[kin.index("vehicle_x")] = x
        kin.update(q)
        compiled.update(kin.data, q)
        coal_only.update(kin.data, q)
        np.testing.assert_allclose(compiled.distances, coal_only.distances, atol=1e-6)
        for mine, theirs in zip(compiled.witness(k), coal_only.witness(k), strict=True):
            np.testing.assert_allclose(mine, theirs, atol=1e-6)


def test_padding_reaches_the_kernel() -> None:
    kin = kinematics("smartpal5")
    dist = robot_distances(kin)
    q = kin.home()
    dist.compute(q)
    before = dist.distances.copy()
    hand = [i for i, (a, b) in enumerate(dist.pair_links) if "r_flange" in (a, b)]
    assert hand
    dist.set_padding(["r_flange"], 0.02)
    dist.compute(q)
    np.testing.assert_allclose(dist.distances[hand], before[hand] - 0.02, atol=1e-12)


def segment_box_brute_force(a: np.ndarray, b: np.ndarray, h: np.ndarray) -> float:
    """The least signed distance to the box along the segment, sampled: every 1/2000 of it,
    then every 1e-6 of it between the neighbours of the least sample. The signed distance
    to a convex set is convex, so along the segment its minimum lies there (was 200 001
    samples everywhere, 5e-6 apart: 9-16 s for the 300 segments of the test below)."""

    def sampled(t: np.ndarray) -> np.ndarray:
        q = np.abs(a + t[:, None] * (b - a)) - h
        return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)

    coarse = np.linspace(0.0, 1.0, 2001)
    k = int(np.argmin(sampled(coarse)))
    lo, hi = coarse[max(k - 1, 0)], coarse[min(k + 1, coarse.size - 1)]
    return float(sampled(np.linspace(lo, hi, 1001)).min())


def test_segment_box_minimum_is_exact() -> None:
    """Outside (the exact piecewise minimum) and through the box (the deepest point)."""
    rng = np.random.default_rng(5)
    h = np.array([0.3, 0.2, 0.1])
    scratch = np.zeros(8)
    inside = 0
    for _ in range(300):
        a, b = rng.uniform(-0.6, 0.6, 3), rng.uniform(-0.6, 0.6, 3)
        e = b - a
        t = ck._segment_box_t(a[0], a[1], a[2], e[0], e[1], e[2], h, scratch)
        x = a + t * e
        got = ck._box_signed(x[0], x[1], x[2], h[0], h[1], h[2])
        want = segment_box_brute_force(a, b, h)
        assert got <= want + 1e-9  # never above the sampled minimum ...
        assert got >= want - 1e-5  # ... and the sampling's resolution below it at most
        inside += got < 0
    assert inside > 10


def test_turned_off_by_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("IMOTION_JIT", "0")
    assert not jit.available()
    assert not robot_distances(kinematics("pa10")).compiled


def test_unsupported_joints_fall_back_to_coal() -> None:
    """A model with a spherical joint (3 dofs): coal computes its pairs."""
    model = pin.Model()
    ball = model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    model.appendBodyToJoint(ball, pin.Inertia.Random(), pin.SE3.Identity())
    geometry = pin.GeometryModel()
    geometry.addGeometryObject(
        pin.GeometryObject("a/0", 0, 0, pin.SE3.Identity(), coal.Sphere(0.1))
    )
    with pytest.raises(ck.Unsupported):
        ck.CompiledPairs(model, geometry, np.zeros((0, 2), dtype=np.int64))

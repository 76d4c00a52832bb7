"""controller.model.collision: coal geometry, distances, witness points, distance Jacobians."""

from __future__ import annotations

from functools import cache

import numpy as np
import pinocchio as pin
import pytest

from config import robot_ids
from controller.model.collision import CollisionDistances, geometry_model, hand_links, link_of
from controller.model.collision_pairs import collision_path, load_collision_pairs
from controller.model.collision_shapes import collision_shapes
from controller.model.kinematics import Kinematics
from controller.model.model_export import export_urdf
from controller.model.model_source import ModelSource
from controller.model.profile import RobotProfile
from controller.model.robot import load_robot

#: Every test with the compiled kernels and with coal alone.
pytestmark = pytest.mark.usefixtures("jit_backend")

ROBOTS = robot_ids()
#: Central-difference step [rad or m] and the agreement asked of the analytic rows: with a
#: GJK tolerance of 1e-12 m the distances are smooth to ~1e-12, so the difference quotient's
#: error is O(h^2) plus 1e-12/h, far below 1e-6.
STEP = 1e-6
FD_TOL = 1e-6


@cache
def kinematics(robot_id: str) -> Kinematics:
    return Kinematics(load_robot(robot_id))


def distances(robot_id: str, gjk_tolerance: float | None = 1e-12) -> CollisionDistances:
    r = load_robot(robot_id)
    pairs = load_collision_pairs(collision_path(r)).checked
    return CollisionDistances(kinematics(robot_id).model, r.model, pairs, gjk_tolerance)


def random_configurations(model: pin.Model, count: int, seed: int) -> list[np.ndarray]:
    lo = np.where(np.abs(model.lowerPositionLimit) > 100, -1.0, model.lowerPositionLimit)
    hi = np.where(np.abs(model.upperPositionLimit) > 100, 1.0, model.upperPositionLimit)
    rng = np.random.default_rng(seed)
    return [rng.uniform(lo, hi) for _ in range(count)]


def toy(gap: float) -> tuple[pin.Model, ModelSource]:
    """Two spheres (r 0.1) on a slider along x, centres ``0.2 + gap`` apart at q = 0."""
    source = ModelSource.model_validate(
        {
            "robot": "toy",
            "root": "base",
            "links": {
                "base": {"radius": 0, "geoms": [{"type": "sphere", "size": [0.1]}]},
                "slider": {"radius": 0, "geoms": [{"type": "sphere", "size": [0.1]}]},
            },
            "joints": [
                {
                    "name": "x",
                    "type": "prismatic",
                    "parent": "base",
                    "child": "slider",
                    "xyz": [0.2 + gap, 0, 0],
                    "axis": [1, 0, 0],
                }
            ],
        }
    )
    model = pin.buildModelFromXML(export_urdf(source, RobotProfile.model_construct(joints={})))
    return model, source


# -------------------------------------------------------------------------------- geometry
@pytest.mark.parametrize("robot_id", ROBOTS)
def test_geometry_model_has_one_object_per_shape_at_its_place(robot_id: str) -> None:
    k = kinematics(robot_id)
    shapes = collision_shapes(k.robot.model)
    gm = geometry_model(k.model, k.robot.model)
    assert gm.ngeoms == len(shapes)
    gd = pin.GeometryData(gm)
    q = random_configurations(k.model, 1, seed=5)[0]
    data = k.model.createData()
    pin.framesForwardKinematics(k.model, data, q)
    pin.updateGeometryPlacements(k.model, data, gm, gd)
    for obj, placement, s in zip(gm.geometryObjects, gd.oMg, shapes, strict=True):
        assert link_of(obj.name) == s.link
        frame = data.oMf[k.model.getFrameId(s.link, pin.BODY)]
        np.testing.assert_allclose(placement.translation, frame.act(s.pos), atol=1e-12)


# ------------------------------------------------------------------------------- distances
def test_two_spheres_distance_witness_points_and_normal() -> None:
    model, source = toy(gap=0.3)
    dist = CollisionDistances(model, source, [("base", "slider")])
    dist.compute(np.array([0.1]))
    assert len(dist) == 1
    assert dist.distances[0] == pytest.approx(0.4, abs=1e-12)
    p1, p2, n = dist.witness(0)
    np.testing.assert_allclose(p1, [0.1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(p2, [0.5, 0, 0], atol=1e-12)
    np.testing.assert_allclose(n, [-1, 0, 0], atol=1e-12)  # from shape 2 towards shape 1
    # the slider moving away at 1 m/s opens the gap at 1 m/s; the base is world-fixed
    np.testing.assert_allclose(dist.jacobian(), [[1.0]], atol=1e-12)


def test_overlapping_shapes_have_negative_distance() -> None:
    model, source = toy(gap=0.0)
    dist = CollisionDistances(model, source, [("base", "slider")])
    dist.compute(np.array([-0.05]))
    assert dist.distances[0] == pytest.approx(-0.05, abs=1e-9)
    np.testing.assert_allclose(dist.jacobian(), [[1.0]], atol=1e-9)
    assert dist.closest() == 0


def test_no_pairs_is_fine() -> None:
    model, source = toy(gap=0.3)
    dist = CollisionDistances(model, source, [])
    dist.compute(np.zeros(1))
    assert len(dist) == 0 and dist.closest() == -1
    assert dist.jacobian().shape == (0, 1)


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_update_from_kinematics_equals_compute(robot_id: str) -> None:
    k = kinematics(robot_id)
    dist = distances(robot_id)
    q = random_configurations(k.model, 1, seed=11)[0]
    dist.compute(q)
    own, own_jac = dist.distances.copy(), dist.jacobian()
    k.update(q)
    dist.update(k.data, k.q)
    np.testing.assert_allclose(dist.distances, own, atol=1e-12)
    np.testing.assert_allclose(dist.jacobian(), own_jac, atol=1e-12)
    rows = [0, len(dist) - 1]
    np.testing.assert_allclose(dist.jacobian(rows), own_jac[rows], atol=1e-12)


def test_compiled_distances_need_no_pinocchio_data() -> None:
    """The compiled kernels place the shapes from q: update(None, q) gives the distances and
    rows update(data, q) gives; without them (or for box-box pairs) data is required."""
    dist = distances("smartpal5")
    if not dist.compiled:
        with pytest.raises(ValueError, match="needs Pinocchio's data"):
            dist.update(None, np.zeros(dist.model.nv))
        return
    assert not dist.needs_data
    k = kinematics("smartpal5")
    q = random_configurations(k.model, 1, seed=12)[0]
    k.update(q)
    dist.update(k.data, k.q)
    with_data, rows = dist.distances.copy(), dist.jacobian()
    dist.update(None, k.q)
    np.testing.assert_array_equal(dist.distances, with_data)
    np.testing.assert_array_equal(dist.jacobian(), rows)


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_distances_on_the_kinematics_placements_equal_their_own(robot_id: str) -> None:
    """update(..., chain=kin.placed_chain()) reads the kinematics' joint placements: the
    same distances, witnesses and rows to the last bit; a chain of another model is refused."""
    k = kinematics(robot_id)
    dist = distances(robot_id)
    chain = k.placed_chain()
    if not dist.compiled or chain is None:
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    data = k.data if dist.needs_data else None
    for q in random_configurations(k.model, 5, seed=21):
        k.update(q)
        dist.update(data and k.data, k.q)
        own = dist.distances.copy(), dist.witnesses.copy(), dist.jacobian()
        dist.update(data and k.data, k.q, k.placed_chain())
        np.testing.assert_array_equal(dist.distances, own[0])
        np.testing.assert_array_equal(dist.witnesses, own[1])
        np.testing.assert_array_equal(dist.jacobian(), own[2])
    other = next(r for r in ROBOTS if r != robot_id)
    stranger = kinematics(other).placed_chain()
    assert stranger is not None
    with pytest.raises(ValueError, match="not of this model"):
        dist.update(data and k.data, k.q, stranger)


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_every_checked_pair_has_rows(robot_id: str) -> None:
    dist = distances(robot_id)
    checked = load_collision_pairs(collision_path(load_robot(robot_id))).checked
    assert set(dist.pair_links) == set(checked)


# ------------------------------------------------------------------- finite differences
@pytest.mark.parametrize("robot_id", ROBOTS)
def test_distances_and_jacobian_rows_match_central_differences(robot_id: str) -> None:
    """d(q ± h e_i) differenced against n^T (J_p1 - J_p2) e_i, for separated pairs (d > 1 mm)
    at 8 seeded configurations within the joint limits."""
    k = kinematics(robot_id)
    dist = distances(robot_id)
    nv = k.model.nv
    checked = 0
    for q in random_configurations(k.model, 8, seed=2024):
        dist.compute(q)
        separated = dist.distances > 1e-3
        jac = dist.jacobian()
        fd = np.zeros_like(jac)
        for i in range(nv):
            step = np.zeros(nv)
            step[i] = STEP
            dist.compute(q + step)
            plus = dist.distances.copy()
            dist.compute(q - step)
            fd[:, i] = (plus - dist.distances) / (2 * STEP)
        np.testing.assert_allclose(jac[separated], fd[separated], atol=FD_TOL, rtol=0)
        checked += int(separated.sum())
    assert checked > 0


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_default_gjk_tolerance_gives_the_same_distances_to_a_micrometre(robot_id: str) -> None:
    k = kinematics(robot_id)
    tight, default = distances(robot_id), distances(robot_id, gjk_tolerance=None)
    for q in random_configurations(k.model, 5, seed=8):
        tight.compute(q)
        default.compute(q)
        np.testing.assert_allclose(default.distances, tight.distances, atol=1e-5)


# ---------------------------------------------------------------------------------- padding
def test_padding_shrinks_the_hand_rows_by_its_radius_and_keeps_the_jacobian() -> None:
    k = kinematics("smartpal5")
    dist = distances("smartpal5")
    hand = hand_links(k.robot.model, "r_flange")
    assert hand == ["r_flange", "r_thumb"]
    q = random_configurations(k.model, 1, seed=3)[0]
    dist.compute(q)
    before, jac = dist.distances.copy(), dist.jacobian()
    dist.set_padding(hand, 0.03)
    dist.compute(q)
    rows = np.array([a in hand or b in hand for a, b in dist.pair_links])
    both = np.array([a in hand and b in hand for a, b in dist.pair_links])
    expected = np.where(rows, 0.03, 0.0) * (1 + both)
    np.testing.assert_allclose(before - dist.distances, expected, atol=1e-9)
    separated = dist.distances > 1e-3
    np.testing.assert_allclose(dist.jacobian()[separated], jac[separated], atol=1e-9)
    dist.set_padding(hand, 0.0)
    dist.compute(q)
    np.testing.assert_allclose(dist.distances, before, atol=1e-12)
    assert dist.padding == {"r_flange": 0.0, "r_thumb": 0.0}


def test_padding_refuses_bad_values_and_unknown_links() -> None:
    dist = distances("pa10")
    with pytest.raises(ValueError, match="finite and >= 0"):
        dist.set_padding(["flange"], -0.01)
    with pytest.raises(ValueError, match="finite and >= 0"):
        dist.set_padding(["flange"], float("nan"))
    with pytest.raises(ValueError, match="not a link with collision shapes"):
        dist.set_padding(["nowhere"], 0.01)


def test_the_documented_distances_example_runs() -> None:
    """docs/collision.md's Python example under "## Distances" (both back ends)."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "collision.md").read_text()
    code = text[text.index("## Distances") :].split("```python\n", 1)[1].split("```", 1)[0]
    scope: dict[str, object] = {}
    exec(compile(code, "docs/collision.md", "exec"), scope)
    assert isinstance(scope["dist"], CollisionDistances)
    rows = scope["rows"]
    assert isinstance(rows, np.ndarray) and rows.shape[1] == kinematics("smartpal5").nv

"""controller.model.model_export: the generated robot.urdf / robot.xml of every shipped robot."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from functools import cache

import mujoco
import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given
from hypothesis import strategies as st

from config import robot_ids
from controller.model.collision_pairs import collision_path, load_collision_pairs, rest_poses
from controller.model.collision_shapes import collision_shapes
from controller.model.model_export import UNBOUNDED, export_mjcf, export_urdf, num, nums
from controller.model.robot import Robot, load_robot

ROBOTS = robot_ids()
REGENERATE = "run `make models` to regenerate it from model.yaml + profile.yaml"


@cache
def robot(robot_id: str) -> Robot:
    return load_robot(robot_id)


@cache
def mj_model(robot_id: str) -> mujoco.MjModel:
    r = robot(robot_id)
    return mujoco.MjModel.from_xml_string(export_mjcf(r.model, r.profile))


@cache
def pin_model(robot_id: str) -> pin.Model:
    return pin.buildModelFromUrdf(str(robot(robot_id).urdf_path))


def moving_joints(robot_id: str) -> list[str]:
    return [j.name for j in robot(robot_id).model.joints if j.type != "fixed"]


def bounded_joints(robot_id: str) -> list[str]:
    return [n for n, s in robot(robot_id).joints.items() if math.isfinite(s.lower)]


def unbounded_joints(robot_id: str) -> list[str]:
    return [n for n, s in robot(robot_id).joints.items() if not math.isfinite(s.lower)]


def test_every_shipped_robot_is_covered() -> None:
    assert ROBOTS == ["pa10", "rh", "seednoid", "smartpal5"]


# ------------------------------------------------------------------ stale generated files
@pytest.mark.parametrize("robot_id", ROBOTS)
def test_committed_urdf_is_up_to_date(robot_id: str) -> None:
    r = robot(robot_id)
    committed = r.urdf_path.read_text(encoding="utf-8")
    assert committed == export_urdf(r.model, r.profile), f"{r.urdf_path} is stale: {REGENERATE}"


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_committed_mjcf_is_up_to_date(robot_id: str) -> None:
    r = robot(robot_id)
    committed = r.mjcf_path.read_text(encoding="utf-8")
    expected = export_mjcf(r.model, r.profile)  # no contact pairs (tools/gen_models.py)
    assert committed == expected, f"{r.mjcf_path} is stale: {REGENERATE}"


# ---------------------------------------------------------------------------------- num
@given(st.floats(allow_nan=False, allow_infinity=False))
def test_num_round_trips_finite_floats(value: float) -> None:
    assert float(num(value)) == value


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_num_round_trips_numpy_floats(value: float) -> None:
    assert float(num(np.float64(value))) == value


@pytest.mark.parametrize(("value", "text"), [(0.0, "0"), (-0.0, "0"), (1.0, "1.0"), (0.1, "0.1")])
def test_num_text(value: float, text: str) -> None:
    assert num(value) == text


def test_nums_joins_with_spaces() -> None:
    assert nums((0.0, 0.5, -2.0)) == "0 0.5 -2.0"


# ------------------------------------------------------------------------------- parsing
@pytest.mark.parametrize("robot_id", ROBOTS)
def test_urdf_parses_with_pinocchio(robot_id: str) -> None:
    model = pin_model(robot_id)
    # Pinocchio's URDF parser orders sibling branches its own way: compare as sets.
    assert sorted(model.names[1:]) == sorted(moving_joints(robot_id))
    assert model.nq == len(moving_joints(robot_id))


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_mjcf_parses_with_mujoco(robot_id: str) -> None:
    model = mj_model(robot_id)
    assert [model.joint(i).name for i in range(model.njnt)] == moving_joints(robot_id)
    links = robot(robot_id).model.link_names
    assert [model.body(i).name for i in range(1, model.nbody)] == links


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_committed_mjcf_parses_with_mujoco(robot_id: str) -> None:
    model = mujoco.MjModel.from_xml_path(str(robot(robot_id).mjcf_path))
    assert model.njnt == len(moving_joints(robot_id))


# -------------------------------------------------------------------------------- limits
@pytest.mark.parametrize("robot_id", ROBOTS)
def test_mjcf_ranges_equal_profile_limits_in_si(robot_id: str) -> None:
    model = mj_model(robot_id)
    specs = robot(robot_id).joints
    for name in bounded_joints(robot_id):
        jid = model.joint(name).id
        assert model.jnt_limited[jid] == 1, name
        assert tuple(model.jnt_range[jid]) == (specs[name].lower, specs[name].upper), name


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_mjcf_revolute_range_is_radians_of_profile_degrees(robot_id: str) -> None:
    r = robot(robot_id)
    model = mj_model(robot_id)
    for name in bounded_joints(robot_id):
        lim = r.profile.joints[name]
        assert lim.lower is not None and lim.upper is not None
        scale = math.radians(1.0) if r.model.joint(name).type == "revolute" else 1.0
        lower, upper = model.jnt_range[model.joint(name).id]
        assert lower == pytest.approx(lim.lower * scale, rel=1e-15, abs=0), name
        assert upper == pytest.approx(lim.upper * scale, rel=1e-15, abs=0), name


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_urdf_limits_equal_profile_limits_in_si(robot_id: str) -> None:
    model = pin_model(robot_id)
    specs = robot(robot_id).joints
    for name in bounded_joints(robot_id):
        idx = model.idx_qs[model.getJointId(name)]
        assert model.lowerPositionLimit[idx] == specs[name].lower, name
        assert model.upperPositionLimit[idx] == specs[name].upper, name
        assert model.velocityLimit[idx] == specs[name].velocity, name


def test_some_robots_have_unbounded_vehicle_joints() -> None:
    with_vehicle = [rid for rid in ROBOTS if unbounded_joints(rid)]
    assert with_vehicle == ["rh", "seednoid", "smartpal5"]
    for rid in with_vehicle:
        assert unbounded_joints(rid) == ["vehicle_x", "vehicle_y", "vehicle_theta"]


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_mjcf_unbounded_vehicle_joints_have_no_range(robot_id: str) -> None:
    model = mj_model(robot_id)
    root = ET.fromstring(robot(robot_id).mjcf_path.read_text(encoding="utf-8"))
    elements = {e.get("name"): e for e in root.iter("joint")}
    for name in unbounded_joints(robot_id):
        assert model.jnt_limited[model.joint(name).id] == 0, name
        assert "range" not in elements[name].attrib, name


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_urdf_unbounded_vehicle_joints_have_plus_minus_1e4(robot_id: str) -> None:
    root = ET.fromstring(robot(robot_id).urdf_path.read_text(encoding="utf-8"))
    limits = {e.get("name"): e.find("limit") for e in root.iter("joint")}
    model = pin_model(robot_id)
    assert UNBOUNDED == 1e4
    for name in unbounded_joints(robot_id):
        limit = limits[name]
        assert limit is not None, name
        assert float(limit.get("lower", "nan")) == -1e4, name
        assert float(limit.get("upper", "nan")) == 1e4, name
        idx = model.idx_qs[model.getJointId(name)]
        assert model.lowerPositionLimit[idx] == -1e4, name
        assert model.upperPositionLimit[idx] == 1e4, name


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_urdf_and_mjcf_agree_on_joint_axes(robot_id: str) -> None:
    mj = mj_model(robot_id)
    root = ET.fromstring(robot(robot_id).urdf_path.read_text(encoding="utf-8"))
    urdf_axes = {
        e.get("name"): e.find("axis") for e in root.iter("joint") if e.find("axis") is not None
    }
    for name in moving_joints(robot_id):
        axis_el = urdf_axes[name]
        assert axis_el is not None
        urdf_axis = [float(v) for v in axis_el.get("xyz", "").split()]
        np.testing.assert_allclose(mj.jnt_axis[mj.joint(name).id], urdf_axis, atol=1e-15)
        assert np.linalg.norm(urdf_axis) == pytest.approx(1.0, abs=1e-15)


# ----------------------------------------------------------------------------- collision
def collision_names(robot_id: str) -> list[str]:
    counts: dict[str, int] = {}
    names = []
    for s in collision_shapes(robot(robot_id).model):
        i = counts.get(s.link, 0)
        counts[s.link] = i + 1
        names.append(f"{s.link}/{i}")
    return names


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_urdf_collision_elements_parse_with_pinocchio(robot_id: str) -> None:
    path = str(robot(robot_id).urdf_path)
    model = pin.buildModelFromUrdf(path)
    geometry = pin.buildGeomFromUrdf(model, path, pin.GeometryType.COLLISION)
    shapes = collision_shapes(robot(robot_id).model)
    # a capsule is written as a cylinder and two end spheres
    assert geometry.ngeoms == sum(3 if s.type == "capsule" else 1 for s in shapes)


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_mjcf_collision_geoms_are_hidden_and_collide_only_in_pairs(robot_id: str) -> None:
    model = mujoco.MjModel.from_xml_path(str(robot(robot_id).mjcf_path))
    names = collision_names(robot_id)
    assert names
    for name in names:
        g = model.geom(name)
        assert int(g.group[0]) == 3, name
        assert int(g.contype[0]) == 0 and int(g.conaffinity[0]) == 0, name
    for i in range(model.ngeom):  # every other geom still collides with nothing
        assert model.geom_contype[i] == 0 and model.geom_conaffinity[i] == 0


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_mjcf_collision_geoms_sit_where_the_shapes_are(robot_id: str) -> None:
    """At a random pose, each MuJoCo collision geom's centre is the shape's centre."""

    r = robot(robot_id)
    model = mj_model(robot_id)
    data = mujoco.MjData(model)
    pm = pin_model(robot_id)
    pdata = pm.createData()
    rng = np.random.default_rng(7)
    q = pin.neutral(pm)
    for name in moving_joints(robot_id):
        value = float(rng.uniform(-1.0, 1.0))
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = value
        q[pm.idx_qs[pm.getJointId(name)]] = value
    mujoco.mj_kinematics(model, data)
    pin.framesForwardKinematics(pm, pdata, q)
    for name, s in zip(collision_names(robot_id), collision_shapes(r.model), strict=True):
        frame = pdata.oMf[pm.getFrameId(s.link, pin.BODY)]
        np.testing.assert_allclose(data.geom(name).xpos, frame.act(s.pos), atol=1e-9)


def _model_with_pairs(robot_id: str) -> mujoco.MjModel:
    """The robot's MJCF with its checked pairs as contact pairs (the contact tests' model;
    the shipped robot.xml leaves them out: they halve the simulation's speed)."""
    r = robot(robot_id)
    checked = load_collision_pairs(collision_path(r)).checked
    return mujoco.MjModel.from_xml_string(export_mjcf(r.model, r.profile, checked))


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_mjcf_contact_pairs_are_the_checked_pairs(robot_id: str) -> None:
    model = _model_with_pairs(robot_id)
    checked = set(load_collision_pairs(collision_path(robot(robot_id))).checked)
    assert checked
    seen = set()
    for i in range(model.npair):
        a = model.geom(model.pair_geom1[i]).name.rsplit("/", 1)[0]
        b = model.geom(model.pair_geom2[i]).name.rsplit("/", 1)[0]
        seen.add((a, b))
    assert seen == checked
    shipped = mujoco.MjModel.from_xml_path(str(robot(robot_id).mjcf_path))
    assert shipped.npair == 0  # the shipped model simulates without collision pairs


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_mujoco_reports_no_robot_contact_at_the_rest_poses(robot_id: str) -> None:
    """The checked pairs leave the simulated robot free where it starts (home, grippers
    open or closed)."""
    r = robot(robot_id)
    model = _model_with_pairs(robot_id)
    data = mujoco.MjData(model)
    for pose in rest_poses(r):
        data.qpos[:] = 0.0
        for name, value in pose.items():
            data.qpos[model.jnt_qposadr[model.joint(name).id]] = value
        mujoco.mj_forward(model, data)
        assert data.ncon == 0, [
            (model.geom(c.geom1).name, model.geom(c.geom2).name) for c in data.contact[: data.ncon]
        ]

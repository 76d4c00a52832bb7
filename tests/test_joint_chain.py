"""controller.model.joint_chain: compiled joint placements and Jacobian columns."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from controller.model import jit
from controller.model.joint_chain import PRISMATIC, REVOLUTE, JointChain, Unsupported
from tests.support import ROBOT_IDS, kinematics, random_configuration

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba not installed")


@pytest.mark.parametrize("robot_id", ROBOT_IDS)
def test_placements_and_columns_are_pinocchios(robot_id: str) -> None:
    """Every joint's world placement and Jacobian column (revolute and prismatic: the
    vehicle's x and y) equal Pinocchio's at random configurations."""
    kin = kinematics(robot_id)
    chain = JointChain(kin.model)
    data = kin.model.createData()
    rng = np.random.default_rng(3)
    kinds = set()
    for _ in range(20):
        q = random_configuration(kin, rng)
        chain.forward(q)
        pin.computeJointJacobians(kin.model, data, q)
        for j in range(1, kin.model.njoints):
            placement = data.oMi[j]
            np.testing.assert_allclose(chain.joint_world[j, :3], placement.rotation, atol=1e-12)
            np.testing.assert_allclose(chain.joint_world[j, 3], placement.translation, atol=1e-12)
        for v in range(kin.nv):
            axis, origin = chain.columns[v]
            kind = int(chain.column_kind[v])
            kinds.add(kind)
            if kind == REVOLUTE:  # (v_O, w) = (origin x axis, axis)
                np.testing.assert_allclose(data.J[3:, v], axis, atol=1e-12)
                np.testing.assert_allclose(data.J[:3, v], np.cross(origin, axis), atol=1e-12)
            else:
                np.testing.assert_allclose(data.J[:3, v], axis, atol=1e-12)
                np.testing.assert_allclose(data.J[3:, v], 0.0, atol=1e-12)
    assert REVOLUTE in kinds
    if kin.has_vehicle:
        assert PRISMATIC in kinds


def test_a_joint_of_more_than_one_dof_is_refused() -> None:
    model = pin.Model()
    model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    with pytest.raises(Unsupported, match="ball"):
        JointChain(model)


@pytest.mark.parametrize("robot_id", ROBOT_IDS)
def test_a_frames_placement_and_jacobian_are_pinocchios(robot_id: str) -> None:
    """frame_world: every frame's world placement and LOCAL_WORLD_ALIGNED Jacobian (vehicle
    columns included) equal Pinocchio's at random configurations."""
    from controller.model.joint_chain import frame_world

    kin = kinematics(robot_id)
    model = kin.model
    chain = JointChain(model)
    data = model.createData()
    rng = np.random.default_rng(9)
    for _ in range(5):
        q = random_configuration(kin, rng)
        chain.forward(q)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for fid in range(1, len(model.frames)):
            frame = model.frames[fid]
            joint = frame.parentJoint
            local = np.zeros((4, 3))
            local[:3], local[3] = frame.placement.rotation, frame.placement.translation
            support = np.array(
                [model.joints[j].idx_v for j in model.supports[joint] if j > 0], dtype=np.int64
            )
            jac, placement = np.zeros((6, kin.nv)), np.zeros((4, 3))
            frame_world(
                chain.joint_world, chain.columns, chain.column_kind, joint, local, support,
                jac, placement,
            )  # fmt: skip
            ref = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(jac, ref, atol=1e-12)
            np.testing.assert_allclose(placement[:3], data.oMf[fid].rotation, atol=1e-12)
            np.testing.assert_allclose(placement[3], data.oMf[fid].translation, atol=1e-12)

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

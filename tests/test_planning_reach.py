"""controller.gateway.planning.reach: reach and speed bounds from the kinematic chain."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from controller.gateway.planning.reach import out_of_reach, reach, speed_limit
from controller.model.redundant_axes import RedundantAxis
from controller.vocabulary import RightLeft
from tests.support import kinematics

RIGHT = RightLeft.RIGHT


def random_configurations(kin, n: int, seed: int = 1):  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(seed)
    specs = [kin.robot.joints[name] for name in kin.joint_names]
    lo = np.clip([s.lower for s in specs], -2.0, 2.0)  # the vehicle's are unbounded
    hi = np.clip([s.upper for s in specs], -2.0, 2.0)
    for _ in range(n):
        yield rng.uniform(lo, hi)


@pytest.mark.parametrize("robot", ["smartpal5", "pa10", "seednoid", "rh"])
@pytest.mark.parametrize("with_lumbar", [False, True])
def test_the_control_point_never_leaves_the_reach_sphere(robot: str, with_lumbar: bool) -> None:
    kin = kinematics(robot)
    kin.update(kin.home())
    radius, anchor = reach(kin, RIGHT, with_lumbar)
    moving = set(kin.robot.unit_joints("RIGHT_ARM"))
    if with_lumbar:
        moving |= set(kin.robot.unit_joints("LUMBER"))
    home = kin.home()
    index = [kin.index(n) for n in moving]
    for q in random_configurations(kin, 200):
        mixed = home.copy()
        mixed[index] = q[index]
        kin.update(mixed)
        assert np.linalg.norm(kin.pose(RIGHT).translation - anchor) <= radius + 1e-9


@pytest.mark.parametrize("robot", ["smartpal5", "pa10"])
def test_the_speed_bound_covers_every_joint_velocity_at_its_limit(robot: str) -> None:
    kin = kinematics(robot)
    arm = [kin.index(n) for n in kin.robot.unit_joints("RIGHT_ARM")]
    v_max = np.array([kin.robot.joints[n].velocity for n in kin.robot.unit_joints("RIGHT_ARM")])
    rng = np.random.default_rng(2)
    for q in random_configurations(kin, 100):
        kin.update(q)
        t_max, r_max = speed_limit(kin, RIGHT)
        jac = kin.jacobian(RIGHT)[:, arm]
        qd = v_max * rng.choice([-1.0, 1.0], size=len(arm))
        twist = jac @ qd
        assert np.linalg.norm(twist[:3]) <= t_max + 1e-9
        assert np.linalg.norm(twist[3:]) <= r_max + 1e-9


def test_far_targets_are_out_of_reach_unless_the_vehicle_may_bring_the_arm() -> None:
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    here = kin.pose(RIGHT)
    near = pin.SE3(here.rotation, here.translation + np.array([0.1, 0.0, 0.0]))
    far = pin.SE3(here.rotation, here.translation + np.array([5.0, 0.0, 0.0]))
    workspace = kin.robot.profile.vehicle.workspace.si()  # type: ignore[union-attr]
    assert out_of_reach(kin, RIGHT, near, {}, workspace) is None
    reason = out_of_reach(kin, RIGHT, far, {}, workspace)
    assert reason is not None and "beyond its reach" in reason
    vehicle = {RedundantAxis.VEHICLE_X: True, RedundantAxis.VEHICLE_Y: True}
    assert out_of_reach(kin, RIGHT, far, vehicle, workspace) is None
    beyond = pin.SE3(here.rotation, here.translation + np.array([50.0, 0.0, 0.0]))
    assert out_of_reach(kin, RIGHT, beyond, vehicle, workspace) is not None

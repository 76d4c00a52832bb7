"""Pinocchio (robot.urdf) and MuJoCo (robot.xml) describe the same kinematics."""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin

from tests.support import VEHICLE_SPAN, robot

CONFIGURATIONS = 1000
TOL = 1e-9  # [m] and [rad]


def test_forward_kinematics_agree_on_random_configurations(robot_id: str) -> None:
    r = robot(robot_id)
    pm = pin.buildModelFromUrdf(str(r.urdf_path))
    pd = pm.createData()
    mm = mujoco.MjModel.from_xml_path(str(r.mjcf_path))
    md = mujoco.MjData(mm)
    assert pm.nq == mm.nq == len(r.profile.joints)

    qpos_adr = [int(mm.joint(pm.names[j]).qposadr[0]) for j in range(1, pm.njoints)]
    lower = np.maximum(pm.lowerPositionLimit, -VEHICLE_SPAN)
    upper = np.minimum(pm.upperPositionLimit, VEHICLE_SPAN)
    frames = [pm.getFrameId(mm.body(b).name, pin.BODY) for b in range(1, mm.nbody)]
    assert len(frames) == len(r.model.link_names)

    rng = np.random.default_rng(20261121)
    worst_p = worst_r = 0.0
    for _ in range(CONFIGURATIONS):
        q = rng.uniform(lower, upper)
        pin.framesForwardKinematics(pm, pd, q)
        md.qpos[qpos_adr] = q
        mujoco.mj_kinematics(mm, md)
        for b, fid in enumerate(frames, start=1):
            pose = pd.oMf[fid]
            worst_p = max(worst_p, float(np.abs(pose.translation - md.xpos[b]).max()))
            dr = pose.rotation @ md.xmat[b].reshape(3, 3).T
            worst_r = max(worst_r, float(np.linalg.norm(pin.log3(dr))))
    assert worst_p <= TOL, f"link origins differ by {worst_p:.3g} m"
    assert worst_r <= TOL, f"link orientations differ by {worst_r:.3g} rad"


def test_every_mujoco_joint_is_a_pinocchio_joint_with_the_same_axis(robot_id: str) -> None:
    r = robot(robot_id)
    pm = pin.buildModelFromUrdf(str(r.urdf_path))
    mm = mujoco.MjModel.from_xml_path(str(r.mjcf_path))
    names = {mm.joint(j).name for j in range(mm.njnt)}
    assert names == set(pm.names[1:])

"""controller.model.kinematics: poses, Jacobians, self-motion, frames, offsets, public geometry."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from controller.model.kinematics import Kinematics
from controller.vocabulary import FrameType, LumbarAxis, RightLeft, UnitType
from tests.support import kinematics, random_configuration

#: Every test with the compiled elbow kernel and with the Python/Pinocchio code.
pytestmark = pytest.mark.usefixtures("jit_backend")

FD_STEP = 1e-6
FD_TOL = 1e-6
SAMPLES = 25


def pose_difference(a: pin.SE3, b: pin.SE3) -> tuple[float, float]:
    """Translation [m] and rotation [rad] distance between two poses."""
    return (
        float(np.linalg.norm(a.translation - b.translation)),
        float(np.linalg.norm(pin.log3(a.rotation @ b.rotation.T))),
    )


def numeric_pose_jacobian(kin: Kinematics, q: np.ndarray, side: RightLeft, frame: FrameType):
    jac = np.zeros((6, kin.nv))
    for i in range(kin.nv):
        dq = np.zeros(kin.nv)
        dq[i] = FD_STEP
        kin.update(q + dq)
        plus = kin.pose(side, frame)
        kin.update(q - dq)
        minus = kin.pose(side, frame)
        jac[:3, i] = (plus.translation - minus.translation) / (2 * FD_STEP)
        jac[3:, i] = pin.log3(plus.rotation @ minus.rotation.T) / (2 * FD_STEP)
    kin.update(q)
    return jac


def numeric_gradient(kin: Kinematics, q: np.ndarray, f, circular: bool = False) -> np.ndarray:
    """Central differences of ``f`` over every joint; ``circular`` wraps differences to ±π."""
    rows = []
    for i in range(kin.nv):
        dq = np.zeros(kin.nv)
        dq[i] = FD_STEP
        kin.update(q + dq)
        plus = np.atleast_1d(f())
        kin.update(q - dq)
        minus = np.atleast_1d(f())
        diff = np.angle(np.exp(1j * (plus - minus))) if circular else plus - minus
        rows.append(diff / (2 * FD_STEP))
    kin.update(q)
    return np.array(rows).T


@pytest.mark.parametrize("frame", list(FrameType))
def test_control_point_jacobian_matches_finite_differences(robot_id: str, frame: FrameType):
    kin = kinematics(robot_id)
    rng = np.random.default_rng(1)
    for _ in range(SAMPLES):
        q = random_configuration(kin, rng)
        kin.update(q)
        for side in kin.arms:
            jac = kin.jacobian(side, frame)
            assert jac.shape == (6, kin.nv)
            err = np.abs(jac - numeric_pose_jacobian(kin, q, side, frame)).max()
            assert err <= FD_TOL, f"{side.name} {frame.name}: {err:.3g}"


def test_elbow_jacobian_matches_finite_differences(robot_id: str):
    kin = kinematics(robot_id)
    sides = [s for s in kin.arms if kin.has_elbow(s)]
    if not sides:
        pytest.skip(f"{robot_id} has no 7-axis arm")
    rng = np.random.default_rng(2)
    checked = 0
    while checked < SAMPLES:
        q = random_configuration(kin, rng)
        kin.update(q)
        for side in sides:
            if kin.elbow_offset(side) < 0.02:  # nearly stretched: angle barely defined
                continue
            jac = kin.elbow_jacobian(side)
            num = numeric_gradient(kin, q, lambda s=side: kin.elbow_angle(s), circular=True)[0]
            assert np.abs(jac - num).max() <= FD_TOL
            checked += 1


def test_elbow_jacobian_is_zero_off_the_arm(robot_id: str):
    kin = kinematics(robot_id)
    for side in kin.arms:
        if not kin.has_elbow(side):
            continue
        kin.update(kin.home())
        jac = kin.elbow_jacobian(side)
        arm = kin.unit_indices(UnitType[f"{side.name}_ARM"])
        off = np.delete(jac, arm)
        assert np.all(off == 0.0)
        assert np.abs(jac[arm]).max() > 0.1


def test_vehicle_jacobian_matches_finite_differences(robot_id: str):
    kin = kinematics(robot_id)
    if not kin.has_vehicle:
        pytest.skip(f"{robot_id} has no vehicle")
    rng = np.random.default_rng(3)
    for _ in range(SAMPLES):
        q = random_configuration(kin, rng)
        kin.update(q)
        num = numeric_gradient(kin, q, kin.vehicle_pose)
        assert np.abs(kin.vehicle_jacobian() - num).max() <= FD_TOL


def test_vehicle_pose_and_rows_are_the_same_compiled_and_through_pinocchio(robot_id: str):
    from controller.model import jit

    if not jit.available():  # this module's "python" variant: nothing compiled to compare
        pytest.skip("compiled kernels off (IMOTION_JIT=0 or no numba)")
    compiled, plain = kinematics(robot_id), kinematics(robot_id)
    if not compiled.has_vehicle:
        pytest.skip(f"{robot_id} has no vehicle")
    plain._compiled_vehicle = False
    rng = np.random.default_rng(4)
    for trial in range(SAMPLES):
        q = random_configuration(compiled, rng)
        if trial % 2:  # an original frame that is not the world
            origin, theta = pin.SE3.Random(), float(rng.normal())
            for kin in (compiled, plain):
                kin.set_original_frame(origin, theta)
        for kin in (compiled, plain):
            kin.update(q)
        np.testing.assert_allclose(compiled.vehicle_pose(), plain.vehicle_pose(), atol=1e-12)
        np.testing.assert_allclose(
            compiled.vehicle_jacobian(), plain.vehicle_jacobian(), atol=1e-12
        )
        assert not compiled.vehicle_jacobian().flags.writeable


def null_space_direction(kin: Kinematics, side: RightLeft, previous: np.ndarray | None):
    """Unit self-motion direction of an arm (full-length vector), sign kept continuous."""
    arm = kin.unit_indices(UnitType[f"{side.name}_ARM"])
    jac = kin.jacobian(side)[:, arm]
    n = np.zeros(kin.nv)
    n[arm] = np.linalg.svd(jac)[2][-1]
    if previous is not None and n @ previous < 0:
        n = -n
    elif previous is None and kin.elbow_jacobian(side) @ n < 0:
        n = -n
    return n


@pytest.mark.parametrize("robot_id", ["pa10", "smartpal5", "seednoid"])
def test_self_motion_moves_the_elbow_and_not_the_flange(robot_id: str):
    """Small steps along the arm's null space: flange fixed to 1e-9 per step, elbow turns."""
    kin = kinematics(robot_id)
    q = kin.home()
    for side in kin.arms:
        kin.update(q)
        n = None
        start_angle = kin.elbow_angle(side)
        start_flange = kin.flange_pose(side)
        for _ in range(200):
            before = kin.flange_pose(side)
            n = null_space_direction(kin, side, n)
            q = q + 2e-5 * n
            kin.update(q)
            dp, dr = pose_difference(kin.flange_pose(side), before)
            assert dp <= 1e-9 and dr <= 1e-9, f"step moved the flange {dp:.2g} m, {dr:.2g} rad"
        turned = kin.elbow_angle(side) - start_angle
        assert turned > 1e-3, f"elbow turned only {turned:.3g} rad"
        drift = pose_difference(kin.flange_pose(side), start_flange)
        assert max(drift) <= 200e-9


def newton_hold(kin: Kinematics, q: np.ndarray, side: RightLeft, target: pin.SE3) -> np.ndarray:
    """Correct the arm joints until the flange is back on ``target`` (to 1e-13)."""
    arm = kin.unit_indices(UnitType[f"{side.name}_ARM"])
    for _ in range(20):
        kin.update(q)
        err = pin.log6(target.actInv(kin.flange_pose(side))).vector
        if np.abs(err).max() < 1e-13:
            break
        fid = kin.model.getFrameId(kin.robot.profile.arms[side.name].flange)
        local = pin.getFrameJacobian(kin.model, kin.data, fid, pin.LOCAL)[:, arm]
        q = q.copy()
        q[arm] -= np.linalg.pinv(local) @ err
    kin.update(q)
    return q


@pytest.mark.parametrize("robot_id", ["pa10", "smartpal5", "seednoid"])
def test_large_self_motion_swings_the_elbow_with_the_flange_held(robot_id: str):
    kin = kinematics(robot_id)
    side = RightLeft.RIGHT
    q = kin.home()
    kin.update(q)
    target = kin.flange_pose(side).copy()
    start = kin.elbow_angle(side)
    n = None
    for _ in range(20):
        n = null_space_direction(kin, side, n)
        q = newton_hold(kin, q + 0.01 * n, side, target)
        dp, dr = pose_difference(kin.flange_pose(side), target)
        assert dp <= 1e-9 and dr <= 1e-9
    assert abs(kin.elbow_angle(side) - start) > math.radians(3)


def test_pa10_zero_pose_matches_the_public_joint_placements():
    """robots.md: J1 0.200, +0.115, +0.280, +0.170, +0.250, +0.250 (x -0.0025), +0.080."""
    kin = kinematics("pa10")
    kin.update(np.zeros(kin.nv))
    expected = {
        "J1": (0, 0, 0.2),
        "J2": (0, 0, 0.315),
        "J3": (0, 0, 0.595),
        "J4": (0, 0, 0.765),
        "J5": (0, 0, 1.015),
        "J6": (-0.0025, 0, 1.265),
        "J7": (-0.0025, 0, 1.345),
    }
    axes = {"J1": 2, "J2": 0, "J3": 2, "J4": 0, "J5": 2, "J6": 0, "J7": 2}
    for name, xyz in expected.items():
        jid = kin.model.getJointId(name)
        placement = kin.data.oMi[jid]
        assert np.allclose(placement.translation, xyz, atol=1e-12), name
        assert np.allclose(placement.rotation, np.eye(3), atol=1e-12), name
        axis = np.zeros(3)
        axis[axes[name]] = 1.0
        jac = pin.getJointJacobian(kin.model, kin.data, jid, pin.LOCAL_WORLD_ALIGNED)
        assert np.allclose(jac[3:, kin.index(name)], axis, atol=1e-12), name
    # Flange: wrist -> flange 0.080 above J6; arm straight up, so pose = pure translation.
    assert np.allclose(kin.flange_pose(RightLeft.RIGHT).translation, (-0.0025, 0, 1.345))


def test_smartpal_shoulders_and_arm_lengths_match_robots_md():
    kin = kinematics("smartpal5")
    kin.update(np.zeros(kin.nv))
    world = kin.original_frame
    for side, y in ((RightLeft.RIGHT, -0.2), (RightLeft.LEFT, 0.2)):
        prefix = side.name[0].lower()

        def at(link: str) -> np.ndarray:
            return kin.data.oMf[kin.model.getFrameId(link)].translation

        assert np.allclose(at(f"{prefix}_arm_link1"), (-0.025, y, 1.1265), atol=1e-12)
        elbow, wrist = at(f"{prefix}_arm_link4"), at(f"{prefix}_arm_link6")
        assert np.allclose(elbow - at(f"{prefix}_arm_link1"), (0.02, 0, -0.25), atol=1e-12)
        assert np.allclose(wrist - elbow, (-0.02, 0, -0.28), atol=1e-12)
        flange = world * kin.flange_pose(side)
        assert np.allclose(flange.translation - wrist, (0, 0, -0.056), atol=1e-12)
        tool = world * kin.pose(side)
        assert np.allclose(tool.translation - flange.translation, (0, 0, -0.11), atol=1e-12)
    # Waist joints at 0.4365 and 0.21 above it; the original frame sits on the first one.
    assert np.allclose(world.translation, (0, 0, 0.4365))
    assert np.allclose(
        kin.data.oMi[kin.model.getJointId("lumbar_upper")].translation, (0, 0, 0.6465)
    )


def test_control_point_offset_is_settable_at_run_time(robot_id: str):
    kin = kinematics(robot_id)
    side = RightLeft.RIGHT
    default = kin.control_point_offset(side)
    arm = kin.robot.profile.arms["RIGHT"].tool_offset
    assert np.allclose(default.translation, arm.xyz)
    offset = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([0.01, -0.02, 0.15]))
    kin.set_control_point_offset(side, offset)
    assert max(pose_difference(kin.control_point_offset(side), offset)) < 1e-12
    q = kin.home()
    kin.update(q)
    expected = kin.flange_pose(side) * offset
    assert max(pose_difference(kin.pose(side), expected)) < 1e-12
    num = numeric_pose_jacobian(kin, q, side, FrameType.ORIGINAL_FRAME)
    assert np.abs(kin.jacobian(side) - num).max() <= FD_TOL


def test_frames_follow_the_vehicle_and_reset(robot_id: str):
    kin = kinematics(robot_id)
    if not kin.has_vehicle:
        pytest.skip(f"{robot_id} has no vehicle")
    side = RightLeft.RIGHT
    q = kin.home()
    kin.update(q)
    current_before = kin.pose(side, FrameType.CURRENT_FRAME)
    original_before = kin.pose(side, FrameType.ORIGINAL_FRAME)
    vx, vy, vt = kin.unit_indices(UnitType.VEHICLE)
    q[vx], q[vy], q[vt] = 1.0, -0.5, math.pi / 2
    kin.update(q)
    # The current frame rides with the vehicle: the control point did not move in it.
    assert max(pose_difference(kin.pose(side, FrameType.CURRENT_FRAME), current_before)) < 1e-12
    # In the original frame it moved by the vehicle's planar motion.
    planar = pin.SE3(pin.rpy.rpyToMatrix(0, 0, math.pi / 2), np.array([1.0, -0.5, 0]))
    assert max(pose_difference(kin.pose(side), planar * original_before)) < 1e-12
    assert np.allclose(kin.vehicle_pose(), (1.0, -0.5, math.pi / 2))
    kin.reset_original_frame()
    assert np.allclose(kin.vehicle_pose(), 0.0)
    assert max(pose_difference(kin.pose(side), kin.pose(side, FrameType.CURRENT_FRAME))) < 1e-12
    # Turning on the spot twice is 4π, not 0: θ is unwrapped.
    q[vt] += 4 * math.pi
    kin.update(q)
    assert kin.vehicle_pose()[2] == pytest.approx(4 * math.pi)


def test_smartpal_lumbar_ry_is_the_sum_of_both_pitch_joints():
    kin = kinematics("smartpal5")
    q = kin.home()
    q[kin.index("lumbar_lower")] = math.radians(-5)
    q[kin.index("lumbar_upper")] = math.radians(40)
    kin.update(q)
    assert kin.lumbar_axes() == [LumbarAxis.Ry]
    assert kin.lumbar_angle(LumbarAxis.Ry) == pytest.approx(math.radians(35))
    row = kin.lumbar_jacobian(LumbarAxis.Ry)
    assert row[kin.index("lumbar_lower")] == row[kin.index("lumbar_upper")] == 1.0
    # Positive pitch bends the trunk forward: the shoulders (above the pivots) go forward, down.
    shoulder = kin.model.getFrameId("r_arm_link1")
    kin.update(kin.home())
    before = kin.data.oMf[shoulder].translation.copy()
    q = kin.home()
    q[kin.index("lumbar_upper")] = math.radians(10)
    kin.update(q)
    after = kin.data.oMf[shoulder].translation
    assert after[0] > before[0] + 0.05
    assert after[2] < before[2]


def test_unit_indices_follow_spec_order(robot_id: str):
    kin = kinematics(robot_id)
    for unit in UnitType:
        names = kin.robot.unit_joints(unit)
        idx = kin.unit_indices(unit)
        assert [kin.joint_names[i] for i in idx] == list(names)
    grippers = set(kin.robot.gripper_joints)
    assert not grippers & set(kin.joint_names), "gripper joints are not QP variables"


def test_cached_elbow_and_vehicle_quantities_follow_every_update():
    """Issue 14: the elbow swivel and Jacobian and the vehicle pose and Jacobian are cached
    per update; after each update (and after the original frame moves) they equal a fresh
    computation, and the cached arrays are read-only (nobody can corrupt the next reader's)."""
    kin = kinematics("smartpal5")
    fresh = Kinematics(kin.robot)
    rng = np.random.default_rng(3)
    for i in range(5):
        q = random_configuration(kin, rng)
        kin.update(q)
        first = (kin.elbow_angle(RightLeft.RIGHT), kin.elbow_jacobian(RightLeft.LEFT).copy())
        first_vehicle = kin.vehicle_pose().copy()
        if i == 3:  # the vehicle pose is read in the original frame: a reset must show
            kin.reset_original_frame()
            fresh.update(q)
            fresh.reset_original_frame()
        fresh.update(q)
        assert kin.elbow_angle(RightLeft.RIGHT) == fresh.elbow_angle(RightLeft.RIGHT) == first[0]
        np.testing.assert_array_equal(kin.elbow_jacobian(RightLeft.LEFT), first[1])
        np.testing.assert_array_equal(
            kin.elbow_jacobian(RightLeft.LEFT), fresh.elbow_jacobian(RightLeft.LEFT)
        )
        np.testing.assert_array_equal(kin.vehicle_pose(), fresh.vehicle_pose())
        np.testing.assert_array_equal(kin.vehicle_jacobian(), fresh.vehicle_jacobian())
        if i == 3:
            np.testing.assert_allclose(kin.vehicle_pose(), 0.0, atol=1e-12)
            assert not np.allclose(first_vehicle, 0.0)
    for cached in (
        kin.elbow_jacobian(RightLeft.RIGHT),
        kin.vehicle_pose(),
        kin.vehicle_jacobian(),
        kin.lumbar_jacobian(LumbarAxis.Ry),
    ):
        with pytest.raises(ValueError):
            cached[0] = 1.0


def test_a_control_cycle_computes_each_elbow_once():
    """Issue 14: tasks, constraints and the arrival check all read the elbow angle and its
    Jacobian; one control cycle computes them at most once per arm."""
    import math as m

    from controller.model.redundant_axes import elbow_axis
    from controller.motion.motions import CPHoldMotion
    from tests.motion_support import DT, make_core

    core = make_core("smartpal5")
    side = RightLeft.RIGHT
    goal = core.kin.elbow_angle(side) + m.radians(5)
    speed = np.array([m.radians(20)])
    core.start(CPHoldMotion(core.kin, DT, (side,), {elbow_axis(side): goal}, speed, 2 * speed))
    kin = core.kin
    calls = {"swivel": 0, "jacobian": 0, "kernel": 0}
    swivel, jacobian = kin._compute_swivel, kin._compute_elbow_jacobian
    kernel = kin._update_elbows

    def count_swivel(s: RightLeft):
        calls["swivel"] += 1
        return swivel(s)

    def count_jacobian(s: RightLeft):
        calls["jacobian"] += 1
        return jacobian(s)

    def count_kernel() -> None:
        calls["kernel"] += 1
        kernel()

    kin._compute_swivel = count_swivel  # type: ignore[method-assign]
    kin._compute_elbow_jacobian = count_jacobian  # type: ignore[method-assign]
    kin._update_elbows = count_kernel  # type: ignore[method-assign]
    cycles = 0
    while core.motion is not None:
        core.cycle()
        cycles += 1
    assert cycles > 10
    if kin._elbow_args is not None:  # compiled: one call for every arm, nothing else
        assert 0 < calls["kernel"] <= cycles
        assert calls["swivel"] == calls["jacobian"] == 0
    else:
        assert 0 < calls["swivel"] <= len(kin.arms) * cycles
        assert calls["jacobian"] <= len(kin.arms) * cycles


def test_an_elbow_row_is_valid_until_the_next_update() -> None:
    """The Jacobian row is read-only; the next update writes the new configuration's row
    (compiled path: into the same array), and a copy keeps the old one."""
    kin = kinematics("smartpal5")
    rng = np.random.default_rng(7)
    side = RightLeft.RIGHT
    kin.update(random_configuration(kin, rng))
    row = kin.elbow_jacobian(side)
    kept = row.copy()
    with pytest.raises(ValueError):
        row[0] = 1.0
    q = random_configuration(kin, rng)
    kin.update(q)
    reference = kinematics("smartpal5")
    reference.update(q)
    np.testing.assert_array_equal(kin.elbow_jacobian(side), reference.elbow_jacobian(side))
    assert not np.array_equal(kept, kin.elbow_jacobian(side))


def test_compiled_elbow_equals_the_python_swivel(monkeypatch: pytest.MonkeyPatch) -> None:
    """The compiled kernel's angle, offset and row against swivel() and the frame Jacobians."""
    from controller.model import jit

    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    rng = np.random.default_rng(12)
    for robot_id in ("smartpal5", "seednoid", "pa10"):
        compiled = kinematics(robot_id)
        monkeypatch.setenv("IMOTION_JIT", "0")
        python = kinematics(robot_id)
        monkeypatch.delenv("IMOTION_JIT")
        assert compiled._elbow_args is not None and python._elbow_args is None
        for _ in range(50):
            q = random_configuration(compiled, rng)
            compiled.update(q)
            python.update(q)
            for side in compiled.arms:
                if not compiled.has_elbow(side):
                    continue
                assert compiled.elbow_angle(side) == pytest.approx(
                    python.elbow_angle(side), abs=1e-12
                )
                assert compiled.elbow_offset(side) == pytest.approx(
                    python.elbow_offset(side), abs=1e-12
                )
                np.testing.assert_allclose(
                    compiled.elbow_jacobian(side), python.elbow_jacobian(side), atol=1e-9
                )


def test_an_array_changed_after_the_update_does_not_change_the_elbow() -> None:
    """The elbows are computed lazily from the configuration of the update, not from the
    caller's array as it is when they are first asked for."""
    kin = kinematics("smartpal5")
    q = random_configuration(kin, np.random.default_rng(4))
    kin.update(q)
    reference = kinematics("smartpal5")
    reference.update(q.copy())
    q += 0.3  # the caller reuses its array before anyone asks for the elbow
    for side in kin.arms:
        assert kin.elbow_angle(side) == reference.elbow_angle(side)
        np.testing.assert_array_equal(kin.elbow_jacobian(side), reference.elbow_jacobian(side))


def test_compiled_control_point_equals_pinocchio(monkeypatch: pytest.MonkeyPatch) -> None:
    """The control point's world Jacobian and placement from the shared compiled placements
    against Pinocchio's, on every robot, with a moved control point too."""
    from controller.model import jit

    if not jit.available():
        pytest.skip("compiled kernels are off in this variant")
    rng = np.random.default_rng(21)
    for robot_id in ("smartpal5", "seednoid", "pa10", "rh"):
        compiled = kinematics(robot_id)
        monkeypatch.setenv("IMOTION_JIT", "0")
        python = kinematics(robot_id)
        monkeypatch.delenv("IMOTION_JIT")
        assert compiled._cp_world and not python._cp_world
        offset = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([0.01, -0.02, 0.15]))
        for trial in range(30):
            if trial == 15:
                for kin in (compiled, python):
                    for side in kin.arms:
                        kin.set_control_point_offset(side, offset)
            q = random_configuration(compiled, rng)
            compiled.update(q)
            python.update(q)
            for side in compiled.arms:
                jac, rot, pos = compiled.control_point_world(side)
                ref_jac, ref_rot, ref_pos = python.control_point_world(side)
                np.testing.assert_allclose(jac, ref_jac, atol=1e-12)
                np.testing.assert_allclose(rot, ref_rot, atol=1e-12)
                np.testing.assert_allclose(pos, ref_pos, atol=1e-12)


def test_pinocchios_data_is_computed_when_read_and_is_the_last_updates() -> None:
    """With the compiled chain an update runs no Pinocchio pass (a control cycle does not
    need one); reading ``data`` afterwards gives Pinocchio's results at that update's q."""
    from controller.model import jit

    if not jit.available():
        pytest.skip("compiled kernels are off in this variant")
    kin = kinematics("smartpal5")
    calls: list[int] = []
    compute = pin.computeJointJacobians

    def counted(*args: object) -> object:
        calls.append(1)
        return compute(*args)

    rng = np.random.default_rng(5)
    reference = kin.model.createData()
    try:
        pin.computeJointJacobians = counted
        for _ in range(3):
            q = random_configuration(kin, rng)
            kin.update(q)
            for side in kin.arms:  # the cycle's queries: on the compiled chain
                kin.control_point_world(side)
                kin.elbow_angle(side)
                kin.elbow_jacobian(side)
                kin.pose(side, FrameType.CURRENT_FRAME)  # soft limits, arrival checks
            kin.body_pose()
            kin.vehicle_pose()
            kin.vehicle_jacobian()
        assert not calls
        data = kin.data  # read: computed now, once
        assert kin.data is data and len(calls) == 1
    finally:
        pin.computeJointJacobians = compute
    pin.computeJointJacobians(kin.model, reference, q)
    pin.updateFramePlacements(kin.model, reference)
    np.testing.assert_allclose(data.J, reference.J, atol=1e-12)
    for fid in (0, kin.model.nframes // 2, kin.model.nframes - 1):
        np.testing.assert_allclose(
            data.oMf[fid].homogeneous, reference.oMf[fid].homogeneous, atol=1e-12
        )


def test_poses_on_the_compiled_chain_are_pinocchios(monkeypatch: pytest.MonkeyPatch) -> None:
    """pose() in both frames and body_pose() from the shared placements equal Pinocchio's."""
    from controller.model import jit

    if not jit.available():
        pytest.skip("compiled kernels are off in this variant")
    rng = np.random.default_rng(8)
    for robot_id in ("smartpal5", "pa10"):
        compiled = kinematics(robot_id)
        monkeypatch.setenv("IMOTION_JIT", "0")
        python = kinematics(robot_id)
        monkeypatch.delenv("IMOTION_JIT")
        for _ in range(10):
            q = random_configuration(compiled, rng)
            compiled.update(q)
            python.update(q)
            got, want = compiled.body_pose(), python.body_pose()
            np.testing.assert_allclose(got.homogeneous, want.homogeneous, atol=1e-12)
            for side in compiled.arms:
                for frame in FrameType:
                    got, want = compiled.pose(side, frame), python.pose(side, frame)
                    np.testing.assert_allclose(got.homogeneous, want.homogeneous, atol=1e-12)

"""hal.mujoco_backend: lifecycle, holding, tracking, servo off, faults, every robot."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from hal.interface import HardwareFault, HardwareState, JointCommand
from hal.mujoco_backend import (
    FAULT_NON_FINITE,
    MAX_TIMESTEP,
    MujocoBackend,
    default_initial,
    default_joint_names,
    default_substeps,
)
from tests.support import robot

DT = 0.002
#: Holding error allowed over 1 s of simulated time [rad] or [m].
HOLD_TOL = 1e-4
#: Tracking error allowed for the 0.3 rad, 0.5 Hz sine [rad]. Measured: 6.6e-4 rad, mostly
#: the integrator's half-step lag v·h/2 = 0.94 rad/s × 0.5 ms = 4.7e-4 rad, plus the servo's
#: acceleration error a/ω² ≈ 3 rad/s² / (2π·40 Hz)² ≈ 5e-5 rad and the arms' dynamic coupling.
TRACK_TOL = 2e-3


def backend(robot_id: str = "smartpal5", **kwargs) -> MujocoBackend:
    hw = MujocoBackend(robot(robot_id), kwargs.pop("dt", DT), **kwargs)
    hw.configure()
    return hw


def hold(hw: MujocoBackend, cycles: int) -> float:
    """Command the current position for ``cycles`` writes; the largest deviation seen."""
    start = hw.read().position
    command = JointCommand(start.copy(), np.zeros_like(start))
    worst = 0.0
    for _ in range(cycles):
        hw.write(command)
        worst = max(worst, float(np.abs(hw.read().position - start).max()))
    return worst


def test_lifecycle_transitions_and_wrong_states():
    hw = MujocoBackend(robot("pa10"), DT)
    assert hw.state is HardwareState.UNCONFIGURED
    with pytest.raises(RuntimeError, match="configured"):
        hw.read()
    with pytest.raises(RuntimeError, match="INACTIVE"):
        hw.activate()
    with pytest.raises(RuntimeError):
        _ = hw.model
    with pytest.raises(RuntimeError):
        hw.inject_fault(HardwareFault(0x400, "J1", "test"))
    hw.write(JointCommand(np.zeros(9)))  # no model yet: a no-op
    hw.deactivate()  # a quick stop is always allowed
    assert hw.reset_faults() is False
    assert hw.state is HardwareState.UNCONFIGURED

    hw.configure()
    assert hw.state is HardwareState.INACTIVE
    with pytest.raises(RuntimeError, match="UNCONFIGURED"):
        hw.configure()
    hw.deactivate()
    assert hw.state is HardwareState.INACTIVE
    assert hw.reset_faults() is True

    hw.activate()
    assert hw.state is HardwareState.ACTIVE
    hw.activate()  # already on: a no-op
    assert hw.state is HardwareState.ACTIVE
    assert hw.reset_faults() is False  # nothing to reset, and not INACTIVE
    hw.deactivate()
    assert hw.state is HardwareState.INACTIVE

    hw.shutdown()
    assert hw.state is HardwareState.FINALIZED
    with pytest.raises(RuntimeError):
        hw.read()
    with pytest.raises(RuntimeError):
        hw.activate()
    with pytest.raises(RuntimeError):
        hw.configure()
    hw.write(JointCommand(np.zeros(9)))
    hw.shutdown()
    assert hw.state is HardwareState.FINALIZED


def test_default_joints_and_initial_configuration():
    rob = robot("smartpal5")
    hw = backend()
    units = [n for joints in rob.profile.units.values() for n in joints]
    assert list(hw.joint_names) == [*units, "r_gripper", "l_gripper"]
    assert set(hw.joint_names) == set(rob.profile.joints)
    state = hw.read()
    assert state.stamp == 0.0
    assert state.position.shape == state.velocity.shape == (len(hw.joint_names),)
    expected = default_initial(rob)
    assert expected["r_arm_j4"] == pytest.approx(math.radians(90))
    assert expected["r_gripper"] == 0.0
    np.testing.assert_allclose(state.position, [expected[n] for n in hw.joint_names])
    np.testing.assert_array_equal(state.velocity, 0.0)


def test_model_has_servos_gravity_compensation_and_timestep():
    hw = backend()
    model = hw.model
    n = len(hw.joint_names)
    assert model.nu == 2 * n
    assert model.actuator(0).name == f"{hw.joint_names[0]}_pos"
    assert model.actuator(n).name == f"{hw.joint_names[0]}_ff"
    assert hw.substeps == 2
    assert model.opt.timestep == pytest.approx(DT / 2)
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY
    assert np.all(hw.kp > 0) and np.all(hw.kv > 0)
    assert np.all(model.dof_armature > 0)


def test_gravity_off_moves_the_robot_as_gravity_compensated_at_every_body():
    """The stand-in switches gravity off: the same equations of motion as gravity on with
    every body compensated (gravcomp = 1), at random configurations and velocities."""
    path = str(robot("smartpal5").mjcf_path)
    compensated, off = mujoco.MjSpec.from_file(path), mujoco.MjSpec.from_file(path)
    for body in compensated.bodies:
        body.gravcomp = 1.0
    off.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_GRAVITY
    m_on, m_off = compensated.compile(), off.compile()
    assert m_on.ngravcomp > 0 and np.linalg.norm(m_on.opt.gravity) > 9.0
    d_on, d_off = mujoco.MjData(m_on), mujoco.MjData(m_off)
    rng = np.random.default_rng(4)
    for _ in range(10):
        d_on.qpos[:] = d_off.qpos[:] = rng.uniform(-1.0, 1.0, m_on.nq)
        d_on.qvel[:] = d_off.qvel[:] = rng.uniform(-1.0, 1.0, m_on.nv)
        mujoco.mj_forward(m_on, d_on)
        mujoco.mj_forward(m_off, d_off)
        assert np.abs(d_on.qfrc_gravcomp).max() > 1.0  # gravity is compensated, not absent
        np.testing.assert_allclose(d_off.qacc, d_on.qacc, rtol=1e-9, atol=1e-9)


def test_custom_joint_subset_and_initial_values():
    rob = robot("smartpal5")
    names = ("r_arm_j4", "r_arm_j1", "vehicle_x")
    hw = backend(joint_names=names, initial={"r_arm_j1": 0.5, "vehicle_x": 1.25})
    assert hw.joint_names == names
    np.testing.assert_allclose(hw.read().position, [math.radians(90), 0.5, 1.25])
    hw.activate()
    hw.write(JointCommand(np.array([1.5, 0.6, 1.25]), np.zeros(3)))
    for _ in range(200):
        hw.write(JointCommand(np.array([1.5, 0.6, 1.25]), np.zeros(3)))
    np.testing.assert_allclose(hw.read().position, [1.5, 0.6, 1.25], atol=1e-5)
    # The joints not exposed are held where they started.
    data, model = hw.data, hw.model
    q_l4 = data.qpos[model.joint("l_arm_j4").qposadr[0]]
    assert q_l4 == pytest.approx(math.radians(rob.profile.home["l_arm_j4"]), abs=1e-4)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dt": 0.0}, "dt"),
        ({"dt": math.nan}, "dt"),
        ({"substeps": 0}, "substeps"),
        ({"dt": 0.004, "substeps": 2}, "timestep"),
        ({"joint_names": ["r_arm_j1", "nope"]}, "unknown joints"),
        ({"joint_names": ["r_arm_j1", "r_arm_j1"]}, "duplicates"),
        ({"initial": {"nope": 0.0}}, "unknown joint"),
        ({"initial": {"r_arm_j4": 3.0}}, "outside"),
        ({"initial": {"r_arm_j4": math.inf}}, "outside"),
    ],
)
def test_constructor_rejects_bad_arguments(kwargs: dict, match: str):
    dt = kwargs.pop("dt", DT)
    with pytest.raises(ValueError, match=match):
        MujocoBackend(robot("smartpal5"), dt, **kwargs)


def test_default_substeps_keep_the_timestep_at_most_one_millisecond():
    assert default_substeps(0.002) == 2
    assert default_substeps(0.001) == 1
    assert default_substeps(0.0005) == 1
    assert default_substeps(0.0025) == 3
    for dt in (0.0005, 0.001, 0.002, 0.0025, 0.01):
        assert dt / default_substeps(dt) <= MAX_TIMESTEP * (1 + 1e-12)


def test_activate_holds_every_robot_still_for_one_second(robot_id: str):
    hw = backend(robot_id)
    rob = robot(robot_id)
    assert list(hw.joint_names) == list(default_joint_names(rob))
    initial = default_initial(rob)
    hw.activate()
    np.testing.assert_allclose(hw.read().position, [initial[n] for n in hw.joint_names])
    cycles = round(1.0 / DT)
    assert hold(hw, cycles) < HOLD_TOL
    assert hw.sim_time == pytest.approx(1.0)
    assert hw.read().stamp == pytest.approx(1.0)
    assert hw.state is HardwareState.ACTIVE


def test_each_write_advances_simulated_time_by_dt_in_every_configured_state():
    hw = backend("pa10")
    n = len(hw.joint_names)
    command = JointCommand(hw.read().position + 0.2, np.zeros(n))
    stamps = []
    for step in (None, hw.activate, hw.deactivate):
        if step is not None:
            step()
        before = hw.read().position
        for _ in range(10):
            hw.write(command if hw.state is not HardwareState.ACTIVE else JointCommand(before))
            stamps.append(hw.read().stamp)
        if hw.state is HardwareState.INACTIVE:
            # Set-points are ignored with the servos off.
            np.testing.assert_allclose(hw.read().position, before, atol=1e-9)
    np.testing.assert_allclose(np.diff(stamps), DT, atol=1e-12)


@pytest.mark.usefixtures("jit_backend")
def test_tracks_a_sine_on_every_arm_joint_with_velocity_feed_forward():
    rob = robot("smartpal5")
    hw = backend()
    hw.activate()
    q0 = hw.read().position.copy()
    arm = set(rob.unit_joints("RIGHT_ARM") + rob.unit_joints("LEFT_ARM"))
    # Each arm joint moves 0..0.6 rad towards the larger side of its range, from rest.
    sign = np.zeros(len(q0))
    for i, name in enumerate(hw.joint_names):
        if name in arm:
            spec = rob.joints[name]
            sign[i] = 1.0 if spec.upper - q0[i] > q0[i] - spec.lower else -1.0
    amplitude, omega = 0.3, 2 * math.pi * 0.5

    def reference(t: float) -> tuple[np.ndarray, np.ndarray]:
        q = q0 + sign * amplitude * (1 - math.cos(omega * t))
        return q, sign * amplitude * omega * math.sin(omega * t)

    worst = np.zeros(len(q0))
    travel = np.zeros(len(q0))
    for _ in range(round(2.0 / DT)):
        state = hw.read()
        worst = np.maximum(worst, np.abs(state.position - reference(state.stamp)[0]))
        travel = np.maximum(travel, np.abs(state.position - q0))
        # A command is the set-point for the end of the cycle.
        hw.write(JointCommand(*reference(state.stamp + DT)))
    assert hw.sim_time == pytest.approx(2.0)
    assert worst.max() < TRACK_TOL, dict(zip(hw.joint_names, worst, strict=True))
    assert travel[sign != 0].min() > 0.59  # every arm joint really moved its 0.6 rad
    assert travel[sign == 0].max() < TRACK_TOL  # waist, vehicle and grippers held


def test_deactivate_stops_tracking():
    hw = backend("pa10")
    hw.activate()
    q0 = hw.read().position.copy()
    n = len(q0)
    velocity = np.zeros(n)
    velocity[0] = 0.5  # J1 at 0.5 rad/s
    for k in range(1, 101):
        hw.write(JointCommand(q0 + velocity * k * DT, velocity))
    moving = hw.read()
    assert moving.position[0] == pytest.approx(q0[0] + 0.1, abs=2e-3)
    hw.deactivate()
    for k in range(101, 601):
        hw.write(JointCommand(q0 + velocity * k * DT, velocity))
    stopped = hw.read()
    # Servo off: the drive's brake damping stops J1 within its remaining momentum.
    assert abs(stopped.position[0] - moving.position[0]) < 0.01
    assert abs(stopped.velocity[0]) < 1e-3
    assert np.abs(hw.data.ctrl).max() == 0.0


@pytest.mark.usefixtures("jit_backend")
@pytest.mark.parametrize("field", ["position", "velocity"])
@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_set_point_faults_naming_the_joint(field: str, bad: float):
    hw = backend()
    hw.activate()
    start = hw.read()
    position, velocity = start.position.copy(), np.zeros(len(start.position))
    j = hw.joint_names.index("l_arm_j3")
    (position if field == "position" else velocity)[j] = bad
    hw.write(JointCommand(position, velocity))
    assert hw.state is HardwareState.FAULT
    (fault,) = hw.faults()
    assert fault.code == FAULT_NON_FINITE == 0x40F
    assert fault.source == "l_arm_j3"
    assert "non-finite" in fault.description
    state = hw.read()
    assert np.isfinite(state.position).all()
    assert state.stamp == pytest.approx(DT)  # the faulty cycle still advanced time
    # In FAULT: servos off, set-points ignored, time advances; activate refused.
    hw.write(JointCommand(start.position + 0.3))
    assert hw.read().stamp == pytest.approx(2 * DT)
    np.testing.assert_allclose(hw.read().position, start.position, atol=1e-6)
    with pytest.raises(RuntimeError, match="fault"):
        hw.activate()
    hw.deactivate()
    assert hw.state is HardwareState.FAULT
    assert hw.reset_faults() is True
    assert hw.state is HardwareState.INACTIVE and hw.faults() == []
    hw.activate()
    assert hold(hw, 50) < HOLD_TOL


@pytest.mark.usefixtures("jit_backend")
@pytest.mark.filterwarnings("ignore:overflow encountered")
def test_finite_set_points_whose_changes_overflow_a_sum_are_not_called_non_finite(
    monkeypatch, tmp_path
):
    """write() checks the set-points through the sum of their changes; an overflow of that
    sum (finite set-points) takes the element-wise check, which accepts them."""
    monkeypatch.chdir(tmp_path)  # MuJoCo writes MUJOCO_LOG.TXT where it runs
    hw = backend()
    hw.activate()
    start = hw.read().position
    velocity = np.zeros(len(start))
    velocity[[0, 1]] = 1.5e308  # finite; their sum is not
    hw.write(JointCommand(start.copy(), velocity))
    assert all(f.source == "mujoco" for f in hw.faults())  # diverged, maybe; never a joint


def test_wrong_command_shape_raises():
    hw = backend("pa10")
    hw.activate()
    with pytest.raises(ValueError, match="position"):
        hw.write(JointCommand(np.zeros(3)))
    with pytest.raises(ValueError, match="velocity"):
        hw.write(JointCommand(hw.read().position, np.zeros(3)))
    assert hw.state is HardwareState.ACTIVE


@pytest.mark.usefixtures("jit_backend")
def test_command_without_velocity_means_zero_feed_forward():
    hw = backend("pa10")
    hw.activate()
    target = hw.read().position + 0.05
    for _ in range(250):
        hw.write(JointCommand(target))
    np.testing.assert_allclose(hw.read().position, target, atol=1e-5)


def test_inject_fault_disables_servos_and_reset_returns_to_inactive():
    hw = backend("rh")
    hw.activate()
    fault = HardwareFault(0x401, "J2", "drive fault (injected)")
    hw.inject_fault(fault)
    assert hw.state is HardwareState.FAULT
    assert hw.faults() == [fault]
    hw.inject_fault(HardwareFault(0x402, "can0", "bus off (injected)"))
    assert [f.code for f in hw.faults()] == [0x401, 0x402]
    assert np.all(hw.model.actuator_gainprm[:, 0] == 0.0)
    assert hold(hw, 50) < HOLD_TOL  # gravity-compensated and braked: stays put
    assert hw.reset_faults() is True
    assert hw.state is HardwareState.INACTIVE
    assert hw.faults() == []
    hw.activate()
    assert hw.state is HardwareState.ACTIVE


def test_diverged_simulation_is_reset_and_reported(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)  # MuJoCo appends its warning to ./MUJOCO_LOG.TXT
    hw = backend("pa10")
    hw.activate()
    start = hw.read().position.copy()
    for _ in range(5):
        hw.write(JointCommand(start))
    before = hw.sim_time
    hw.data.qvel[0] = math.nan
    hw.write(JointCommand(start))
    assert hw.state is HardwareState.ACTIVE  # the step is still to take
    hw.advance()
    assert hw.state is HardwareState.FAULT
    assert hw.faults()[0].source == "mujoco"
    assert hw.sim_time > before  # time never goes backwards
    state = hw.read()
    np.testing.assert_allclose(state.position, start, atol=1e-9)
    assert np.isfinite(state.velocity).all()
    assert hw.reset_faults() is True


def test_write_leaves_the_steps_to_advance_and_any_look_at_the_state_takes_them(monkeypatch):
    """write() only sets the servo references; advance() (the loop's slack) takes the
    substeps once; read(), data, sim_time and the next write() take them when it was not
    called."""
    hw = backend(dt=DT)  # 2 substeps
    hw.activate()
    steps = []
    real_step = mujoco.mj_step
    monkeypatch.setattr(mujoco, "mj_step", lambda *a: (steps.append(a), real_step(*a)))
    q0 = hw.read().position.copy()
    for look in (
        hw.advance,
        hw.read,
        lambda: hw.data,
        lambda: hw.sim_time,
        lambda: hw.write(JointCommand(q0)),
        lambda: hw.set_servo_mask(np.ones(len(q0), dtype=bool)),
        hw.deactivate,
    ):
        hw.activate()
        hw.write(JointCommand(q0 + 0.01))
        assert steps == []
        look()
        assert sum(a[2] if len(a) == 3 else 1 for a in steps) == hw.substeps  # (m, d[, n])
        hw.advance()  # nothing left (the write among the looks left its own step)
        steps.clear()
        hw.advance()
        assert steps == []


@pytest.mark.parametrize("compiled", [True, False])
def test_the_simulation_is_the_same_with_or_without_advance(compiled: bool):
    """The loop's advance() between cycles, or none (each read taking the step): the same
    simulation to the last bit, through a servo mask change and a servo off."""
    runs = []
    for call_advance in (True, False):
        hw = backend(dt=DT)
        hw._compiled = compiled
        hw.activate()
        q0 = hw.read().position.copy()
        mask = np.ones(len(q0), dtype=bool)
        out = []
        for k in range(30):
            if k == 10:
                mask[:3] = False
                hw.set_servo_mask(mask)
            if k == 20:
                hw.deactivate()
            hw.write(JointCommand(q0 + 0.1 * math.sin(0.3 * k), np.full(len(q0), 0.05)))
            if call_advance:
                hw.advance()
            out.append(np.concatenate([hw.read().position, hw.read().velocity, hw.data.ctrl]))
        runs.append(out)
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)


def test_the_collision_pass_is_off_only_when_no_geom_can_collide(monkeypatch):
    contact = mujoco.mjtDisableBit.mjDSBL_CONTACT
    assert backend().model.opt.disableflags & contact  # the generated models: none can
    build = MujocoBackend._build_spec

    def with_a_colliding_geom(self: MujocoBackend) -> mujoco.MjSpec:
        spec = build(self)
        spec.geoms[0].contype = 1
        return spec

    monkeypatch.setattr(MujocoBackend, "_build_spec", with_a_colliding_geom)
    assert not backend().model.opt.disableflags & contact


def test_the_compiled_interpolation_gives_the_same_simulation_bit_for_bit():
    """write()'s set-point interpolation compiled and in NumPy: the same servo references to
    the last bit (with and without velocity, two substeps per cycle)."""
    runs = []
    for compiled in (True, False):
        hw = backend(dt=DT)  # 2 substeps at 2 ms
        hw._compiled = compiled
        hw.activate()
        q0 = hw.read().position.copy()
        out = []
        for k in range(40):
            t = k * DT
            v = np.full(len(q0), 0.4 * math.cos(2 * t))
            command = JointCommand(q0 + 0.2 * math.sin(2 * t), v if k % 3 else np.zeros(0))
            hw.write(command)
            out.append(np.concatenate([hw.read().position, hw.data.ctrl]))
        runs.append(out)
    assert hw.substeps == 2
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)

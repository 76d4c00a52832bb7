"""The MuJoCo stand-in for the drives: a :class:`HardwareInterface` over a simulated robot.

The robot's generated MJCF (``robot.xml``, never edited) is loaded with
:class:`mujoco.MjSpec` and extended in memory:

* **Servos.** Each joint gets two actuators, together a PD servo with velocity feed-forward::

      force = kp (q_ref - q) + kv (v_ref - q̇)

  The first actuator (``<joint>_pos``, ``ctrl`` = position set-point ``q_ref``) is a position
  servo with affine bias ``-kp q - kv q̇``; the second (``<joint>_ff``, ``ctrl`` = velocity
  set-point ``v_ref``) adds ``kv v_ref``. Keeping the damping inside an actuator (rather than
  in ``qfrc_applied``) lets the ``implicitfast`` integrator treat it implicitly, which keeps
  the stiff servos stable. Layout of ``data.ctrl``: the ``_pos`` actuators of
  :attr:`MujocoBackend.joint_names` first, then those of the model's other joints, then the
  ``_ff`` actuators in the same order.
* **Gains.** Per joint, critically damped at a fixed servo bandwidth ω = 2π·
  :data:`SERVO_BANDWIDTH_HZ`: ``kp = m ω²``, ``kv = 2 ζ m ω`` with ``m`` the joint's reflected
  inertia (the diagonal of the joint-space inertia matrix at the initial configuration, armature
  included) [kg·m²] or [kg].
* **Armature.** Each joint gets an armature of :data:`ARMATURE_RATIO` times its own diagonal
  inertia: a stand-in for the motor rotor inertia reflected through the gear, which on real
  geared arms is of the order of the link inertia. It bounds the stiffest closed-loop mode:
  with armature ``c·D`` and gains scaled by ``(1 + c)·D``, every mode of the coupled servo
  loop is at most ω·√((1 + c)/c) (√2·ω for c = 1), at any configuration. Without it the tiny
  wrist and finger inertias of the stand-in models couple into modes 80 times stiffer.
* **Gravity compensation.** Gravity is switched off (``mjDSBL_GRAVITY``): the same motion as
  compensating it at every body (``gravcomp = 1``), without computing both terms each step.
  Holding and tracking carry no gravity bias (the servo has no integrator).
* **Contacts.** The generated models give no geom a contact type, so nothing collides: the
  collision pass is then switched off (``mjDSBL_CONTACT``). A model with colliding geoms
  keeps it.
* **Timestep.** ``dt / substeps`` with ``substeps`` chosen so the timestep is at most
  :data:`MAX_TIMESTEP` [s]; ω·timestep stays below 0.4.

Lockstep timing: each :meth:`MujocoBackend.write` advances simulated time by exactly ``dt``
(``substeps`` MuJoCo steps), in every configured state, so a control loop runs the same
whether the servos are on or off. The steps are taken by :meth:`MujocoBackend.advance`, which
the control loop calls in its slack after the cycle (the plant moves while the controller
sleeps, as a real one does, and the physics is not the controller's compute time); a read,
a write or any other look at the state takes them first when it was not called, so the
simulation is the same either way. A command is the set-point for the *end* of the cycle: as a
drive in cyclic synchronous position mode interpolates, the servo reference moves linearly
from the previous set-point to the new one over the cycle (position and velocity, evaluated
at each substep's midpoint). Measured on SmartPal V at dt = 2 ms, a 0.3 rad, 0.5 Hz sine on
all 14 arm joints is tracked within 7e-4 rad, mostly the integrator's half-step lag
(≈ v·timestep/2).

Lifecycle (see :mod:`hal.interface`):

* ``configure()`` compiles the model and sets the initial configuration. UNCONFIGURED only.
* ``activate()``: servo on, each servo holding the measured position (nothing jumps).
  INACTIVE -> ACTIVE; a no-op in ACTIVE; RuntimeError otherwise.
* ``deactivate()``: servo off (``kp`` and feed-forward zeroed; the damping ``kv`` stays as the
  stand-in for the drive's dynamic brake, so the gravity-compensated robot stays put).
  ACTIVE -> INACTIVE; a no-op in every other state, so a quick stop can always be sent.
* ``read()``: valid in INACTIVE, ACTIVE and FAULT; RuntimeError before configure and after
  shutdown. ``stamp`` is the simulated time [s].
* ``write()``: set-points are used in ACTIVE and ignored (time still advances) in INACTIVE
  and FAULT; a no-op before configure and after shutdown. A set-point of the wrong length
  raises ValueError. A non-finite set-point never reaches MuJoCo: the backend goes to FAULT
  (:data:`FAULT_NON_FINITE`, source = the joint) with the servos off.
* A diverged simulation (MuJoCo's bad qpos/qvel/qacc warnings) is put back at the initial
  configuration, keeping the simulated time, and reported as a FAULT from source ``"mujoco"``.
* ``inject_fault()`` (tests) puts the backend in FAULT with the servos off;
  ``reset_faults()`` clears every fault and returns to INACTIVE.

Not thread-safe: one control loop owns the backend.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

from controller.model import jit
from controller.model.robot import Robot
from hal.interface import (
    HardwareFault,
    HardwareInterface,
    HardwareState,
    JointCommand,
    JointState,
)

#: Servo bandwidth [Hz]: the natural frequency of each joint's critically damped servo.
SERVO_BANDWIDTH_HZ = 40.0
#: Damping ratio ζ of each joint's servo.
DAMPING_RATIO = 1.0
#: Armature per joint as a multiple of the joint's own diagonal inertia.
ARMATURE_RATIO = 1.0
#: Largest MuJoCo timestep [s] the default substeps allow.
MAX_TIMESTEP = 1e-3
#: Alarm code of a non-finite set-point or a diverged simulation.
FAULT_NON_FINITE = 0x40F

_DIVERGENCE_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)
#: Their places in ``MjData.warning.number`` (consecutive in MuJoCo's enum: one slice).
_DIVERGENCE_SLICE = slice(
    min(int(w) for w in _DIVERGENCE_WARNINGS), max(int(w) for w in _DIVERGENCE_WARNINGS) + 1
)
assert _DIVERGENCE_SLICE.stop - _DIVERGENCE_SLICE.start == len(_DIVERGENCE_WARNINGS)

# What :meth:`MujocoBackend.advance` has to do: nothing; substeps on the compiled references;
# substeps on the NumPy interpolation; substeps holding the controls as they are.
_STEP_NONE, _STEP_REFERENCES, _STEP_FRACTIONS, _STEP_HOLD = range(4)


def default_joint_names(robot: Robot) -> tuple[str, ...]:
    """Every joint of the profile: unit joints in the order of its units, then grippers."""
    units = tuple(n for joints in robot.profile.units.values() for n in joints)
    return units + robot.gripper_joints


def default_initial(robot: Robot) -> dict[str, float]:
    """Home pose with the grippers closed, in SI [rad] or [m], for every profile joint."""
    initial = robot.home()
    for gripper in robot.profile.grippers.values():
        for name, closed in zip(gripper.joints, gripper.closed, strict=True):
            initial[name] = robot.joints[name].to_si(closed)
    return initial


def default_substeps(dt: float) -> int:
    """Fewest MuJoCo steps per cycle of ``dt`` [s] keeping the timestep <= MAX_TIMESTEP."""
    return max(1, math.ceil(dt / MAX_TIMESTEP - 1e-9))


class MujocoBackend(HardwareInterface):
    """Simulated drives for ``robot``, advanced ``dt`` [s] per :meth:`write` (lockstep; the
    steps taken by :meth:`advance`)."""

    def __init__(
        self,
        robot: Robot,
        dt: float,
        joint_names: Sequence[str] | None = None,
        substeps: int | None = None,
        initial: dict[str, float] | None = None,
    ):
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        if substeps is None:
            substeps = default_substeps(dt)
        if substeps < 1:
            raise ValueError(f"substeps must be >= 1, got {substeps}")
        if dt / substeps > MAX_TIMESTEP * (1 + 1e-9):
            raise ValueError(
                f"timestep dt/substeps = {dt / substeps:g} s exceeds {MAX_TIMESTEP:g} s: "
                "the stiff servos need more substeps"
            )
        all_joints = default_joint_names(robot)
        names = tuple(all_joints if joint_names is None else joint_names)
        unknown = [n for n in names if n not in robot.joints]
        if unknown:
            raise ValueError(f"{robot.id}: unknown joints {unknown}")
        if len(set(names)) != len(names):
            raise ValueError(f"{robot.id}: joint_names has duplicates: {list(names)}")
        start = default_initial(robot)
        for name, value in (initial or {}).items():
            spec = robot.joints.get(name)
            if spec is None:
                raise ValueError(f"{robot.id}: initial value for unknown joint {name!r}")
            if not (math.isfinite(value) and spec.lower <= value <= spec.upper):
                raise ValueError(
                    f"{robot.id}: initial {name} = {value!r} is outside "
                    f"[{spec.lower:g}, {spec.upper:g}]"
                )
            start[name] = float(value)

        self.robot = robot
        self.joint_names = names
        #: Every actuated joint: :attr:`joint_names` first, then the profile's other joints.
        self._actuated = names + tuple(n for n in all_joints if n not in names)
        self._initial = start
        self._dt = float(dt)
        self._substeps = int(substeps)
        self._state = HardwareState.UNCONFIGURED
        self._faults: list[HardwareFault] = []
        self._model: mujoco.MjModel | None = None
        self._data: mujoco.MjData | None = None
        n, total = len(names), len(self._actuated)
        # qpos/qvel addresses of every actuated joint, and views of the exposed ones.
        self._qadr_all = np.zeros(total, dtype=np.intp)
        self._dofadr_all = np.zeros(total, dtype=np.intp)
        self._qadr = self._qadr_all[:n]
        self._dofadr = self._dofadr_all[:n]
        self._kp = np.zeros(total)
        self._kv = np.zeros(total)
        # Set-points of the previous cycle (rows: position, velocity), their change this cycle
        # and scratch for the interpolation: one array per pair, so that each substep's
        # interpolation is two NumPy calls (:meth:`write` runs every cycle).
        self._prev = np.zeros((2, n))
        self._q_prev, self._v_prev = self._prev
        self._delta = np.zeros((2, n))
        self._dq, self._dv = self._delta
        self._delta_flat = self._delta.reshape(-1)
        self._ones = np.ones(2 * n)
        self._scratch = np.zeros((2, n))
        self._fractions = tuple((j + 0.5) / substeps for j in range(substeps))
        #: The set-points' interpolation compiled (:func:`_servo_references`): the fractions
        #: as an array and each substep's references (rows: position, velocity).
        self._compiled = jit.available()
        self._fraction_array = np.array(self._fractions)
        self._references = np.zeros((substeps, 2, n))
        #: Views of ``data.ctrl`` (rows: the exposed joints' ``_pos`` and ``_ff`` actuators),
        #: of the divergence warning counters and of qpos/qvel, set by :meth:`configure`.
        self._ctrl_pair = np.zeros((2, n))
        self._warnings = np.zeros(len(_DIVERGENCE_WARNINGS), dtype=np.int32)
        self._qpos = self._qvel = np.zeros(0)
        self._servo_mask = np.zeros(n, dtype=bool)  # which exposed joints have the servo on
        self._divergences = 0
        #: The step the last :meth:`write` left for :meth:`advance` (``_STEP_*``), and the
        #: set-points the Python interpolation moves ``_prev`` to after it.
        self._pending = _STEP_NONE
        self._next = np.zeros((2, n))

    # ----------------------------------------------------------------------------- queries

    @property
    def state(self) -> HardwareState:
        return self._state

    @property
    def dt(self) -> float:
        """Simulated time per :meth:`write` [s]."""
        return self._dt

    @property
    def substeps(self) -> int:
        """MuJoCo steps per :meth:`write`."""
        return self._substeps

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled model (servos added); for renderers. Valid once configured."""
        if self._model is None:
            raise RuntimeError(f"MujocoBackend has no model in state {self._state.value}")
        return self._model

    @property
    def data(self) -> mujoco.MjData:
        """The simulation state; for renderers (read it, do not step it). Once configured.
        The last :meth:`write`'s step is taken first when :meth:`advance` has not been."""
        if self._data is None:
            raise RuntimeError(f"MujocoBackend has no data in state {self._state.value}")
        if self._pending:
            self.advance()
        return self._data

    @property
    def sim_time(self) -> float:
        """Simulated time [s] since configure()."""
        return float(self.data.time)

    @property
    def kp(self) -> np.ndarray:
        """Servo stiffness per joint of :attr:`joint_names` [N·m/rad] or [N/m]."""
        return self._kp[: len(self.joint_names)].copy()

    @property
    def kv(self) -> np.ndarray:
        """Servo damping per joint of :attr:`joint_names` [N·m·s/rad] or [N·s/m]."""
        return self._kv[: len(self.joint_names)].copy()

    def faults(self) -> list[HardwareFault]:
        return list(self._faults)

    # --------------------------------------------------------------------------- lifecycle

    def configure(self) -> None:
        """Compile the model with servos and set the initial configuration."""
        if self._state is not HardwareState.UNCONFIGURED:
            raise RuntimeError(f"configure() needs UNCONFIGURED, backend is {self._state.value}")
        spec = self._build_spec()
        # First compile: the reflected inertia at the initial configuration sizes the
        # armature and gains; second compile: the final model with them.
        model = spec.compile()
        data = mujoco.MjData(model)
        self._set_initial(model, data)
        inertia = _diagonal_inertia(model, data)
        total = len(self._actuated)
        omega = 2.0 * math.pi * SERVO_BANDWIDTH_HZ
        for i, name in enumerate(self._actuated):
            joint = spec.joint(name)
            dof = int(model.joint(name).dofadr[0])
            joint.armature = float(joint.armature) + ARMATURE_RATIO * inertia[dof]
            m = (1.0 + ARMATURE_RATIO) * inertia[dof]
            self._kp[i] = m * omega**2
            self._kv[i] = 2.0 * DAMPING_RATIO * m * omega
            spec.actuator(f"{name}_pos").gainprm = _prm(self._kp[i])
            spec.actuator(f"{name}_pos").biasprm = _prm(0.0, -self._kp[i], -self._kv[i])
            spec.actuator(f"{name}_ff").gainprm = _prm(self._kv[i])
        model = spec.compile()
        if not (model.geom_contype.any() or model.geom_conaffinity.any()):
            # No geom can touch another: skip the collision pass of every step (a quarter of
            # mj_step on SmartPal V, 22 -> 16 us).
            model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        data = mujoco.MjData(model)
        self._set_initial(model, data)
        assert model.nu == 2 * total
        for i, name in enumerate(self._actuated):
            joint = model.joint(name)
            self._qadr_all[i] = joint.qposadr[0]
            self._dofadr_all[i] = joint.dofadr[0]
        self._model, self._data = model, data
        # Live views into the MjData (mj_resetData keeps its buffers): ctrl is [_pos of
        # every actuated joint, _ff of every actuated joint], the exposed joints first in each.
        self._ctrl_pair = data.ctrl.reshape(2, total)[:, : len(self.joint_names)]
        self._qpos, self._qvel = data.qpos, data.qvel
        self._warnings = data.warning.number[_DIVERGENCE_SLICE]
        self._servo(on=False)
        self._divergences = self._divergence_count()
        self._state = HardwareState.INACTIVE

    def activate(self) -> None:
        """Servo on, holding the measured position. INACTIVE -> ACTIVE."""
        if self._state is HardwareState.ACTIVE:
            return
        if self._state is not HardwareState.INACTIVE:
            raise RuntimeError(f"activate() needs INACTIVE, backend is {self._state.value}")
        self._servo(on=True)
        self._state = HardwareState.ACTIVE

    def deactivate(self) -> None:
        """Servo off (quick stop). ACTIVE -> INACTIVE; a no-op in every other state."""
        if self._state is HardwareState.ACTIVE:
            self._servo(on=False)
            self._state = HardwareState.INACTIVE

    def reset_faults(self) -> bool:
        """Clear every fault: FAULT -> INACTIVE. True when the backend is in INACTIVE."""
        if self._state is HardwareState.FAULT:
            self._faults.clear()
            self._state = HardwareState.INACTIVE
        return self._state is HardwareState.INACTIVE

    def shutdown(self) -> None:
        """Release the simulation. Any state -> FINALIZED."""
        self._model = None
        self._data = None
        self._pending = _STEP_NONE
        self._faults.clear()
        self._state = HardwareState.FINALIZED

    @property
    def servo_mask(self) -> np.ndarray:
        """Servo on/off per joint of :attr:`joint_names` as last set (the array itself:
        read it, do not write it)."""
        return self._servo_mask

    def set_servo_mask(self, enabled: Sequence[bool] | np.ndarray) -> None:
        """Servo on/off per joint of :attr:`joint_names` while ACTIVE (the drive emulator
        enables each drive on its own). A joint switched on holds its measured position; a
        joint switched off keeps only the ``kv`` damping. Other joints are left as they are."""
        if self._state is not HardwareState.ACTIVE:
            raise RuntimeError(f"set_servo_mask() needs ACTIVE, backend is {self._state.value}")
        n, total = len(self.joint_names), len(self._actuated)
        mask = np.asarray(enabled, dtype=bool)
        if mask.shape != (n,):
            raise ValueError(f"servo mask has shape {mask.shape}, expected ({n},)")
        model, data = self.model, self.data
        switched_on = np.flatnonzero(mask & ~self._servo_mask)
        if switched_on.size:
            hold = data.qpos[self._qadr[switched_on]]
            data.ctrl[switched_on] = hold
            self._q_prev[switched_on] = hold
            self._v_prev[switched_on] = 0.0
        kp = np.where(mask, self._kp[:n], 0.0)
        model.actuator_gainprm[:n, 0] = kp
        model.actuator_biasprm[:n, 1] = -kp
        model.actuator_gainprm[total : total + n, 0] = np.where(mask, self._kv[:n], 0.0)
        self._servo_mask[:] = mask

    def inject_fault(self, fault: HardwareFault) -> None:
        """Raise ``fault`` as if a drive reported it (for tests): servos off, state FAULT."""
        if self._data is None:
            raise RuntimeError(f"inject_fault() needs a configured backend ({self._state.value})")
        self._enter_fault(fault)

    # ------------------------------------------------------------------------------ cycle

    def read(self) -> JointState:
        """Measured position [rad]/[m], velocity [rad/s]/[m/s], stamp = simulated time [s]."""
        data = self._data
        if data is None:
            raise RuntimeError(f"read() needs a configured backend, it is {self._state.value}")
        if self._pending:
            self.advance()
        return JointState(
            position=self._qpos[self._qadr],  # views kept since configure: gathers only
            velocity=self._qvel[self._dofadr],
            stamp=float(data.time),
        )

    def write(self, command: JointCommand) -> None:
        """Apply the set-points (ACTIVE only); the simulation advances by ``dt`` in
        :meth:`advance` (the loop's slack), or at the latest when it is next looked at."""
        model, data = self._model, self._data
        if model is None or data is None:
            return
        n = len(self.joint_names)
        position = np.asarray(command.position, dtype=float)
        velocity = np.asarray(command.velocity, dtype=float)
        if position.shape != (n,):
            raise ValueError(f"command.position has shape {position.shape}, expected ({n},)")
        if velocity.shape not in ((n,), (0,)):
            raise ValueError(f"command.velocity has shape {velocity.shape}, expected ({n},)")
        if self._pending:  # the previous write's step was not taken yet: first that one
            self.advance()
        pending = _STEP_HOLD
        if self._state is HardwareState.ACTIVE and self._compiled:
            # Contiguous float64 in (no copy when it is already): the kernel is built for it.
            position = np.ascontiguousarray(position)
            velocity = np.ascontiguousarray(velocity)
            if _servo_references(
                position, velocity, self._prev, self._fraction_array, self._references
            ):
                pending = _STEP_REFERENCES
            else:
                self._accept(position, velocity)  # a non-finite set-point: FAULT, servos off
        elif self._state is HardwareState.ACTIVE:
            np.subtract(position, self._q_prev, out=self._dq)
            if velocity.size:
                np.subtract(velocity, self._v_prev, out=self._dv)
            else:
                np.negative(self._v_prev, out=self._dv)
            # Finite set-points give a finite sum of changes (an overflow takes the long way).
            finite = math.isfinite(self._delta_flat.dot(self._ones))
            if finite or self._accept(position, velocity):
                q_next, v_next = self._next
                q_next[:] = position
                if velocity.size:
                    v_next[:] = velocity
                else:
                    v_next.fill(0.0)
                pending = _STEP_FRACTIONS
        self._pending = pending

    def advance(self) -> None:
        """Advance the simulation by ``dt`` [s] (``substeps`` MuJoCo steps) on the last
        :meth:`write`'s set-points; nothing when that is done already. :meth:`read`,
        :attr:`data` and every other look at the state do it first, so a caller that never
        calls it sees the same simulation."""
        pending = self._pending
        if not pending:
            return
        self._pending = _STEP_NONE
        model, data = self._model, self._data
        if model is None or data is None:
            return
        end_time = data.time + self._dt
        if pending == _STEP_REFERENCES:
            ctrl, references = self._ctrl_pair, self._references
            for j in range(self._substeps):
                ctrl[...] = references[j]
                mujoco.mj_step(model, data)
        elif pending == _STEP_FRACTIONS:
            prev, delta, scratch, ctrl = self._prev, self._delta, self._scratch, self._ctrl_pair
            for fraction in self._fractions:
                np.multiply(delta, fraction, out=scratch)
                np.add(prev, scratch, out=ctrl)
                mujoco.mj_step(model, data)
            prev[...] = self._next
        else:
            mujoco.mj_step(model, data, self._substeps)
        if self._divergence_count() != self._divergences:
            self._recover_divergence(end_time)

    # ---------------------------------------------------------------------------- helpers

    def _accept(self, position: np.ndarray, velocity: np.ndarray) -> bool:
        """True when every set-point is finite; otherwise FAULT naming the first bad joint."""
        finite = np.isfinite(position)
        if velocity.size:
            finite &= np.isfinite(velocity)
        if finite.all():
            return True
        i = int(np.argmin(finite))
        v = float(velocity[i]) if velocity.size else 0.0
        self._enter_fault(
            HardwareFault(
                FAULT_NON_FINITE,
                self.joint_names[i],
                f"non-finite set-point: position {float(position[i])!r}, velocity {v!r}",
            )
        )
        return False

    def _enter_fault(self, fault: HardwareFault) -> None:
        self._servo(on=False)
        self._faults.append(fault)
        self._state = HardwareState.FAULT

    def _servo(self, on: bool) -> None:
        """Servo on: hold the measured position with ``kp``/``kv``. Off: only ``kv`` damping."""
        model, data = self.model, self.data
        total = len(self._actuated)
        if on:
            qpos = data.qpos[self._qadr_all]
            data.ctrl[:total] = qpos
            self._q_prev[:] = qpos[: len(self.joint_names)]
        else:
            data.ctrl[:total] = 0.0
        data.ctrl[total:] = 0.0
        self._v_prev.fill(0.0)
        kp = self._kp if on else np.zeros(total)
        model.actuator_gainprm[:total, 0] = kp
        model.actuator_biasprm[:total, 1] = -kp
        model.actuator_gainprm[total:, 0] = self._kv if on else 0.0
        self._servo_mask.fill(on)

    def _divergence_count(self) -> int:
        # A live view of ``warning.number`` kept since configure (not three MjWarningStat
        # wrappers, nor a new array per call: this runs every cycle).
        return int(sum(self._warnings.tolist()))

    def _recover_divergence(self, now: float) -> None:
        """Put a diverged simulation back at the initial configuration at time ``now``; FAULT.

        MuJoCo has already reset the state to the model's zero pose and time 0 (its auto-reset)
        at the failing substep.
        """
        model, data = self.model, self.data
        mujoco.mj_resetData(model, data)
        self._set_initial(model, data)
        data.time = now
        self._divergences = self._divergence_count()
        self._enter_fault(
            HardwareFault(
                FAULT_NON_FINITE,
                "mujoco",
                f"simulation diverged at t = {now:.3f} s; reset to the initial configuration",
            )
        )

    def _build_spec(self) -> mujoco.MjSpec:
        spec = mujoco.MjSpec.from_file(str(self.robot.mjcf_path))
        spec.option.timestep = self._dt / self._substeps
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        # Gravity fully compensated at every body is no gravity: the flag skips both the
        # gravity terms and their compensation (a fifth of mj_step on SmartPal V).
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_GRAVITY
        for suffix in ("pos", "ff"):
            for name in self._actuated:
                spec.add_actuator(
                    name=f"{name}_{suffix}",
                    trntype=mujoco.mjtTrn.mjTRN_JOINT,
                    target=name,
                    dyntype=mujoco.mjtDyn.mjDYN_NONE,
                    gaintype=mujoco.mjtGain.mjGAIN_FIXED,
                    gainprm=_prm(0.0),
                    biastype=(
                        mujoco.mjtBias.mjBIAS_AFFINE
                        if suffix == "pos"
                        else mujoco.mjtBias.mjBIAS_NONE
                    ),
                    biasprm=_prm(),
                )
        return spec

    def _set_initial(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        for name, value in self._initial.items():
            data.qpos[model.joint(name).qposadr[0]] = value
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)


@jit.jit
def _servo_references(
    position: np.ndarray,
    velocity: np.ndarray,
    prev: np.ndarray,
    fractions: np.ndarray,
    references: np.ndarray,
) -> bool:
    """:meth:`MujocoBackend.write`'s interpolation compiled: False (nothing written) when a
    set-point is not finite; else ``references[j]`` := ``prev + fractions[j]·(new − prev)``
    per substep (rows: position, velocity; no ``velocity``: zero) and ``prev`` := the new
    set-points."""
    n = position.shape[0]
    with_velocity = velocity.shape[0] > 0
    for i in range(n):
        if not math.isfinite(position[i]) or (with_velocity and not math.isfinite(velocity[i])):
            return False
    for i in range(n):
        v = velocity[i] if with_velocity else 0.0
        dq, dv = position[i] - prev[0, i], v - prev[1, i]
        for j in range(fractions.shape[0]):
            references[j, 0, i] = prev[0, i] + dq * fractions[j]
            references[j, 1, i] = prev[1, i] + dv * fractions[j]
        prev[0, i], prev[1, i] = position[i], v
    return True


if jit.available():  # compile (or load) at import: never in a control cycle
    _servo_references(np.zeros(1), np.zeros(1), np.zeros((2, 1)), np.ones(1), np.zeros((1, 2, 1)))
    _servo_references(np.zeros(1), np.zeros(0), np.zeros((2, 1)), np.ones(1), np.zeros((1, 2, 1)))


def _prm(*values: float) -> list[float]:
    """A MuJoCo gain/bias parameter vector (10 entries) starting with ``values``."""
    return [float(v) for v in values] + [0.0] * (10 - len(values))


def _diagonal_inertia(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Diagonal of the joint-space inertia matrix at ``data``'s configuration [kg·m²]/[kg]."""
    diagonal = np.zeros(model.nv)
    unit = np.zeros(model.nv)
    column = np.zeros(model.nv)
    for i in range(model.nv):
        unit[i] = 1.0
        mujoco.mj_mulM(model, data, column, unit)
        diagonal[i] = column[i]
        unit[i] = 0.0
    return diagonal

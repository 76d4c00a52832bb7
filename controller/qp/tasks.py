"""Tasks: costs ‖J v − e‖²_W on the joint velocities ``v`` of one cycle.

Each task returns its Jacobian ``J`` (m x nv) and desired rate ``e`` (m), where
``e = feed-forward + gain · error``: the motion generator supplies the target and its rate,
the gain [1/s] pulls the measured state back onto it.

Priorities (see :mod:`controller.qp.ik`): control-point tasks are level 1, redundant-axis
tasks level 2 (solved in the null space of level 1), the posture task regularises both.
"""

from __future__ import annotations

import abc
import math

import numpy as np
import pinocchio as pin

from controller.model import jit
from controller.model.joint_chain import frame_world
from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, axis_jacobian, axis_value
from controller.vocabulary import RightLeft

#: Weight of the posture (regularisation) task, relative to weight-1 tasks of any level.
POSTURE_WEIGHT = 1e-7
#: Default feedback gain [1/s].
DEFAULT_GAIN = 20.0
#: Rotation errors are weighted as translation errors at this distance [m] from the axis.
ROTATION_SCALE = 0.3
#: Elbow tasks fade out when the elbow comes closer than this to the shoulder-wrist line [m].
ELBOW_FADE = 0.02


class Task(abc.ABC):
    """A cost on the cycle's joint velocities."""

    #: Per-row weights (length m), applied as ``W = diag(weight)``.
    weight: np.ndarray
    #: 1: control points; 2: redundant axes (null space of level 1); 0: regularisation, in both.
    level: int = 1
    #: True when J never changes: the IK then writes it into its buffers only once.
    constant_jacobian: bool = False

    @abc.abstractmethod
    def compute(self, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
        """``(J, e)`` at the state of the last ``kin.update``."""

    def compute_into(self, kin: Kinematics, jac: np.ndarray | None, rate: np.ndarray) -> None:
        """:meth:`compute` written into ``jac`` (m x nv; None: J is already there, see
        :attr:`constant_jacobian`) and ``rate`` (m), the IK's stacked buffers. Override where
        writing in place saves work."""
        J, e = self.compute(kin)
        if len(e) != len(rate):
            raise ValueError(f"{type(self).__name__} has {len(e)} rows, not {len(rate)}")
        rate[...] = e
        if jac is not None:
            jac[...] = J


class ControlPointTask(Task):
    """Drive a control point to ``target`` (original frame) with feed-forward ``twist``.

    ``twist`` [m/s, rad/s]: linear then angular velocity in the original frame's axes.
    """

    def __init__(
        self, side: RightLeft, target: pin.SE3, gain: float = DEFAULT_GAIN, weight: float = 1.0
    ):
        self.side = side
        # The task's own pose, written in place from here on (the compiled rows read its
        # rotation and translation through views made once: Pinocchio builds a new one at
        # every access).
        self._target = pin.SE3.Identity()
        self._target_arrays = (self._target.rotation, self._target.translation)
        self.target = target
        self.twist = np.zeros(6)
        self.gain = gain
        self.weight = np.array([weight] * 3 + [weight * ROTATION_SCALE**2] * 3)

    @property
    def target(self) -> pin.SE3:
        """The pose to reach [m] (original frame): the task's own, changed in place by
        :meth:`set_target` and through :attr:`target_buffers`."""
        return self._target

    @target.setter
    def target(self, target: pin.SE3) -> None:
        # Copied into the task's own pose: the task keeps no reference to ``target``.
        rotation, translation = self._target_arrays
        rotation[...] = target.rotation
        translation[...] = target.translation

    @property
    def target_buffers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The target's rotation (3x3) and translation [m] and the feed-forward twist
        [m/s, rad/s], writable in place: a motion's path writes them every cycle
        (:meth:`controller.motion.paths.LinePath.follow`) without building a pose."""
        rotation, translation = self._target_arrays
        return rotation, translation, self.twist

    @property
    def gain(self) -> float:
        """Gain of the error feedback [1/s]."""
        return self._gain

    @gain.setter
    def gain(self, gain: float) -> None:
        self._gain = float(gain)

    def set_target(self, target: pin.SE3, twist: np.ndarray | None = None) -> None:
        """Target pose and feed-forward twist (None: zero), both copied."""
        self.target = target
        if twist is None:
            self.twist.fill(0.0)
        else:
            self.twist[...] = twist

    def error(self, kin: Kinematics) -> np.ndarray:
        """Position error [m] and rotation error [rad] (target − measured, original axes)."""
        out = np.empty(6)
        pose_error(self.target, kin.pose(self.side), out)
        return out

    def compute(self, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
        rate = self.error(kin)
        rate *= self.gain
        rate += self.twist
        return kin.jacobian(self.side), rate

    def compute_into(self, kin: Kinematics, jac: np.ndarray | None, rate: np.ndarray) -> None:
        if _COMPILED:
            r_o, p_o = kin.original_arrays
            target_rotation, target_translation = self._target_arrays
            chain = kin.control_point_chain(self.side)
            if chain is not None:  # the point placed and its rows written in one call
                joint_world, columns, kinds, joint, local, support, world, placement = chain
                _control_point_task(
                    joint_world, columns, kinds, joint, local, support, world, placement, r_o,
                    p_o, target_rotation, target_translation, self.twist, self._gain,
                    jac is not None, _NO_ROWS if jac is None else jac, rate,
                )  # fmt: skip
                return
            world, rotation, translation = kin.control_point_world(self.side)
            _control_point_rows(
                world, rotation, translation, r_o, p_o, target_rotation, target_translation,
                self.twist, self._gain, jac is not None, _NO_ROWS if jac is None else jac, rate,
            )  # fmt: skip
            return
        if jac is not None:
            jac[...] = kin.jacobian(self.side)
        pose_error(self.target, kin.pose(self.side), rate)
        rate *= self.gain
        rate += self.twist


def pose_error(target: pin.SE3, pose: pin.SE3, out: np.ndarray | None = None) -> np.ndarray:
    """Position [m] and rotation [rad] error (target − pose), in the axes of the frame both
    poses are given in; written into ``out`` when given."""
    if out is None:
        out = np.empty(6)
    if _COMPILED:
        _pose_error(target.rotation, target.translation, pose.rotation, pose.translation, out)
        return out
    np.subtract(target.translation, pose.translation, out=out[:3])
    out[3:] = pin.log3((target * pose.inverse()).rotation)
    return out


#: Whether :func:`pose_error` uses its compiled form (decided at import).
_COMPILED = jit.available()


@jit.jit
def _pose_error(
    target_rot: np.ndarray,
    target_pos: np.ndarray,
    pose_rot: np.ndarray,
    pose_pos: np.ndarray,
    out: np.ndarray,
) -> None:
    """:func:`pose_error` compiled: the translation difference and ``log3(R_t R_pᵀ)`` (the
    rotation vector, angle in [0, π]; tests compare it with Pinocchio's ``log3``)."""
    for i in range(3):
        out[i] = target_pos[i] - pose_pos[i]
    r = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            r[a, b] = (
                target_rot[a, 0] * pose_rot[b, 0]
                + target_rot[a, 1] * pose_rot[b, 1]
                + target_rot[a, 2] * pose_rot[b, 2]
            )
    cos = min(max(0.5 * (r[0, 0] + r[1, 1] + r[2, 2] - 1.0), -1.0), 1.0)
    sx, sy, sz = r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]  # 2 sin θ · axis
    theta = math.atan2(0.5 * math.sqrt(sx * sx + sy * sy + sz * sz), cos)  # exact near 0, π
    if theta < 1e-4:  # θ / (2 sin θ) by its series
        k = 0.5 + theta * theta / 12.0
        out[3], out[4], out[5] = k * sx, k * sy, k * sz
    elif theta < math.pi - 1e-3:
        k = 0.5 * theta / math.sin(theta)
        out[3], out[4], out[5] = k * sx, k * sy, k * sz
    else:  # near π: the axis from the symmetric part, (R + Rᵀ)/2 − cos·I = (1 − cos) a aᵀ
        one = 1.0 - cos
        best = 0
        for i in (1, 2):
            if r[i, i] > r[best, best]:
                best = i
        col = np.empty(3)
        for i in range(3):
            col[i] = (0.5 * (r[i, best] + r[best, i]) - (cos if i == best else 0.0)) / one
        norm = math.sqrt(col[0] * col[0] + col[1] * col[1] + col[2] * col[2])
        sign = 1.0 if col[0] * sx + col[1] * sy + col[2] * sz >= 0.0 else -1.0
        k = sign * theta / norm
        out[3], out[4], out[5] = k * col[0], k * col[1], k * col[2]


@jit.jit
def _control_point_rows(
    world: np.ndarray,
    rotation: np.ndarray,
    translation: np.ndarray,
    r_o: np.ndarray,
    p_o: np.ndarray,
    target_rot: np.ndarray,
    target_pos: np.ndarray,
    twist: np.ndarray,
    gain: float,
    write_jac: bool,
    jac: np.ndarray,
    rate: np.ndarray,
) -> None:
    """:meth:`ControlPointTask.compute_into` compiled: with ``R_o``, ``p_o`` the original
    frame, the pose ``(R_oᵀ R, R_oᵀ (p − p_o))`` of the placement ``(R, p)``, ``rate`` :=
    ``gain`` · :func:`pose_error` (target − pose) + ``twist``, and (``write_jac``) ``jac`` :=
    the world Jacobian's linear and angular rows turned into the original frame's axes."""
    pose_rot = np.empty((3, 3))
    pose_pos = np.empty(3)
    for a in range(3):
        s = 0.0
        for c in range(3):
            s += r_o[c, a] * (translation[c] - p_o[c])
        pose_pos[a] = s
        for b in range(3):
            s = 0.0
            for c in range(3):
                s += r_o[c, a] * rotation[c, b]
            pose_rot[a, b] = s
    _pose_error(target_rot, target_pos, pose_rot, pose_pos, rate)
    for i in range(6):
        rate[i] = gain * rate[i] + twist[i]
    if write_jac:
        for j in range(world.shape[1]):
            for half in (0, 3):
                x, y, z = world[half, j], world[half + 1, j], world[half + 2, j]
                for a in range(3):
                    jac[half + a, j] = r_o[0, a] * x + r_o[1, a] * y + r_o[2, a] * z


@jit.jit
def _control_point_task(
    joint_world: np.ndarray,
    columns: np.ndarray,
    column_kind: np.ndarray,
    joint: int,
    local: np.ndarray,
    support: np.ndarray,
    world: np.ndarray,
    placement: np.ndarray,
    r_o: np.ndarray,
    p_o: np.ndarray,
    target_rot: np.ndarray,
    target_pos: np.ndarray,
    twist: np.ndarray,
    gain: float,
    write_jac: bool,
    jac: np.ndarray,
    rate: np.ndarray,
) -> None:
    """:func:`~controller.model.joint_chain.frame_world` (the control point's placement and
    world Jacobian into ``placement`` and ``world``, see
    :meth:`Kinematics.control_point_chain`), then :func:`_control_point_rows`: a task's cycle
    in one compiled call."""
    frame_world(joint_world, columns, column_kind, joint, local, support, world, placement)
    _control_point_rows(
        world, placement[:3], placement[3], r_o, p_o, target_rot, target_pos, twist, gain,
        write_jac, jac, rate,
    )  # fmt: skip


#: No Jacobian rows to write (a dummy of the rows' layout).
_NO_ROWS = np.zeros((8, 1), order="F")[1:7]


class AxisTask(Task):
    """Drive one redundant axis to ``target`` [rad or m] with feed-forward ``rate``.

    Level 2 by default; ``level=1`` makes it a primary task (unit moves of the vehicle).
    """

    def __init__(
        self,
        axis: RedundantAxis,
        target: float,
        gain: float = DEFAULT_GAIN,
        weight: float = 1.0,
        level: int = 2,
    ):
        self.level = level
        self.axis = axis
        self.target = target
        self.rate = 0.0
        self.gain = gain
        self.base_weight = weight
        self.weight = np.array([weight])

    def set_target(self, target: float, rate: float = 0.0) -> None:
        self.target = target
        self.rate = rate

    def error(self, kin: Kinematics) -> float:
        err = self.target - axis_value(kin, self.axis)
        return math.remainder(err, math.tau) if self.axis.is_elbow else err

    def compute(self, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
        jac, rate = np.zeros((1, kin.nv)), np.zeros(1)
        self.compute_into(kin, jac, rate)
        return jac, rate

    def compute_into(self, kin: Kinematics, jac: np.ndarray | None, rate: np.ndarray) -> None:
        """The one row, written in place (every cycle: no temporaries)."""
        axis = self.axis
        if axis.is_elbow:  # the angle loses meaning as the arm stretches: fade out
            fade = min(1.0, kin.elbow_offset(axis.side) / ELBOW_FADE)
            self.weight[0] = self.base_weight * fade * fade
        if len(rate) != 1:
            raise ValueError(f"AxisTask has 1 row, not {len(rate)}")
        if jac is not None:
            jac[0] = axis_jacobian(kin, axis)
        rate[0] = self.rate + self.gain * self.error(kin)


class PostureTask(Task):
    """Pull the joints in ``joints`` toward ``reference`` [rad, m]; keeps redundancy tame.

    Level 0 (regularisation) by default; ``level=1`` with weight 1 makes it a joint-space
    tracking task (PTP and unit moves).
    """

    constant_jacobian = True  # rows of the identity, made for ``joints`` once

    def __init__(
        self,
        reference: np.ndarray,
        joints: np.ndarray,
        gain: float = 1.0,
        weight: float = POSTURE_WEIGHT,
        level: int = 0,
    ):
        self.level = level
        self.rate = np.zeros(len(joints))
        # Own copies, contiguous and writable (what the compiled posture path is built for).
        self.reference = np.array(reference, dtype=float)
        self.joints = np.array(joints, dtype=np.int64)
        #: ``joints`` as a slice when they are consecutive (a view, not a gather, per cycle).
        self._take: slice | np.ndarray = self.joints
        if len(self.joints) and np.array_equal(
            self.joints, np.arange(self.joints[0], self.joints[0] + len(self.joints))
        ):
            self._take = slice(int(self.joints[0]), int(self.joints[-1]) + 1)
        self.gain = gain
        self.weight = np.full(len(self.joints), weight)
        self._jac: np.ndarray | None = None
        self._every = False

    def _jacobian(self, nv: int) -> np.ndarray:
        if self._jac is None or self._jac.shape[1] != nv:
            #: ``joints`` is every joint in order: no indexing needed.
            self._jac, self._every = _identity_rows(self.joints, nv)
        return self._jac

    def compute(self, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
        err = self.reference[self.joints] - kin.q[self.joints]
        return self._jacobian(kin.nv), self.rate + self.gain * err

    def compute_into(self, kin: Kinematics, jac: np.ndarray | None, rate: np.ndarray) -> None:
        if jac is not None or self._jac is None:
            J = self._jacobian(kin.nv)
            if jac is not None:
                jac[...] = J
        q, reference = kin.q, self.reference
        if self._every and len(reference) == len(q):
            np.subtract(reference, q, out=rate)
        else:
            take = self._take
            np.subtract(reference[take], q[take], out=rate)
        if self.gain != 1.0:  # x·1 = x exactly: skip the product
            rate *= self.gain
        rate += self.rate


#: Rows of the identity by (joints, nv): the Jacobians of posture tasks, shared read-only
#: (every motion makes a new posture task over the same joints; making its J cost ~8 µs).
_IDENTITY_ROWS: dict[tuple[bytes, int], tuple[np.ndarray, bool]] = {}
#: Entries :data:`_IDENTITY_ROWS` keeps at most (then it starts over).
_IDENTITY_ROWS_SIZE = 64


def _identity_rows(joints: np.ndarray, nv: int) -> tuple[np.ndarray, bool]:
    """Rows ``joints`` of the ``nv`` x ``nv`` identity (read-only), and whether ``joints``
    is every joint in order."""
    key = (joints.tobytes(), nv)
    found = _IDENTITY_ROWS.get(key)
    if found is None:
        jac = np.zeros((len(joints), nv))
        jac[np.arange(len(joints)), joints] = 1.0
        jac.flags.writeable = False
        if len(_IDENTITY_ROWS) >= _IDENTITY_ROWS_SIZE:
            _IDENTITY_ROWS.clear()
        found = _IDENTITY_ROWS[key] = (jac, bool(np.array_equal(joints, np.arange(nv))))
    return found


if _COMPILED:  # compile (or load) at import for Pinocchio's arrays: never in a control cycle
    _one = pin.SE3.Identity()
    _pose_error(_one.rotation, _one.translation, _one.rotation, _one.translation, np.empty(6))
    _rows = np.zeros((8, 2), order="F")[1:7]  # a task's rows: a slice of the F-order stack
    _control_point_rows(
        pin.Data(pin.Model()).J, _one.rotation, _one.translation, np.eye(3), np.zeros(3),
        _one.rotation, _one.translation, np.zeros(6), 1.0, True, _rows, np.zeros(6),
    )  # fmt: skip
    _placement = np.zeros((4, 3))  # the compiled kinematics' buffers (Kinematics._cp_world)
    _control_point_task(
        np.zeros((2, 4, 3)), np.zeros((1, 2, 3)), np.zeros(1, dtype=np.int64), 1,
        np.zeros((4, 3)), np.zeros(0, dtype=np.int64), np.zeros((6, 1)), _placement, np.eye(3),
        np.zeros(3), _one.rotation, _one.translation, np.zeros(6), 1.0, True, _rows,
        np.zeros(6),
    )  # fmt: skip
    _control_point_rows(
        np.zeros((6, 2)), _placement[:3], _placement[3], np.eye(3), np.zeros(3),
        _one.rotation, _one.translation, np.zeros(6), 1.0, True, _rows, np.zeros(6),
    )  # fmt: skip

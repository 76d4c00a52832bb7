"""Whole-body kinematics on Pinocchio: control points, elbow angles, waist and vehicle.

The model is the robot's generated URDF with the gripper joints locked: its configuration
``q`` holds every unit joint (vehicle x [m], y [m], θ [rad]; waist and arm joints [rad]) and
``nq == nv``. Call :meth:`Kinematics.update` once per cycle; every query after it reads the
cached results.

Frames
------
* *world*: Pinocchio's root frame, where the vehicle joints are zero.
* *original frame*: a world-fixed frame, set at start-up to the body frame's pose at the zero
  configuration and re-set by :meth:`reset_original_frame` to the body frame's current pose.
* *current frame*: the body frame (profile ``body_frame``: the first waist joint or the arm
  base), riding with the vehicle.

Jacobians are ``6 x nv`` with the linear velocity of the control point first and the angular
velocity second, both expressed in the axes of the requested frame.

Per-update cache: the elbow swivel (angle, offset, gradient) and Jacobian, the vehicle pose
and Jacobian are computed at most once per :meth:`Kinematics.update` however many tasks,
constraints and motions ask (issue 14); the composite waist rows once for good. Arrays
returned from the cache are read-only: copy before modifying. With compiled kernels
(:mod:`controller.model.jit`) the joints' placements are computed once per update when first
needed (:func:`~controller.model.joint_chain.forward`, no placements read back from
Pinocchio) and shared: the elbows' angle, offset and Jacobian row come from one call of
:func:`~controller.model.elbow.elbows_at` for all arms (with the chain's Jacobian columns),
a control point's or the body frame's (the vehicle pose's) placement and Jacobian from one
call of :func:`~controller.model.joint_chain.frame_world`. Pinocchio's own pass
(``computeJointJacobians`` + ``updateFramePlacements``) then runs only when something reads
:attr:`Kinematics.data` after an update (a control cycle does not; without the compiled
kernels every update runs it).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from controller.conversions import offset_to_se3
from controller.model import jit
from controller.model.elbow import Swivel, elbows_at, swivel
from controller.model.joint_chain import JointChain, Unsupported, frame_world
from controller.model.robot import Robot
from controller.vocabulary import FrameType, LumbarAxis, RightLeft, UnitType


class _FrameBuffers(NamedTuple):
    """A frame's arguments and outputs of :func:`frame_world`: its ``joint``, placement on
    it (``local``), the velocity columns that move it (``support``), and the Jacobian and
    placement it writes (with views of the placement's rotation and translation)."""

    joint: int
    local: np.ndarray
    support: np.ndarray
    jac: np.ndarray
    placement: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray


class Kinematics:
    """Kinematic queries for one robot; not thread-safe (one instance per control loop)."""

    def __init__(self, robot: Robot):
        self.robot = robot
        full = pin.buildModelFromUrdf(str(robot.urdf_path))
        locked = [full.getJointId(n) for n in robot.gripper_joints]
        model = pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full
        assert model.nq == model.nv, "imotion models use one-DoF joints only"
        self.nv: int = model.nv
        #: Joint names in the order of ``q``.
        self.joint_names: list[str] = [model.names[j] for j in range(1, model.njoints)]
        self._q_index = {n: model.joints[model.getJointId(n)].idx_q for n in self.joint_names}

        self._cp_frame: dict[RightLeft, int] = {}
        self._flange_frame: dict[RightLeft, int] = {}
        for side_name, arm in robot.profile.arms.items():
            side = RightLeft[side_name]
            flange = model.getFrameId(arm.flange, pin.BODY)
            parent = model.frames[flange]
            offset = offset_to_se3(arm.tool_offset.xyz, arm.tool_offset.rpy)
            frame = pin.Frame(
                f"control_point_{side_name.lower()}",
                parent.parentJoint,
                flange,
                parent.placement * offset,
                pin.FrameType.OP_FRAME,
            )
            self._flange_frame[side] = flange
            self._cp_frame[side] = model.addFrame(frame)
        self._body_frame = model.getFrameId(robot.profile.body_frame, pin.BODY)
        self._elbow_frames: dict[RightLeft, tuple[int, int, int, int]] = {}
        self._elbow_dirs: dict[RightLeft, tuple[np.ndarray, np.ndarray]] = {}
        for side_name, ref in robot.profile.redundant_axes.elbow.items():
            side = RightLeft[side_name]
            first_joint = robot.model.joint(robot.unit_joints(f"{side_name}_ARM")[0])
            base = model.getFrameId(first_joint.parent, pin.BODY)
            ids = tuple(model.getFrameId(n, pin.BODY) for n in (ref.shoulder, ref.elbow, ref.wrist))
            self._elbow_frames[side] = (base, *ids)
            f = np.asarray(ref.forward, dtype=float)
            t = np.asarray(ref.down, dtype=float)
            self._elbow_dirs[side] = (f / np.linalg.norm(f), t / np.linalg.norm(t))

        vehicle = robot.unit_joints("VEHICLE")
        #: Position of the vehicle's θ joint in ``q`` (None: no vehicle).
        self._theta_index = self._q_index[vehicle[2]] if vehicle else None
        self._units = {
            unit: np.array([self._q_index[n] for n in robot.unit_joints(unit.name)], dtype=int)
            for unit in UnitType
        }
        #: Each arm's columns: a slice when they are consecutive (a view, no copy).
        self._arm_columns: dict[RightLeft, slice | np.ndarray] = {}
        for side in self._elbow_frames:
            cols = self._units[UnitType[f"{side.name}_ARM"]]
            consecutive = len(cols) and np.array_equal(
                cols, np.arange(cols[0], cols[0] + len(cols))
            )
            self._arm_columns[side] = slice(cols[0], cols[-1] + 1) if consecutive else cols
        #: Cached per-update quantities (cleared by :meth:`update`).
        self._elbow_cache: dict[RightLeft, Swivel] = {}
        self._elbow_jac_cache: dict[RightLeft, np.ndarray] = {}
        self._vehicle_cache: tuple[np.ndarray, np.ndarray] | None = None
        self._lumbar_rows: dict[LumbarAxis, np.ndarray] = {}
        self.model = model
        self._data = model.createData()
        #: Pinocchio's pass (joint Jacobians, frame placements) done for this update's q.
        self._pin_done = False
        #: With compiled kernels: the arguments of :func:`~controller.model.elbow.elbows_at`
        #: after the placements, the arms in their order, and their (angle, offset).
        self._elbow_args: tuple[np.ndarray, ...] | None = None
        self._elbow_sides = list(self._elbow_frames)
        self._elbow_values = np.zeros((len(self._elbow_sides), 2))
        self._elbows_done = False
        #: Compiled path: each arm's position in the kernel's outputs, its (angle, offset) as
        #: floats after the last call, and its Jacobian row: a read-only view of one buffer
        #: the kernel writes in place (only the arm's columns; the others stay 0).
        self._elbow_index = {side: i for i, side in enumerate(self._elbow_sides)}
        self._elbow_list: list[list[float]] = []
        self._elbow_out = np.zeros((len(self._elbow_sides), self.nv))
        self._elbow_rows = [self._elbow_out[i] for i in range(len(self._elbow_sides))]
        for row in self._elbow_rows:
            row.flags.writeable = False
        #: The vehicle pose and rows from one compiled call (:func:`_vehicle_rows`).
        self._compiled_vehicle = jit.available()
        #: With compiled kernels: the joints' world placements and Jacobian columns, computed
        #: once per update when first needed (:meth:`_place`) and read by the elbows and the
        #: control points (None: Pinocchio's placements and Jacobians are read instead).
        self._chain: JointChain | None = None
        if jit.available():
            try:
                self._chain = JointChain(model)
            except Unsupported:
                self._chain = None
        self._placed = False
        #: Per arm, compiled: the control point's buffers for :func:`frame_world`, and that
        #: call's arguments (:meth:`control_point_chain`).
        self._cp_world: dict[RightLeft, _FrameBuffers] = {}
        self._cp_chain_args: dict[RightLeft, tuple[Any, ...]] = {}
        #: Compiled: the body frame's (the vehicle pose's), on the shared placements too,
        #: and whether they hold this update's placement.
        self._body_world: _FrameBuffers | None = None
        self._body_placed = False
        if self._chain is not None:
            chain = self._chain
            for side, fid in self._cp_frame.items():
                cp = self._cp_world[side] = self._frame_buffers(fid)
                self._set_cp_local(side)
                self._cp_chain_args[side] = (
                    chain.joint_world, chain.columns, chain.column_kind, cp.joint, cp.local,
                    cp.support, cp.jac, cp.placement,
                )  # fmt: skip
            self._body_world = self._frame_buffers(self._body_frame)
            local = model.frames[self._body_frame].placement
            self._body_world.local[:3] = local.rotation
            self._body_world.local[3] = local.translation
            if self._elbow_sides:
                self._elbow_args = self._elbow_arrays(self._chain)
        self._q = pin.neutral(model)
        self.update(self._q)
        if self._elbow_args is not None:  # compile (or load) now, not in a control cycle
            self._update_elbows()
        for side in self._cp_world:
            self.control_point_world(side)
        self._original_theta = 0.0
        self._set_original(self.data.oMf[self._body_frame].copy())

    def _frame_buffers(self, fid: int) -> _FrameBuffers:
        """Zeroed :func:`frame_world` buffers for frame ``fid`` (its ``local`` to be set)."""
        model = self.model
        joint = model.frames[fid].parentJoint
        support = [model.joints[j].idx_v for j in model.supports[joint] if j > 0]
        placement = np.zeros((4, 3))
        return _FrameBuffers(
            joint, np.zeros((4, 3)), np.array(support, dtype=np.int64), np.zeros((6, self.nv)),
            placement, placement[:3], placement[3],
        )  # fmt: skip

    # ------------------------------------------------------------------------ indexing
    def index(self, joint: str) -> int:
        """Position of a joint in ``q``."""
        return self._q_index[joint]

    def unit_indices(self, unit: UnitType) -> np.ndarray:
        """Positions in ``q`` of a unit's joints, in spec order (empty if the robot lacks it).

        The array is shared: do not modify it.
        """
        return self._units[unit]

    def home(self) -> np.ndarray:
        """The profile's home pose as a configuration vector."""
        q = np.zeros(self.nv)
        for name, value in self.robot.home().items():
            q[self._q_index[name]] = value
        return q

    @property
    def arms(self) -> list[RightLeft]:
        return list(self._cp_frame)

    # -------------------------------------------------------------------------- update
    def update(self, q: np.ndarray) -> None:
        """Compute placements and Jacobians for configuration ``q`` (SI, length ``nv``).

        ``q`` is copied: the elbows are computed from it when first asked for, and a caller
        may change its array before that."""
        self._q = np.array(q, dtype=float)
        self._pin_done = False
        if self._chain is None:  # every query reads Pinocchio's results: compute them now
            self._pin_update()
        if self._elbow_args is None:
            self._elbow_cache.clear()
            self._elbow_jac_cache.clear()
        self._elbows_done = False
        self._placed = False
        self._body_placed = False
        self._vehicle_cache = None

    @property
    def data(self) -> pin.Data:
        """Pinocchio's data at the last update's ``q`` (joint Jacobians and frame placements,
        ``computeJointJacobians`` + ``updateFramePlacements``). With the compiled joint chain
        it is computed when first asked for after an update: the cycle's queries (control
        points, elbows, vehicle) read the chain's placements and never need it."""
        if not self._pin_done:
            self._pin_update()
        return self._data

    def _pin_update(self) -> None:
        pin.computeJointJacobians(self.model, self._data, self._q)
        pin.updateFramePlacements(self.model, self._data)
        self._pin_done = True

    @property
    def _oMf(self) -> pin.StdVec_SE3:
        """The frames' world placements (:attr:`data`'s; each item access builds an SE3)."""
        return self.data.oMf

    @property
    def q(self) -> np.ndarray:
        return self._q

    # -------------------------------------------------------------------------- frames
    @property
    def original_frame(self) -> pin.SE3:
        """The original frame's pose in the world."""
        return self._original

    def body_pose(self) -> pin.SE3:
        """The current frame's (body frame's) pose in the world (a new SE3)."""
        body = self._body_world
        if body is None:
            return self.data.oMf[self._body_frame]
        self._body_placement()
        return pin.SE3(body.rotation, body.translation)

    def _body_placement(self) -> None:
        """Compiled: the body frame's placement and Jacobian into its buffers, once per
        update (the vehicle rows and every current-frame pose read them)."""
        if self._body_placed:
            return
        body, chain = self._body_world, self._chain
        assert body is not None and chain is not None
        self._place()
        self._body_placed = True
        frame_world(
            chain.joint_world, chain.columns, chain.column_kind, body.joint, body.local,
            body.support, body.jac, body.placement,
        )  # fmt: skip

    def reset_original_frame(self) -> None:
        """Original frame := the body frame's current pose (``resetOriginalFrame``)."""
        self._original_theta = self._vehicle_theta_joint()
        self._set_original(self.body_pose().copy())

    def copy_frames_from(self, other: Kinematics) -> None:
        """Take ``other``'s control-point offsets and original frame (a planning copy)."""
        for side in self.arms:
            self.set_control_point_offset(side, other.control_point_offset(side))
        self._original_theta = other._original_theta
        self._set_original(other.original_frame.copy())

    @property
    def original_theta(self) -> float:
        """Vehicle θ joint value [rad] when the original frame was set (unwraps θ)."""
        return self._original_theta

    def set_original_frame(self, pose: pin.SE3, theta: float) -> None:
        """Restore an original frame published elsewhere (pose in the world, θ joint [rad])."""
        self._original_theta = float(theta)
        self._set_original(pose.copy())

    def _set_original(self, pose: pin.SE3) -> None:
        self._vehicle_cache = None  # the vehicle pose is read in the original frame
        self._original = pose
        #: The original frame's rotation and translation [m] as arrays (for compiled code).
        self.original_arrays = (
            np.array(pose.rotation, dtype=float, order="C"),
            np.array(pose.translation, dtype=float),
        )
        rot6 = np.zeros((6, 6))
        rot6[:3, :3] = rot6[3:, 3:] = pose.rotation.T
        #: Rotation of world-aligned Jacobians into the original frame's axes (None: identity).
        self._to_original = None if np.array_equal(pose.rotation, np.eye(3)) else rot6

    def _frame_of(self, frame: FrameType) -> pin.SE3:
        return self._original if frame == FrameType.ORIGINAL_FRAME else self.body_pose()

    # ------------------------------------------------------------------ control points
    def control_point_offset(self, side: RightLeft) -> pin.SE3:
        """The control point's pose relative to the flange [m]."""
        flange = self.model.frames[self._flange_frame[side]].placement
        return flange.actInv(self.model.frames[self._cp_frame[side]].placement)

    def set_control_point_offset(self, side: RightLeft, offset: pin.SE3) -> None:
        """Move the control point to ``offset`` relative to the flange [m].

        Takes effect at the next :meth:`update`.
        """
        flange = self.model.frames[self._flange_frame[side]].placement
        self.model.frames[self._cp_frame[side]].placement = flange * offset
        if side in self._cp_world:
            self._set_cp_local(side)

    def _set_cp_local(self, side: RightLeft) -> None:
        """The compiled path's copy of the control point's placement on its joint."""
        placement = self.model.frames[self._cp_frame[side]].placement
        local = self._cp_world[side].local
        local[:3] = placement.rotation
        local[3] = placement.translation

    def placed_chain(self) -> JointChain | None:
        """The compiled joint chain placed at this update's ``q`` (placing it now if no query
        has yet), for other users of the same placements in the cycle (the collision
        distances); None without the compiled kernels. Read it, do not place it: valid until
        the next :meth:`update`."""
        if self._chain is None:
            return None
        self._place()
        return self._chain

    def _place(self) -> None:
        """The joints' world placements and Jacobian columns at this update's ``q``, once."""
        if not self._placed:
            assert self._chain is not None
            self._chain.forward(self._q)
            self._placed = True

    def flange_pose(self, side: RightLeft, frame: FrameType = FrameType.ORIGINAL_FRAME) -> pin.SE3:
        return self._frame_of(frame).actInv(self.data.oMf[self._flange_frame[side]])

    def pose(self, side: RightLeft, frame: FrameType = FrameType.ORIGINAL_FRAME) -> pin.SE3:
        """Control-point pose in the original or the current frame [m]."""
        base = self._original if frame == FrameType.ORIGINAL_FRAME else self.body_pose()
        if side in self._cp_world:  # on the shared placements (no Pinocchio pass)
            _, rotation, translation = self.control_point_world(side)
            return base.actInv(pin.SE3(rotation, translation))
        return base.actInv(self._oMf[self._cp_frame[side]])

    def jacobian(self, side: RightLeft, frame: FrameType = FrameType.ORIGINAL_FRAME) -> np.ndarray:
        """``6 x nv`` Jacobian of the control point in the original or the current frame.

        Original frame: d/dt of the pose in that (world-fixed) frame. Current frame: d/dt of the
        pose relative to the moving body frame, so vehicle motion does not show in it.
        """
        if frame == FrameType.ORIGINAL_FRAME:  # the hot path, inlined
            jac: np.ndarray = pin.getFrameJacobian(
                self.model, self.data, self._cp_frame[side], pin.LOCAL_WORLD_ALIGNED
            )
            to_original = self._to_original
            return jac if to_original is None else to_original.dot(jac)
        return self._frame_jacobian(self._cp_frame[side], frame)

    def control_point_world(self, side: RightLeft) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The control point's ``6 x nv`` Jacobian in world axes (linear, angular), its
        rotation and translation [m] in the world: what :meth:`pose` and :meth:`jacobian`
        rotate into the original frame (:attr:`original_arrays`). Not to be modified, and
        valid until the next :meth:`update` (compiled: one call on the shared placements of
        :meth:`_place`, into buffers kept for the arm; else read from Pinocchio)."""
        cp = self._cp_world.get(side)
        if cp is not None:
            chain = self._chain
            assert chain is not None
            self._place()
            frame_world(
                chain.joint_world, chain.columns, chain.column_kind, cp.joint, cp.local,
                cp.support, cp.jac, cp.placement,
            )  # fmt: skip
            return cp.jac, cp.rotation, cp.translation
        fid = self._cp_frame[side]
        jac = pin.getFrameJacobian(self.model, self.data, fid, pin.LOCAL_WORLD_ALIGNED)
        placement = self._oMf[fid]
        return jac, placement.rotation, placement.translation

    def control_point_chain(self, side: RightLeft) -> tuple[Any, ...] | None:
        """Compiled: :func:`~controller.model.joint_chain.frame_world`'s arguments for the
        control point on this update's placements (computed here if needed), for a kernel
        that places the point itself (the control-point task's); None without the chain."""
        args = self._cp_chain_args.get(side)
        if args is not None:
            self._place()
        return args

    def _frame_jacobian(self, fid: int, frame: FrameType) -> np.ndarray:
        jac: np.ndarray = pin.getFrameJacobian(self.model, self.data, fid, pin.LOCAL_WORLD_ALIGNED)
        if frame == FrameType.ORIGINAL_FRAME:
            to_original = self._to_original
            return jac if to_original is None else to_original.dot(jac)
        else:
            # Subtract the body's rigid motion carried to the control point.
            body = self.body_pose()
            jb = pin.getFrameJacobian(
                self.model, self.data, self._body_frame, pin.LOCAL_WORLD_ALIGNED
            )
            lever = self.data.oMf[fid].translation - body.translation
            jac = jac - np.vstack([jb[:3] - pin.skew(lever) @ jb[3:], jb[3:]])
            rot = body.rotation.T
        out = np.empty_like(jac)
        out[:3] = rot @ jac[:3]
        out[3:] = rot @ jac[3:]
        return out

    # --------------------------------------------------------------------------- elbow
    def has_elbow(self, side: RightLeft) -> bool:
        return side in self._elbow_frames

    def _swivel(self, side: RightLeft) -> Swivel:
        cached = self._elbow_cache.get(side)
        if cached is None:
            cached = self._elbow_cache[side] = self._compute_swivel(side)
        return cached

    def _compute_swivel(self, side: RightLeft) -> Swivel:
        # The swivel angle is built from dot and cross products only, so it is the same in
        # any frame: rotate the two reference directions (2 products) rather than the three
        # points, and the gradients come out in world axes, as the frame Jacobians are.
        base, fs, fe, fw = self._elbow_frames[side]
        forward, down = self._elbow_dirs[side]
        p = self.data.oMf
        r_base = p[base].rotation
        return swivel(
            p[fs].translation, p[fe].translation, p[fw].translation, r_base @ forward, r_base @ down
        )

    def _elbow_arrays(self, chain: JointChain) -> tuple[np.ndarray, ...]:
        """:func:`~controller.model.elbow.elbows_at`'s arguments after the joints' placements,
        for this model's arms: each arm's four frames (arm base, shoulder, elbow, wrist) as
        their joint and placement on it, directions, the chain's velocity columns, the arm's
        columns and which of them move each point."""
        model, sides = self.model, self._elbow_sides
        n = len(sides)
        width = max(len(self._units[UnitType[f"{side.name}_ARM"]]) for side in sides)
        frame_joint = np.zeros((n, 4), dtype=np.int64)
        frame_local = np.zeros((n, 4, 4, 3))
        directions = np.zeros((n, 2, 3))
        arm_columns = np.zeros((n, width), dtype=np.int64)
        counts = np.zeros(n, dtype=np.int64)
        masks = np.zeros((n, 3, width))
        column_joint = {model.joints[j].idx_v: j for j in range(1, model.njoints)}
        for i, side in enumerate(sides):
            for k, fid in enumerate(self._elbow_frames[side]):
                frame = model.frames[fid]
                frame_joint[i, k] = frame.parentJoint
                frame_local[i, k, :3] = frame.placement.rotation
                frame_local[i, k, 3] = frame.placement.translation
            directions[i] = self._elbow_dirs[side]  # forward, down (arm base)
            cols = self._units[UnitType[f"{side.name}_ARM"]]
            counts[i] = len(cols)
            arm_columns[i, : len(cols)] = cols
            for k, fid in enumerate(self._elbow_frames[side][1:]):
                moves = set(model.supports[model.frames[fid].parentJoint])
                masks[i, k, : len(cols)] = [column_joint[c] in moves for c in cols.tolist()]
        return (
            frame_joint, frame_local, directions, chain.columns, chain.column_kind, arm_columns,
            counts, masks,
        )  # fmt: skip

    def _update_elbows(self) -> None:
        """Every arm's elbow angle, offset and Jacobian row in one compiled call, into the
        buffers :meth:`elbow_angle`, :meth:`elbow_offset` and :meth:`elbow_jacobian` read."""
        assert self._elbow_args is not None and self._chain is not None
        self._place()
        elbows_at(self._elbow_out, self._elbow_values, self._chain.joint_world, *self._elbow_args)
        self._elbow_list = self._elbow_values.tolist()
        self._elbows_done = True

    def elbow_angle(self, side: RightLeft) -> float:
        """Elbow (swivel) angle [rad]; see :mod:`controller.model.elbow` for the definition."""
        if self._elbow_args is None:
            return self._swivel(side).angle
        if not self._elbows_done:
            self._update_elbows()
        return self._elbow_list[self._elbow_index[side]][0]

    def elbow_offset(self, side: RightLeft) -> float:
        """Distance [m] of the elbow from the shoulder-wrist line (0 = fully stretched)."""
        if self._elbow_args is None:
            return self._swivel(side).offset
        if not self._elbows_done:
            self._update_elbows()
        return self._elbow_list[self._elbow_index[side]][1]

    def elbow_jacobian(self, side: RightLeft) -> np.ndarray:
        """``nv`` gradient of the elbow angle [rad per unit of q]; zero off the arm's joints.

        Read-only, valid until the next :meth:`update` (the compiled path writes the next
        configuration's row into the same array then: copy it to keep it)."""
        if self._elbow_args is not None:
            if not self._elbows_done:
                self._update_elbows()
            return self._elbow_rows[self._elbow_index[side]]
        cached = self._elbow_jac_cache.get(side)
        if cached is None:
            cached = self._elbow_jac_cache[side] = self._compute_elbow_jacobian(side)
        return cached

    def _compute_elbow_jacobian(self, side: RightLeft) -> np.ndarray:
        sw = self._swivel(side)
        _, fs, fe, fw = self._elbow_frames[side]
        model, data, world = self.model, self.data, pin.LOCAL_WORLD_ALIGNED
        # The angle is invariant to the arm base's motion: the arm's own columns only.
        arm = self._arm_columns[side]
        row = sw.grad_shoulder.dot(pin.getFrameJacobian(model, data, fs, world)[:3, arm])
        row += sw.grad_elbow.dot(pin.getFrameJacobian(model, data, fe, world)[:3, arm])
        row += sw.grad_wrist.dot(pin.getFrameJacobian(model, data, fw, world)[:3, arm])
        out = np.zeros(self.nv)
        out[arm] = row
        out.flags.writeable = False
        return out

    # ------------------------------------------------------------------ waist, vehicle
    def lumbar_axes(self) -> list[LumbarAxis]:
        return [LumbarAxis(a) for a in self.robot.profile.redundant_axes.lumbar]

    def lumbar_jacobian(self, axis: LumbarAxis) -> np.ndarray:
        """``nv`` row mapping joint velocities to the composite waist angle's rate (constant:
        built once, read-only)."""
        row = self._lumbar_rows.get(axis)
        if row is None:
            row = np.zeros(self.nv)
            for name, weight in self.robot.profile.redundant_axes.lumbar[axis.value].items():
                row[self._q_index[name]] = weight
            row.flags.writeable = False
            self._lumbar_rows[axis] = row
        return row

    def lumbar_angle(self, axis: LumbarAxis) -> float:
        """Composite waist angle [rad] (e.g. SmartPal V lumbarRy = lower + upper pitch)."""
        return float(self.lumbar_jacobian(axis).dot(self._q))

    @property
    def has_vehicle(self) -> bool:
        return bool(self.robot.unit_joints("VEHICLE"))

    def _vehicle_theta_joint(self) -> float:
        theta = self._theta_index
        return 0.0 if theta is None else float(self._q[theta])

    def vehicle_pose(self) -> np.ndarray:
        """Planar pose (x [m], y [m], θ [rad]) of the body frame in the original frame.

        θ is unwrapped (taken from the θ joint), so a vehicle that turned twice reads 4π.
        Read-only (cached until the next :meth:`update`).
        """
        return self._vehicle()[0]

    def vehicle_jacobian(self) -> np.ndarray:
        """``3 x nv`` Jacobian of :meth:`vehicle_pose` (read-only, cached per update)."""
        return self._vehicle()[1]

    def _vehicle(self) -> tuple[np.ndarray, np.ndarray]:
        cached = self._vehicle_cache
        if cached is None and self._compiled_vehicle:
            body = self._body_world
            if body is not None:  # the body frame on the shared placements
                self._body_placement()
                world, translation = body.jac, body.translation
            else:
                fid = self._body_frame
                world = pin.getFrameJacobian(self.model, self.data, fid, pin.LOCAL_WORLD_ALIGNED)
                translation = self._oMf[fid].translation
            theta = self._vehicle_theta_joint() - self._original_theta
            pose, rows = np.empty(3), np.empty((3, self.nv))
            r_o, p_o = self.original_arrays
            _vehicle_rows(world, translation, r_o, p_o, theta, pose, rows)
            pose.flags.writeable = False
            rows.flags.writeable = False
            cached = self._vehicle_cache = (pose, rows)
        elif cached is None:
            rel = self._original.actInv(self.body_pose())
            theta = self._vehicle_theta_joint() - self._original_theta
            pose = np.array([rel.translation[0], rel.translation[1], theta])
            jac = self._frame_jacobian(self._body_frame, FrameType.ORIGINAL_FRAME)
            rows = np.vstack([jac[0], jac[1], jac[5]])
            pose.flags.writeable = False
            rows.flags.writeable = False
            cached = self._vehicle_cache = (pose, rows)
        return cached


@jit.jit
def _vehicle_rows(
    world: np.ndarray,
    translation: np.ndarray,
    r_o: np.ndarray,
    p_o: np.ndarray,
    theta: float,
    pose: np.ndarray,
    rows: np.ndarray,
) -> None:
    """:meth:`Kinematics.vehicle_pose` and :meth:`Kinematics.vehicle_jacobian` compiled: the
    body frame's x, y [m] in the original frame ``(r_o, p_o)`` and ``theta``, and the rows
    of x, y (linear) and θ (angular z) of its world Jacobian ``world`` in the original
    frame's axes."""
    for a in range(2):
        pose[a] = (
            r_o[0, a] * (translation[0] - p_o[0])
            + r_o[1, a] * (translation[1] - p_o[1])
            + r_o[2, a] * (translation[2] - p_o[2])
        )
    pose[2] = theta
    for j in range(world.shape[1]):
        x, y, z = world[0, j], world[1, j], world[2, j]
        rows[0, j] = r_o[0, 0] * x + r_o[1, 0] * y + r_o[2, 0] * z
        rows[1, j] = r_o[0, 1] * x + r_o[1, 1] * y + r_o[2, 1] * z
        rows[2, j] = r_o[0, 2] * world[3, j] + r_o[1, 2] * world[4, j] + r_o[2, 2] * world[5, j]


if jit.available():  # compile (or load) at import, for Pinocchio's arrays: never in a cycle
    _vehicle_rows(
        pin.Data(pin.Model()).J, pin.SE3.Identity().translation, np.eye(3), np.zeros(3), 0.0,
        np.zeros(3), np.zeros((3, 0)),
    )  # fmt: skip

"""A Pinocchio model's joints as packed arrays, and their forward kinematics compiled.

Reading placements back from Pinocchio costs ~1 µs per frame in Python (each access builds an
SE3 object and its arrays), more than computing them: :func:`forward` recomputes every
joint's world placement and Jacobian column of a configuration in one compiled call
(~1 µs for SmartPal V's 27 joints). The collision kernels
(:mod:`controller.model.collision_kernel`), the elbow angles
(:func:`controller.model.elbow.elbows_at`) and the control points (:func:`frame_world`,
through :class:`controller.model.kinematics.Kinematics`) read them.

Placements are stored as 4 x 3 arrays: rows 0-2 the rotation, row 3 the translation [m].
Only 1-dof revolute and prismatic joints are supported (:class:`Unsupported` otherwise);
callers fall back to Pinocchio then.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from controller.model.jit import jit

#: Joint kinds: the column of a revolute joint turns points about its axis, a prismatic one
#: moves them along it.
REVOLUTE, PRISMATIC = 0, 1


class Unsupported(ValueError):
    """The model or geometry has something the compiled kernels do not handle."""


@jit
def compose(world: np.ndarray, frame: np.ndarray, out: np.ndarray) -> None:
    """``out`` := ``world`` ∘ ``frame``, placements as rotation rows 0-2 and translation
    row 3 (``frame`` may have more rows: only 0-3 are read)."""
    for a in range(3):
        s = world[3, a]
        for b in range(3):
            s += world[a, b] * frame[3, b]
        out[3, a] = s
        for b in range(3):
            s = 0.0
            for c in range(3):
                s += world[a, c] * frame[c, b]
            out[a, b] = s


@jit
def forward(
    q: np.ndarray,
    joint_int: np.ndarray,
    joint_frame: np.ndarray,
    joint_world: np.ndarray,
    columns: np.ndarray,
    column_kind: np.ndarray,
) -> None:
    """The joints' world placements ``joint_world`` at ``q`` [rad, m] (joint 0, the world,
    is left as it is) and the Jacobian ``columns`` by velocity index (world axis, a point
    of it [m]) with their kinds, from ``joint_int`` (parent, kind, velocity index) and
    ``joint_frame`` (placement rotation, translation, axis). Parents come before children."""
    r = np.empty((4, 3))  # a joint's placement before its motion
    for j in range(1, joint_int.shape[0]):
        p, kind, v = joint_int[j, 0], joint_int[j, 1], joint_int[j, 2]
        compose(joint_world[p], joint_frame[j], r)
        x = q[v]
        ux, uy, uz = joint_frame[j, 4, 0], joint_frame[j, 4, 1], joint_frame[j, 4, 2]
        for a in range(3):
            columns[v, 0, a] = r[a, 0] * ux + r[a, 1] * uy + r[a, 2] * uz
        column_kind[v] = kind
        for a in range(3):
            joint_world[j, 3, a] = r[3, a]
        if kind == REVOLUTE:
            co, si = math.cos(x), math.sin(x)
            t = 1.0 - co
            m00, m01, m02 = co + ux * ux * t, ux * uy * t - uz * si, ux * uz * t + uy * si
            m10, m11, m12 = uy * ux * t + uz * si, co + uy * uy * t, uy * uz * t - ux * si
            m20, m21, m22 = uz * ux * t - uy * si, uz * uy * t + ux * si, co + uz * uz * t
            for a in range(3):
                r0, r1, r2 = r[a, 0], r[a, 1], r[a, 2]
                joint_world[j, a, 0] = r0 * m00 + r1 * m10 + r2 * m20
                joint_world[j, a, 1] = r0 * m01 + r1 * m11 + r2 * m21
                joint_world[j, a, 2] = r0 * m02 + r1 * m12 + r2 * m22
        else:
            for a in range(3):
                joint_world[j, 3, a] += columns[v, 0, a] * x
                for b in range(3):
                    joint_world[j, a, b] = r[a, b]
        for a in range(3):
            columns[v, 1, a] = joint_world[j, 3, a]


@jit
def frame_world(
    joint_world: np.ndarray,
    columns: np.ndarray,
    column_kind: np.ndarray,
    joint: int,
    local: np.ndarray,
    support: np.ndarray,
    jac: np.ndarray,
    placement: np.ndarray,
) -> None:
    """A frame's world ``placement`` (4 x 3) and its ``6 x nv`` Jacobian ``jac`` in world
    axes at the frame's origin (Pinocchio's LOCAL_WORLD_ALIGNED: linear [m/s], angular
    [rad/s] per unit of velocity), after :func:`forward`: the frame sits at ``local`` on
    ``joint``, which the velocity columns ``support`` move. Other columns are left at 0
    (``jac`` is written only there: zero it once)."""
    compose(joint_world[joint], local, placement)
    px, py, pz = placement[3, 0], placement[3, 1], placement[3, 2]
    for k in range(support.shape[0]):
        v = support[k]
        ax, ay, az = columns[v, 0, 0], columns[v, 0, 1], columns[v, 0, 2]
        if column_kind[v] == REVOLUTE:
            dx, dy, dz = px - columns[v, 1, 0], py - columns[v, 1, 1], pz - columns[v, 1, 2]
            jac[0, v] = ay * dz - az * dy
            jac[1, v] = az * dx - ax * dz
            jac[2, v] = ax * dy - ay * dx
            jac[3, v], jac[4, v], jac[5, v] = ax, ay, az
        else:
            jac[0, v], jac[1, v], jac[2, v] = ax, ay, az
            jac[3, v] = jac[4, v] = jac[5, v] = 0.0


class JointChain:
    """The arrays :func:`forward` reads and writes for one model (written in place, never
    replaced; not thread-safe: one per user).

    ``joint_int`` (parent, kind, velocity index), ``joint_frame`` (placement rotation rows,
    translation, axis), ``joint_world`` (rotation rows, translation [m]), ``columns`` (axis,
    origin [m]) and ``column_kind`` by velocity index. Raises :class:`Unsupported` for
    joints other than 1-dof revolute/prismatic ones."""

    def __init__(self, model: pin.Model):
        nj = model.njoints
        data = model.createData()
        pin.forwardKinematics(model, data, pin.neutral(model))
        self.joint_int = np.zeros((nj, 3), dtype=np.int64)
        self.joint_frame = np.zeros((nj, 5, 3))
        for j in range(1, nj):
            joint = model.joints[j]
            if joint.nq != 1 or joint.nv != 1 or joint.idx_q != joint.idx_v:
                raise Unsupported(f"joint {model.names[j]!r} ({joint.shortname()}) is not 1-dof")
            motion = np.asarray(data.joints[j].S).ravel()
            linear, angular = motion[:3], motion[3:]
            if np.linalg.norm(angular) > 0.5 and np.linalg.norm(linear) < 1e-12:
                kind, axis = REVOLUTE, angular
            elif np.linalg.norm(linear) > 0.5 and np.linalg.norm(angular) < 1e-12:
                kind, axis = PRISMATIC, linear
            else:
                raise Unsupported(f"joint {model.names[j]!r} ({joint.shortname()})")
            self.joint_int[j] = model.parents[j], kind, joint.idx_v
            placement = model.jointPlacements[j]
            self.joint_frame[j, :3] = placement.rotation
            self.joint_frame[j, 3] = placement.translation
            self.joint_frame[j, 4] = axis
        self.joint_world = np.zeros((nj, 4, 3))
        self.joint_world[0, :3] = np.eye(3)
        self.columns = np.zeros((model.nv, 2, 3))
        self.column_kind = np.zeros(model.nv, dtype=np.int64)
        #: :func:`forward`'s arguments after ``q``.
        self.arrays = (
            self.joint_int,
            self.joint_frame,
            self.joint_world,
            self.columns,
            self.column_kind,
        )

    def forward(self, q: np.ndarray) -> None:
        """:func:`forward` at ``q`` [rad, m]."""
        forward(q, *self.arrays)

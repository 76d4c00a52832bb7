"""The gateway's view of the robot: the published snapshot, seen through kinematics.

Queries (feedback poses, joints, gripper openings) and motion planning both need the robot's
kinematics at its measured state. Each :class:`RobotView` owns one :class:`Kinematics`,
refreshed from the snapshot (joints, original frame, control-point offsets) under a lock;
the gateway keeps one view for queries and one for planning so a long reachability check
never holds up a getFeedbackPos call.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pinocchio as pin

from controller.contract.snapshot import Snapshot, SnapshotReader, StateHeader
from controller.conversions import m_to_mm, rad_to_deg
from controller.model.kinematics import Kinematics
from controller.model.robot import Robot
from controller.vocabulary import FrameType, RightLeft, UnitType

#: Answers of :meth:`RobotView.pose` kept (a few snapshots' worth of both arms and frames).
POSE_CACHE = 16


def pose_inputs(snap: Snapshot) -> tuple[bytes, bytes, bytes, float]:
    """What a control-point pose of ``snap`` depends on: the measured joints, the
    control-point offsets and the original frame (a key: equal inputs, equal poses)."""
    return (snap.q.tobytes(), snap.offsets.tobytes(), snap.original.tobytes(), snap.original_theta)


class RobotView:
    def __init__(self, robot: Robot, reader: SnapshotReader, hw_joints: list[str]):
        self.robot = robot
        self.reader = reader
        self.kin = Kinematics(robot)
        self.hw_joints = list(hw_joints)
        self.hw_index = np.array([self.hw_joints.index(n) for n in self.kin.joint_names])
        self._lock = threading.Lock()
        #: The snapshot frames (offsets, original frame, θ) ``kin`` was last given.
        self._frames: tuple[bytes, bytes, float] | None = None
        self.arms = self.kin.arms
        #: Recent answers of :meth:`pose` by what they depend on.
        self._poses: dict[tuple[object, ...], tuple[pin.SE3, float]] = {}

    def snapshot(self) -> Snapshot:
        return self.reader.read()

    def state(self) -> StateHeader:
        return self.reader.read_state()

    @contextmanager
    def at(self, snap: Snapshot, q: np.ndarray | None = None) -> Iterator[Kinematics]:
        """The kinematics at ``snap`` (or at configuration ``q`` with ``snap``'s frames)."""
        with self._lock:
            yield self._set(snap, q)

    def _set(self, snap: Snapshot, q: np.ndarray | None) -> Kinematics:
        """``kin`` at ``snap`` (or ``q``); the caller holds ``_lock``."""
        kin = self.kin
        # The frames change only on a command (setControlPointOffset, resetOriginalFrame):
        # set again only when they did (~70 us saved per call). This is the only place
        # that sets this Kinematics' frames.
        frames = (snap.offsets.tobytes(), snap.original.tobytes(), snap.original_theta)
        if frames != self._frames:
            for k, side in enumerate((RightLeft.RIGHT, RightLeft.LEFT)):
                if side in kin.arms:
                    off = np.vstack([snap.offsets[k], [0.0, 0.0, 0.0, 1.0]])
                    kin.set_control_point_offset(side, pin.SE3(off))
            # The controller publishes its frames before the gateway starts: always valid.
            original = np.vstack([snap.original, [0.0, 0.0, 0.0, 1.0]])
            kin.set_original_frame(pin.SE3(original), snap.original_theta)
            self._frames = frames
        kin.update(snap.q[self.hw_index] if q is None else q)
        return kin

    def measured_q(self, snap: Snapshot) -> np.ndarray:
        """Kinematic configuration (SI) of a snapshot."""
        return snap.q[self.hw_index]

    def unit_joint_names(self, unit: UnitType) -> tuple[str, ...]:
        return self.robot.unit_joints(unit.name)

    def has_unit(self, unit: UnitType) -> bool:
        return bool(self.unit_joint_names(unit))

    def unit_positions(self, snap: Snapshot, unit: UnitType, commanded: bool = False) -> np.ndarray:
        """A unit's joints in spec units: deg; vehicle x, y in mm and θ in deg (original
        frame). ``commanded``: the controller's command instead of the measurement."""
        q = snap.q_cmd if commanded else snap.q
        if unit == UnitType.VEHICLE:
            with self.at(snap, q[self.hw_index] if commanded else None) as kin:
                x, y, th = kin.vehicle_pose()
            return np.array([*m_to_mm([x, y]), rad_to_deg(th)])
        out = []
        for name in self.unit_joint_names(unit):
            spec = self.robot.joints[name]
            value = q[self.hw_joints.index(name)]
            out.append(rad_to_deg(value) if spec.kind == "revolute" else m_to_mm(value))
        return np.array(out)

    def unit_limits(self, unit: UnitType) -> list[tuple[float, float]]:
        """``(upper, lower)`` position limits of a unit's joints, spec units (none for the
        vehicle, whose x, y, θ are not joints)."""
        if unit == UnitType.VEHICLE:
            return []
        out = []
        for name in self.unit_joint_names(unit):
            spec = self.robot.joints[name]
            if spec.kind == "revolute":
                out.append((float(rad_to_deg(spec.upper)), float(rad_to_deg(spec.lower))))
            else:
                out.append((float(m_to_mm(spec.upper)), float(m_to_mm(spec.lower))))
        return out

    def pose(self, snap: Snapshot, side: RightLeft, frame: FrameType) -> tuple[pin.SE3, float]:
        """Control-point pose [m] in ``frame`` and elbow angle [rad] (0 for 6-axis arms).

        A function of the snapshot's measured joints, frames and offsets alone: the answers
        for the last few of those are kept, so clients polling a robot that stands still (or
        several within one cycle) cost a look-up (~5 us), not the kinematics (~110 us).
        """
        key = (side, frame, *pose_inputs(snap))
        known = self._poses.get(key)
        if known is None:
            with self._lock:
                # Again under the lock: readers of one snapshot arriving together (the
                # first computing, the others waiting here) run the kinematics once.
                known = self._poses.get(key)
                if known is None:
                    kin = self._set(snap, None)
                    known = (kin.pose(side, frame).copy(), self._elbow(kin, side))
                    if len(self._poses) >= POSE_CACHE:
                        self._poses.clear()
                    self._poses[key] = known
        return known[0].copy(), known[1]

    @staticmethod
    def _elbow(kin: Kinematics, side: RightLeft) -> float:
        return kin.elbow_angle(side) if kin.has_elbow(side) else 0.0

    def gripper_ratio(self, snap: Snapshot, side: RightLeft) -> float | None:
        """Opening 0 (closed) .. 1 (open) from the gripper's first joint; None: no gripper."""
        g = next((v for k, v in self.robot.profile.grippers.items() if k == side.name), None)
        if g is None or g.joints[0] not in self.hw_joints:
            return None
        spec = self.robot.joints[g.joints[0]]
        pos = snap.q[self.hw_joints.index(g.joints[0])]
        lo, hi = spec.to_si(g.closed[0]), spec.to_si(g.open[0])
        return float(np.clip((pos - lo) / (hi - lo), 0.0, 1.0))

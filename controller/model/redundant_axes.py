"""The redundant axes of Spec A as one concept: a scalar value and its Jacobian row.

=================  ===========================================  ============
axis               value                                        unit (SI)
=================  ===========================================  ============
rightElbow         elbow (swivel) angle of the right 7-axis arm  [rad]
leftElbow          elbow angle of the left 7-axis arm            [rad]
lumbarRx/Ry/Rz     composite waist angle (profile weights)       [rad]
vehicleX/Y         body-frame origin in the original frame       [m]
vehicleTheta       body-frame heading in the original frame      [rad]
=================  ===========================================  ============

Which axes a robot has follows from its profile (see :func:`available_axes`).
"""

from __future__ import annotations

import enum

import numpy as np

from controller.model.kinematics import Kinematics
from controller.vocabulary import LumbarAxis, RightLeft, UnitType


class RedundantAxis(enum.Enum):
    RIGHT_ELBOW = "rightElbow"
    LEFT_ELBOW = "leftElbow"
    LUMBAR_RX = "lumbarRx"
    LUMBAR_RY = "lumbarRy"
    LUMBAR_RZ = "lumbarRz"
    VEHICLE_X = "vehicleX"
    VEHICLE_Y = "vehicleY"
    VEHICLE_THETA = "vehicleTheta"

    def __init__(self, value: str) -> None:
        # Worked out once per member: the cycle asks these several times per axis.
        #: An arm's elbow angle.
        self.is_elbow = value in ("rightElbow", "leftElbow")
        #: A composite waist angle.
        self.is_lumbar = value.startswith("lumbar")
        #: A vehicle coordinate.
        self.is_vehicle = value.startswith("vehicle")
        self._side = RightLeft.RIGHT if value == "rightElbow" else RightLeft.LEFT
        self._lumbar = LumbarAxis(value.removeprefix("lumbar")) if self.is_lumbar else None
        vehicle = ("vehicleX", "vehicleY", "vehicleTheta")
        self._vehicle_index = vehicle.index(value) if self.is_vehicle else -1

    @property
    def side(self) -> RightLeft:
        """The arm of an elbow axis."""
        return self._side

    @property
    def lumbar(self) -> LumbarAxis:
        """The waist angle of a lumbar axis (ValueError for other axes)."""
        if self._lumbar is None:
            raise ValueError(f"{self.value} is not a waist axis")
        return self._lumbar

    @property
    def vehicle_index(self) -> int:
        """0, 1, 2 for a vehicle axis's x, y, θ (ValueError for other axes)."""
        if self._vehicle_index < 0:
            raise ValueError(f"{self.value} is not a vehicle axis")
        return self._vehicle_index


def elbow_axis(side: RightLeft) -> RedundantAxis:
    return RedundantAxis.RIGHT_ELBOW if side == RightLeft.RIGHT else RedundantAxis.LEFT_ELBOW


def available_axes(kin: Kinematics) -> list[RedundantAxis]:
    """The robot's redundant axes, in :class:`RedundantAxis` order."""
    out = []
    for axis in RedundantAxis:
        if axis.is_elbow:
            ok = kin.has_elbow(axis.side)
        elif axis.is_lumbar:
            ok = axis.lumbar in kin.lumbar_axes()
        else:
            ok = kin.has_vehicle
        if ok:
            out.append(axis)
    return out


def axis_value(kin: Kinematics, axis: RedundantAxis) -> float:
    """Current value of ``axis`` (SI) from the last :meth:`Kinematics.update`."""
    if axis.is_elbow:
        return kin.elbow_angle(axis.side)
    if axis.is_lumbar:
        return kin.lumbar_angle(axis.lumbar)
    return float(kin.vehicle_pose()[axis.vehicle_index])


def axis_jacobian(kin: Kinematics, axis: RedundantAxis) -> np.ndarray:
    """``nv`` row: rate of ``axis`` per joint velocity."""
    if axis.is_elbow:
        return kin.elbow_jacobian(axis.side)
    if axis.is_lumbar:
        return kin.lumbar_jacobian(axis.lumbar)
    row: np.ndarray = kin.vehicle_jacobian()[axis.vehicle_index]
    return row


def axis_joints(kin: Kinematics, axis: RedundantAxis) -> np.ndarray:
    """Indices in ``q`` of the joints that move ``axis`` alone (lumbar: its weighted joints;
    vehicle: the vehicle joints; elbow: the arm's joints)."""
    if axis.is_elbow:
        return kin.unit_indices(UnitType[f"{axis.side.name}_ARM"])
    if axis.is_lumbar:
        return np.flatnonzero(kin.lumbar_jacobian(axis.lumbar))
    return kin.unit_indices(UnitType.VEHICLE)

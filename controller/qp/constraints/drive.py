"""The differential drive's row: a two-wheeled base cannot move sideways."""

from __future__ import annotations

import math

import numpy as np

from controller.model.kinematics import Kinematics
from controller.qp.constraints.protocol import (
    ConstraintSetup,
    CycleState,
    Level,
    Relaxation,
    RowBlock,
)
from controller.vocabulary import UnitType


class DifferentialDrive:
    """No sideways body velocity: ``−sinθ·ẋ + cosθ·ẏ = 0`` [m/s] at the measured heading θ.

    Physics, not a preference: never relaxed. Its coefficients are on the vehicle's x and y
    only, so with the base frozen the IK checks the row instead of solving it (it holds at
    rest).
    """

    name = "differential drive"
    levels = Level.BOTH
    relaxation = Relaxation.HARD
    max_rows = 1
    holds_at_rest = True

    def __init__(self, kin: Kinematics):
        x, y, heading = (int(i) for i in kin.unit_indices(UnitType.VEHICLE))
        self._x, self._y, self._heading = x, y, heading
        #: The vehicle's x and y joints.
        self.joints = np.array([x, y])

    @staticmethod
    def applies(kin: Kinematics) -> bool:
        """Whether ``kin``'s robot has a differential base."""
        vehicle = kin.robot.profile.vehicle
        return vehicle is not None and vehicle.type == "differential"

    def configure(self, kin: Kinematics, setup: ConstraintSetup) -> None:
        """Nothing to configure: the row always applies."""

    def compute_qp_inequalities(self, cycle: CycleState, rows: RowBlock) -> int:
        theta = float(cycle.kin.q[self._heading])
        C = rows.C
        C[0, self._x] = -math.sin(theta)
        C[0, self._y] = math.cos(theta)
        rows.lo[0] = rows.hi[0] = 0.0
        return 1

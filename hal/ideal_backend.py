"""Perfect drives: the measured state is exactly the last command (no dynamics, no delay).

For tests that check the controller's own guarantees (limits, masks, paths) quickly and
without the tracking error of a simulated plant. Lifecycle as in :mod:`hal.interface`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from controller.model.robot import Robot
from hal.interface import HardwareFault, HardwareInterface, HardwareState, JointCommand, JointState


class IdealBackend(HardwareInterface):
    """Position = commanded position, velocity = commanded velocity, time += dt per write."""

    def __init__(
        self,
        robot: Robot,
        dt: float,
        joint_names: Sequence[str] | None = None,
        initial: dict[str, float] | None = None,
    ):
        units = [n for joints in robot.profile.units.values() for n in joints]
        self.joint_names = tuple(joint_names or (*units, *robot.gripper_joints))
        self.dt = dt
        start = robot.home()
        for g in robot.profile.grippers.values():
            for name, closed in zip(g.joints, g.closed, strict=True):
                start[name] = robot.joints[name].to_si(closed)
        start.update(initial or {})
        self._position = np.array([start.get(n, 0.0) for n in self.joint_names])
        self._velocity = np.zeros(len(self.joint_names))
        self._state = HardwareState.UNCONFIGURED
        self._faults: list[HardwareFault] = []
        self.time = 0.0

    @property
    def state(self) -> HardwareState:
        return self._state

    def configure(self) -> None:
        self._state = HardwareState.INACTIVE

    def activate(self) -> None:
        if self._state == HardwareState.INACTIVE:
            self._state = HardwareState.ACTIVE

    def deactivate(self) -> None:
        if self._state == HardwareState.ACTIVE:
            self._state = HardwareState.INACTIVE
        self._velocity[:] = 0.0

    def read(self) -> JointState:
        return JointState(self._position.copy(), self._velocity.copy(), self.time)

    def write(self, command: JointCommand) -> None:
        if self._state == HardwareState.UNCONFIGURED:
            return
        self.time += self.dt
        if self._state != HardwareState.ACTIVE:
            return
        if not np.all(np.isfinite(command.position)):
            self.inject_fault(HardwareFault(0x40F, "command", "non-finite position command"))
            return
        self._position = np.array(command.position, dtype=float)
        if len(command.velocity):
            self._velocity = np.array(command.velocity, dtype=float)

    def faults(self) -> list[HardwareFault]:
        return list(self._faults)

    def place(self, positions: dict[str, float]) -> None:
        """Put joints at ``positions`` (SI) at rest, as if moved there by hand (tests)."""
        for name, value in positions.items():
            self._position[self.joint_names.index(name)] = value
        self._velocity[:] = 0.0

    def inject_fault(self, fault: HardwareFault) -> None:
        """Enter FAULT with ``fault`` (tests)."""
        self._faults.append(fault)
        self._state = HardwareState.FAULT
        self._velocity[:] = 0.0

    def reset_faults(self) -> bool:
        self._faults.clear()
        if self._state == HardwareState.FAULT:
            self._state = HardwareState.INACTIVE
        return True

    def shutdown(self) -> None:
        self._state = HardwareState.FINALIZED

"""The hardware-layer interface every backend implements (MuJoCo stand-in, CAN drives).

Lifecycle, as in ros2_control::

    UNCONFIGURED --configure()--> INACTIVE --activate()--> ACTIVE
    ACTIVE --deactivate()--> INACTIVE        (quick stop, drives disabled: servo off)
    any --fault--> FAULT --reset_faults()--> INACTIVE (once the cause is gone)
    any --shutdown()--> FINALIZED

Per cycle the loop calls :meth:`HardwareInterface.read` then :meth:`HardwareInterface.write`,
and :meth:`HardwareInterface.advance` in the time left before the next cycle.
All values are SI: [rad], [rad/s] for revolute joints, [m], [m/s] for prismatic ones (vehicle
x/y, parallel fingers), in the order of :attr:`HardwareInterface.joint_names`.

``read`` is valid in INACTIVE, ACTIVE and FAULT (the state is still measured). ``write`` moves
the drives only when ACTIVE; a simulated backend still advances its time on every write once
configured, so the loop keeps its rhythm with the servos off. An empty ``velocity`` in a
:class:`JointCommand` means no feed-forward.
"""

from __future__ import annotations

import abc
import enum
from dataclasses import dataclass, field

import numpy as np


class HardwareState(enum.Enum):
    UNCONFIGURED = "unconfigured"
    INACTIVE = "inactive"
    ACTIVE = "active"
    FAULT = "fault"
    FINALIZED = "finalized"


@dataclass(frozen=True)
class HardwareFault:
    """An active fault. ``code`` is from imotion's alarm table (>= 0x400 for hardware)."""

    code: int
    #: Which joint/drive or bus, e.g. ``"r_arm_j3"`` or ``"can0"``.
    source: str
    description: str


@dataclass
class JointState:
    """Measured state, one entry per joint of :attr:`HardwareInterface.joint_names`."""

    position: np.ndarray
    velocity: np.ndarray
    #: Monotonic time [s] the measurement refers to.
    stamp: float = 0.0


@dataclass
class JointCommand:
    """Position set-point with velocity feed-forward, one entry per joint."""

    position: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(0))


class HardwareInterface(abc.ABC):
    """What the control loop needs from the hardware (or its stand-in)."""

    #: Joint names in the order of every array this interface exchanges.
    joint_names: tuple[str, ...]

    @property
    @abc.abstractmethod
    def state(self) -> HardwareState: ...

    @abc.abstractmethod
    def configure(self) -> None:
        """Open buses / load the model and set drives up. UNCONFIGURED -> INACTIVE."""

    @abc.abstractmethod
    def activate(self) -> None:
        """Enable every drive, holding the current position. INACTIVE -> ACTIVE."""

    @abc.abstractmethod
    def deactivate(self) -> None:
        """Quick-stop and disable every drive. ACTIVE -> INACTIVE."""

    @abc.abstractmethod
    def read(self) -> JointState:
        """Latest measured state (valid in INACTIVE, ACTIVE and FAULT)."""

    @abc.abstractmethod
    def write(self, command: JointCommand) -> None:
        """Send one cycle's set-points (ignored unless ACTIVE)."""

    def advance(self) -> None:
        """Work :meth:`write` may leave for later, done now; the loop calls it in its slack,
        after the cycle's step. A simulated backend advances its time here (the plant moves
        while the controller sleeps, as a real one does); :meth:`read` does it first when it
        was not called. Default: nothing to do (real drives move on their own)."""
        return None

    @abc.abstractmethod
    def faults(self) -> list[HardwareFault]:
        """Faults active now (empty when healthy)."""

    @abc.abstractmethod
    def reset_faults(self) -> bool:
        """Try to clear faults; True when the backend is back in INACTIVE."""

    @abc.abstractmethod
    def shutdown(self) -> None:
        """Release everything. Any state -> FINALIZED."""

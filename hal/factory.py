"""Choose a hardware backend by name (``imotiond --hal sim|hil|can``).

=====  ========================================================================
name   backend
=====  ========================================================================
sim    MuJoCo stand-in (:class:`hal.mujoco_backend.MujocoBackend`), lock-step
ideal  perfect drives (:class:`hal.ideal_backend.IdealBackend`), for tests
hil    CAN backend and the drive emulator in its own process (:mod:`hal.hil`)
can    CAN backend on the buses of the robot's drive profile
=====  ========================================================================
"""

from __future__ import annotations

from typing import Any

from controller.model.robot import Robot
from hal.interface import HardwareInterface

HAL_KINDS = ("sim", "ideal", "hil", "can")


def make_hardware(
    kind: str, robot: Robot, dt: float, options: dict[str, Any] | None = None
) -> HardwareInterface:
    """An unconfigured backend of ``kind`` for ``robot`` at period ``dt`` [s].

    ``options`` are backend-specific settings from the daemon configuration (``hal_options``).
    Raises ``ValueError`` naming the problem for an unknown kind or bad options.
    """
    options = dict(options or {})
    if kind == "sim":
        from hal.mujoco_backend import MujocoBackend

        return MujocoBackend(robot, dt)
    if kind == "ideal":
        from hal.ideal_backend import IdealBackend

        return IdealBackend(robot, dt)
    if kind == "hil":
        from hal.hil import make_hil_backend

        return make_hil_backend(robot, dt, options)
    if kind == "can":
        from hal.can.factory import make_can_backend

        return make_can_backend(kind, robot, dt, options)
    raise ValueError(f"unknown hal {kind!r}: choose one of {', '.join(HAL_KINDS)}")

"""Helpers for closed-loop motion tests: a motion core on the ideal or MuJoCo backend."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from controller.contract.motion_specs import MotionSpec
from controller.control.core import CoreState, MotionCore
from controller.motion.motions import Motion
from hal.ideal_backend import IdealBackend
from hal.mujoco_backend import MujocoBackend
from tests.support import robot

DT = 0.002


def make_core(robot_id: str, backend: str = "ideal", dt: float = DT) -> MotionCore:
    """A servo-on motion core at the home pose."""
    r = robot(robot_id)
    hw = IdealBackend(r, dt) if backend == "ideal" else MujocoBackend(r, dt)
    core = MotionCore(r, hw, dt)
    core.servo_on()
    for _ in range(5):
        core.cycle()
    return core


def run_motion(
    core: MotionCore,
    motion: Motion,
    each: Callable[[MotionCore], None] | None = None,
    max_cycles: int = 20000,
) -> int:
    """Start ``motion`` and cycle until it ends; ``each(core)`` after every cycle."""
    core.start(motion)
    cycles = 0
    while core.motion is not None and cycles < max_cycles:
        core.cycle()
        cycles += 1
        if each is not None:
            each(core)
    assert core.motion is None, f"motion still running after {max_cycles} cycles"
    assert core.state == CoreState.READY, core.alarms
    return cycles


def chord_twist(a: pin.SE3, b: pin.SE3, dt: float) -> np.ndarray:
    """The constant twist taking pose ``a`` to ``b`` in ``dt`` [s] (linear then angular,
    world axes [m/s, rad/s]), through log3: the reference for the paths' closed forms."""
    out = np.empty(6)
    out[:3] = (b.translation - a.translation) / dt
    out[3:] = pin.log3(b.rotation @ a.rotation.T) / dt
    return out


def build_planned(core: MotionCore, spec: MotionSpec) -> Motion:
    """``spec``'s motion built as the control process builds it: at the configuration it was
    planned from (``spec.planned_from``), then run on the measured state."""
    return spec.build_as_planned(core.kin, core.dt)

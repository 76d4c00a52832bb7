"""Everything the start-up checks before touching hardware, shared by ``--check`` and start.

``imotiond --check`` answers OK only when :func:`preflight` finds nothing, and the start
runs the same function first, so a configuration ``--check`` accepts does not fail at start
for a reason it could have seen: the security rules, the robot (its profile loads), the
hardware layer's options (``hal_options``, a typed model per ``hal``: unknown keys, wrong
types and negative times are refused), the loop rate (the loop's own range, and for ``can`` /
``hil`` the CAN bus load of the robot's drive profile at that rate).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from controller.contract.config import DaemonConfig, security_problems
from controller.control.loop import MAX_RATE_HZ, MIN_RATE_HZ
from controller.model.robot import Robot, load_robot
from controller.model.yaml_source import ConfigError

#: A time option [s]: a number >= 0 (not a boolean, not a string).
_Seconds = Field(default=None, ge=0.0, strict=True)
Seconds = float | None


class _Options(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class SimOptions(_Options):
    """``hal: sim`` (MuJoCo) takes no options."""


class IdealOptions(_Options):
    """``hal: ideal`` (perfect drives) takes no options."""


class HilOptions(_Options):
    """``hal: hil``: the CAN backend and the drive emulator (hal/hil.py)."""

    #: ``process`` (default: its own process on unix buses) or ``thread`` (lockstep).
    emulator: Literal["process", "thread"] | None = None
    #: SCHED_FIFO priority of the emulator process's thread (0: normal scheduling).
    emulator_priority: int | None = Field(default=None, ge=0, le=99, strict=True)
    #: 0x405 only after TPDO1 is missing this long too [s].
    tpdo_timeout: Seconds = _Seconds
    #: Both heartbeat consumers at least this long [s].
    heartbeat_timeout: Seconds = _Seconds
    #: Another drive profile (default config/robots/<id>/drives.yaml).
    drives: Path | None = None
    #: How long read() may wait for missing TPDOs [s].
    feedback_wait: Seconds = _Seconds
    #: Bound of activate() [s].
    enable_timeout: Seconds = _Seconds
    #: Bound of reset_faults() [s].
    reset_timeout: Seconds = _Seconds
    #: Per SDO request at set-up [s].
    sdo_timeout: Seconds = _Seconds
    #: Longest wait for the emulator to answer a cycle's SYNCs [s].
    lockstep_timeout: Seconds = _Seconds


class CanOptions(_Options):
    """``hal: can``: the CAN backend on the profile's buses (hal/can/factory.py)."""

    #: Per bus, python-can settings overriding the profile's.
    buses: dict[str, dict[str, Any]] = {}
    drives: Path | None = None
    feedback_wait: Seconds = _Seconds
    tpdo_timeout: Seconds = _Seconds
    heartbeat_timeout: Seconds = _Seconds
    enable_timeout: Seconds = _Seconds
    reset_timeout: Seconds = _Seconds
    sdo_timeout: Seconds = _Seconds


HAL_OPTIONS: dict[str, type[_Options]] = {
    "sim": SimOptions,
    "ideal": IdealOptions,
    "hil": HilOptions,
    "can": CanOptions,
}


@dataclass
class Preflight:
    """What the start needs from the checks: the robot and the validated hal options."""

    problems: list[str] = field(default_factory=list)
    robot: Robot | None = None
    #: ``hal_options`` as the hardware factory takes them (only the keys given).
    hal_options: dict[str, Any] = field(default_factory=dict)


def hal_options(cfg: DaemonConfig) -> tuple[dict[str, Any], list[str]]:
    """``(options, problems)``: ``cfg.hal_options`` checked against the model of ``cfg.hal``."""
    model = HAL_OPTIONS[cfg.hal]
    try:
        parsed = model.model_validate(cfg.hal_options)
    except ValidationError as exc:
        known = ", ".join(model.model_fields) or "none"
        problems = []
        for err in exc.errors():
            key = ".".join(str(p) for p in err["loc"])
            problems.append(f"hal_options.{key}: {err['msg']} (hal {cfg.hal} options: {known})")
        return {}, problems
    return parsed.model_dump(exclude_none=True, exclude_unset=True), []


def rate_problems(cfg: DaemonConfig, robot: Robot, options: dict[str, Any]) -> list[str]:
    """The loop rate against the loop's range and, for CAN, the drive profile's bus load."""
    rate = cfg.loop.rate_hz
    if not MIN_RATE_HZ <= rate <= MAX_RATE_HZ:
        span = f"{MIN_RATE_HZ:g}..{MAX_RATE_HZ:g} Hz"
        return [f"loop.rate_hz: {rate:g} Hz is outside the loop's {span}"]
    if cfg.hal not in ("can", "hil"):
        return []
    from hal.can import busload
    from hal.can.drive_profile import drives_path, load_drive_profile

    path = Path(options["drives"]) if "drives" in options else drives_path(robot)
    try:
        profile = load_drive_profile(path, robot)
        busload.check(profile, rate)
    except (ConfigError, ValueError, OSError) as exc:
        return [f"hal {cfg.hal}: {exc}"]
    return []


def preflight(cfg: DaemonConfig) -> Preflight:
    """Every check the start makes before opening hardware (see the module docstring)."""
    result = Preflight(problems=list(security_problems(cfg)))
    try:
        result.robot = load_robot(cfg.robot)
    except (ConfigError, ValueError, OSError) as exc:
        result.problems.append(f"robot: {cfg.robot}: {exc}")
    options, problems = hal_options(cfg)
    result.problems += problems
    result.hal_options = options
    if result.robot is not None and not problems:
        result.problems += rate_problems(cfg, result.robot, options)
    return result

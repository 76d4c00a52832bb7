"""What every service works with: configuration, views of the robot, the planner, and the
command channel to the control process."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

from controller.contract.config import DaemonConfig
from controller.contract.snapshot import Snapshot, StateHeader
from controller.errors import Refused
from controller.gateway.planning.planner import Planner
from controller.gateway.planning.robot_view import RobotView
from controller.model.robot import Robot
from controller.vocabulary import ReturnCode


class CommandChannel(Protocol):
    """The control process's command link: ``call`` answers ``(ok, value, message)``; on a
    refusal ``value`` is the return code."""

    def call(self, name: str, **args: Any) -> tuple[bool, Any, str]: ...


#: Commands after which nothing the gateway queued is left: relative moves build on the
#: measured state again.
_FORGET_QUEUE = frozenset({"stop", "abort", "servo_off", "clear_alarms"})


@dataclass
class Context:
    """Configuration, a view for queries, the planner (with its own view), the control link."""

    config: DaemonConfig
    view: RobotView  #: for queries
    planner: Planner  #: owns its own view, for planning
    control: CommandChannel

    @property
    def robot(self) -> Robot:
        return self.view.robot

    def snapshot(self) -> Snapshot:
        return self.view.snapshot()

    def state(self) -> StateHeader:
        """The snapshot's states and counters alone (a third of :meth:`snapshot`'s cost)."""
        return self.view.state()

    def call(self, name: str, sv_on_code: bool = True, **args: Any) -> Any:
        """Run a control command; a refusal becomes a Refused with the family's code.

        ``sv_on_code``: the operation lists NOT_SV_ON_ERR (else servo off is STATUS_ERR).
        """
        if name in _FORGET_QUEUE:
            self.planner.forget_queue()
        ok, value, message = self.control.call(name, **args)
        if ok:
            return value
        code = ReturnCode(value) if value in ReturnCode._value2member_map_ else ReturnCode.NG
        if code == ReturnCode.NOT_SV_ON_ERR and not sv_on_code:
            code = ReturnCode.STATUS_ERR
        raise Refused(code, message)

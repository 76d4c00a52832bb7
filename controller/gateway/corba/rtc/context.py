"""The component's own execution context (``RTC::ExecutionContextService``, periodic).

imotion's control loop runs in the control process at ``loop.rate_hz``; this context reports
that rate and kind (PERIODIC) and keeps the component's life-cycle state for the tools
(``rtact``, ``rtdeact``, ``rtreset``, ``rtcat``). It runs no thread and calls no
``on_execute``: the state is bookkeeping only. Activating or deactivating the component
never moves the robot, never switches servos and never stops a motion (docs/rtc.md); the
provided services answer in every state.
"""

from __future__ import annotations

import logging
import math
import threading
from typing import Any, Protocol

from omniORB import CORBA
from rtctree.rtc import RTC, RTC__POA

from controller.gateway.corba.rtc.nvlist import nvlist

_log = logging.getLogger("imotiond.rtc")


class Actions(Protocol):
    """What the context calls on its component (RTC::ComponentAction, in-process)."""

    def on_startup(self, handle: int) -> Any: ...
    def on_shutdown(self, handle: int) -> Any: ...
    def on_activated(self, handle: int) -> Any: ...
    def on_deactivated(self, handle: int) -> Any: ...
    def on_reset(self, handle: int) -> Any: ...


class ExecutionContext(RTC__POA.ExecutionContextService):
    """Periodic context owned by the component (handle 0 in the component)."""

    HANDLE = 0

    def __init__(self, actions: Actions, rate_hz: float, active: bool = False):
        self._actions = actions
        self._rate = float(rate_hz)
        self._lock = threading.Lock()
        self._running = False
        self._state = RTC.ACTIVE_STATE if active else RTC.INACTIVE_STATE
        self.ref: Any = None  # this context's object reference
        self.owner: Any = None  # the component's object reference

    def attach(self, ref: Any, owner: Any) -> None:
        self.ref = ref
        self.owner = owner

    def _mine(self, comp: Any) -> bool:
        return not CORBA.is_nil(comp) and self.owner is not None and comp._is_equivalent(self.owner)

    @property
    def state(self) -> Any:
        with self._lock:
            return self._state

    # -- RTC::ExecutionContext --------------------------------------------------------------

    def is_running(self) -> bool:
        with self._lock:
            return self._running

    def start(self) -> Any:
        with self._lock:
            if self._running:
                return RTC.PRECONDITION_NOT_MET
            self._running = True
        self._actions.on_startup(self.HANDLE)
        return RTC.RTC_OK

    def stop(self) -> Any:
        with self._lock:
            if not self._running:
                return RTC.PRECONDITION_NOT_MET
            self._running = False
        self._actions.on_shutdown(self.HANDLE)
        return RTC.RTC_OK

    def get_rate(self) -> float:
        return self._rate

    def set_rate(self, rate: float) -> Any:
        if not math.isfinite(rate) or rate <= 0.0:
            return RTC.BAD_PARAMETER
        if rate == self._rate:
            return RTC.RTC_OK
        return RTC.UNSUPPORTED  # the loop's rate is loop.rate_hz in imotiond's configuration

    def add_component(self, comp: Any) -> Any:
        if CORBA.is_nil(comp):
            return RTC.BAD_PARAMETER
        if self._mine(comp):
            return RTC.PRECONDITION_NOT_MET  # already its only participant
        return RTC.UNSUPPORTED  # this context drives no other component

    def remove_component(self, comp: Any) -> Any:
        if self._mine(comp):
            return RTC.PRECONDITION_NOT_MET  # the owner stays
        return RTC.BAD_PARAMETER  # not a participant

    def activate_component(self, comp: Any) -> Any:
        return self._transition(comp, RTC.INACTIVE_STATE, RTC.ACTIVE_STATE, "activated")

    def deactivate_component(self, comp: Any) -> Any:
        return self._transition(comp, RTC.ACTIVE_STATE, RTC.INACTIVE_STATE, "deactivated")

    def reset_component(self, comp: Any) -> Any:
        return self._transition(comp, RTC.ERROR_STATE, RTC.INACTIVE_STATE, "reset")

    def get_component_state(self, comp: Any) -> Any:
        if not self._mine(comp):
            return RTC.CREATED_STATE  # as OpenRTM answers for a non-participant
        return self.state

    def get_kind(self) -> Any:
        return RTC.PERIODIC

    # -- RTC::ExecutionContextService -------------------------------------------------------

    def get_profile(self) -> Any:
        props = nvlist({"type": "PeriodicExecutionContext", "rate": repr(self._rate)})
        return RTC.ExecutionContextProfile(
            RTC.PERIODIC, self._rate, self.owner, [self.owner], props
        )

    # -- helpers ----------------------------------------------------------------------------

    def _transition(self, comp: Any, source: Any, target: Any, action: str) -> Any:
        if not self._mine(comp):
            return RTC.BAD_PARAMETER
        with self._lock:
            if self._state != source:
                return RTC.PRECONDITION_NOT_MET
            self._state = target
        call = {
            "activated": self._actions.on_activated,
            "deactivated": self._actions.on_deactivated,
            "reset": self._actions.on_reset,
        }[action]
        call(self.HANDLE)
        _log.info("RT component %s (state only: the robot is not affected)", action)
        return RTC.RTC_OK

    def force_inactive(self) -> None:
        """Back to INACTIVE without a call (the component exits)."""
        with self._lock:
            if self._state == RTC.ACTIVE_STATE:
                self._state = RTC.INACTIVE_STATE

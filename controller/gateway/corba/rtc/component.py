"""The RT component object (``OpenRTM::DataFlowComponent``: RTObject + LightweightRTObject +
ComponentAction + DataFlowComponentAction + SDO).

What tools and OpenRTM components call works: profile, ports, owned and participating
execution contexts and their handles (owned: 0; attached: 1000 + i, as OpenRTM numbers
them), ``is_alive``, the SDO configuration. The ``on_*`` actions do nothing and return
RTC_OK. Life cycle: the component is created alive (``initialize`` answers
PRECONDITION_NOT_MET); ``exit`` withdraws it (deactivated, connections dropped, naming
binding removed) but leaves imotion and its services running; ``finalize`` is only reached
through ``exit``. SDO operations imotion does not support raise the SDO exception the IDL
lists for them, never a CORBA system exception.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Sequence
from typing import Any

from omniORB import CORBA
from rtctree.rtc import RTC, OpenRTM__POA, SDOPackage

from controller.gateway.corba.rtc.context import ExecutionContext
from controller.gateway.corba.rtc.nvlist import nvlist
from controller.gateway.corba.rtc.port import ServicePort

_log = logging.getLogger("imotiond.rtc")

#: First handle of an execution context attached from outside (OpenRTM's ECOTHER_OFFSET).
OTHER_OFFSET = 1000


class RtObject(OpenRTM__POA.DataFlowComponent):
    def __init__(
        self,
        profile: dict[str, str],
        properties: dict[str, str],
        ports: Sequence[ServicePort],
        on_exit: Callable[[], None],
    ):
        self._profile = dict(profile)
        self._properties = dict(properties)
        self._ports = list(ports)
        self._on_exit = on_exit
        self._lock = threading.Lock()
        self._others: list[Any] = []  # attached execution contexts (None: detached slot)
        self._exited = False
        self.context: ExecutionContext | None = None
        self.context_ref: Any = None
        self.configuration_ref: Any = None
        self.ref: Any = None

    def attach(self, ref: Any, context: ExecutionContext, context_ref: Any, config: Any) -> None:
        self.ref = ref
        self.context = context
        self.context_ref = context_ref
        self.configuration_ref = config

    @property
    def exited(self) -> bool:
        with self._lock:
            return self._exited

    # -- RTC::LightweightRTObject ---------------------------------------------------------------

    def initialize(self) -> Any:
        return RTC.PRECONDITION_NOT_MET  # created alive by imotion's gateway

    def finalize(self) -> Any:
        return RTC.PRECONDITION_NOT_MET if not self.exited else RTC.RTC_OK

    def exit(self) -> Any:
        with self._lock:
            if self._exited:
                return RTC.RTC_OK
            self._exited = True
        _log.warning(
            "RT component %s: exit requested: withdrawn from the naming service (imotion and "
            "its services keep running; restart the gateway to register it again)",
            self._profile["instance_name"],
        )
        if self.context is not None:
            if self.context.state == RTC.ACTIVE_STATE:
                self.on_deactivated(ExecutionContext.HANDLE)
            self.context.force_inactive()
        for port in self._ports:
            port.disconnect_all()
        self._on_exit()
        return RTC.RTC_OK

    def is_alive(self, exec_context: Any) -> bool:
        if CORBA.is_nil(exec_context) or self.exited:
            return False
        return self.get_context_handle(exec_context) >= 0

    def attach_context(self, exec_context: Any) -> int:
        if CORBA.is_nil(exec_context):
            return -1
        try:
            service = exec_context._narrow(RTC.ExecutionContextService)
        except CORBA.Exception:
            return -1
        if CORBA.is_nil(service):
            return -1
        with self._lock:
            for i, slot in enumerate(self._others):
                if slot is None:
                    self._others[i] = service
                    return OTHER_OFFSET + i
            self._others.append(service)
            return OTHER_OFFSET + len(self._others) - 1

    def detach_context(self, exec_handle: int) -> Any:
        index = exec_handle - OTHER_OFFSET
        with self._lock:
            if not 0 <= index < len(self._others) or self._others[index] is None:
                return RTC.BAD_PARAMETER
            self._others[index] = None
        return RTC.RTC_OK

    def get_context(self, exec_handle: int) -> Any:
        if exec_handle == ExecutionContext.HANDLE:
            return self.context_ref
        index = exec_handle - OTHER_OFFSET
        with self._lock:
            if 0 <= index < len(self._others):
                return self._others[index]
        return None

    def get_owned_contexts(self) -> list[Any]:
        return [self.context_ref]

    def get_participating_contexts(self) -> list[Any]:
        with self._lock:
            return [ec for ec in self._others if ec is not None]

    def get_context_handle(self, cxt: Any) -> int:
        if CORBA.is_nil(cxt):
            return -1
        if cxt._is_equivalent(self.context_ref):
            return ExecutionContext.HANDLE
        with self._lock:
            others = list(self._others)
        for i, ec in enumerate(others):
            if ec is not None and cxt._is_equivalent(ec):
                return OTHER_OFFSET + i
        return -1

    # -- RTC::ComponentAction, RTC::DataFlowComponentAction: nothing to do -------------------

    def on_initialize(self) -> Any:
        return RTC.RTC_OK

    def on_finalize(self) -> Any:
        return RTC.RTC_OK

    def on_startup(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    def on_shutdown(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    def on_activated(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    def on_deactivated(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    def on_aborting(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    def on_error(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    def on_reset(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    def on_execute(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    def on_state_update(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    def on_rate_changed(self, exec_handle: int) -> Any:
        return RTC.RTC_OK

    # -- RTC::RTObject ----------------------------------------------------------------------

    def get_component_profile(self) -> Any:
        p = self._profile
        return RTC.ComponentProfile(
            p["instance_name"],
            p["type_name"],
            p["description"],
            p["version"],
            p["vendor"],
            p["category"],
            [port.get_port_profile() for port in self._ports],
            None,
            nvlist(self._properties),
        )

    def get_ports(self) -> list[Any]:
        return [port.ref for port in self._ports]

    # -- SDOPackage::SDO --------------------------------------------------------------------

    def get_owned_organizations(self) -> list[Any]:
        return []

    def get_sdo_id(self) -> str:
        return self._profile["instance_name"]

    def get_sdo_type(self) -> str:
        return self._profile["description"]  # what OpenRTM answers

    def get_device_profile(self) -> Any:
        p = self._profile
        return SDOPackage.DeviceProfile(
            p["category"], p["vendor"], p["type_name"], p["version"], []
        )

    def get_service_profiles(self) -> list[Any]:
        return []

    def get_service_profile(self, service_id: str) -> Any:
        raise SDOPackage.InvalidParameter(f"no SDO service {service_id!r}")

    def get_sdo_service(self, service_id: str) -> Any:
        raise SDOPackage.InvalidParameter(f"no SDO service {service_id!r}")

    def get_configuration(self) -> Any:
        return self.configuration_ref

    def get_monitoring(self) -> Any:
        raise SDOPackage.InterfaceNotImplemented("no SDO monitoring")

    def get_organizations(self) -> list[Any]:
        return []

    def get_status_list(self) -> list[Any]:
        return []

    def get_status(self, name: str) -> Any:
        raise SDOPackage.InvalidParameter(f"no SDO status {name!r}")

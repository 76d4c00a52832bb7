"""The RT component around imotion's CORBA servants, as the gateway creates it.

``RtComponent(orb, poa, settings, provided, rate_hz, rebind_interval_s)`` activates the
component, its execution context, one service port per distinct ``port_name`` of
``provided`` and the SDO configuration in ``poa``; ``start(naming_root)`` registers it as
``<host>.host_cxt/<name>.rtc`` and keeps it registered (checked every ``rebind_interval_s``
[s]; the gateway passes ``corba.rebind_interval_s``); ``close()`` disconnects its ports,
unbinds the name and deactivates the objects. The servants themselves (``provided``) are
the caller's: they keep serving whatever the component does.
"""

from __future__ import annotations

import logging
import socket
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from controller.contract.rtc_config import TYPE_NAMES, InterfaceKey, RtcConfig
from controller.gateway.corba.rtc.component import RtObject
from controller.gateway.corba.rtc.context import ExecutionContext
from controller.gateway.corba.rtc.naming import NameBinding
from controller.gateway.corba.rtc.port import ProvidedInterface, ServicePort
from controller.gateway.corba.rtc.sdo import Configuration
from controller.version import version

_log = logging.getLogger("imotiond.rtc")


def group_by_port(provided: Sequence[ProvidedInterface]) -> dict[str, list[ProvidedInterface]]:
    """Interfaces per port, in order; ValueError for an instance name used twice on a port."""
    ports: dict[str, list[ProvidedInterface]] = {}
    for item in provided:
        same = ports.setdefault(item.port_name, [])
        if any(p.instance_name == item.instance_name for p in same):
            raise ValueError(
                f"RT component port {item.port_name}: instance name {item.instance_name!r} "
                "is used twice (corba.rtc.ports)"
            )
        same.append(item)
    return ports


class RtComponent:
    def __init__(
        self,
        orb: Any,
        poa: Any,
        settings: RtcConfig,
        provided: Sequence[ProvidedInterface],
        rate_hz: float,
        rebind_interval_s: float = 10.0,
    ):
        self.settings = settings
        self.rebind_interval_s = rebind_interval_s
        self.host = settings.host_context or socket.gethostname()
        self.name_path = [(self.host, "host_cxt"), (settings.name, "rtc")]
        self._orb = orb
        self._poa = poa
        self._lock = threading.Lock()
        self._binding: NameBinding | None = None
        self._oids: list[Any] = []
        self.ior_file: Path | None = None  # written by the gateway, removed at close
        name = settings.name
        self.ports = [
            ServicePort(orb, name, port, items) for port, items in group_by_port(provided).items()
        ]
        profile = {
            "instance_name": name,
            "type_name": settings.type_name,
            "description": settings.description,
            "version": version(),
            "vendor": settings.vendor,
            "category": settings.category,
        }
        properties = {
            **profile,
            "implementation_id": settings.type_name,
            "activity_type": "PERIODIC",
            "kind": "DataFlowComponent",
            "max_instance": "1",
            "language": "Python",
            "lang_type": "SCRIPT",
            "exec_cxt.periodic.type": "PeriodicExecutionContext",
            "exec_cxt.periodic.rate": repr(float(rate_hz)),
            "naming.names": "/".join(f"{i}.{k}" for i, k in self.name_path),
        }
        config = {
            "preset": settings.preset,
            "rate_hz": repr(float(rate_hz)),
            "activate_at_start": str(settings.activate_at_start).lower(),
        }
        for item in provided:
            config[f"port.{item.port_name}.{item.instance_name}"] = item.type_name
        self.rtobject = RtObject(profile, properties, self.ports, on_exit=self._withdraw)
        self.context = ExecutionContext(self.rtobject, rate_hz, settings.activate_at_start)
        self.configuration = Configuration(config)
        try:
            self.ref = self._activate(self.rtobject)
            context_ref = self._activate(self.context)
            config_ref = self._activate(self.configuration)
            self.rtobject.attach(self.ref, self.context, context_ref, config_ref)
            self.context.attach(context_ref, self.ref)
            for port in self.ports:
                port.attach(self._activate(port), self.ref)
        except Exception:
            self._deactivate_all()
            raise
        self.context.start()

    def _activate(self, servant: Any) -> Any:
        oid = self._poa.activate_object(servant)
        self._oids.append(oid)
        return self._poa.id_to_reference(oid)

    def _deactivate_all(self) -> None:
        for oid in reversed(self._oids):
            try:
                self._poa.deactivate_object(oid)
            except Exception as exc:  # the POA may already be going down with the ORB
                _log.debug("deactivate: %s", exc)
        self._oids.clear()

    @property
    def name_text(self) -> str:
        """``<host>.host_cxt/<name>.rtc``."""
        return "/".join(f"{i}.{k}" for i, k in self.name_path)

    @property
    def binds(self) -> int:
        """How often the naming binding was made (the first one included)."""
        with self._lock:
            return self._binding.binds if self._binding is not None else 0

    @property
    def ior(self) -> str:
        """The component's IOR (for an IOR file when there is no naming service)."""
        return str(self._orb.object_to_string(self.ref))

    def start(self, naming_root: Any) -> None:
        """Register in the naming service (``CosNaming::NamingContext``; None: none) and keep
        it registered."""
        if self.rtobject.exited:
            return
        if naming_root is None:
            _log.info("RT component %s: no naming service, not registered", self.settings.name)
            return
        binding = NameBinding(naming_root, self.name_path, self.ref, self.rebind_interval_s)
        with self._lock:
            self._binding = binding
        binding.start()
        ports = ", ".join(p.port_name for p in self.ports)
        _log.info("RT component %s serving ports %s", self.name_text, ports)

    def _withdraw(self) -> None:
        """``exit()`` from a tool: stop being registered (the services keep running)."""
        with self._lock:
            binding, self._binding = self._binding, None
        if binding is not None:
            binding.close(unbind=True)

    def close(self) -> None:
        """Disconnect every port (consumers are told), unbind, deactivate the objects."""
        for port in self.ports:
            port.disconnect_all()
        self._withdraw()
        if self.ior_file is not None:
            self.ior_file.unlink(missing_ok=True)
        if self.context.is_running():
            self.context.stop()
        self._deactivate_all()


def provided_interfaces(
    settings: RtcConfig, objrefs: dict[InterfaceKey, Any]
) -> list[ProvidedInterface]:
    """What to provide for the servants ``objrefs`` (by interface key), named as configured."""
    out = []
    for key, objref in objrefs.items():
        names = settings.names(key)
        out.append(ProvidedInterface(names.port, names.instance, TYPE_NAMES[key], objref))
    return out

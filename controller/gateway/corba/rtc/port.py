"""A CorbaPort service port (``RTC::PortService``) providing imotion's CORBA interfaces.

The connection protocol is OpenRTM's (facts in ../shared/spec/corba.md): ``connect`` on any
port of a connector profile calls ``notify_connect`` on its first port; each port publishes
what it provides into the profile's properties, forwards the profile to the next port and
keeps it. A provider publishes the IOR of every interface under
``<rtc>.port.<port>.provided.<type>.<instance>`` and ``port.<type>.<instance>``; a consumer
later (or earlier: it reads the returned profile) in the list picks it up by type and
instance name. ``notify_disconnect`` forwards the same way and forgets the profile.

Thread-safe: the connector list is guarded by a lock that is never held across a remote call
(a profile's next port may call back into this process).
"""

from __future__ import annotations

import logging
import threading
import uuid
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import omniORB
from omniORB import CORBA
from rtctree.rtc import RTC, RTC__POA

from controller.gateway.corba.rtc.nvlist import nv, nv_find

_log = logging.getLogger("imotiond.rtc")

#: Longest wait for another component's port (notify_*, liveness) [ms].
PEER_TIMEOUT_MS = 2000


@dataclass(frozen=True)
class ProvidedInterface:
    """One CORBA object provided on a service port (OpenRTM ``registerProvider``)."""

    port_name: str  #: service port it is provided on
    instance_name: str  #: what consumers match, with the type name
    type_name: str  #: IDL interface, e.g. ``JARA_ARM::ManipulatorCommonInterface_Middle``
    objref: Any  #: the servant's object reference


def _peer(port: Any) -> Any:
    """A peer's port reference with a call timeout (a hung peer must not hang us)."""
    omniORB.setClientCallTimeout(port, PEER_TIMEOUT_MS)
    return port


def _allows_duplicates(properties: list[Any]) -> bool:
    value = nv_find(properties, "dataport.allow_dup_connection")
    return value is not None and value.strip().upper() == "YES"


class ServicePort(RTC__POA.PortService):
    """One CorbaPort with only provided interfaces."""

    def __init__(self, orb: Any, owner_name: str, port_name: str, provided: Sequence[Any]):
        self.port_name = port_name
        self._full_name = f"{owner_name}.{port_name}"
        self._interfaces = [
            RTC.PortInterfaceProfile(p.instance_name, p.type_name, RTC.PROVIDED) for p in provided
        ]
        self._published: list[tuple[str, str]] = []
        for item in provided:
            ior = orb.object_to_string(item.objref)
            descriptor = f"{item.type_name}.{item.instance_name}"
            self._published.append((f"{owner_name}.port.{port_name}.provided.{descriptor}", ior))
            self._published.append((f"port.{descriptor}", ior))
        self._properties = [nv("port.port_type", "CorbaPort")]
        self._lock = threading.Lock()
        self._connectors: list[Any] = []
        self.ref: Any = None  # this port's object reference (set once activated)
        self.owner: Any = None  # the RTObject's reference

    def attach(self, ref: Any, owner: Any) -> None:
        self.ref = ref
        self.owner = owner

    # -- RTC::PortService ------------------------------------------------------------------

    def get_port_profile(self) -> Any:
        self._drop_dead_connectors()
        with self._lock:
            connectors = list(self._connectors)
        return RTC.PortProfile(
            self._full_name, self._interfaces, self.ref, connectors, self.owner, self._properties
        )

    def get_connector_profiles(self) -> list[Any]:
        self._drop_dead_connectors()
        with self._lock:
            return list(self._connectors)

    def get_connector_profile(self, connector_id: str) -> Any:
        found = self._find(connector_id)
        return found if found is not None else RTC.ConnectorProfile("", "", [], [])

    def connect(self, profile: Any) -> tuple[Any, Any]:
        if not profile.connector_id:
            profile.connector_id = str(uuid.uuid4())
        elif self._find(profile.connector_id) is not None:
            return RTC.PRECONDITION_NOT_MET, profile
        if not profile.ports or CORBA.is_nil(profile.ports[0]):
            return RTC.BAD_PARAMETER, profile
        try:
            ret, profile = _peer(profile.ports[0]).notify_connect(profile)
        except CORBA.Exception as exc:
            _log.warning("%s: connect %s failed: %s", self._full_name, profile.name, exc)
            return RTC.BAD_PARAMETER, profile
        if ret != RTC.RTC_OK:
            _log.warning("%s: connect %s refused: %s", self._full_name, profile.name, ret)
            self.disconnect(profile.connector_id)
        return ret, profile

    def notify_connect(self, profile: Any) -> tuple[Any, Any]:
        if self._index(profile.ports) < 0:  # not a connection of this port: keep nothing
            return RTC.BAD_PARAMETER, profile
        if not _allows_duplicates(profile.properties) and self._already_connected(profile):
            return RTC.PRECONDITION_NOT_MET, profile
        profile.properties = list(profile.properties) + [nv(k, v) for k, v in self._published]
        ret, profile = self._connect_next(profile)
        with self._lock:
            self._connectors = [
                c for c in self._connectors if c.connector_id != profile.connector_id
            ] + [profile]
        if ret == RTC.RTC_OK:
            _log.info("%s: connected %s (%s)", self._full_name, profile.name, profile.connector_id)
        return ret, profile

    def disconnect(self, connector_id: str) -> Any:
        found = self._find(connector_id)
        if found is None:
            return RTC.BAD_PARAMETER
        if not found.ports:
            return RTC.PRECONDITION_NOT_MET
        for port in found.ports:
            if CORBA.is_nil(port):
                continue
            try:
                return _peer(port).notify_disconnect(connector_id)
            except CORBA.Exception as exc:  # a dead peer: the next port carries on
                _log.info("%s: notify_disconnect on a peer failed: %s", self._full_name, exc)
        return RTC.RTC_ERROR

    def notify_disconnect(self, connector_id: str) -> Any:
        found = self._find(connector_id)
        if found is None:
            return RTC.BAD_PARAMETER
        ret = self._disconnect_next(found)
        with self._lock:
            self._connectors = [c for c in self._connectors if c.connector_id != connector_id]
        _log.info("%s: disconnected %s (%s)", self._full_name, found.name, connector_id)
        return ret

    def disconnect_all(self) -> Any:
        ret = RTC.RTC_OK
        with self._lock:
            ids = [c.connector_id for c in self._connectors]
        for connector_id in ids:
            result = self.disconnect(connector_id)
            if result != RTC.RTC_OK:
                ret = result
        return ret

    # -- helpers ---------------------------------------------------------------------------

    def _find(self, connector_id: str) -> Any:
        with self._lock:
            for connector in self._connectors:
                if connector.connector_id == connector_id:
                    return connector
        return None

    def _is_me(self, port: Any) -> bool:
        return not CORBA.is_nil(port) and self.ref is not None and port._is_equivalent(self.ref)

    def _index(self, ports: Sequence[Any]) -> int:
        for i, port in enumerate(ports):
            if self._is_me(port):
                return i
        return -1

    def _already_connected(self, profile: Any) -> bool:
        """Whether another connector already joins this port to one of the profile's ports."""
        others = [p for p in profile.ports if not CORBA.is_nil(p) and not self._is_me(p)]
        with self._lock:
            existing = [c for c in self._connectors if c.connector_id != profile.connector_id]
        return any(
            not CORBA.is_nil(q) and q._is_equivalent(p)
            for c in existing
            for q in c.ports
            for p in others
        )

    def _connect_next(self, profile: Any) -> tuple[Any, Any]:
        index = self._index(profile.ports)
        if index < 0:
            return RTC.BAD_PARAMETER, profile
        if index + 1 >= len(profile.ports):
            return RTC.RTC_OK, profile
        nxt = profile.ports[index + 1]
        if CORBA.is_nil(nxt):
            return RTC.BAD_PARAMETER, profile
        try:
            ret, returned = _peer(nxt).notify_connect(profile)
        except CORBA.Exception as exc:
            _log.warning("%s: next port of %s failed: %s", self._full_name, profile.name, exc)
            return RTC.RTC_ERROR, profile
        return ret, returned

    def _disconnect_next(self, profile: Any) -> Any:
        index = self._index(profile.ports)
        if index < 0:
            return RTC.BAD_PARAMETER
        for port in profile.ports[index + 1 :]:
            if CORBA.is_nil(port):
                continue
            try:
                return _peer(port).notify_disconnect(profile.connector_id)
            except CORBA.Exception as exc:
                _log.info("%s: a next port is gone: %s", self._full_name, exc)
        return RTC.RTC_OK if index + 1 >= len(profile.ports) else RTC.RTC_ERROR

    def _drop_dead_connectors(self) -> None:
        """Forget connections whose peer ports no longer exist (as OpenRTM does on reads)."""
        with self._lock:
            connectors = list(self._connectors)
        for connector in connectors:
            if not all(self._alive(p) for p in connector.ports):
                _log.warning(
                    "%s: peer of %s is gone: disconnecting", self._full_name, connector.name
                )
                self.disconnect(connector.connector_id)
                with self._lock:  # whatever the peers answered: this port forgets it
                    self._connectors = [
                        c for c in self._connectors if c.connector_id != connector.connector_id
                    ]

    def _alive(self, port: Any) -> bool:
        if CORBA.is_nil(port) or self._is_me(port):
            return True
        try:
            return not _peer(port)._non_existent()
        except CORBA.Exception:
            return False

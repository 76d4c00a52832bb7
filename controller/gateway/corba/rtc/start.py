"""Gateway start-up of the RT component (``corba.enabled`` and ``corba.rtc.enabled``)."""

from __future__ import annotations

import logging
from typing import Any

import CosNaming
import omniORB

from controller.contract.config import DaemonConfig
from controller.gateway.corba.rtc.rt_component import RtComponent, provided_interfaces

_log = logging.getLogger("imotiond.rtc")

#: Longest wait for one naming-service call [ms].
NAMING_TIMEOUT_MS = 2000
IOR_FILE = "rtc.ior"


def naming_root(orb: Any, uri: str | None) -> Any:
    """The naming service's root context (no call made: it may be down now), or None."""
    if uri is None:
        return None
    root = orb.string_to_object(uri)._unchecked_narrow(CosNaming.NamingContext)
    omniORB.setClientCallTimeout(root, NAMING_TIMEOUT_MS)
    return root


def start_rtc(cfg: DaemonConfig, corba: Any) -> RtComponent | None:
    """The RT component around ``corba``'s servants (a ``CorbaServer``), registered in
    ``corba.naming_uri()`` and, with ``corba.ior_dir``, written to ``<ior_dir>/rtc.ior``;
    None when ``corba.rtc.enabled`` is false."""
    settings = cfg.corba.rtc
    if not settings.enabled:
        return None
    provided = provided_interfaces(settings, corba.refs)
    component = RtComponent(
        corba.orb, corba.poa, settings, provided, cfg.loop.rate_hz, cfg.corba.rebind_interval_s
    )
    try:
        if cfg.corba.ior_dir is not None:
            path = cfg.corba.ior_dir / IOR_FILE
            path.write_text(component.ior + "\n")
            component.ior_file = path
        component.start(naming_root(corba.orb, cfg.corba.naming_uri()))
    except Exception:
        component.close()
        raise
    return component

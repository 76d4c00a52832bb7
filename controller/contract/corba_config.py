"""The ``corba:`` section of the daemon configuration: the original CORBA interfaces, served
by the gateway process beside gRPC (docs/corba.md).

IIOP here has no TLS and no authentication: the endpoint is on loopback or a Unix socket
unless ``allow_remote`` says otherwise, and then the daemon warns loudly at start that gRPC's
motion-token rules do not apply to CORBA clients.
"""

from __future__ import annotations

import importlib.util
import ipaddress
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from controller.contract.rtc_config import RtcConfig

#: The naming service that ``start_naming_service`` starts (omniNames on 127.0.0.1).
DEFAULT_NAMING_PORT = 2809

Units = Literal["mm_deg", "si"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class CorbaNames(_Strict):
    """Names under which each servant is bound in the naming service (CosNaming string
    names: ``/`` separates contexts, ``.`` an id from its kind). None: not bound. An
    interface the robot does not have (JARA_ARM_LEFT on a one-arm robot, JARA_ARM_DUAL
    without two arms) is never served, whatever its name."""

    spec_a: str | None = "imotion/IntegratedMotionInterface"
    jara_arm_common: str | None = "imotion/JARA_ARM.ManipulatorCommonInterface_Common"
    jara_arm_middle: str | None = "imotion/JARA_ARM.ManipulatorCommonInterface_Middle"
    jara_arm_left_common: str | None = "imotion/JARA_ARM_LEFT.LeftManipulatorCommonInterface_Common"
    jara_arm_left_middle: str | None = "imotion/JARA_ARM_LEFT.LeftManipulatorCommonInterface_Middle"
    jara_dual_common: str | None = "imotion/JARA_ARM_DUAL.DualManipulatorCommonInterface_Common"
    jara_dual_middle: str | None = "imotion/JARA_ARM_DUAL.DualManipulatorCommonInterface_Middle"

    @field_validator("*")
    @classmethod
    def _name(cls, value: str | None) -> str | None:
        if value is not None:
            parts = value.split("/")
            if not value or any(not p or p in (".",) for p in parts):
                raise ValueError(f"{value!r}: expected a name like imotion/IntegratedMotion")
        return value


class CorbaUnits(_Strict):
    """Units of each interface family on the wire. Spec A has no SI edition (mm, deg);
    JARA_ARM / JARA_ARM_LEFT and JARA_ARM_DUAL: ``mm_deg`` (NEDO v1.0, Spec B: the default)
    or ``si`` (m, rad, m/s, rad/s: clients of the JARA 2014 SI edition)."""

    spec_a: Literal["mm_deg"] = "mm_deg"
    jara_arm: Units = "mm_deg"
    jara_dual: Units = "mm_deg"


class CorbaConfig(_Strict):
    #: Serve the CORBA interfaces (needs the ``corba`` extra: pip install 'imotion[corba]').
    enabled: bool = False
    #: Naming service to bind the servants in (corbaloc::host:port/NameService, corbaname:
    #: or IOR:); None: none (IOR files and the RT component only). With
    #: ``start_naming_service`` and no value: the started one.
    naming_service: str | None = None
    #: omniORB endpoint of the servants: giop:tcp:HOST:PORT (port 0: any free port) or
    #: giop:unix:PATH. Anything but loopback or a Unix socket needs ``allow_remote``.
    endpoint: str = "giop:tcp:127.0.0.1:0"
    #: Serve on a non-loopback endpoint. IIOP has no TLS and no authentication here and the
    #: gRPC motion-token rules do not apply: anyone reaching the port can drive the robot.
    allow_remote: bool = False
    names: CorbaNames = CorbaNames()
    #: Write each servant's IOR to ``<ior_dir>/<key>.ior`` (keys as in ``names``); None: no
    #: files.
    ior_dir: Path | None = None
    units: CorbaUnits = CorbaUnits()
    #: Start omniNames ourselves on 127.0.0.1:``naming_port`` (data in the runtime
    #: directory), stopped with the gateway.
    start_naming_service: bool = False
    naming_port: int = Field(default=DEFAULT_NAMING_PORT, ge=1, le=65535)
    #: How often the bindings are checked and renewed (a restarted naming service forgets
    #: them) [s].
    rebind_interval_s: float = Field(default=2.0, gt=0.0, le=3600.0)
    #: The OpenRTM-compatible RT component around the servants (docs/rtc.md).
    rtc: RtcConfig = RtcConfig()

    @field_validator("endpoint")
    @classmethod
    def _endpoint(cls, value: str) -> str:
        parse_endpoint(value)
        return value

    @field_validator("naming_service")
    @classmethod
    def _naming(cls, value: str | None) -> str | None:
        if value is not None and not value.startswith(("corbaloc:", "corbaname:", "IOR:")):
            raise ValueError(
                f"{value!r}: expected a corbaloc URI, e.g. corbaloc::127.0.0.1:2809/NameService"
            )
        return value

    def naming_uri(self) -> str | None:
        """The naming service to bind in (the started one when none is configured)."""
        if self.naming_service is None and self.start_naming_service:
            return f"corbaloc::127.0.0.1:{self.naming_port}/NameService"
        return self.naming_service


def parse_endpoint(endpoint: str) -> tuple[str, str, int | None]:
    """``("unix", path, None)`` or ``("tcp", host, port)`` of an omniORB endpoint."""
    if endpoint.startswith("giop:unix:"):
        return "unix", endpoint.removeprefix("giop:unix:"), None
    if not endpoint.startswith("giop:tcp:"):
        raise ValueError(f"{endpoint!r}: expected giop:tcp:HOST:PORT or giop:unix:PATH")
    host, sep, port_text = endpoint.removeprefix("giop:tcp:").rpartition(":")
    if not sep or not host:
        raise ValueError(f"{endpoint!r}: expected giop:tcp:HOST:PORT (HOST 127.0.0.1, [::1], ...)")
    try:
        port = int(port_text)
    except ValueError:
        raise ValueError(f"{endpoint!r}: port {port_text!r} is not a number") from None
    if not 0 <= port <= 65535:
        raise ValueError(f"{endpoint!r}: port {port} is outside 0..65535")
    return "tcp", host.strip("[]"), port


def endpoint_is_local(endpoint: str) -> bool:
    kind, host, _ = parse_endpoint(endpoint)
    if kind == "unix" or host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a host name: may resolve to anything


def corba_problems(cfg: CorbaConfig) -> list[str]:
    """Why the daemon must not start with this CORBA set-up (empty: fine)."""
    if not cfg.enabled:
        return []
    problems = []
    if importlib.util.find_spec("omniORB") is None:
        problems.append(
            "corba.enabled: omniORBpy is not installed: pip install 'imotion[corba]' "
            "(or set corba.enabled: false)"
        )
    if not endpoint_is_local(cfg.endpoint) and not cfg.allow_remote:
        problems.append(
            f"corba.endpoint: {cfg.endpoint} is not loopback or a Unix socket: IIOP has no TLS "
            "and no authentication here; set corba.allow_remote: true to serve there anyway"
        )
    return problems


def corba_warnings(cfg: CorbaConfig) -> list[str]:
    """What is allowed but unsafe (logged as warnings at start)."""
    if cfg.enabled and not endpoint_is_local(cfg.endpoint):
        return [
            f"CORBA serves on {cfg.endpoint}, off loopback: IIOP has no TLS and no "
            "authentication, and gRPC's motion-token rules do NOT apply to CORBA clients: "
            "anyone who reaches this port can drive the robot"
        ]
    return []

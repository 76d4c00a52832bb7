"""Settings of the OpenRTM-compatible RT component (``corba.rtc`` in the daemon's configuration).

An OpenRTM consumer finds a provided interface only when both its *type name* (the IDL
interface, fixed) and its *instance name* match; rtshell scripts name the *port*
(``rtcon /localhost/host.host_cxt/imotion0.rtc:manipMiddle ...``). Existing clients use
different names, so port and instance names come from a preset and can be overridden per
interface (docs/rtc.md lists the presets and where each name comes from).
"""

from __future__ import annotations

import re
from typing import Literal

from pydantic import BaseModel, ConfigDict, field_validator, model_validator

#: The interfaces imotion provides over CORBA, by key (the keys of ``corba.names``): Spec A,
#: JARA_ARM (right arm), JARA_ARM_LEFT (left arm), JARA_ARM_DUAL.
InterfaceKey = Literal[
    "spec_a",
    "jara_arm_common",
    "jara_arm_middle",
    "jara_arm_left_common",
    "jara_arm_left_middle",
    "jara_dual_common",
    "jara_dual_middle",
]

#: IDL type name of each interface, as OpenRTM writes it in port interface profiles.
TYPE_NAMES: dict[InterfaceKey, str] = {
    "spec_a": "IntegratedMotionInterface",
    "jara_arm_common": "JARA_ARM::ManipulatorCommonInterface_Common",
    "jara_arm_middle": "JARA_ARM::ManipulatorCommonInterface_Middle",
    "jara_arm_left_common": "JARA_ARM_LEFT::LeftManipulatorCommonInterface_Common",
    "jara_arm_left_middle": "JARA_ARM_LEFT::LeftManipulatorCommonInterface_Middle",
    "jara_dual_common": "JARA_ARM_DUAL::DualManipulatorCommonInterface_Common",
    "jara_dual_middle": "JARA_ARM_DUAL::DualManipulatorCommonInterface_Middle",
}

# Port and instance names: no "." (OpenRTM joins "<rtc>.port.<port>.provided.<type>.<inst>")
# and no "/" or ":" (rtshell paths are "/ns/host.host_cxt/<rtc>.rtc:<port>").
_NAME = re.compile(r"^[A-Za-z0-9_\-]+$")


def _check_name(value: str, what: str) -> str:
    if not _NAME.match(value):
        raise ValueError(f"{what} {value!r}: use letters, digits, '_' and '-' only")
    return value


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


class PortNames(_Strict):
    """Where one interface is provided: the service port and the interface instance name."""

    port: str
    instance: str

    @field_validator("port", "instance")
    @classmethod
    def _names(cls, value: str) -> str:
        return _check_name(value, "name")


def _preset(names: dict[InterfaceKey, tuple[str, str]]) -> dict[InterfaceKey, PortNames]:
    return {key: PortNames(port=port, instance=inst) for key, (port, inst) in names.items()}


#: Shipped naming conventions (docs/rtc.md says where each name was read).
PRESETS: dict[str, dict[InterfaceKey, PortNames]] = {
    # SEED-Noid upper-body RTCs (rsdlab SeedUpperBody-RTM-pkg) and their controllers; the
    # instance names are also those of the JARA C++ samples (rtc-template defaults).
    "seed_noid": _preset(
        {
            "spec_a": ("IntegratedMotionInterface", "IntegratedMotionInterface"),
            "jara_arm_common": (
                "RightManipulatorCommonInterface_Common",
                "ManipulatorCommonInterface_Common",
            ),
            "jara_arm_middle": (
                "RightManipulatorCommonInterface_Middle",
                "ManipulatorCommonInterface_Middle",
            ),
            "jara_arm_left_common": (
                "LeftManipulatorCommonInterface_Common",
                "LeftManipulatorCommonInterface_Common",
            ),
            "jara_arm_left_middle": (
                "LeftManipulatorCommonInterface_Middle",
                "LeftManipulatorCommonInterface_Middle",
            ),
            "jara_dual_common": (
                "DualManipulatorCommonInterface_Common",
                "DualManipulatorCommonInterface_Common",
            ),
            "jara_dual_middle": (
                "DualManipulatorCommonInterface_Middle",
                "DualManipulatorCommonInterface_Middle",
            ),
        }
    ),
    # The JARA arm RTCs written with the "<module>_<interface>" instance names: the Mikata arm
    # (rsdlab MikataSyatem, ports manipCommon / manipMiddle) and its test/consumer RTCs.
    "jara": _preset(
        {
            "spec_a": ("IntegratedMotionInterface", "IntegratedMotionInterface"),
            "jara_arm_common": ("manipCommon", "JARA_ARM_ManipulatorCommonInterface_Common"),
            "jara_arm_middle": ("manipMiddle", "JARA_ARM_ManipulatorCommonInterface_Middle"),
            "jara_arm_left_common": (
                "leftManipCommon",
                "JARA_ARM_LEFT_LeftManipulatorCommonInterface_Common",
            ),
            "jara_arm_left_middle": (
                "leftManipMiddle",
                "JARA_ARM_LEFT_LeftManipulatorCommonInterface_Middle",
            ),
            "jara_dual_common": (
                "dualManipCommon",
                "JARA_ARM_DUAL_DualManipulatorCommonInterface_Common",
            ),
            "jara_dual_middle": (
                "dualManipMiddle",
                "JARA_ARM_DUAL_DualManipulatorCommonInterface_Middle",
            ),
        }
    ),
}


class RtcConfig(_Strict):
    """The RT component registered as ``<host_context>.host_cxt/<name>.rtc``."""

    #: Serve the RT component (when CORBA is enabled).
    enabled: bool = True
    #: Instance name (``<name>.rtc`` in the naming service; rtshell paths use it).
    name: str = "imotion0"
    #: Component type name (OpenRTM: the implementation, e.g. ``SeedUpperBodyRTC``).
    type_name: str = "imotion"
    vendor: str = "imotion"
    category: str = "Manipulator"
    description: str = "imotion whole-body motion controller"
    #: Naming context ``<host_context>.host_cxt``; None: this machine's host name.
    host_context: str | None = None
    #: Port and instance names of every interface: a shipped preset ...
    preset: Literal["seed_noid", "jara"] = "seed_noid"
    #: ... with per-interface overrides, e.g.
    #: ``{jara_arm_middle: {port: arm, instance: arm_middle}}``.
    ports: dict[InterfaceKey, PortNames] = {}
    #: Component state at start: INACTIVE (as an OpenRTM component after initialize) or
    #: ACTIVE. The state is bookkeeping only (docs/rtc.md): it never moves the robot.
    activate_at_start: bool = False

    @field_validator("name", "type_name")
    @classmethod
    def _names(cls, value: str) -> str:
        return _check_name(value, "name")

    @field_validator("host_context")
    @classmethod
    def _host(cls, value: str | None) -> str | None:
        if value is not None and (not value or "/" in value or ":" in value):
            raise ValueError(f"host_context {value!r}: a host name, without '/' or ':'")
        return value

    @model_validator(mode="after")
    def _distinct(self) -> RtcConfig:
        seen: dict[tuple[str, str], str] = {}
        for key in TYPE_NAMES:
            names = self.names(key)
            pair = (names.port, names.instance)
            if pair in seen:
                raise ValueError(
                    f"ports: {key} and {seen[pair]} both use port {names.port!r} with instance "
                    f"{names.instance!r} (one instance name per port)"
                )
            seen[pair] = key
        return self

    def names(self, key: InterfaceKey) -> PortNames:
        """Port and instance name of one interface (override, else the preset's)."""
        return self.ports.get(key) or PRESETS[self.preset][key]

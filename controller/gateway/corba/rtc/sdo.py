"""The component's SDO configuration (``SDOPackage::Configuration``), read-only.

``rtcat`` lists the configuration sets; imotion has one, ``default``, showing the settings
the component was started with. They are changed in imotiond's configuration, not over
CORBA: every write is refused with ``SDOPackage::NotAvailable`` (saying why), except the
service-profile operations, which answer False (rtctree turns that into a clean error).
"""

from __future__ import annotations

from typing import Any

from omniORB import any as corba_any
from rtctree.rtc import SDOPackage, SDOPackage__POA

from controller.gateway.corba.rtc.nvlist import nvlist

DEFAULT_SET = "default"
_READ_ONLY = (
    "imotion's RT component settings are read-only: change them in imotiond's configuration"
)


class Configuration(SDOPackage__POA.Configuration):
    def __init__(self, values: dict[str, str]):
        self._values = dict(values)
        self._set = SDOPackage.ConfigurationSet(
            DEFAULT_SET, "imotion settings (read-only)", nvlist(self._values)
        )

    # -- reads ------------------------------------------------------------------------------

    def get_configuration_parameters(self) -> list[Any]:
        return []

    def get_configuration_parameter_values(self) -> list[Any]:
        return nvlist(self._values)

    def get_configuration_parameter_value(self, name: str) -> Any:
        if name not in self._values:
            raise SDOPackage.InvalidParameter(f"no configuration parameter {name!r}")
        return corba_any.to_any(self._values[name])

    def get_configuration_sets(self) -> list[Any]:
        return [self._set]

    def get_configuration_set(self, config_id: str) -> Any:
        if config_id != DEFAULT_SET:
            # The IDL allows only NotAvailable / InternalError here; OpenRTM raises the latter.
            raise SDOPackage.InternalError(f"no configuration set {config_id!r}")
        return self._set

    def get_active_configuration_set(self) -> Any:
        return self._set

    def activate_configuration_set(self, config_id: str) -> bool:
        if config_id != DEFAULT_SET:
            raise SDOPackage.InvalidParameter(f"no configuration set {config_id!r}")
        return True

    # -- writes: refused ------------------------------------------------------------------------

    def add_service_profile(self, profile: Any) -> bool:
        return False  # no observers or loggers: rtctree reports InvalidSdoServiceError

    def remove_service_profile(self, service_id: str) -> bool:
        return False

    def set_device_profile(self, profile: Any) -> bool:
        raise SDOPackage.NotAvailable(_READ_ONLY)

    def add_organization(self, organization: Any) -> bool:
        raise SDOPackage.NotAvailable("imotion's RT component joins no organization")

    def remove_organization(self, organization_id: str) -> bool:
        raise SDOPackage.NotAvailable("imotion's RT component joins no organization")

    def set_configuration_parameter(self, name: str, value: Any) -> bool:
        raise SDOPackage.NotAvailable(_READ_ONLY)

    def set_configuration_set_values(self, configuration_set: Any) -> bool:
        raise SDOPackage.NotAvailable(_READ_ONLY)

    def add_configuration_set(self, configuration_set: Any) -> bool:
        raise SDOPackage.NotAvailable(_READ_ONLY)

    def remove_configuration_set(self, config_id: str) -> bool:
        raise SDOPackage.NotAvailable(_READ_ONLY)

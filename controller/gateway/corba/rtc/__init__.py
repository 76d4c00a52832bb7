"""The OpenRTM-compatible RT component around imotion's CORBA servants (docs/rtc.md).

Uses the OMG RTC / SDO / OpenRTM stubs shipped by ``rtctree-aist`` (the ``corba`` extra).
"""

from controller.gateway.corba.rtc.port import ProvidedInterface
from controller.gateway.corba.rtc.rt_component import RtComponent, provided_interfaces

__all__ = ["ProvidedInterface", "RtComponent", "provided_interfaces"]

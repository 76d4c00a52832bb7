"""CAN master side (CiA 402 over python-can); see docs/can.md."""

from hal.can.unix_bus import register

register()  # interface "unix" also without the installed entry point

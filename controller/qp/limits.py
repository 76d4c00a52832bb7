"""The limits' former home: the names other modules import from here.

The constraints now live in :mod:`controller.qp.constraints` (the protocol, the joint box,
the redundant-axis rows, the differential drive); import them from there.
"""

from controller.qp.constraints import BRAKING_SHARE, INF, AxisRows, JointBox

__all__ = ["BRAKING_SHARE", "INF", "AxisRows", "JointBox"]

"""imotion controller: kinematics, QP, motion generation, loop, service and daemon."""

__version__ = "0.1.0"

"""Transport-independent services: one object per interface family (Spec A, JARA_ARM,
JARA_ARM_DUAL). They take spec-unit Python values (mm, deg, s, %; enums from
:mod:`controller.vocabulary`), convert them through :mod:`controller.conversions`, check the
state, plan (:mod:`controller.gateway.planning`) and call the control process. They return plain
results or raise :class:`controller.errors.ImotionError` subclasses carrying the return code.

A transport (gRPC today, CORBA next) maps its messages onto these calls and back, nothing
more.
"""

"""The gateway's service objects, one of each per gateway, shared by every transport (gRPC
and CORBA see the same JARA settings, the same redundant-axes mask, the same queue)."""

from __future__ import annotations

from dataclasses import dataclass

from controller.gateway.services.context import Context
from controller.gateway.services.jara_arm import JaraArmService
from controller.gateway.services.jara_dual import JaraDualService
from controller.gateway.services.jara_settings import JaraSettingsService
from controller.gateway.services.spec_a import SpecAService


@dataclass
class Services:
    ctx: Context
    spec_a: SpecAService
    arms: JaraArmService  #: JARA motions (JARA_ARM, JARA_ARM_LEFT, JARA_ARM_DUAL)
    settings: JaraSettingsService  #: JARA per-arm settings
    dual: JaraDualService

    @classmethod
    def build(cls, ctx: Context) -> Services:
        arms = JaraArmService(ctx)
        return cls(ctx, SpecAService(ctx), arms, JaraSettingsService(arms), JaraDualService(arms))

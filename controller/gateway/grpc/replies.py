"""Spec A and JARA_ARM states of a snapshot: see :mod:`controller.gateway.services.states`
(kept here for the servicers and tests that import them from the gRPC package)."""

from __future__ import annotations

from controller.gateway.services.states import jara_state, spec_a_state
from controller.vocabulary import CoreState, JaraState, SpecAState

__all__ = ["CoreState", "JaraState", "SpecAState", "jara_state", "spec_a_state"]

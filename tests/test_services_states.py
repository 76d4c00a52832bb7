"""controller.gateway.services.states: Spec A states and the JARA bits (ruling 15.9)."""

from __future__ import annotations

from controller.gateway.services.states import jara_state, spec_a_state
from controller.vocabulary import CoreState, JaraState, SpecAState
from tests.planning_support import robot, snapshot


def test_spec_a_states():
    rob = robot("pa10")
    assert spec_a_state(snapshot(rob))[0] == SpecAState.READY
    state, text = spec_a_state(snapshot(rob, state=CoreState.BUSY, moving=True, queue=2))
    assert state == SpecAState.BUSY and "(2 queued)" in text


def test_jara_moving_bit_means_the_axes_move():
    rob = robot("pa10")
    assert jara_state(snapshot(rob, state=CoreState.BUSY, moving=True)) & JaraState.MOVING
    # paused and still, with a motion queued behind: 0x10 alone (plus servo on)
    paused = jara_state(snapshot(rob, state=CoreState.PAUSED, motion=True, queue=1))
    assert paused == JaraState.SERVO_ON | JaraState.PAUSED
    assert not jara_state(snapshot(rob)) & JaraState.MOVING

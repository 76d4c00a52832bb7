"""Closed loop on MuJoCo: random commands never bring robot geoms into contact (issue 10).

A seeded, bounded subset (``CI_COMMANDS`` per robot, well under a minute for the four
robots); the full figure (10 000 commands) is ``python tools/collision_property.py``, or this
test with ``IMOTION_COLLISION_COMMANDS=2500`` (per robot). What a command is and what is
checked: ``tests/collision_support.py``.
"""

from __future__ import annotations

import os

import pytest

from config import robot_ids
from tests.collision_support import run

CI_COMMANDS = int(os.environ.get("IMOTION_COLLISION_COMMANDS", "25"))


@pytest.mark.parametrize("robot_id", robot_ids())
def test_random_commands_keep_every_checked_pair_apart(robot_id: str) -> None:
    stats = run(robot_id, CI_COMMANDS, seed=1)
    assert stats.commands == CI_COMMANDS
    assert not stats.qp_failures, stats.failures
    assert not stats.contact_cycles, sorted(stats.contacts)  # MuJoCo's own detection
    assert not stats.below_security, stats.min_distance  # never below d_s (0.1 mm slack)

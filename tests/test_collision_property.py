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


#: PA10's link5-flange distance is flat (35 mm) for |J6| up to ~85 deg, then drops steeply
#: (the derived capsules' end spheres sit on the J6 axis): the first-order rows see nothing
#: coming until the kink, and a wrist swinging at full speed cannot brake in the 3 cm left.
#: A model matter (tighter wrist shapes in model.yaml); strict: remove the mark once it passes.
KINKED = pytest.mark.xfail(
    reason="PA10 link5-flange: flat-then-steep distance (see docs/collision.md)", strict=True
)


@pytest.mark.parametrize(
    "robot_id", [pytest.param(r, marks=KINKED) if r == "pa10" else r for r in robot_ids()]
)
def test_random_commands_keep_every_checked_pair_apart(robot_id: str) -> None:
    stats = run(robot_id, CI_COMMANDS, seed=1)
    assert stats.commands == CI_COMMANDS
    assert not stats.qp_failures, stats.failures
    assert not stats.contact_cycles, sorted(stats.contacts)  # MuJoCo's own detection
    assert not stats.below_security, stats.min_distance  # never below d_s (0.1 mm slack)

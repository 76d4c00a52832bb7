"""controller.gateway.services.context: command refusals become codes; a stop forgets the
queue's end (issue 15.1)."""

from __future__ import annotations

import numpy as np
import pytest

from controller.errors import Refused
from controller.vocabulary import ReturnCode
from tests.planning_support import context


def test_refusals_carry_the_family_code():
    ctx, _, channel = context("pa10")
    channel.refuse["start"] = (int(ReturnCode.NOT_SV_ON_ERR), "servos off")
    with pytest.raises(Refused) as err:
        ctx.call("start", spec=None)
    assert err.value.code == ReturnCode.NOT_SV_ON_ERR
    with pytest.raises(Refused) as err:
        ctx.call("start", sv_on_code=False, spec=None)
    assert err.value.code == ReturnCode.STATUS_ERR
    channel.refuse["pause"] = (12345, "odd")
    with pytest.raises(Refused) as err:
        ctx.call("pause")
    assert err.value.code == ReturnCode.NG


@pytest.mark.parametrize("name", ["stop", "abort", "servo_off", "clear_alarms"])
def test_commands_that_empty_the_queue_forget_its_end(name):
    ctx, _, _ = context("pa10")
    ctx.planner.remember(np.zeros(3))
    ctx.call(name)
    assert ctx.planner.tail is None

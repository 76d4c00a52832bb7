"""hal.can.factory via hal.factory.make_hardware: can options, bus-load refusal, the TPDO
timeout in time (hil: tests/test_hil.py)."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
import yaml

from config import ROBOTS_DIR
from hal.can.backend import CanBackend
from hal.factory import make_hardware
from hal.interface import HardwareState
from tests.support import robot


def test_can_backend_with_bus_overrides():
    hw = make_hardware(
        "can", robot("pa10"), 0.002, {"buses": {"arm_a": {"interface": "virtual", "channel": "x"}}}
    )
    assert isinstance(hw, CanBackend)
    assert hw.bus_kwargs("arm_a") == {"interface": "virtual", "channel": "x"}
    assert hw.bus_kwargs("arm_b")["channel"] == "can1"
    assert hw.state is HardwareState.UNCONFIGURED


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"nope": 1}, "unknown keys"),
        ({"feedback_wait": -1}, "feedback_wait"),
        ({"buses": {"ghost": {}}}, "unknown bus 'ghost'"),
        ({"buses": 3}, "hal.options.buses"),
        ({"lockstep_timeout": 1.0}, "unknown keys"),
        ({"tpdo_timeout": "x"}, "tpdo_timeout"),
    ],
)
def test_bad_options(options: dict, message: str):
    with pytest.raises(ValueError, match=message):
        make_hardware("can", robot("pa10"), 0.002, options)


def test_overloaded_profile_is_refused_with_the_table(tmp_path: Path):
    path = tmp_path / "drives.yaml"
    data = yaml.safe_load((ROBOTS_DIR / "smartpal5" / "drives.yaml").read_text())
    for drive in data["drives"].values():
        drive["bus"] = "body"
    data["buses"] = {"body": data["buses"]["body"]}
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ValueError) as err:
        make_hardware("can", robot("smartpal5"), 0.002, {"drives": str(path)})
    text = str(err.value)
    assert "body" in text and "over 100 %: refused" in text


def test_busy_profile_warns(caplog: pytest.LogCaptureFixture):
    with caplog.at_level(logging.WARNING):
        make_hardware("can", robot("seednoid"), 0.002)
    assert "above 70 %" in caplog.text


def test_tpdo_timeout_in_seconds_raises_the_cycle_count():
    hw = make_hardware("can", robot("pa10"), 0.002, {"tpdo_timeout": 0.1})
    assert isinstance(hw, CanBackend) and hw.profile.tpdo_timeout_cycles == 50
    hw = make_hardware("can", robot("pa10"), 0.002, {"tpdo_timeout": 0.001})
    assert isinstance(hw, CanBackend) and hw.profile.tpdo_timeout_cycles == 3  # drives.yaml's


def test_heartbeat_timeout_raises_both_consumer_times():
    hw = make_hardware("can", robot("pa10"), 0.002, {"heartbeat_timeout": 0.5})
    assert isinstance(hw, CanBackend)
    assert hw.profile.heartbeat.master_consumer_ms == hw.profile.heartbeat.drive_consumer_ms == 500
    hw = make_hardware("can", robot("pa10"), 0.002, {"heartbeat_timeout": 0.1})
    assert isinstance(hw, CanBackend) and hw.profile.heartbeat.master_consumer_ms == 300

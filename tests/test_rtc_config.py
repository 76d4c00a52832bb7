"""corba.rtc settings: presets per client convention, overrides, names checked."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from controller.contract.config import load_config
from controller.contract.rtc_config import PRESETS, TYPE_NAMES, PortNames, RtcConfig
from controller.model.yaml_source import ConfigError


def test_default_preset_is_seed_noids_names() -> None:
    cfg = RtcConfig()
    assert cfg.preset == "seed_noid"
    assert cfg.names("jara_arm_common") == PortNames(
        port="RightManipulatorCommonInterface_Common", instance="ManipulatorCommonInterface_Common"
    )
    assert cfg.names("jara_arm_left_middle").instance == "LeftManipulatorCommonInterface_Middle"


def test_jara_preset_has_the_mikata_arms_names() -> None:
    cfg = RtcConfig(preset="jara")
    assert cfg.names("jara_arm_middle") == PortNames(
        port="manipMiddle", instance="JARA_ARM_ManipulatorCommonInterface_Middle"
    )
    assert cfg.names("jara_arm_common").port == "manipCommon"


def test_every_preset_names_every_interface_once_per_port() -> None:
    for preset in PRESETS.values():
        assert set(preset) == set(TYPE_NAMES)
        pairs = [(n.port, n.instance) for n in preset.values()]
        assert len(pairs) == len(set(pairs))


def test_an_override_replaces_one_interface() -> None:
    cfg = RtcConfig.model_validate(
        {"preset": "jara", "ports": {"jara_arm_middle": {"port": "arm", "instance": "mid"}}}
    )
    assert cfg.names("jara_arm_middle") == PortNames(port="arm", instance="mid")
    assert cfg.names("jara_arm_common").port == "manipCommon"


@pytest.mark.parametrize(
    "data",
    [
        {"name": "a.b"},
        {"name": "a/b"},
        {"name": ""},
        {"type_name": "x:y"},
        {"host_context": "a/b"},
        {"host_context": ""},
        {"preset": "other"},
        {"ports": {"nope": {"port": "a", "instance": "b"}}},
        {"ports": {"spec_a": {"port": "a.b", "instance": "b"}}},
        {"ports": {"spec_a": {"port": "a"}}},
        {"rebind_interval_s": 1.0},
        {"unknown": 1},
    ],
)
def test_bad_settings_are_refused(data: dict[str, object]) -> None:
    with pytest.raises(ValidationError):
        RtcConfig.model_validate(data)


def test_a_dotted_host_name_is_fine() -> None:
    assert RtcConfig(host_context="robot.local").host_context == "robot.local"


def test_the_daemon_configuration_carries_corba_rtc() -> None:
    cfg = load_config(None, sets=["corba.rtc.preset=jara", "corba.rtc.name=arm0"])
    assert cfg.corba.rtc.preset == "jara" and cfg.corba.rtc.name == "arm0"
    assert cfg.corba.rtc.enabled  # served whenever corba.enabled
    with pytest.raises(ConfigError, match=r"corba\.rtc\.preset"):
        load_config(None, sets=["corba.rtc.preset=nope"])


def test_one_instance_name_twice_on_a_port_is_refused() -> None:
    same = {"port": "arm", "instance": "x"}
    with pytest.raises(ValidationError, match="one instance name per port"):
        RtcConfig.model_validate({"ports": {"jara_arm_common": same, "jara_arm_middle": same}})
    other = {"port": "arm", "instance": "y"}  # one port, two instances: fine
    RtcConfig.model_validate({"ports": {"jara_arm_common": same, "jara_arm_middle": other}})

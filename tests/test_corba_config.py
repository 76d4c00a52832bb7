"""The ``corba:`` configuration section (controller/contract/corba_config.py)."""

from __future__ import annotations

from unittest import mock

import pytest

from controller.contract.config import load_config, security_problems, security_warnings
from controller.contract.corba_config import (
    CorbaConfig,
    corba_problems,
    endpoint_is_local,
    parse_endpoint,
)
from controller.model.yaml_source import ConfigError


def test_defaults_off_loopback_any_port_no_naming() -> None:
    c = load_config(None).corba
    assert not c.enabled and c.naming_service is None and c.ior_dir is None
    assert c.endpoint == "giop:tcp:127.0.0.1:0" and not c.allow_remote
    assert c.units.spec_a == c.units.jara_arm == c.units.jara_dual == "mm_deg"
    assert c.names.spec_a == "imotion/IntegratedMotionInterface"
    assert c.names.jara_arm_middle == "imotion/JARA_ARM.ManipulatorCommonInterface_Middle"


def test_the_two_settings_of_the_issue_are_enough() -> None:
    cfg = load_config(
        None,
        sets=["corba.enabled=true", "corba.naming_service=corbaloc::127.0.0.1:2809/NameService"],
    )
    assert cfg.corba.enabled
    assert cfg.corba.naming_uri() == "corbaloc::127.0.0.1:2809/NameService"
    assert security_problems(cfg) == []


def test_started_naming_service_is_the_default_uri() -> None:
    c = CorbaConfig(enabled=True, start_naming_service=True, naming_port=12809)
    assert c.naming_uri() == "corbaloc::127.0.0.1:12809/NameService"


@pytest.mark.parametrize(
    ("key", "value", "where"),
    [
        ("corba.endpoint", "tcp:127.0.0.1:0", "corba.endpoint"),
        ("corba.endpoint", "giop:tcp:127.0.0.1:99999", "corba.endpoint"),
        ("corba.endpoint", "giop:tcp::x", "corba.endpoint"),
        ("corba.naming_service", "127.0.0.1:2809", "corba.naming_service"),
        ("corba.units.jara_arm", "inch", "corba.units.jara_arm"),
        ("corba.units.spec_a", "si", "corba.units.spec_a"),
        ("corba.names.spec_a", "a//b", "corba.names.spec_a"),
        ("corba.rebind_interval_s", "0", "corba.rebind_interval_s"),
        ("corba.bogus", "1", "corba.bogus"),
    ],
)
def test_bad_values_name_the_key(key: str, value: str, where: str) -> None:
    with pytest.raises(ConfigError, match=where.replace(".", r"\.")):
        load_config(None, sets=[f"{key}={value}"])


def test_endpoints() -> None:
    assert parse_endpoint("giop:tcp:127.0.0.1:2810") == ("tcp", "127.0.0.1", 2810)
    assert parse_endpoint("giop:tcp:[::1]:0") == ("tcp", "::1", 0)
    assert parse_endpoint("giop:unix:/run/imotion/corba.sock") == (
        "unix",
        "/run/imotion/corba.sock",
        None,
    )
    assert endpoint_is_local("giop:unix:/tmp/x") and endpoint_is_local("giop:tcp:[::1]:0")
    assert not endpoint_is_local("giop:tcp:0.0.0.0:2810")
    assert not endpoint_is_local("giop:tcp:robot.local:2810")


def test_remote_endpoint_needs_allow_remote_then_warns_loudly() -> None:
    sets = ["corba.enabled=true", "corba.endpoint=giop:tcp:0.0.0.0:2810"]
    cfg = load_config(None, sets=sets)
    assert any("corba.allow_remote" in p for p in security_problems(cfg))
    cfg = load_config(None, sets=[*sets, "corba.allow_remote=true"])
    assert security_problems(cfg) == []
    (warning,) = [w for w in security_warnings(cfg) if "CORBA" in w]
    assert "no TLS" in warning and "motion-token" in warning


def test_remote_endpoint_is_fine_while_corba_is_off() -> None:
    cfg = load_config(None, sets=["corba.endpoint=giop:tcp:0.0.0.0:2810"])
    assert security_problems(cfg) == [] and not any("CORBA" in w for w in security_warnings(cfg))


def test_without_omniorb_the_problem_says_how_to_enable_it() -> None:
    with mock.patch("importlib.util.find_spec", return_value=None):
        (problem,) = corba_problems(CorbaConfig(enabled=True))
    assert "pip install 'imotion[corba]'" in problem
    with mock.patch("importlib.util.find_spec", return_value=None):
        assert corba_problems(CorbaConfig(enabled=False)) == []

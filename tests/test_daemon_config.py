"""controller.contract.config: defaults, the YAML file, --set and flag overrides, listen
addresses and the security rules."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from controller.contract.config import (
    DEFAULT_LISTEN,
    DaemonConfig,
    is_local,
    load_config,
    parse_listen,
    security_problems,
)
from controller.model.yaml_source import ConfigError


def test_defaults():
    cfg = load_config()
    assert cfg.robot == "smartpal5" and cfg.hal == "sim" and cfg.listen == DEFAULT_LISTEN
    assert cfg.listen == "127.0.0.1:50051"
    assert cfg.period == pytest.approx(1.0 / cfg.loop.rate_hz)
    assert cfg.security.tokens.motion is None and cfg.security.tls_cert is None
    assert security_problems(cfg) == []


def test_file_then_set_then_flags(tmp_path: Path):
    path = tmp_path / "imotiond.yaml"
    path.write_text(
        "robot: pa10\nqueue_depth: 4\nloop:\n  rate_hz: 250\n  solver: proxqp\n"
        "security:\n  tokens:\n    read: r1\n"
    )
    cfg = load_config(
        path,
        {"robot": "rh", "hal": None, "loop.rate_hz": 1000.0},
        ["queue_depth=16", "security.tokens.motion=m1", "loop.rate_hz=333", "robot=seednoid"],
    )
    assert cfg.robot == "rh"  # flag beats --set beats file
    assert cfg.loop.rate_hz == 1000.0
    assert cfg.queue_depth == 16  # --set beats file
    assert cfg.loop.solver == "proxqp"  # untouched file value in the same section
    assert cfg.security.tokens.read == "r1" and cfg.security.tokens.motion == "m1"
    assert cfg.hal == "sim"  # a None flag does not override


def test_set_values_are_yaml(tmp_path: Path):
    cfg = load_config(
        None,
        None,
        ["realtime.enabled=false", "hal_options={port: 3}", "security.tokens.read='007'"],
    )
    assert cfg.realtime.enabled is False
    assert cfg.hal_options == {"port": 3}
    assert cfg.security.tokens.read == "007"


@pytest.mark.parametrize(
    "text, where",
    [
        ("loop:\n  rate_hz: 5\n", "loop.rate_hz"),
        ("loop:\n  rate_hz: .inf\n", "loop.rate_hz"),
        ("loop:\n  rate_hz: .nan\n", "loop.rate_hz"),
        ("queue_depth: 0\n", "queue_depth"),
        ("bogus: 1\n", "bogus"),
        ("loop:\n  bogus: 1\n", "loop.bogus"),
        ("hal: can2\n", "hal"),
        ("listen: nowhere\n", "listen"),
        ("listen: 'host:99999'\n", "listen"),
        ("listen: 'unix:'\n", "listen"),
        ("stop_timeout_s: 0\n", "stop_timeout_s"),
        ("jara:\n  max_speed_cartesian: [1]\n", "jara.max_speed_cartesian"),
        ("realtime:\n  priority: 10\n  helper_priority: 10\n", "realtime"),
        ("realtime:\n  helper_priority: -1\n", "realtime.helper_priority"),
        ("realtime:\n  loop_cpus: [-1]\n", "realtime.loop_cpus"),
        ("realtime:\n  loop_cpus: []\n", "realtime.loop_cpus"),
        ("realtime:\n  loop_cpus: one\n", "realtime.loop_cpus"),
        ("realtime:\n  spin_us: -1\n", "realtime.spin_us"),
    ],
)
def test_invalid_settings_name_the_file_and_key(tmp_path: Path, text: str, where: str):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    message = str(err.value)
    assert message.startswith(str(path)) and f": {where}" in message, message


def test_file_problems(tmp_path: Path):
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("loop: [1, 2\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(bad)
    bad.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="mapping of settings"):
        load_config(bad)
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    assert load_config(empty) == DaemonConfig()


@pytest.mark.parametrize(
    "item, fragment",
    [
        ("loop.rate_hz", "expected KEY=VALUE"),
        ("=3", "expected KEY=VALUE"),
        ("robot.name=x", "--set: robot: Input should be a valid string"),
        ("loop.rate_hz=fast", "--set: loop.rate_hz"),
    ],
)
def test_bad_set_items(item: str, fragment: str):
    with pytest.raises(ConfigError, match=re.escape(fragment)):
        load_config(None, None, [item])


def test_set_below_a_plain_value():
    with pytest.raises(ConfigError, match=r"--set robot\.name: robot is not a section"):
        load_config(None, None, ["robot=pa10", "robot.name=x"])


@pytest.mark.parametrize(
    "address, parsed",
    [
        ("127.0.0.1:50051", ("tcp", "127.0.0.1", 50051)),
        ("[::1]:7", ("tcp", "::1", 7)),
        ("localhost:0", ("tcp", "localhost", 0)),
        ("unix:/run/imotion.sock", ("unix", "/run/imotion.sock", None)),
        ("unix:///run/imotion.sock", ("unix", "/run/imotion.sock", None)),
    ],
)
def test_parse_listen(address: str, parsed: tuple):
    assert parse_listen(address) == parsed


@pytest.mark.parametrize("address", ["50051", ":50051", "host:port", "host:-1", "unix:"])
def test_parse_listen_rejects(address: str):
    with pytest.raises(ValueError, match=r"\S"):
        parse_listen(address)


@pytest.mark.parametrize(
    "address, local",
    [
        ("127.0.0.1:1", True),
        ("127.8.9.10:1", True),
        ("[::1]:1", True),
        ("localhost:1", True),
        ("unix:/tmp/x.sock", True),
        ("0.0.0.0:1", False),
        ("[::]:1", False),
        ("192.168.1.5:1", False),
        ("robot.lan:1", False),  # a name may resolve to anything
    ],
)
def test_is_local(address: str, local: bool):
    assert is_local(address) is local


def _cfg(**sets: object) -> DaemonConfig:
    return load_config(None, dict(sets))  # type: ignore[arg-type]


def test_security_off_loopback_needs_tls_and_a_token(tmp_path: Path):
    problems = security_problems(_cfg(listen="0.0.0.0:50051"))
    assert len(problems) == 2
    assert any("TLS is required" in p for p in problems)
    assert any("security.tokens.motion" in p for p in problems)
    cert, key = tmp_path / "c.pem", tmp_path / "k.pem"
    cert.write_text("x")
    key.write_text("y")
    tls = {"security.tls_cert": str(cert), "security.tls_key": str(key)}
    only_tls = security_problems(_cfg(listen="0.0.0.0:50051", **tls))
    assert len(only_tls) == 1 and "token" in only_tls[0]
    only_read = _cfg(listen="0.0.0.0:50051", **tls, **{"security.tokens.read": "r"})
    assert any("security.tokens.motion" in p for p in security_problems(only_read))
    full = _cfg(listen="0.0.0.0:50051", **tls, **{"security.tokens.motion": "m"})
    assert security_problems(full) == []
    assert security_problems(_cfg(listen="unix:/tmp/imotion.sock")) == []


def test_security_tls_files(tmp_path: Path):
    cert = tmp_path / "c.pem"
    cert.write_text("x")
    half = security_problems(_cfg(**{"security.tls_cert": str(cert)}))
    assert any("go together" in p for p in half)
    missing = security_problems(
        _cfg(**{"security.tls_cert": str(cert), "security.tls_key": str(tmp_path / "no.pem")})
    )
    assert missing == [f"security.tls_key: {tmp_path / 'no.pem'} is not a readable file"]


def test_security_token_rules_on_loopback():
    read_only = _cfg(**{"security.tokens.read": "r"})
    (problem,) = security_problems(read_only)
    assert "lock every client out" in problem
    strict = _cfg(**{"security.require_tokens_locally": True})
    (problem,) = security_problems(strict)
    assert "require_tokens_locally" in problem
    both = _cfg(**{"security.require_tokens_locally": True, "security.tokens.motion": "m"})
    assert security_problems(both) == []


def test_gateway_nice_is_bounded():
    assert load_config(None, None, []).gateway_nice == -5
    assert load_config(None, None, ["gateway_nice=0"]).gateway_nice == 0
    for bad in ("-21", "20", "1.5", "high"):
        with pytest.raises(ConfigError, match="gateway_nice"):
            load_config(None, None, [f"gateway_nice={bad}"])


def test_gateway_switch_interval_is_bounded():
    assert load_config(None, None, []).gateway_switch_interval_s == 0.0005
    assert (
        load_config(None, None, ["gateway_switch_interval_s=0.005"]).gateway_switch_interval_s
        == 0.005
    )
    for bad in ("0", "-1", "nan", "1"):
        with pytest.raises(ConfigError, match="gateway_switch_interval_s"):
            load_config(None, None, [f"gateway_switch_interval_s={bad}"])


def test_streams_and_workers_are_independent():
    """The streams have threads of their own (test_gateway_process pins it): any number of
    them goes with any number of workers."""
    cfg = load_config(None, None, ["workers=2", "monitor.max_streams=8"])
    assert (cfg.workers, cfg.monitor.max_streams) == (2, 8)


def test_the_spin_must_leave_part_of_the_period_to_sleep(tmp_path: Path):
    """``realtime.spin_us`` is checked against the period of ``loop.rate_hz``."""
    assert load_config().realtime.spin_us == 0.0
    cfg = load_config(None, None, ["loop.rate_hz=1000", "realtime.spin_us=900"])
    assert cfg.realtime.spin_us == 900
    path = tmp_path / "spin.yaml"
    path.write_text("loop:\n  rate_hz: 1000\nrealtime:\n  spin_us: 1000\n")
    with pytest.raises(ConfigError) as err:
        load_config(path)
    message = str(err.value)
    assert message.startswith(str(path)), message
    assert ": realtime: " in message and "spin_us (1000) must be below the loop's period" in message
    assert "(1000 µs at loop.rate_hz 1000)" in message, message

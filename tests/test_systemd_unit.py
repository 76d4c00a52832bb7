"""config/systemd: the shipped unit file and the example configuration."""

from __future__ import annotations

import configparser
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from controller.contract.config import DaemonConfig, load_config, security_problems

SYSTEMD = Path(__file__).resolve().parents[1] / "config" / "systemd"
UNIT = SYSTEMD / "imotiond.service"
EXAMPLE = SYSTEMD / "imotiond.yaml"


def unit() -> configparser.ConfigParser:
    parser = configparser.ConfigParser(strict=False, interpolation=None)
    parser.optionxform = str  # type: ignore[assignment,method-assign]  # keys are case-sensitive
    parser.read_string(UNIT.read_text())
    return parser


def test_unit_has_the_key_settings() -> None:
    svc = unit()["Service"]
    assert svc["Type"] == "notify"
    assert svc["NotifyAccess"] == "main"
    assert svc["WatchdogSec"].endswith("s") and float(svc["WatchdogSec"][:-1]) > 1.0
    assert svc["ExecStart"] == "/usr/local/bin/imotiond --config /etc/imotion/imotiond.yaml"
    assert svc["Restart"] == "on-failure"
    assert svc["KillSignal"] == "SIGTERM"
    assert svc["KillMode"] == "mixed"  # SIGTERM to the control process, which stops the rest
    assert float(svc["TimeoutStopSec"].rstrip("s")) >= 2.0
    assert svc["RuntimeDirectory"] == "imotion"
    assert svc["LimitRTPRIO"] == "99"
    assert svc["LimitMEMLOCK"] == "infinity"
    assert svc["RestrictRealtime"] == "no"
    assert "CPUSchedulingPolicy" not in svc  # the daemon makes only its loop thread FIFO
    # the gateway may lower its nice value to the example configuration's gateway_nice
    assert int(svc["LimitNICE"]) <= load_config(EXAMPLE).gateway_nice < 0
    assert svc["NoNewPrivileges"] == "yes"
    assert svc["ProtectSystem"] == "strict"
    assert "/run/imotion" in svc["ReadWritePaths"].split()
    assert "AF_CAN" in svc["RestrictAddressFamilies"].split()
    assert "PrivateNetwork" not in svc
    assert unit()["Install"]["WantedBy"] == "multi-user.target"


def test_example_configuration_validates_and_matches_the_unit() -> None:
    cfg = load_config(EXAMPLE)
    assert security_problems(cfg) == []
    assert str(cfg.runtime_dir) == "/run/imotion"
    assert cfg.listen.startswith("unix:/run/imotion/")
    assert cfg.gateway == "process"
    svc = unit()["Service"]
    assert f"--config /etc/imotion/{EXAMPLE.name}" in svc["ExecStart"]


def test_example_configuration_mentions_every_setting() -> None:
    text = EXAMPLE.read_text()

    def keys(model: type, prefix: str = "") -> list[str]:
        out = []
        for name, field in model.model_fields.items():  # type: ignore[attr-defined]
            sub = field.annotation
            if isinstance(sub, type) and hasattr(sub, "model_fields"):
                out += keys(sub, f"{prefix}{name}.")
            else:
                out.append(f"{prefix}{name}")
        return out

    missing = [k for k in keys(DaemonConfig) if f"{k.rsplit('.', 1)[-1]}:" not in text]
    assert missing == []


def test_systemd_analyze_verify(tmp_path: Path) -> None:
    tool = shutil.which("systemd-analyze")
    if tool is None:
        pytest.skip("systemd-analyze is not installed on this machine")
    # verify checks that ExecStart exists: point it at this environment's imotiond.
    exe = Path(sys.executable).with_name("imotiond")
    if not exe.is_file():
        pytest.skip(f"no imotiond console script next to {sys.executable}")
    text = UNIT.read_text().replace("/usr/local/bin/imotiond", str(exe))
    copy = tmp_path / UNIT.name
    copy.write_text(text)
    proc = subprocess.run(
        [tool, "verify", "--man=no", str(copy)], capture_output=True, text=True, timeout=60
    )
    problems = [
        line
        for line in (proc.stdout + proc.stderr).splitlines()
        if UNIT.name in line or "imotiond" in line
    ]
    assert proc.returncode == 0 and not problems, proc.stdout + proc.stderr

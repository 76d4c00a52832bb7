"""controller.daemon.preflight: ``imotiond --check`` refuses what the start would refuse."""

from __future__ import annotations

import logging
import subprocess
import sys
from collections.abc import Iterator

import pytest

from controller.contract.config import load_config
from controller.daemon.main import main
from controller.daemon.preflight import hal_options, preflight
from controller.logs import stop_logging


@pytest.fixture(autouse=True)
def _keep_root_logging() -> Iterator[None]:
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    yield
    stop_logging()  # the writer thread holds this test's captured stderr
    root.handlers[:] = handlers
    root.setLevel(level)


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["--robot", "nosuch"], "robot: nosuch: unknown robot"),
        (["--set", "hal_options.bogus=1"], "hal_options.bogus: Extra inputs"),
        (["--rate", "3000"], "loop.rate_hz: 3000 Hz is outside the loop's 1..2000 Hz"),
        (["--hal", "can", "--set", "hal_options.sdo_timeout=-1"], "hal_options.sdo_timeout"),
        (["--hal", "can", "--set", "hal_options.sdo_timeout=yes"], "hal_options.sdo_timeout"),
        (["--hal", "hil", "--set", "hal_options.buses={}"], "hal_options.buses"),
        (["--hal", "can", "--robot", "seednoid", "--rate", "2000"], "would be loaded"),
    ],
)
def test_check_refuses_what_the_start_would_refuse(
    argv: list[str], fragment: str, capsys: pytest.CaptureFixture[str]
):
    assert main([*argv, "--check"]) == 2
    out, err = capsys.readouterr()
    assert "configuration OK" not in out
    assert fragment in err


def test_check_accepts_a_good_configuration(capsys: pytest.CaptureFixture[str]):
    argv = ["--hal", "hil", "--set", "hal_options.sdo_timeout=0.5", "--rate", "500", "--check"]
    assert main(argv) == 0
    assert capsys.readouterr().out.strip() == "configuration OK"


def test_hal_options_keep_only_the_given_keys():
    cfg = load_config(None, {"hal": "can"}, ["hal_options.sdo_timeout=1", "hal_options.buses={}"])
    options, problems = hal_options(cfg)
    assert problems == [] and options == {"sdo_timeout": 1.0, "buses": {}}


def test_preflight_gives_the_robot_to_the_start():
    checked = preflight(load_config(None, {"robot": "pa10", "hal": "ideal"}))
    assert checked.problems == [] and checked.robot is not None
    assert checked.hal_options == {}


def test_start_refuses_before_touching_hardware():
    """The real command: a bad option ends the start with exit 2 and the reason."""
    done = subprocess.run(
        [sys.executable, "-m", "controller.daemon.main", "--hal", "ideal",
         "--set", "hal_options.bogus=1", "--listen", "127.0.0.1:0"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert done.returncode == 2
    assert "hal_options.bogus" in done.stderr

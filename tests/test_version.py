"""controller.version: ``--version`` of every tool (imotiond, imotion, imotion-sim)."""

from __future__ import annotations

import argparse
import subprocess
import sys

import pytest

from controller.version import add_version_argument, version, version_line


def test_version_is_the_installed_distribution_version():
    assert version()[0].isdigit()
    assert version_line("imotiond") == f"imotiond {version()}"


def test_add_version_argument_prints_prog_and_version(capsys: pytest.CaptureFixture[str]):
    parser = argparse.ArgumentParser(prog="tool")
    add_version_argument(parser)
    with pytest.raises(SystemExit) as exit_info:
        parser.parse_args(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out.strip() == f"tool {version()}"


@pytest.mark.parametrize(
    "module, prog",
    [
        ("controller.daemon.main", "imotiond"),
        ("controller.cli", "imotion"),
        ("hal.emulator.main", "imotion-sim"),
    ],
)
def test_every_tool_answers_version(module: str, prog: str):
    done = subprocess.run(
        [sys.executable, "-m", module, "--version"], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"{prog} {version()}"

"""hal.can.tool (imotion-can): every subcommand against the emulator over virtual buses.

The emulator runs its threads (the tool is a separate master with real timing); durations
are kept short and nothing asserts wall-clock time.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hal.can.tool import main
from hal.emulator.emulator import DriveEmulator


@pytest.fixture(scope="module")
def emu():
    e = DriveEmulator("pa10", period=0.002)
    e.start()
    yield e
    e.close()


def on(emu: DriveEmulator, bus: str = "arm_a") -> list[str]:
    interface, channel = emu.channels[bus]
    return ["--robot", "pa10", "--bus", bus, "--interface", interface, "--channel", channel]


def test_plan_prints_the_table(capsys: pytest.CaptureFixture[str]):
    assert main(["--robot", "smartpal5", "plan"]) == 0
    out = capsys.readouterr().out
    assert "arm_r_shoulder" in out and "68.1 %" in out
    assert main(["--robot", "seednoid", "plan", "--rate", "1000"]) == 1  # over 100 %


def test_scan_lists_nodes_and_identity(emu: DriveEmulator, capsys: pytest.CaptureFixture[str]):
    assert main([*on(emu), "scan", "--listen", "0.3"]) == 0
    out = capsys.readouterr().out
    for name in ("J1", "J2", "J3", "J4"):
        assert name in out
    assert "0x" in out


def test_state_and_sdo(emu: DriveEmulator, capsys: pytest.CaptureFixture[str]):
    assert main([*on(emu), "state"]) == 0
    assert "switch on disabled" in capsys.readouterr().out
    assert main([*on(emu), "sdo", "write", "J2", "0x6065", "0", "5000"]) == 0
    assert main([*on(emu), "sdo", "read", "J2", "0x6065"]) == 0
    assert "= 5000" in capsys.readouterr().out
    assert main([*on(emu), "sdo", "read", "J2", "0x5FFF"]) == 1
    assert "node 2 on bus arm_a" in capsys.readouterr().err


def test_enable_jog_disable(emu: DriveEmulator, capsys: pytest.CaptureFixture[str]):
    assert main([*on(emu, "arm_b"), "enable", "J5", "--hold", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "operation enabled" in out and "disabled" in out
    assert main([*on(emu, "arm_b"), "jog", "J6", "2", "--speed", "20"]) == 0
    out = capsys.readouterr().out
    assert "J6: 60.0000 -> " in out and "(goal 62.0000)" in out
    assert main([*on(emu, "arm_b"), "disable", "J6"]) == 0
    assert "switch on disabled" in capsys.readouterr().out


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf"])
def test_record_replay_load(emu: DriveEmulator, tmp_path: Path, suffix: str, capsys):
    path = tmp_path / f"bus{suffix}"
    # Traffic: J1's heartbeat every 10 ms.
    assert main([*on(emu), "sdo", "write", "J1", "0x1017", "0", "10"]) == 0
    assert main([*on(emu), "record", str(path), "--seconds", "0.4"]) == 0
    assert path.stat().st_size > 0
    assert "recorded" in capsys.readouterr().out
    assert main([*on(emu), "sdo", "write", "J1", "0x1017", "0", "0"]) == 0
    assert main([*on(emu), "replay", str(path)]) == 0
    assert "replayed" in capsys.readouterr().out
    if suffix == ".log":
        assert main([*on(emu), "load", "--seconds", "0.3"]) == 0
        assert "frames/s" in capsys.readouterr().out
        text = path.read_text()
        assert "701#" in text  # candump format: J1's heartbeat


def test_bad_arguments_exit_2(capsys: pytest.CaptureFixture[str]):
    assert main(["--robot", "nope", "plan"]) == 2
    assert main(["--robot", "pa10", "--bus", "nope", "state"]) == 2
    assert main(["--robot", "pa10", "--channel", "x", "state"]) == 2
    assert main(["--robot", "pa10", "--bus", "arm_a", "enable", "J7"]) == 2
    assert main(["--robot", "pa10", "sdo", "write", "J1", "0x6065"]) == 2
    assert "needs --bus" in capsys.readouterr().err


# ---------------------------------------------------------------------- command line
def test_global_options_go_before_or_after_the_operation(capsys: pytest.CaptureFixture[str]):
    assert main(["plan", "--robot", "smartpal5"]) == 0  # the README's own example
    assert "smartpal5" in capsys.readouterr().out
    assert main(["--robot", "smartpal5", "plan", "--robot", "pa10", "--rate", "250"]) == 0
    out = capsys.readouterr().out
    assert "pa10" in out and "250 Hz" in out
    assert main(["--robot", "pa10", "plan"]) == 0 and "pa10" in capsys.readouterr().out


def test_version(capsys: pytest.CaptureFixture[str]):
    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.startswith("imotion-can ")


@pytest.mark.parametrize(
    ("argv", "hint"),
    [
        (["scn"], "did you mean 'scan'?"),
        (["plan", "--raet", "100"], "did you mean '--rate'?"),
        (["--robt", "pa10", "plan"], "did you mean '--robot'?"),
        (["scan", "--lisen", "1"], "did you mean '--listen'?"),
        (["sdo", "raed", "J1", "0x1000"], "did you mean 'read'?"),
    ],
)
def test_did_you_mean(argv: list[str], hint: str, capsys: pytest.CaptureFixture[str]):
    with pytest.raises(SystemExit) as done:
        main(argv)
    assert done.value.code == 2
    assert hint in capsys.readouterr().err


def test_nothing_close_gets_no_hint(capsys: pytest.CaptureFixture[str]):
    with pytest.raises(SystemExit):
        main(["xyzzy"])
    assert "did you mean" not in capsys.readouterr().err

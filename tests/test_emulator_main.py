"""``imotion-sim``: argument handling, stdin commands, and one cross-process run in which a
python-can ``remote`` bus in this process talks to the emulator's bridge on 127.0.0.1."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import can
import pytest

from hal.emulator.emulator import DriveEmulator
from hal.emulator.main import handle_command, main

ROOT = Path(__file__).resolve().parents[1]


def _frame(can_id: int, data: bytes = b"") -> can.Message:
    return can.Message(arbitration_id=can_id, data=data, is_extended_id=False)


@pytest.mark.parametrize("interface", ["unix", "remote"])
def test_cross_process_nmt_sync_tpdo_heartbeat_and_sigterm(interface: str, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    where = ["--unix", str(tmp_path)] if interface == "unix" else ["--serve", "127.0.0.1:0"]
    process = subprocess.Popen(
        [sys.executable, "-m", "hal.emulator.main", "--robot", "pa10", *where],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env=env, cwd=ROOT,
    )  # fmt: skip
    bus = None
    try:
        assert process.stdout is not None and process.stdin is not None
        lines = [process.stdout.readline() for _ in range(2)]
        fields = [dict(item.split("=", 1) for item in line.split()) for line in lines]
        assert [f["bus"] for f in fields] == ["arm_a", "arm_b"]
        assert all(f["interface"] == interface for f in fields)
        prefix = str(tmp_path) if interface == "unix" else "ws://127.0.0.1:"
        assert all(f["channel"].startswith(prefix) for f in fields)
        bus = can.Bus(interface=interface, channel=fields[0]["channel"])
        bus.send(_frame(0x601, bytes([0x2B, 0x17, 0x10, 0, 20, 0, 0, 0])))  # 0x1017 = 20 ms
        bus.send(_frame(0x000, bytes([0x01, 0])))  # NMT start all
        seen: dict[int, bytes] = {}
        for _ in range(200):  # bounded: SYNC until TPDOs of nodes 1-4 and a heartbeat came
            bus.send(_frame(0x080))
            while (msg := bus.recv(0.02)) is not None:
                seen[msg.arbitration_id] = bytes(msg.data)
            if {0x181, 0x182, 0x183, 0x184, 0x701} <= set(seen):
                break
        assert seen[0x581][0] == 0x60  # SDO download confirmed
        assert {0x181, 0x182, 0x183, 0x184} <= set(seen)
        assert seen[0x181][:2] == bytes([0x40, 0x02])  # statusword: Switch on disabled
        assert seen.get(0x701) == b"\x05"  # heartbeat: OPERATIONAL
        process.stdin.write("inject heartbeat_loss J1\nstatus\n")
        process.stdin.flush()
        assert process.stdout.readline().startswith("ok inject heartbeat_loss J1")
        status = process.stdout.readline()
        assert "heartbeat_loss:J1" in status
        fields = dict(word.split("=", 1) for word in status.split()[1:] if "=" in word)
        assert len(fields["gc"].split("/")) == 3 and float(fields["gc_max_ms"]) >= 0.0
    finally:
        if bus is not None:
            bus.shutdown()
        process.send_signal(signal.SIGTERM)
        try:
            code = process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            process.kill()
            raise
    assert code == 0, process.stderr.read() if process.stderr else ""


def test_bad_arguments_exit_2_with_the_reason(capsys):
    assert main(["--robot", "no_such_robot"]) == 2
    assert "no_such_robot" in capsys.readouterr().err
    assert main(["--robot", "pa10", "--channel", "vcan0"]) == 2
    assert "--interface" in capsys.readouterr().err
    assert main(["--robot", "pa10", "--interface", "socketcan", "--channel", "vcan0"]) == 2
    assert "2 buses" in capsys.readouterr().err
    assert main(["--robot", "pa10", "--interface", "x", "--channel", "nope=vcan0"]) == 2
    assert "unknown bus 'nope'" in capsys.readouterr().err
    assert main(["--robot", "pa10", "--serve", "localhost"]) == 2
    assert "HOST:PORT" in capsys.readouterr().err
    assert main(["--robot", "pa10", "--serve", "127.0.0.1:0", "--unix", "x"]) == 2
    assert "not both" in capsys.readouterr().err
    assert main(["--robot", "pa10", "--unix", "x", "--realtime", "120"]) == 2
    assert "SCHED_FIFO" in capsys.readouterr().err


def test_a_bus_that_cannot_be_opened_exits_2(capsys):
    code = main(["--robot", "pa10", "--interface", "no_such_interface",
                 "--channel", "arm_a=x", "--channel", "arm_b=y"])  # fmt: skip
    assert code == 2
    assert "bus arm_a" in capsys.readouterr().err


@pytest.fixture(scope="module")
def emulator():
    emu = DriveEmulator("pa10")
    yield emu
    emu.close()


def test_stdin_commands(emulator):
    assert handle_command(emulator, "inject refuse_enable J2") == "ok inject refuse_enable J2"
    assert "refuse_enable:J2" in handle_command(emulator, "status")
    assert handle_command(emulator, "inject emcy J1 code=0x2310 fault=false").startswith("ok")
    assert handle_command(emulator, "clear - J2") == "ok clear 1"
    assert handle_command(emulator, "inject bus_off - bus=arm_b").startswith("ok")
    assert handle_command(emulator, "clear bus_off") == "ok clear 1"
    assert handle_command(emulator, "inject melt J1").startswith("error unknown fault kind")
    assert handle_command(emulator, "inject emcy J9").startswith("error fault emcy: unknown drive")
    assert handle_command(emulator, "inject emcy J1 code").startswith("error inject: parameter")
    assert handle_command(emulator, "fly").startswith("error unknown command")
    assert handle_command(emulator, "   ") == ""

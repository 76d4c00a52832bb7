"""tools/demo_session.py --quick: the main job end to end (daemon child, gRPC, outputs)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_quick_session_runs_and_writes_its_outputs(tmp_path: Path) -> None:
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tools" / "demo_session.py"),
            "--quick",
            "--out",
            str(tmp_path),
        ],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=240,
    )
    lines = proc.stdout.strip().splitlines()
    assert lines, proc.stderr
    summary = json.loads(lines[-1])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert summary["ok"] and summary["daemon_exit"] == 0
    assert summary["not_ok_returns"] == 0
    session = json.loads((tmp_path / "session.json").read_text())
    calls = [r["call"].split("(")[0] for r in session["returns"]]
    for name in (
        "servoOn",
        "moveLinearCartesianRel",
        "moveCPHoldRel",
        "moveUnitAbs",
        "pause",
        "resume",
        "stop",
    ):
        assert name in calls
    states = {c["to"] for c in session["state_changes"]}
    assert {"Ready", "Busy", "Pause"} <= states
    figures = session["figures"]
    assert figures["line_end_error_mm"] < 1.0
    assert figures["vehicle_held_hand_error_mm"] < 1.0
    assert figures["paused_line_end_error_mm"] < 1.0
    # the move into the body is refused before anything moves, naming the two links
    refused = figures["refused_move"]
    assert refused["code"] == "CANNOT_REACH_TARGET_ERR", refused
    assert "of lumbar_upper_link (closest allowed" in refused["comment"]
    assert figures["refused_move_hand_moved_mm"] < 0.01
    # the CP-hold into the body runs and stops short of it, saying which links
    into_body = figures["cp_hold_into_body"]
    assert into_body["code"] == "OK" and into_body["outcome"] == "ran; state Ready", into_body
    (blocked,) = [w for w in into_body["alarms"] if w.startswith("0x414")]
    assert "lumbar_upper_link" in blocked and "r_arm_link" in blocked, blocked
    assert into_body["held_hand_moved_mm"] < 1.0
    assert (tmp_path / "joints.png").stat().st_size > 10_000
    assert (tmp_path / "session.mcap").stat().st_size > 1000
    assert (tmp_path / "session-joints.png").stat().st_size > 10_000
    assert summary["frames"] >= 5
    assert (tmp_path / "frames" / "frame_000.png").is_file()
    assert (tmp_path / "frames.png").is_file()

"""``imotion record``, ``imotion plot`` and ``imotion view`` (controller/cli/observe.py,
controller/cli/plot.py, controller/client/recording.py) against a daemon on ``--hal ideal``
with the live view and the black box on."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from controller.cli.main import main
from controller.client.recording import metadata_limits, read_mcap
from controller.gateway.process import Observers, start_observers
from controller.model.alarms import AlarmCode
from tests.daemon_support import TestDaemon


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[TestDaemon, Observers]]:
    bb = tmp_path_factory.mktemp("bb")
    td = TestDaemon(**{"view.listen": "127.0.0.1:0", "blackbox.dir": str(bb),
                       "blackbox.seconds": 1.0, "blackbox.after_s": 0.1})  # fmt: skip
    observers = start_observers(td.cfg, td.daemon.runtime, td.ctx)
    try:
        yield td, observers
    finally:
        observers.close()
        td.close()


def test_record_writes_stream_state_to_mcap(
    served: tuple[TestDaemon, Observers], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    td, _ = served
    td.reset()
    out = tmp_path / "run.mcap"
    code = main(["record", str(out), "--seconds", "0.5", "--rate", "50",
                 "--address", td.address, "--json"])  # fmt: skip
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    assert data["file"] == str(out) and data["samples"] >= 2
    rec = read_mcap(out)
    assert len(rec.messages("/joint_states")) == data["samples"]
    names = [j["name"] for j in rec.messages("/joint_states")[0][1]["joints"]]
    assert "RIGHT_ARM/1" in names and "VEHICLE/3" in names
    assert rec.schemas["/control_points"] == "foxglove.PosesInFrame"
    assert len(rec.messages("/control_points")[0][1]["poses"]) == 2
    assert rec.messages("/state")[0][1]["status_message"]
    assert rec.messages("/loop")[-1][1]["cycle"] > 0
    assert any("state:" in m[1]["message"] for m in rec.messages("/alarms"))
    assert rec.metadata["imotion"]["source"] == "StreamState"
    limits = metadata_limits(rec)  # the arms' soft joint limits, for the plots
    assert limits["RIGHT_ARM/1"]["lower"] < 0.0 < limits["RIGHT_ARM/1"]["upper"]
    assert "LEFT_ARM/7" in limits


def test_plot_of_a_recording_and_of_a_black_box(
    served: tuple[TestDaemon, Observers], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    td, observers = served
    td.reset()
    run = tmp_path / "run.mcap"
    assert main(["record", str(run), "--seconds", "0.3", "--address", td.address]) == 0
    capsys.readouterr()
    assert main(["plot", str(run), "--json"]) == 0
    written = json.loads(capsys.readouterr().out)["written"]
    assert sorted(Path(p).name for p in written) == ["run-joints.png", "run-timing.png"]
    assert all(Path(p).stat().st_size > 10_000 for p in written)
    # a black-box file has commanded joints too: the tracking plot as well
    assert observers.blackbox is not None
    td.controller.core.raise_alarm(AlarmCode.OVERSPEED, "test", "for the plot")
    assert td.wait_for(lambda: bool(observers.blackbox and observers.blackbox.written))
    box = observers.blackbox.written[-1]
    assert main(["plot", str(box), "--out", str(tmp_path / "png")]) == 0
    names = sorted(p.name for p in (tmp_path / "png").iterdir())
    assert names == [f"{box.stem}-{k}.png" for k in ("joints", "timing", "tracking")]
    td.reset()


def test_plot_refuses_missing_and_foreign_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["plot", str(tmp_path / "nope.mcap")]) == 2
    assert "no such file" in capsys.readouterr().err
    bad = tmp_path / "bad.mcap"
    bad.write_text("not mcap")
    assert main(["plot", str(bad)]) == 2
    assert "cannot read it" in capsys.readouterr().err


def test_view_lists_every_channel(
    served: tuple[TestDaemon, Observers], capsys: pytest.CaptureFixture[str]
) -> None:
    _, observers = served
    assert observers.live_view is not None
    url = observers.live_view.url
    assert main(["view", "--url", url, "--listen", "0.5", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["server"] == "imotiond smartpal5"
    assert info["channels"]["/tf"]["schema"] == "foxglove.FrameTransforms"
    assert info["channels"]["/tf"]["messages"] > 0
    assert info["robot_description_chars"] > 1000
    assert info["open_in_foxglove"].startswith("https://app.foxglove.dev/")
    assert main(["view", "--url", url, "--listen", "0"]) == 0
    assert "open in Foxglove" in capsys.readouterr().out


def test_view_without_a_server_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["view", "--url", "ws://127.0.0.1:1", "--timeout", "1"]) == 2
    err = capsys.readouterr().err
    assert "cannot open" in err and len(err.strip().splitlines()) == 1


def test_record_rejects_bad_numbers(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["record", "x.mcap", "--seconds", "-1"]) == 2
    assert "--seconds" in capsys.readouterr().err

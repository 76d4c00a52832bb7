"""Live view (controller/gateway/observe/live_view.py) through a Foxglove-protocol WebSocket client.

A daemon on ``--hal ideal`` (realtime off) serves the view on 127.0.0.1 (port 0); the client
(controller/client/foxglove_ws.py, websockets) subscribes to every channel and checks each
one, the URDF parameter, the asset handler, and that the transforms follow a move.
"""

from __future__ import annotations

import signal
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from controller.client.foxglove_ws import LiveViewClient
from controller.contract.config import load_config, security_problems
from controller.gateway.process import Observers, start_observers
from controller.model.alarms import AlarmCode
from controller.rpc import imotion_pb2 as pb
from tests.daemon_support import TestDaemon

TOPICS = {
    "/robot_description",
    "/tf",
    "/joint_states/measured",
    "/joint_states/commanded",
    "/control_points",
    "/tracking_error",
    "/loop",
    "/state",
    "/alarms",
}


@pytest.fixture(scope="module")
def served() -> Iterator[tuple[TestDaemon, Observers]]:
    td = TestDaemon(**{"view.listen": "127.0.0.1:0", "view.rate_hz": 50.0})
    observers = start_observers(td.cfg, td.daemon.runtime, td.ctx)
    try:
        yield td, observers
    finally:
        observers.close()
        td.close()


@pytest.fixture
def client(served: tuple[TestDaemon, Observers]) -> Iterator[LiveViewClient]:
    _, observers = served
    assert observers.live_view is not None
    with LiveViewClient(observers.live_view.url) as c:
        yield c


def test_serves_on_loopback_and_advertises_every_channel(
    served: tuple[TestDaemon, Observers], client: LiveViewClient
) -> None:
    _, observers = served
    assert observers.live_view is not None
    assert observers.live_view.url.startswith("ws://127.0.0.1:")
    assert set(client.topics()) == TOPICS
    schemas = {t: c.schema_name for t, c in client.topics().items()}
    assert schemas["/tf"] == "foxglove.FrameTransforms"
    assert schemas["/joint_states/measured"] == "foxglove.JointStates"
    assert schemas["/control_points"] == "foxglove.SceneUpdate"
    assert schemas["/alarms"] == "foxglove.Log"


def test_every_channel_carries_its_content(
    served: tuple[TestDaemon, Observers], client: LiveViewClient
) -> None:
    td, _ = served
    td.reset()
    client.subscribe()
    urdf = td.daemon.robot.urdf_path.read_text()
    assert client.next_message("/robot_description")["data"] == urdf
    names = [j["name"] for j in client.next_message("/joint_states/measured")["joints"]]
    assert names == list(td.daemon.hw.joint_names)
    commanded = client.next_message("/joint_states/commanded")["joints"]
    assert len(commanded) == len(names)
    tf = client.next_message("/tf")["transforms"]
    urdf_joints = ET.fromstring(urdf).findall("joint")
    assert len(tf) == len(urdf_joints)
    assert {t["child_frame_id"] for t in tf} == {
        j.find("child").get("link")
        for j in urdf_joints  # type: ignore[union-attr]
    }
    ids = {e["id"] for e in client.next_message("/control_points")["entities"]}
    assert ids == {"right_control_point", "right_target", "left_control_point", "left_target"}
    tracking = client.next_message("/tracking_error")
    assert set(tracking["arms"]) == {"RIGHT", "LEFT"}
    assert tracking["arms"]["RIGHT"]["position_mm"] < 1.0  # ideal drives follow exactly
    loop = client.next_message("/loop")
    assert loop["cycle"] > 0 and len(loop["wake_us"]) == 3
    state = client.next_message("/state")
    assert state["state"] == "ready" and state["servo_on"]
    # alarms: one injected alarm arrives as an error log message, its clearing as info
    td.controller.core.raise_alarm(AlarmCode.OVERSPEED, "test", "injected by the test")
    log = client.wait_for(
        lambda m: isinstance(m, tuple) and m[1] == "/alarms" and "injected" in m[3]["message"]
    )[3]
    assert log["level"] == "ERROR" and "0x0003" in log["message"]
    td.reset()
    cleared = client.wait_for(
        lambda m: isinstance(m, tuple) and m[1] == "/alarms" and m[3]["message"] == "alarms cleared"
    )
    assert cleared[3]["level"] == "INFO"


def test_robot_description_parameter_is_the_urdf(
    served: tuple[TestDaemon, Observers], client: LiveViewClient
) -> None:
    td, _ = served
    params = client.parameters("/robot_description")
    assert params["/robot_description"] == td.daemon.robot.urdf_path.read_text()
    assert "/robot_description" in client.parameters()


def test_assets_come_from_the_robot_directory_only(
    served: tuple[TestDaemon, Observers], client: LiveViewClient
) -> None:
    td, _ = served
    urdf = td.daemon.robot.urdf_path.read_bytes()
    assert client.fetch_asset("package://smartpal5/robot.urdf") == urdf
    assert client.fetch_asset(f"file://{td.daemon.robot.urdf_path}") == urdf
    assert client.fetch_asset("package://smartpal5/../../../../etc/passwd") is None
    assert client.fetch_asset("file:///etc/passwd") is None
    assert client.fetch_asset("http://example.com/x.stl") is None


def test_a_subscribed_client_that_stopped_reading_closes_with_the_handshake(
    served: tuple[TestDaemon, Observers],
) -> None:
    """Every channel at 50 Hz fills websockets' incoming buffer (16 frames) as soon as the
    client stops reading; websockets then stops reading the socket. Closing used to miss the
    server's end of the connection and wait out websockets' 10 s close timeout, at every
    exit of ``imotion view --listen``."""
    td, observers = served
    assert observers.live_view is not None
    with LiveViewClient(observers.live_view.url) as c:
        c.subscribe()
        c.next_message("/tf")
        # websockets' own flag: the buffer is full and it stopped reading the socket
        assert td.wait_for(lambda: c.ws.recv_messages.paused, timeout=10.0)
    # websockets records its close timeout as the connection's exception
    assert not isinstance(c.ws.connection_exc, TimeoutError), c.ws.connection_exc


def _rotation(tf: list[dict], child: str) -> np.ndarray:
    t = next(t for t in tf if t["child_frame_id"] == child)["rotation"]
    return np.array([t.get(k, 0.0) for k in "xyzw"])


def test_transforms_follow_a_move(
    served: tuple[TestDaemon, Observers], client: LiveViewClient
) -> None:
    td, _ = served
    td.reset()
    client.subscribe("/tf", "/joint_states/measured")
    js = client.next_message("/joint_states/measured")["joints"]
    before = {j["name"]: j.get("position", 0.0) for j in js}
    # the child link of r_arm_j1 (first joint of the right arm)
    urdf = ET.fromstring(td.daemon.robot.urdf_path.read_text())
    joint = next(j for j in urdf.findall("joint") if j.get("name") == "r_arm_j1")
    child = joint.find("child").get("link")  # type: ignore[union-attr]
    start = _rotation(client.next_message("/tf")["transforms"], child)
    target = np.degrees(before["r_arm_j1"]) + 20.0
    rid = td.spec_a.MoveUnitAbs(
        pb.MoveUnitAbsRequest(
            unit=pb.RIGHT_ARM,
            abs_pos=[target] + [np.degrees(before[f"r_arm_j{k}"]) for k in range(2, 8)],
            speed=[30.0],
            accel=[100.0],
        )
    ).return_id
    assert rid.id == 0, rid.comment
    assert td.wait_idle()
    moved = client.wait_for(
        lambda m: (
            isinstance(m, tuple)
            and m[1] == "/joint_states/measured"
            and abs(
                next(j.get("position", 0.0) for j in m[3]["joints"] if j["name"] == "r_arm_j1")
                - np.radians(target)
            )
            < 1e-3
        )
    )
    assert moved
    end = _rotation(client.next_message("/tf")["transforms"], child)
    turned = 2.0 * np.degrees(np.arccos(min(1.0, abs(float(end @ start)))))
    assert turned == pytest.approx(20.0, abs=0.5)


def test_remote_address_needs_an_explicit_setting() -> None:
    cfg = load_config(None, {"view.listen": "0.0.0.0:8765"})
    assert any("view.listen" in p and "no authentication" in p for p in security_problems(cfg))
    cfg = load_config(None, {"view.listen": "0.0.0.0:8765", "view.allow_remote": True})
    assert not security_problems(cfg)
    assert not security_problems(load_config(None, {"view.listen": "127.0.0.1:8765"}))


def test_imotiond_serves_the_view_from_its_gateway_process(tmp_path: Path) -> None:
    from tests.test_daemon_process import Imotiond

    d = Imotiond("--robot", "pa10", "--hal", "ideal", "--listen", "127.0.0.1:0",
                 "--set", "realtime.enabled=false", "--set", "view.listen=127.0.0.1:0",
                 "--set", f"blackbox.dir={tmp_path}")  # fmt: skip
    try:
        url = d.wait_line(r"live view on (ws://127\.0\.0\.1:\d+)").group(1)
        assert "proc=gateway" in next(line for line in d.lines if "live view on" in line)
        with LiveViewClient(url) as c:
            assert set(c.topics()) == TOPICS
            urdf = c.parameters("/robot_description")["/robot_description"]
            assert '<robot name="pa10">' in urdf
        d.proc.send_signal(signal.SIGTERM)
        assert d.wait_exit() == 0
    finally:
        d.kill()


def test_imotiond_refuses_a_remote_view_without_allow_remote() -> None:
    from tests.test_daemon_process import Imotiond

    d = Imotiond("--robot", "pa10", "--hal", "ideal", "--set", "view.listen=0.0.0.0:0", "--check")
    assert d.wait_exit() == 2
    assert "view.listen" in d.log and "no authentication" in d.log

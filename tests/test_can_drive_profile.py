"""hal.can.drive_profile: the shipped drives.yaml files and errors that name file and key."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest
import yaml

from config import ROBOTS_DIR, robot_ids
from controller.model.yaml_source import ConfigError
from hal.can.drive_profile import DEFAULT_EDS, drives_path, eds_path, load_drive_profile
from tests.support import robot


@pytest.mark.parametrize("robot_id", robot_ids())
def test_shipped_profiles_load_and_cover_every_joint(robot_id: str):
    r = robot(robot_id)
    p = load_drive_profile(drives_path(r), r)
    assert p.robot == robot_id
    actuated = {n for joints in r.profile.units.values() for n in joints} | set(r.gripper_joints)
    if r.profile.vehicle is not None:
        assert len(p.wheels) == r.profile.vehicle.wheels.count
        actuated -= set(r.unit_joints("VEHICLE"))
    assert actuated | set(p.wheels) == set(p.drives)
    assert eds_path(p, next(iter(p.drives)), r.directory) == DEFAULT_EDS
    assert DEFAULT_EDS.is_file()


def broken(tmp_path: Path, mutate: Any) -> Path:
    path = tmp_path / "drives.yaml"
    shutil.copy(ROBOTS_DIR / "smartpal5" / "drives.yaml", path)
    data = yaml.safe_load(path.read_text())
    mutate(data)
    path.write_text(yaml.safe_dump(data))
    return path


CASES = [
    (
        lambda d: d["drives"]["r_arm_j1"].update(bus="nope"),
        "drives.r_arm_j1.bus: 'nope' is not one",
    ),
    (
        lambda d: d["drives"]["r_arm_j2"].update(node_id=1),
        "drives.r_arm_j2.node_id: 1 is already used by r_arm_j1",
    ),
    (lambda d: d["drives"]["r_arm_j2"].update(node_id=200), "drives.r_arm_j2.node_id"),
    (lambda d: d["drives"]["r_arm_j2"].update(node_id=127), "is the master's node id"),
    (lambda d: d["drives"]["r_arm_j3"].update(counts_per_m=10), "exactly one of counts_per_rev"),
    (lambda d: d["drives"]["r_arm_j3"].update(sign=2), "drives.r_arm_j3.sign"),
    (lambda d: d["drives"].pop("l_gripper"), "joint 'l_gripper' has no drive"),
    (
        lambda d: d["drives"].update(bogus={"bus": "body", "node_id": 99, "counts_per_rev": 1}),
        "drives.bogus: not an actuated joint",
    ),
    (lambda d: d["vehicle"].update(wheels=["wheel_1", "wheel_2"]), "vehicle.wheels: 2 wheels"),
    (
        lambda d: d["vehicle"].update(wheels=["wheel_1", "wheel_2", "ghost"]),
        "vehicle.wheels[2]: 'ghost' is not a drive",
    ),
    (lambda d: d["buses"]["body"].update(fd=True), "needs data_bitrate"),
    (lambda d: d["heartbeat"].update(master_consumer_ms=50), "master_consumer_ms must exceed"),
    (lambda d: d.update(robot="pa10"), "robot: 'pa10' but the robot profile is 'smartpal5'"),
    (lambda d: d.update(extra=1), "extra"),
    (lambda d: d.update(tpdo_timeout_ms=-1), "tpdo_timeout_ms"),
    (lambda d: d["buses"]["body"].update(tpdo_timeout_cycles=0), "buses.body.tpdo_timeout_cycles"),
]


@pytest.mark.parametrize(("mutate", "message"), CASES)
def test_errors_name_file_and_key(tmp_path: Path, mutate: Any, message: str):
    path = broken(tmp_path, mutate)
    with pytest.raises(ConfigError) as err:
        load_drive_profile(path, robot("smartpal5"))
    assert str(path) in str(err.value)
    assert message in str(err.value)


def test_vehicle_joints_as_drives_are_a_stand_in_option(tmp_path: Path):
    def direct(d: dict) -> None:
        for w in ("wheel_1", "wheel_2", "wheel_3"):
            d["drives"].pop(w)
        d.pop("vehicle")
        for i, n in enumerate(("vehicle_x", "vehicle_y")):
            d["drives"][n] = {"bus": "body", "node_id": 40 + i, "counts_per_m": 100000}
        d["drives"]["vehicle_theta"] = {"bus": "body", "node_id": 42, "counts_per_rev": 4096}

    p = load_drive_profile(broken(tmp_path, direct), robot("smartpal5"))
    assert "vehicle_x" in p.drives and not p.wheels


def test_syntax_error_names_the_line(tmp_path: Path):
    path = tmp_path / "drives.yaml"
    path.write_text("robot: [unclosed\n")
    with pytest.raises(ConfigError, match="line"):
        load_drive_profile(path)


def test_tpdo_timeouts_per_profile_and_per_bus(tmp_path: Path):
    def remote(d: dict) -> None:
        d["tpdo_timeout_ms"] = 10
        d["buses"]["body"].update(tpdo_timeout_cycles=10, tpdo_timeout_ms=30)

    p = load_drive_profile(broken(tmp_path, remote), robot("smartpal5"))
    assert p.tpdo_timeout_ms == 10 and p.tpdo_timeout_cycles == 3
    assert (p.buses["body"].tpdo_timeout_cycles, p.buses["body"].tpdo_timeout_ms) == (10, 30)
    assert p.buses["arm_r_wrist"].tpdo_timeout_ms is None
